#include "panotrack/pipeline/accuracy.h"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "panotrack/core/angles.h"

namespace pano {

AccuracySummary CompareToGroundTruth(const std::vector<PoseRow>& est, const std::vector<PoseRow>& gt,
                                     double typical_range) {
  AccuracySummary a;
  std::map<int, const PoseRow*> by_frame;
  for (const PoseRow& r : est)
    if (r.status == PoseStatus::kOk) by_frame[r.frame] = &r;
  std::vector<Eigen::Vector2d> errors;
  std::vector<double> heading;
  for (const PoseRow& g : gt) {
    if (g.status == PoseStatus::kLost) continue;
    ++a.frames;
    auto it = by_frame.find(g.frame);
    if (it == by_frame.end()) continue;
    errors.emplace_back(it->second->pose.x - g.pose.x, it->second->pose.y - g.pose.y);
    heading.push_back(WrapAngle(it->second->pose.theta - g.pose.theta));
  }
  a.tracked = static_cast<int>(by_frame.size());
  a.compared = static_cast<int>(errors.size());
  if (errors.empty()) return a;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  double sum2 = 0, sum_h2 = 0;
  std::vector<double> mags;
  for (size_t i = 0; i < errors.size(); ++i) {
    mean += errors[i];
    sum2 += errors[i].squaredNorm();
    mags.push_back(errors[i].norm());
    a.max = std::max(a.max, mags.back());
    a.mean += mags.back();
    sum_h2 += heading[i] * heading[i];
    a.heading_max_deg = std::max(a.heading_max_deg, std::abs(heading[i]) * 180 / M_PI);
  }
  const double n = static_cast<double>(errors.size());
  mean /= n;
  a.mean /= n;
  a.rms = std::sqrt(sum2 / n);
  a.std = std::sqrt(std::max(0.0, sum2 / n - mean.squaredNorm()));
  a.heading_rms_deg = std::sqrt(sum_h2 / n) * 180 / M_PI;
  std::vector<double> sorted = mags;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double median = sorted[sorted.size() / 2];
  const double limit = std::max(5.0 * median, 0.01 * typical_range);
  Eigen::Vector2d m_in = Eigen::Vector2d::Zero();
  double s_in = 0;
  int n_in = 0;
  for (size_t i = 0; i < errors.size(); ++i) {
    if (mags[i] > limit && limit > 0) {
      ++a.outliers;
      continue;
    }
    m_in += errors[i];
    s_in += errors[i].squaredNorm();
    ++n_in;
  }
  if (n_in > 0) {
    m_in /= n_in;
    a.std_inliers = std::sqrt(std::max(0.0, s_in / n_in - m_in.squaredNorm()));
  }
  return a;
}

std::string FormatAccuracy(const AccuracySummary& a, const std::string& units) {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "position error: RMS %.3f, std %.3f, mean %.3f, max %.3f %s; heading error: RMS %.3f, "
                "max %.3f deg; outliers %d (%.1f %%); frames tracked %d/%d",
                a.rms, a.std, a.mean, a.max, units.c_str(), a.heading_rms_deg, a.heading_max_deg,
                a.outliers, a.compared ? 100.0 * a.outliers / a.compared : 0.0, a.tracked, a.frames);
  return buf;
}

double TypicalRange(const Map& map, const std::vector<PoseRow>& rows) {
  std::vector<Eigen::Vector2d> corners;
  for (const auto& r : map.rectangles) corners.push_back(r.from), corners.push_back(r.to);
  for (const auto& b : map.boxes) corners.push_back(b.min.head<2>()), corners.push_back(b.max.head<2>());
  double sum = 0;
  int n = 0;
  for (const auto& row : rows) {
    if (row.status == PoseStatus::kLost) continue;
    for (const auto& c : corners) sum += (c - Eigen::Vector2d(row.pose.x, row.pose.y)).norm(), ++n;
  }
  return n ? sum / n : 0.0;
}

}  // namespace pano
