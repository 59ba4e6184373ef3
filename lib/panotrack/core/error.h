// The one exception type of the toolkit. Messages are one line that names
// the file (or option), the key or line, and what was expected, so that the
// apps can print them as they are and exit non-zero.
#pragma once

#include <stdexcept>
#include <string>

namespace pano {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace pano
