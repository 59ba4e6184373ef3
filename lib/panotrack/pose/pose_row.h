// One row of a trajectory: the pose of one frame and how it was obtained.
// io/pose_csv.h reads and writes rows as the pose CSV (docs/panoloc.md).
#pragma once

#include <vector>

#include "panotrack/pose/pose2.h"
#include "panotrack/sensor/sensor.h"

namespace pano {

enum class PoseStatus { kOk, kLost, kInit };
const char* PoseStatusName(PoseStatus s);

struct PoseRow {
  int frame = 0;
  double time_s = 0.0;
  PoseStatus status = PoseStatus::kOk;
  Pose2 pose;  // meaningless when status is kLost
  int n_landmarks = 0;
  double residual = 0.0;
  // Trailing columns (std_x, std_y, std_theta for panoloc); NaN where empty.
  std::vector<double> extra;
};

}  // namespace pano
