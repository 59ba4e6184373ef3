// Accuracy of an estimated trajectory against ground truth: position and
// heading errors of the frames both have, and the outliers among them.
#pragma once

#include <string>
#include <vector>

#include "panotrack/pose/pose_row.h"
#include "panotrack/scene/map.h"

namespace pano {

struct AccuracySummary {
  int frames = 0;          // ground-truth frames
  int tracked = 0;         // frames with an estimate (ok)
  int compared = 0;        // frames with both
  double rms = 0.0;        // position error RMS
  double std = 0.0;        // standard deviation of the position error vector (bias removed)
  double max = 0.0;
  double mean = 0.0;       // mean position error magnitude
  double heading_rms_deg = 0.0;
  double heading_max_deg = 0.0;
  int outliers = 0;        // position error above 5x the median and 1 % of the mean range
  double std_inliers = 0.0;
};

// Compares estimated rows with ground-truth rows (matched by frame number).
AccuracySummary CompareToGroundTruth(const std::vector<PoseRow>& estimate,
                                     const std::vector<PoseRow>& truth, double typical_range = 0.0);
std::string FormatAccuracy(const AccuracySummary& a, const std::string& units);

// Mean distance from the poses of `rows` to the map's landmark corners: the
// scale below which a position error is not an outlier.
double TypicalRange(const Map& map, const std::vector<PoseRow>& rows);

}  // namespace pano
