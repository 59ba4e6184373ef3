// Calibration images for panocalib: a chessboard (README, "Files and conventions") ray traced
// in the sensor frame, X_sensor = R(rvec) X_board + tvec (OpenCV convention).
#pragma once

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "panotrack/sensor/calibration.h"
#include "panotrack/io/targets.h"
#include "panotrack/render/render.h"

namespace pano {

struct BoardPose {
  std::array<double, 3> rvec{};
  std::array<double, 3> tvec{};
};

// Reads `rx,ry,rz,tx,ty,tz` lines after a header; names the file and line in errors.
std::vector<BoardPose> ReadBoardPoses(const std::string& path);

// Board corners in the sensor frame: inner corner (i, j) at board (i s, j s, 0),
// row-major (j outer).
std::vector<Eigen::Vector3d> BoardCornersSensor(const TargetBoard& board, const BoardPose& pose);

// True when every inner corner projects inside the image and inside the
// annulus [inner, outer] * limb radius, and the board faces the mirror with its -z side.
bool BoardFullyVisible(const Sensor& sensor, const TargetBoard& board, const BoardPose& pose,
                       double inner = 0.1, double outer = 0.98);

// Fraction of the inner corners that project inside the image and inside
// the annulus [inner, outer] * limb radius (0 when the board shows its back).
double BoardVisibleFraction(const Sensor& sensor, const TargetBoard& board, const BoardPose& pose,
                            double inner = 0.1, double outer = 0.98);

// `n` random board poses around the mirror (bearings spread over the circle),
// each with at least `min_visible` of its inner corners in view (1: fully
// visible; below 1, e.g. 0.4 for ChArUco boards, boards run past the limb);
// deterministic in `seed`. Throws when the board is too big for the sensor.
std::vector<BoardPose> AutoBoardPoses(const Sensor& sensor, const TargetBoard& board, int n,
                                      uint64_t seed, double min_visible = 1.0);

// Renders the board seen from the sensor; other rays see a uniform grey
// (shade `options.background`, 0.45 when 0). Black squares 0.08, white 0.92;
// a white margin of one square surrounds the (cols + 1) x (rows + 1) squares.
// A ChArUco board (board.type charuco) is the image DrawCharucoBoard prints,
// mapped onto the board plane.
cv::Mat RenderBoard(const RayTable& table, const TargetBoard& board, const BoardPose& pose,
                    const RenderOptions& options, int index);

struct TargetsWriteOptions {
  bool overwrite = false;
  // Progress (images written of all); empty: silent.
  std::function<void(int done, int total)> on_progress;
};

// Writes DIR/cal_NNN.png, DIR/targets.yaml (poses), DIR/targets_unknown.yaml
// (no poses) and DIR/truth.yaml (the calibration used), all or nothing.
void WriteTargetImages(const std::string& dir, const Calibration& calib, const TargetBoard& board,
                       const std::vector<BoardPose>& poses, const RenderOptions& options,
                       const TargetsWriteOptions& wo);

}  // namespace pano
