#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <algorithm>
#include <cctype>
#include <filesystem>

#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"
#include "panotrack/core/output_check.h"
#include "panotrack/io/calibration.h"
#include "panotrack/pipeline/unwarp_files.h"
#include "panotrack/video/frame_source.h"

namespace pano {

bool IsVideoPath(const std::string& path) {
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || path.find('/', dot) != std::string::npos) return false;
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == "mp4" || ext == "avi" || ext == "mkv" || ext == "mov";
}

UnwarpView UnwarpVideoFile(const std::string& calib_path, const std::string& input_path,
                           const std::string& out_path, const UnwarpOptions& options, bool overwrite,
                           int* frames) {
  if (out_path.empty()) throw Error("-o: expected an output video");
  NamedPaths reads = FrameSource::InputReads(input_path);
  reads.push_back({"--calib", calib_path});
  CheckPlannedOutputs(reads, {{"-o", out_path}}, overwrite);
  const Calibration calib = ReadCalibration(calib_path);
  UnwarpOptions even = options;
  {
    const UnwarpView first(calib.sensor, options);
    if (options.width == 0) even.width = first.width() + first.width() % 2;
    if (options.height == 0) even.height = first.height() + first.height() % 2;
  }
  const UnwarpView view(calib.sensor, even);
  // The encoder would crop an odd side silently.
  if (view.width() % 2 || view.height() % 2)
    throw Error("unwarp size: a video needs even sides, got " + std::to_string(view.width()) + "x" +
                std::to_string(view.height()));
  FrameSource source(input_path);
  if (source.width() != calib.sensor.image_width || source.height() != calib.sensor.image_height)
    throw Error(input_path + ": the frames are " + std::to_string(source.width()) + "x" +
                std::to_string(source.height()) + ", the calibration's " +
                std::to_string(calib.sensor.image_width) + "x" + std::to_string(calib.sensor.image_height));
  const double fps = source.fps() > 0.0 ? source.fps() : 10.0;
  const cv::Size size(view.width(), view.height());
  AtomicFile file(out_path);
  cv::VideoWriter writer;
  if (!writer.open(file.temp_path(), cv::VideoWriter::fourcc('m', 'p', '4', 'v'), fps, size, true))
    throw Error(out_path + ": cannot open a video writer (" + std::to_string(size.width) + "x" +
                std::to_string(size.height) + ")");
  cv::Mat grey, colour;
  int n = 0;
  while (source.Read(&grey)) {
    cv::cvtColor(view.Unwarp(grey), colour, cv::COLOR_GRAY2BGR);
    writer.write(colour);
    ++n;
  }
  writer.release();
  file.Commit();
  if (frames) *frames = n;
  return view;
}

}  // namespace pano
