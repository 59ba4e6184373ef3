// Many points or pixels through a calibration at once (`panocalib project
// --points FILE`, `panocalib backproject --pixels FILE`): one input per line,
// one output line per input, in the single-point commands' format.
//
// Input: numbers separated by commas and/or whitespace (x y z for points,
// u v for pixels); '#' starts a comment; blank lines are skipped; the first
// line whose fields are all non-numeric is a header and is skipped. Any other
// line that is not exactly the expected count of finite numbers is an error
// "SOURCE:LINE: ..." and nothing is written.
//
// Output: a point that does not project (behind or beyond the mirror, or a
// pixel outside the image) and a pixel without a ray (off the mirror, or
// outside the image) give a line of "nan" fields, so that output line k
// still belongs to input point k; they are counted.
#pragma once

#include <Eigen/Core>
#include <string>

#include "panotrack/sensor/sensor.h"

namespace pano {

// The single-point forms' text (no newline): "u v" (6 decimals), and
// "ox oy oz dx dy dz" (9 decimals).
std::string FormatPixel(const Eigen::Vector2d& pixel);
std::string FormatRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction);

struct BatchProjection {
  std::string text;        // one line per input point or pixel
  int count = 0;           // inputs read
  int no_result = 0;       // not visible / off the mirror: nan lines
  int outside_image = 0;   // pixel outside the image: nan lines
};

// `csv` is the input's text; `source` names it in errors ("points.csv").
// Throws pano::Error "SOURCE:LINE: ..." on a line that cannot be read.
BatchProjection ProjectPointsCsv(const Sensor& sensor, const std::string& csv, const std::string& source);
BatchProjection BackprojectPixelsCsv(const Sensor& sensor, const std::string& csv, const std::string& source);

// "N points: K not visible (nan lines), M outside the image (nan lines)"
// style note for stderr; empty when every input gave a result.
std::string BatchNote(const BatchProjection& b, bool pixels);

}  // namespace pano
