#include "panotrack/pipeline/target_input.h"

#include <opencv2/imgcodecs.hpp>

#include <memory>

#include "panotrack/core/error.h"
#include "panotrack/video/frame_source.h"

namespace pano {

namespace {

// A video read front to back: the frames wanted, in increasing order.
// Decoded by the frame source that panoloc and panomap read videos with, so
// that a truncated or damaged board video fails as theirs do (one line
// naming the file and the frame) instead of calibrating from the frames
// before the damage.
class VideoReader {
 public:
  explicit VideoReader(const std::string& path) : path_(path), source_(path) {}
  cv::Mat Frame(int index) {
    if (index < next_) throw Error(path_ + ": internal: video frames out of order");
    cv::Mat grey;
    for (; next_ <= index; ++next_)
      if (!source_.Read(&grey)) throw Error(path_ + ": the video ends before frame " + std::to_string(index));
    return grey.clone();  // Read()'s buffer is the decoder's to reuse
  }

 private:
  std::string path_;
  FrameSource source_;
  int next_ = 0;
};

}  // namespace

int CountVideoFrames(const std::string& path) {
  // Counted by reading: the container's frame count may be an estimate.
  FrameSource source(path);
  cv::Mat frame;
  int n = 0;
  while (source.Read(&frame)) ++n;
  return n;
}

TargetSet ReadTargetInput(const std::string& path, const TargetInputBoard& input) {
  switch (ClassifyTargetInput(path)) {
    case TargetInputKind::kTargetFile:
      if (input.board_given)
        throw Error("--board: " + path + " is a target file, which gives the board itself");
      return ReadTargets(path);
    case TargetInputKind::kImageFolder:
      if (!input.board_given) throw Error("--board: required with a folder of images (e.g. --board 7x11 --square 30)");
      return TargetsFromFolder(path, input.board, input.units);
    case TargetInputKind::kVideo:
      if (!input.board_given) throw Error("--board: required with a video (e.g. --board 7x11 --square 30)");
      return TargetsFromVideoFrames(path, CountVideoFrames(path), input.every, input.board, input.units);
  }
  throw Error(path + ": internal: unknown input kind");
}

NamedPaths TargetInputReads(const std::string& path, const TargetSet& targets, const std::string& option) {
  NamedPaths reads = {{option, path}};
  for (const TargetImage& ti : targets.images) reads.push_back({"a board image of " + path, ti.resolved});
  return reads;
}

std::vector<cv::Mat> LoadTargetImages(const TargetSet& targets) {
  std::vector<cv::Mat> images;
  std::unique_ptr<VideoReader> video;
  std::string video_path;
  for (const TargetImage& ti : targets.images) {
    cv::Mat im;
    if (ti.frame >= 0) {
      if (!video || video_path != ti.resolved) {
        video = std::make_unique<VideoReader>(ti.resolved);
        video_path = ti.resolved;
      }
      im = video->Frame(ti.frame);
    } else {
      FrameSource::CheckImageComplete(ti.resolved);  // a PNG cut short: one line, not libpng's
      im = cv::imread(ti.resolved, cv::IMREAD_GRAYSCALE);
      if (im.empty()) throw Error(ti.resolved + ": cannot read the image (missing or not an image file)");
    }
    if (!images.empty() && im.size() != images.front().size())
      throw Error(ti.file + ": image size " + std::to_string(im.cols) + "x" + std::to_string(im.rows) +
                  " differs from " + targets.images.front().file + " (" +
                  std::to_string(images.front().cols) + "x" + std::to_string(images.front().rows) +
                  "): all calibration images must come from one camera setting");
    images.push_back(im);
  }
  return images;
}

}  // namespace pano
