// Rendered calibration images for the calibrator's tests.
#pragma once

#include <cstdint>
#include <string>

#include "panotrack/io/targets.h"
#include "panotrack/render/targets_render.h"
#include "panotrack/sensor/calibration.h"
#include "test_paths.h"

namespace pano::test {

// panosim targets --auto n --noise 2 --seed seed with the paper-real sphere
// (board 9 x 6 x 3 cm) into a scratch folder; returns the folder.
inline std::string RenderTargets(const std::string& name, const Calibration& truth, int n, uint64_t seed) {
  const std::string dir = ScratchDir(name) + "/t";
  TargetBoard board;
  board.cols = 9;
  board.rows = 6;
  board.square = 3.0;
  RenderOptions ro;
  ro.noise_sigma = 2.0;
  ro.seed = seed;
  TargetsWriteOptions wo;
  wo.overwrite = true;
  WriteTargetImages(dir, truth, board, AutoBoardPoses(truth.sensor, board, n, seed), ro, wo);
  return dir;
}

}  // namespace pano::test
