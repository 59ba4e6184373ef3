#include "panotrack/io/odometry.h"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>

#include "panotrack/core/angles.h"
#include "panotrack/core/error.h"
#include "panotrack/io/csv_util.h"

namespace pano {

const char* const kOdometryCsvHeader = "time,x,y,theta";

namespace {

// The shortest text that reads back as the same number, for messages.
std::string Number(double v) {
  char buf[64];
  const std::to_chars_result r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

void CheckNonNegative(double v, const char* field) {
  if (!(v >= 0.0) || !std::isfinite(v))
    throw Error(std::string("odometry options: ") + field + " must be a finite number >= 0, got " + Number(v));
}

void CheckSpan(const std::vector<OdometrySample>& samples, double t) {
  if (samples.empty()) throw Error("odometry: no samples");
  if (!(t >= samples.front().time_s && t <= samples.back().time_s))
    throw Error("odometry: time " + Number(t) + " s is outside the samples' times [" +
                Number(samples.front().time_s) + ", " + Number(samples.back().time_s) + "] s");
}

// The index i of the segment [i, i + 1] holding t (i + 1 == size for the last
// sample itself); t within the samples' times.
size_t SegmentOf(const std::vector<OdometrySample>& samples, double t) {
  const auto after = std::upper_bound(samples.begin(), samples.end(), t,
                                      [](double v, const OdometrySample& s) { return v < s.time_s; });
  return static_cast<size_t>(after - samples.begin()) - 1;
}

Pose2 Interpolate(const std::vector<OdometrySample>& samples, size_t i, double t) {
  const OdometrySample& a = samples[i];
  if (i + 1 >= samples.size() || t <= a.time_s) return a.pose;
  const OdometrySample& b = samples[i + 1];
  const double s = (t - a.time_s) / (b.time_s - a.time_s);
  return {a.pose.x + s * (b.pose.x - a.pose.x), a.pose.y + s * (b.pose.y - a.pose.y),
          WrapAngle(a.pose.theta + s * WrapAngle(b.pose.theta - a.pose.theta))};
}

}  // namespace

std::vector<OdometrySample> ReadOdometryCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot open the file");
  std::string line;
  if (!std::getline(in, line))
    throw Error(path + ": empty file (expected the header '" + std::string(kOdometryCsvHeader) + "')");
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (line != kOdometryCsvHeader)
    throw Error(path + ": line 1: expected the header '" + std::string(kOdometryCsvHeader) + "', got '" +
                QuotedText(line) + "'");
  std::vector<OdometrySample> samples;
  for (int lineno = 2; std::getline(in, line); ++lineno) {
    if (line.empty() || line == "\r") continue;
    const std::string where = path + ": line " + std::to_string(lineno);
    const std::vector<std::string> f = SplitCsv(line);
    if (f.size() != 4)
      throw Error(where + ": expected 4 columns, got " + std::to_string(f.size()));
    OdometrySample s;
    s.time_s = ParseCsvDouble(f[0], where, "time");
    s.pose.x = ParseCsvDouble(f[1], where, "x");
    s.pose.y = ParseCsvDouble(f[2], where, "y");
    s.pose.theta = ParseCsvDouble(f[3], where, "theta");
    if (!samples.empty() && !(s.time_s > samples.back().time_s))
      throw Error(where + ": times must increase strictly (" + f[0] + " after " +
                  Number(samples.back().time_s) + ")");
    samples.push_back(s);
  }
  if (samples.empty()) throw Error(path + ": no samples after the header");
  return samples;
}

void OdometryOptions::Check() const {
  if (!(map_units_per_odometry_unit > 0.0) || !std::isfinite(map_units_per_odometry_unit))
    throw Error("odometry options: map_units_per_odometry_unit must be a positive finite number, got " +
                Number(map_units_per_odometry_unit));
  CheckNonNegative(position_variance_per_distance, "position_variance_per_distance");
  CheckNonNegative(heading_variance_per_turn, "heading_variance_per_turn");
  CheckNonNegative(heading_variance_per_distance, "heading_variance_per_distance");
}

Pose2 OdometryPoseAt(const std::vector<OdometrySample>& samples, double t) {
  CheckSpan(samples, t);
  return Interpolate(samples, SegmentOf(samples, t), t);
}

OdometryIncrement Between(const std::vector<OdometrySample>& samples, double t0, double t1,
                          const OdometryOptions& options) {
  options.Check();
  CheckSpan(samples, t0);
  CheckSpan(samples, t1);
  if (t1 < t0) throw Error("odometry: increment from " + Number(t0) + " s back to " + Number(t1) + " s");
  const size_t i0 = SegmentOf(samples, t0);
  const size_t i1 = SegmentOf(samples, t1);
  const Pose2 start = Interpolate(samples, i0, t0);
  const Pose2 end = Interpolate(samples, i1, t1);

  // Walk the path start, samples strictly inside (t0, t1), end: its length,
  // the heading change and the angle turned.
  double distance = 0.0, dtheta = 0.0, turned = 0.0;
  Pose2 prev = start;
  auto walk_to = [&](const Pose2& p) {
    distance += std::hypot(p.x - prev.x, p.y - prev.y);
    const double d = WrapAngle(p.theta - prev.theta);
    dtheta += d;
    turned += std::abs(d);
    prev = p;
  };
  for (size_t i = i0 + 1; i <= i1 && i < samples.size(); ++i)
    if (samples[i].time_s < t1) walk_to(samples[i].pose);
  walk_to(end);

  const double scale = options.map_units_per_odometry_unit;
  const double c = std::cos(start.theta), s = std::sin(start.theta);
  const double wx = end.x - start.x, wy = end.y - start.y;
  OdometryIncrement inc;
  inc.dx = scale * (c * wx + s * wy);
  inc.dy = scale * (-s * wx + c * wy);
  inc.dtheta = dtheta;
  distance *= scale;
  const double position_variance = options.position_variance_per_distance * distance;
  inc.covariance = Eigen::Vector3d(position_variance, position_variance,
                                   options.heading_variance_per_turn * turned +
                                       options.heading_variance_per_distance * distance)
                       .asDiagonal();
  return inc;
}

}  // namespace pano
