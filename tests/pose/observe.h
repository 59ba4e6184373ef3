// Exact bearings of landmarks seen from a pose: the pose tests' observations.
#pragma once

#include <cmath>
#include <vector>

#include "panotrack/core/angles.h"
#include "panotrack/pose/pose2.h"
#include "panotrack/pose/triangulate.h"

namespace pano::test {

inline std::vector<BearingObservation> Observe(const Pose2& pose, const std::vector<Eigen::Vector2d>& lms) {
  std::vector<BearingObservation> obs;
  for (size_t i = 0; i < lms.size(); ++i) {
    BearingObservation o;
    o.landmark = lms[i];
    o.bearing = WrapAngle(std::atan2(lms[i].y() - pose.y, lms[i].x() - pose.x) - pose.theta);
    o.id = static_cast<int>(i);
    obs.push_back(o);
  }
  return obs;
}

}  // namespace pano::test
