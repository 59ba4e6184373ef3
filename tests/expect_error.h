// Checking the toolkit's errors: pano::Error (nothing else), one line, naming
// the file and the problem.
#pragma once

#include <catch2/catch.hpp>

#include <initializer_list>
#include <string>

#include "panotrack/core/error.h"

namespace pano::test {

// The message of the pano::Error that `f` throws, "" when it throws none.
template <typename F>
std::string ErrorOf(F f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// `f` must throw pano::Error whose one-line message names `path` and
// contains every fragment.
template <typename F>
void ExpectError(F f, const std::string& path, std::initializer_list<std::string> fragments) {
  try {
    f();
    FAIL("expected an error for " << path);
  } catch (const Error& e) {
    const std::string msg = e.what();
    INFO("message: " << msg);
    CHECK(msg.find(path) != std::string::npos);
    CHECK(msg.find('\n') == std::string::npos);
    for (const auto& frag : fragments) CHECK(msg.find(frag) != std::string::npos);
  }
}

}  // namespace pano::test
