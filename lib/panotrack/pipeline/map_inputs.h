// What panomap's commands check of their inputs before any work, with the
// same one-line errors: the map's units against the calibration's, a pose
// CSV with one row per frame, the video's frame size.
#pragma once

#include <string>
#include <vector>

#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/pose/pose_row.h"

namespace pano {

std::string SizeText(int width, int height);

// Throws pano::Error when the map's units differ from the calibration's.
void CheckMapUnits(const Calibration& calib, const Map& map, const std::string& map_path,
                   const std::string& calib_path);

// The rows of a pose CSV that must hold frame 0, 1, 2... in order (one row
// per frame of `input`); throws pano::Error naming the first row that does not.
std::vector<PoseRow> ReadPosesOnePerFrame(const std::string& poses_path, const std::string& input);

// Throws pano::Error when `input`'s frames are not the calibration's size.
void CheckFrameSize(int width, int height, const Sensor& sensor, const std::string& input,
                    const std::string& calib_path);

}  // namespace pano
