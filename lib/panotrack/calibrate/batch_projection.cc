#include "panotrack/calibrate/batch_projection.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <iterator>
#include <sstream>
#include <vector>

#include "panotrack/core/atomic_file.h"
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

// Calls `use` with the n numbers of every data line (header, comments and
// blank lines skipped); throws "SOURCE:LINE: ..." on a bad line. A header is
// a first line of n fields, none of them a number.
template <typename Use>
void ForEachRow(const std::string& csv, const std::string& source, size_t n, const char* what, Use use) {
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

std::string ReadInput(const std::string& path) {
  if (path != "-") return ReadFile(path);
  std::string text{std::istreambuf_iterator<char>(std::cin), std::istreambuf_iterator<char>()};
  if (std::cin.bad()) throw Error("standard input: read failed");
  return text;
}

std::string SourceName(const std::string& path) { return path == "-" ? "<stdin>" : path; }

void WriteOutput(const std::string& path, const std::string& text) {
  WriteFileOrStdout(path.empty() ? "-" : path, text, "-o");
}

}  // namespace

std::string FormatPixel(const Eigen::Vector2d& px) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%.6f %.6f", px.x(), px.y());
  return buf;
}

std::string FormatRay(const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  char buf[256];
  std::snprintf(buf, sizeof buf, "%.9f %.9f %.9f %.9f %.9f %.9f", o.x(), o.y(), o.z(), d.x(), d.y(), d.z());
  return buf;
}

BatchProjection ProjectPointsCsv(const Sensor& sensor, const std::string& csv, const std::string& source) {
  BatchProjection b;
  ForEachRow(csv, source, 3, "x y z", [&](const std::vector<double>& p) {
    ++b.count;
    Eigen::Vector2d px;
    if (!sensor.project({p[0], p[1], p[2]}, &px)) {
      ++b.no_result;
      b.text += "nan nan\n";
    } else if (!sensor.inside_image(px)) {
      ++b.outside_image;
      b.text += "nan nan\n";
    } else {
      b.text += FormatPixel(px) + "\n";
    }
  });
  return b;
}

BatchProjection BackprojectPixelsCsv(const Sensor& sensor, const std::string& csv, const std::string& source) {
  BatchProjection b;
  ForEachRow(csv, source, 2, "u v", [&](const std::vector<double>& p) {
    ++b.count;
    const Eigen::Vector2d px(p[0], p[1]);
    Eigen::Vector3d o, d;
    if (!sensor.inside_image(px)) {
      ++b.outside_image;
      b.text += "nan nan nan nan nan nan\n";
    } else if (!sensor.backproject(px, &o, &d)) {
      ++b.no_result;
      b.text += "nan nan nan nan nan nan\n";
    } else {
      b.text += FormatRay(o, d) + "\n";
    }
  });
  return b;
}

BatchProjection ProjectPointsFile(const Sensor& sensor, const std::string& input, const std::string& output) {
  const BatchProjection b = ProjectPointsCsv(sensor, ReadInput(input), SourceName(input));
  WriteOutput(output, b.text);
  return b;
}

BatchProjection BackprojectPixelsFile(const Sensor& sensor, const std::string& input, const std::string& output) {
  const BatchProjection b = BackprojectPixelsCsv(sensor, ReadInput(input), SourceName(input));
  WriteOutput(output, b.text);
  return b;
}

std::string BatchNote(const BatchProjection& b, bool pixels) {
  if (b.no_result == 0 && b.outside_image == 0) return "";
  std::ostringstream s;
  s << b.count << (pixels ? " pixels: " : " points: ");
  if (b.no_result > 0) s << b.no_result << (pixels ? " off the mirror" : " not visible");
  if (b.no_result > 0 && b.outside_image > 0) s << ", ";
  if (b.outside_image > 0) s << b.outside_image << " outside the image";
  s << " (nan lines)";
  return s.str();
}

}  // namespace pano
