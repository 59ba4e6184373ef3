#include <opencv2/imgcodecs.hpp>

#include <filesystem>
#include <utility>

#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"
#include "panotrack/core/output_check.h"
#include "panotrack/io/calibration.h"
#include "panotrack/pipeline/unwarp_files.h"
#include "panotrack/video/frame_source.h"

namespace pano {

UnwarpView UnwarpImageFile(const std::string& calib_path, const std::string& image_path,
                           const std::string& out_path, const UnwarpOptions& options, bool overwrite) {
  if (out_path.empty()) throw Error("-o: expected an output image");
  CheckPlannedOutputs({{"--calib", calib_path}, {"", image_path}}, {{"-o", out_path}}, overwrite);
  const Calibration calib = ReadCalibration(calib_path);
  UnwarpView view(calib.sensor, options);
  // Read here (bounded, a folder refused with its name), decoded by OpenCV:
  // imread says nothing about why it fails.
  const std::string bytes = ReadFile(image_path, size_t{256} << 20);
  if (bytes.empty()) throw Error(image_path + ": empty file, expected an image");
  FrameSource::CheckImageComplete(image_path);  // before libpng prints its own line
  cv::Mat image;
  try {
    image = cv::imdecode(cv::Mat(1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data())),
                         cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw Error(image_path + ": cannot read the image: " + e.what());
  }
  if (image.empty()) throw Error(image_path + ": cannot read the image (not an image format OpenCV decodes)");
  cv::Mat out;
  try {
    out = view.Unwarp(image);
  } catch (const Error& e) {
    throw Error(image_path + ": " + e.what());
  }
  AtomicFile file(out_path);
  bool written = false;
  try {
    written = cv::imwrite(file.temp_path(), out);
  } catch (const cv::Exception& e) {
    throw Error(out_path + ": cannot write the image: " + e.what());
  }
  if (!written) throw Error(out_path + ": cannot write the image (is the folder writable, the extension an image format's?)");
  file.Commit();
  return view;
}

UnwarpResult RunUnwarp(const UnwarpJob& job) {
  int frames = -1;
  UnwarpView view = IsVideoPath(job.output)
                        ? UnwarpVideoFile(job.calibration, job.input, job.output, job.options, job.overwrite, &frames)
                        : UnwarpImageFile(job.calibration, job.input, job.output, job.options, job.overwrite);
  return {std::move(view), frames};
}

}  // namespace pano
