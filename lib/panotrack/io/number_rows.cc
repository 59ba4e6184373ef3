#include "panotrack/io/number_rows.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "panotrack/core/error.h"

namespace pano {

namespace {

// Fields of one line: the text before '#', split at runs of commas and
// whitespace ("1, 2, 3", "1 2 3" and "1,2,3" read alike).
std::vector<std::string> Fields(const std::string& line) {
  std::vector<std::string> fields;
  std::string cur;
  for (char c : line.substr(0, line.find('#'))) {
    if (c == ',' || std::isspace(static_cast<unsigned char>(c))) {
      if (!cur.empty()) fields.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) fields.push_back(cur);
  return fields;
}

bool ParseNumber(const std::string& s, double* x) {
  if (s.empty()) return false;
  char* end = nullptr;
  *x = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && std::isfinite(*x);
}

// Throws "SOURCE:LINE: ..." at the first control character other than tab,
// CR and LF: binary data, whose first "line" would otherwise pass as a
// header and leave no row (and no output) at all.
void CheckText(const std::string& text, const std::string& source) {
  int line_no = 1;
  for (size_t i = 0, line_start = 0; i < text.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c == '\n') ++line_no, line_start = i + 1;
    if ((c < 0x20 && c != '\t' && c != '\r' && c != '\n') || c == 0x7F) {
      char what[96];
      std::snprintf(what, sizeof(what), ": not a text file of numbers (byte 0x%02X at column %zu)", c,
                    i - line_start + 1);
      throw Error(source + ":" + std::to_string(line_no) + what);
    }
  }
}

}  // namespace

void ForEachNumberRow(const std::string& csv, const std::string& source, size_t n, const char* what,
                      const std::function<void(const std::vector<double>&)>& use) {
  CheckText(csv, source);
  std::istringstream in(csv);
  std::string line;
  int line_no = 0;
  bool seen_content = false;
  std::vector<double> values(n);
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::vector<std::string> fields = Fields(line);
    if (fields.empty()) continue;
    const bool first = !seen_content;
    seen_content = true;
    size_t numeric = 0;
    for (size_t k = 0; k < fields.size(); ++k) {
      double x;
      if (ParseNumber(fields[k], &x)) ++numeric;
    }
    if (first && numeric == 0 && fields.size() == n) continue;  // a header line ("x,y,z")
    if (fields.size() != n || numeric != n) {
      std::string bad;
      for (const std::string& f : fields) {
        double x;
        if (!ParseNumber(f, &x)) {
          bad = f;
          break;
        }
      }
      std::string msg = source + ":" + std::to_string(line_no) + ": expected " + std::to_string(n) +
                        " finite numbers (" + what + ")";
      if (fields.size() != n) msg += ", got " + std::to_string(fields.size()) + " fields";
      else msg += ", got '" + bad + "'";
      throw Error(msg);
    }
    for (size_t k = 0; k < n; ++k) ParseNumber(fields[k], &values[k]);
    use(values);
  }
}

}  // namespace pano
