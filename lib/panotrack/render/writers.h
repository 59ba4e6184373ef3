// panosim's outputs: a still PNG, a sequence folder, all written so that
// nothing half-written is ever left in place.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "panotrack/render/presets.h"
#include "panotrack/render/sequence.h"

namespace pano {

// Writes an 8-bit image as PNG atomically; throws pano::Error naming `path`.
void WritePng(const std::string& path, const cv::Mat& image);

// A folder built under a temporary name beside `final_dir` and renamed into
// place by Commit(); removed when destroyed uncommitted. An existing
// `final_dir` is an error unless it is empty or `overwrite`.
class StagingDir {
 public:
  StagingDir(const std::string& final_dir, bool overwrite, const std::string& option = "-o");
  ~StagingDir();
  StagingDir(const StagingDir&) = delete;
  StagingDir& operator=(const StagingDir&) = delete;
  const std::string& path() const { return temp_; }
  std::string File(const std::string& name) const { return temp_ + "/" + name; }
  void Commit();

 private:
  std::string final_;
  std::string temp_;
  bool overwrite_;
  bool committed_ = false;
};

struct SequenceWriteOptions {
  bool frames = false;     // also DIR/frames/frame_%04d.png (lossless)
  bool video = true;       // DIR/video.mp4
  bool overwrite = false;  // replace an existing DIR
  // Progress (frames rendered of all, every tenth and the last) and notes
  // (a video codec other than H.264); empty: silent.
  std::function<void(int done, int total)> on_progress;
  std::function<void(const std::string&)> on_note;
};

struct SequenceWriteResult {
  std::string codec;  // "h264", "mp4v" or "" (no video)
  int frames = 0;
};

// Renders every pose and writes DIR/video.mp4, DIR/gt.csv, DIR/gt.tum, DIR/map.yaml
// (without distractors), DIR/calib.yaml, DIR/case.yaml and, when asked,
// DIR/frames/. With survey error (c.survey) map.yaml is the surveyed map
// (render/sequence.h SurveyMap), DIR/map_true.yaml the room rendered and,
// with gross faults, DIR/map_faults.yaml lists them (MapFaultsYaml). gt.csv: status ok, n_landmarks = corners in view of the map's
// surfaces (people and covers not counted), residual 0. Frames are rendered by
// SequenceRenderer (render/sequence.h); dropped frames are left out of the
// video, gt.csv and frames/, so gt.csv's frame column is the video's frame
// index (constant rate) while its time column is the true time. gt.tum: the
// poses of gt.csv, as written (four decimals), as a TUM trajectory (io/tum.h:
// metres, z the sensor height) on the video's clock (frame / fps, as panoloc
// writes it), for evo.
SequenceWriteResult WriteSequence(const SequenceCase& c, const std::string& dir,
                                  const SequenceWriteOptions& options);

// case.yaml text.
std::string CaseYaml(const SequenceCase& c, const std::string& codec);

// map_faults.yaml text: the map's units, then one entry per fault (id,
// kind: moved / not-in-room / not-in-map, and for a moved one its offset,
// the map's rectangle minus the room's).
std::string MapFaultsYaml(const std::vector<MapFault>& faults, const std::string& units);

}  // namespace pano
