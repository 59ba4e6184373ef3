#include "panotrack/pipeline/map_inputs.h"

#include "panotrack/core/error.h"
#include "panotrack/io/pose_csv.h"

namespace pano {

std::string SizeText(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

void CheckMapUnits(const Calibration& calib, const Map& map, const std::string& map_path,
                   const std::string& calib_path) {
  if (calib.units != map.units)
    throw Error(map_path + ": units '" + map.units + "' differ from the calibration's '" + calib.units + "' (" +
                calib_path + ")");
}

std::vector<PoseRow> ReadPosesOnePerFrame(const std::string& poses_path, const std::string& input) {
  std::vector<PoseRow> rows = ReadPoseCsv(poses_path);
  for (size_t i = 0; i < rows.size(); ++i)
    if (rows[i].frame != static_cast<int>(i))
      throw Error(poses_path + ": row " + std::to_string(i + 1) + " is frame " + std::to_string(rows[i].frame) +
                  ", expected frame " + std::to_string(i) + " (one row per frame of " + input + ")");
  return rows;
}

void CheckFrameSize(int width, int height, const Sensor& sensor, const std::string& input,
                    const std::string& calib_path) {
  if (width != sensor.image_width || height != sensor.image_height)
    throw Error(input + ": frame size " + SizeText(width, height) + " does not match the calibration's " +
                SizeText(sensor.image_width, sensor.image_height) + " (" + calib_path + ")");
}

}  // namespace pano
