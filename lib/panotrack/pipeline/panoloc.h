// panoloc's job: localise through whole inputs, writing pose CSV files, with
// progress reports, summaries, accuracy against ground truth, a debug video
// and a trajectory plot. The app parses options into PanolocOptions, sets up
// the progress display and the cancel flag, and calls RunPanoloc.
#pragma once

#include <atomic>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "panotrack/io/pose_csv.h"
#include "panotrack/io/tum.h"
#include "panotrack/lut/table_cache.h"
#include "panotrack/pipeline/accuracy.h"
#include "panotrack/pipeline/localize_video.h"
#include "panotrack/pose/pose2.h"
#include "panotrack/track/localizer.h"

namespace pano {

struct Progress {
  long frames_done = 0;
  long frames_total = -1;  // -1: unknown (live inputs, inputs that cannot be counted)
  double frames_per_s = 0.0;
};
// Called from a thread of the run, about four times a second, never after
// RunPanoloc returns.
using ProgressCallback = std::function<void(const Progress&)>;

struct PanolocOptions {
  std::vector<std::string> inputs;   // videos, image folders, printf patterns, "-", /dev/video0, rtsp://...
  std::string output;                // one input: the CSV path ("-": standard output)
  std::string out_dir;               // or: DIR/<input name>.csv per input (output_names.h)
  std::string calib_path;
  std::string map_path;
  // A guess of the pose at each input's first frame; else initial_pose of
  // the case.yaml beside the input; else none: a room-wide search.
  std::optional<Pose2> init;
  double fps = 0.0;                  // > 0: time_s = frame / fps; 0: the input's timestamps (VideoRunOptions)
  // Frames resized by this factor (0 < scale <= 1) before tracking, and the
  // calibration scaled to match (ScaledSensor): large frames tracked at the
  // resolution the accuracy needs.
  double scale = 1.0;
  int jobs = 0;                      // inputs processed at once; 0: as many as the threads allow
  int num_threads = 0;               // threads of the whole run; 0: all cores
  // Decoded frames that may wait in memory per input (MiB) so that two
  // groups of pictures decode at a time (FrameSourceOptions); 0: never.
  int decode_memory_mib = 128;
  // Videos decoded on the CPU, on NVDEC (an error where it cannot), or on
  // NVDEC where it can (FrameSourceOptions::hardware).
  HardwareDecoding hardware = HardwareDecoding::kNone;
  bool quiet = false;                // no notes on stderr
  // Folder of the E(D,Z) table cache (lut/table_cache.h): the table the map
  // needs is loaded from there, or built and stored there. Empty: built on
  // every run. panoloc passes DefaultTableCacheDir() unless --no-table-cache.
  std::string table_cache_dir;
  bool verbose = false;              // also notes on the table cache's hits and misses
  // Replace existing output files. Otherwise RunPanoloc refuses, before any
  // work, to start when a planned output (pose CSVs, smoothed CSVs, TUM file,
  // debug video, plot, summary JSON) is an existing file (--force).
  bool overwrite = false;
  // Where the caller will write the run's summary as JSON (summary_json.h;
  // "-": standard output): checked with the other outputs. Empty: none.
  std::string summary_json;
  std::string gt;                    // ground truth CSV (one input), or "auto": DIR/gt.csv beside each input
  std::string debug_video;           // one input only
  std::string plot;                  // one input only
  // A second pose CSV beside each output, <output stem>.smoothed.csv: the
  // fixed-lag smoother's poses, `smooth_lag` frames behind the filter. Needs
  // a file output (not "-" or a special file).
  bool smooth = false;
  int smooth_lag = 10;
  // Wheel odometry CSV (io/odometry.h; one input only): the prediction's
  // control input between frames. Empty: constant velocity.
  std::string odometry;
  double odometry_scale = 1.0;       // map units per unit of the odometry's positions
  // The ok rows also as a TUM trajectory (io/tum.h; one input only), for
  // evo and other SLAM evaluation tools: metres, z the sensor's height.
  // Staged like the pose CSV.
  std::string tum;
  double tum_scale = 0.0;            // metres per map unit; 0: from the map's units (Map::UnitsPerMetre)
  // localizer.num_threads 0: the run's threads shared out between the inputs
  // processed at once, one left to each input's decoder.
  LocalizerOptions localizer;
  ProgressCallback on_progress;              // empty: no progress reports
  const std::atomic<bool>* cancel = nullptr;  // set (e.g. by a signal handler): every input stops
  // Throws pano::Error naming the option (flag and field) that is wrong.
  void Check() const;
};

// Loads the calibration, map and table, then localises every input (in
// parallel, `jobs`). Returns one summary per input, in order; throws
// pano::Error for bad options or files shared by all inputs. A failing input
// does not stop the others.
std::vector<VideoSummary> RunPanoloc(const PanolocOptions& options);

// Loads the calibration's lookup table when it exists, matches and covers
// the map; otherwise builds one (a note on stderr says why), through the
// table cache when `cache.dir` is set, on `num_threads` threads (0: every
// core).
std::shared_ptr<const RadiusTable> TableForMap(const Calibration& calib, const Map& map, bool quiet,
                                               const TableCacheOptions& cache = TableCacheOptions(),
                                               int num_threads = 0);

// `<output stem>.smoothed.csv` beside a pose CSV (out.csv -> out.smoothed.csv).
std::string SmoothedOutputPath(const std::string& output);

// The case.yaml files beside `input` (then one folder up) that
// InitialPoseBeside reads, those that exist; none for a live input.
std::vector<std::string> CaseFilesBeside(const std::string& input);

// Reads initial_pose from the case.yaml beside `input` (or one folder up),
// when there is one. None for live inputs.
std::optional<Pose2> InitialPoseBeside(const std::string& input);

}  // namespace pano
