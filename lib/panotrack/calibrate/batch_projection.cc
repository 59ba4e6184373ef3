#include "panotrack/calibrate/batch_projection.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <vector>

#include "panotrack/core/error.h"
#include "panotrack/io/number_rows.h"

namespace pano {

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
  ForEachNumberRow(csv, source, 3, "x y z", [&](const std::vector<double>& p) {
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
  ForEachNumberRow(csv, source, 2, "u v", [&](const std::vector<double>& p) {
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
