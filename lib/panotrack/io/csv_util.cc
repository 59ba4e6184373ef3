#include "panotrack/io/csv_util.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "panotrack/core/error.h"

namespace pano {

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> out(1);
  for (char c : line) {
    if (c == ',')
      out.emplace_back();
    else if (c != '\r')
      out.back() += c;
  }
  return out;
}

std::string QuotedText(const std::string& text) {
  constexpr size_t kMaxChars = 60;
  std::string out;
  for (unsigned char c : text) {
    if (out.size() >= kMaxChars) return out + "...";
    if (c >= 0x20 && c < 0x7F) {
      out += static_cast<char>(c);
    } else {
      char hex[8];
      std::snprintf(hex, sizeof(hex), "\\x%02X", c);
      out += hex;
    }
  }
  return out;
}

double ParseCsvDouble(const std::string& s, const std::string& where, const char* column) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(s.c_str(), &end);
  if (s.empty() || end != s.c_str() + s.size() || errno == ERANGE || !std::isfinite(v))
    throw Error(where + ": column " + column + ": expected a finite number, got '" + QuotedText(s) + "'");
  return v;
}

}  // namespace pano
