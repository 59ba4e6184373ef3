// Calibration target file (spec section 6): chessboard images, with board
// poses when they are known.
#pragma once

#include <array>
#include <string>
#include <vector>

namespace pano {

// Inner corners a board may have along each side; more are taken for a
// corrupt file rather than allocated.
constexpr int kMaxBoardCorners = 1000;

struct TargetBoard {
  std::string type = "chessboard";
  int cols = 0;  // inner corners along the board's x axis
  int rows = 0;  // inner corners along the board's y axis
  double square = 0.0;
};

struct TargetImage {
  std::string file;           // as written
  std::string resolved;       // relative to the target file's folder
  bool has_pose = false;
  std::array<double, 3> rvec{};  // X_sensor = R(rvec) X_board + tvec
  std::array<double, 3> tvec{};
};

struct TargetSet {
  std::string units = "cm";
  TargetBoard board;
  std::vector<TargetImage> images;
  // True when every image has a pose (known targets).
  bool AllPosesKnown() const;
};

TargetSet ReadTargets(const std::string& path);
// Writes atomically; `with_poses` false leaves rvec/tvec out.
void WriteTargets(const std::string& path, const TargetSet& set, bool with_poses = true);
std::string TargetsToYaml(const TargetSet& set, bool with_poses = true);

}  // namespace pano
