// panoloc's job: localise through whole videos, writing pose CSV files, with
// progress, a summary, accuracy against ground truth, a debug video and a
// trajectory plot. The app parses options into PanolocOptions and calls
// RunPanoloc.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "io/pose_csv.h"
#include "track/localizer.h"

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

struct PanolocOptions {
  std::vector<std::string> inputs;   // videos, image folders or printf patterns
  std::string output;                // one input: the CSV path
  std::string out_dir;               // several: DIR/<input stem>.csv
  std::string calib_path;
  std::string map_path;
  std::optional<Pose2> init;         // else initial_pose of case.yaml beside the input
  double fps = 0.0;                  // 0: the video's own (else 10)
  int jobs = 0;                      // 0: number of cores
  bool quiet = false;
  bool progress = true;              // only shown on a terminal
  std::string gt;                    // ground truth CSV (one input), or "auto": DIR/gt.csv beside each input
  std::string debug_video;           // one input only
  std::string plot;                  // one input only
  LocalizerOptions localizer;
  void Check() const;
};

struct VideoSummary {
  std::string input, output;
  bool ok = false;
  std::string error;
  int frames = 0, n_ok = 0, n_lost = 0;
  double seconds = 0.0;
  bool has_accuracy = false;
  AccuracySummary accuracy;
};

// Localises one input with an already loaded calibration and map. The PH
// tables may be shared between inputs of one calibration and map.
VideoSummary LocalizeVideo(const std::string& input, const std::string& output,
                           const Calibration& calib, const Map& map,
                           std::shared_ptr<const RadiusTable> table, const PanolocOptions& options,
                           const Pose2& init, const std::string& gt_path,
                           const std::string& debug_video, const std::string& plot,
                           std::atomic<long>* frames_done = nullptr,
                           std::shared_ptr<PhTableCache> ph_tables = nullptr);

// Loads the calibration, map and table, then localises every input (in
// parallel, --jobs), printing progress and summaries to stderr/stdout.
// Returns the summaries; throws pano::Error for bad options or files shared
// by all inputs. A failing input does not stop the others.
std::vector<VideoSummary> RunPanoloc(const PanolocOptions& options);

// Loads the calibration's lookup table when it exists, matches and covers
// the map; otherwise builds one (a note on stderr says why).
std::shared_ptr<const RadiusTable> TableForMap(const Calibration& calib, const Map& map, bool quiet);

// Reads initial_pose from the case.yaml beside `input`, when there is one.
std::optional<Pose2> InitialPoseBeside(const std::string& input);

}  // namespace pano
