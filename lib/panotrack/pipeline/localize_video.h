// One input of panoloc from its first frame to its last: the localiser over
// every frame, the pose CSV row by row, and the debug video, plot and
// accuracy when asked for.
#pragma once

#include <atomic>
#include <future>
#include <memory>
#include <optional>
#include <string>

#include "panotrack/io/odometry.h"
#include "panotrack/io/tum.h"
#include "panotrack/pipeline/accuracy.h"
#include "panotrack/pose/pose2.h"
#include "panotrack/sensor/calibration.h"
#include "panotrack/scene/map.h"
#include "panotrack/track/localizer.h"
#include "panotrack/track/motion_model.h"
#include "panotrack/video/frame_source.h"

namespace pano {

// One input and where its results go.
struct VideoJob {
  std::string input;        // video file, image folder, printf pattern or live input ("-", /dev/video0, rtsp://)
  std::string output;       // pose CSV (written as <output>.partial until the run ends); "-": standard output
  // A guess of the pose at the first frame, which tracking starts from; none:
  // the first frame is localised by searching the whole room.
  std::optional<Pose2> init;
  std::string gt;           // ground-truth pose CSV for the accuracy summary; empty: none
  std::string debug_video;  // annotated video; empty: none
  std::string plot;         // trajectory PNG; empty: none
  // Pose CSV of the fixed-lag smoother's estimates (staged like `output`);
  // empty: none. Rows of frames with a measured pose (ok) carry the smoothed
  // pose and standard deviations; every other row is as in `output`.
  std::string smoothed_output;
  // Wheel odometry on the input's clock: the increment between consecutive
  // frames is the prediction's control input. Null: constant velocity.
  std::shared_ptr<const std::vector<OdometrySample>> odometry;
  // TUM trajectory of the ok rows (io/tum.h; staged like `output`); empty: none.
  std::string tum;
};

struct TrackingTables {
  std::shared_ptr<const RadiusTable> table;
  std::shared_ptr<PhTableCache> ph_tables;  // null: each localiser builds its own
};

// Loaded once and shared, read-only, by every input of a run.
struct SharedResources {
  Calibration calib;
  std::string calib_path;  // named in messages
  Map map;
  std::shared_ptr<const RadiusTable> table;
  std::shared_ptr<PhTableCache> ph_tables;  // null: each localiser builds its own
  // Instead of `table` and `ph_tables`: tables still being loaded or built.
  // LocalizeVideo waits for them once its input is open and decoding, so
  // that a table build overlaps the decoder's start.
  std::shared_future<TrackingTables> pending_tables;
  // The room-wide search's index, built once for all inputs (null: each
  // input's localiser builds its own).
  std::shared_ptr<SharedRelocalizationIndex> relocalization_index;
};

// How each input is processed.
struct VideoRunOptions {
  LocalizerOptions localizer;  // num_threads: threads of the per-frame loops
  // FFmpeg's decoding threads per input; 0: FFmpeg's choice (a thread per
  // core, and one more).
  int decoder_threads = 0;
  // FrameSourceOptions::gop_parallel_bytes.
  size_t gop_parallel_bytes = FrameSourceOptions().gop_parallel_bytes;
  // FrameSourceOptions::hardware: the CPU, or NVDEC.
  HardwareDecoding hardware = HardwareDecoding::kNone;
  // Inputs other than live ones are tracked at idle priority while the
  // tracker keeps up with decoding (core/thread_priority.h): decoding, the
  // slower of the two, keeps the cores, and tracking fills the gaps that
  // its threads leave. Needs localizer.num_threads == 1.
  bool track_in_decoding_gaps = false;
  // > 0: time_s = frame / fps, for inputs without timestamps; 0: the input's
  // timestamps, else frame / its frame rate, else frame / 10.
  double fps = 0.0;
  // Frames are resized by this factor before tracking (the calibration in
  // SharedResources is already scaled so).
  double scale = 1.0;
  // Checked before each frame: when set, the frame in progress is finished
  // and the input ends as interrupted, its rows and outputs kept.
  const std::atomic<bool>* cancel = nullptr;
  std::atomic<long>* frames_done = nullptr;  // incremented per frame, for progress displays
  FixedLagSmootherOptions smoother;          // for VideoJob::smoothed_output
  // For VideoJob::odometry: the log's scale, and its noise in map units
  // (OdometryOptionsForMap scales the defaults).
  OdometryOptions odometry;
  bool quiet = false;  // no notes on stderr (odometry not covering frames)
  TumConversion tum;   // for VideoJob::tum: map units to metres, z
};

// The odometry noise defaults (which suit metres) with the length-based
// variances rescaled for the map's units, as the localiser rescales its
// motion model; `map_units_per_odometry_unit` is set from the argument.
OdometryOptions OdometryOptionsForMap(const Map& map, double map_units_per_odometry_unit);

// A run that reads frames but tracks fewer than this fraction of them (over
// at least kMinFramesJudged frames), or none at all, failed: its settings
// rather than the video are likely wrong.
constexpr double kMinTrackedFraction = 0.1;
constexpr int kMinFramesJudged = 20;

enum class VideoEnd {
  kDone,         // every frame read, enough of them tracked
  kFailed,       // nothing done: the input or an output could not be used (error says why)
  kIncomplete,   // the input broke off (decode error): the rows up to there are written
  kInterrupted,  // stopped by the cancel flag: the rows up to there are written
  kNotTracked,   // every frame read, too few tracked (error suggests causes)
};
const char* VideoEndName(VideoEnd end);

struct VideoSummary {
  std::string input, output;
  VideoEnd end = VideoEnd::kFailed;
  bool ok = false;    // end == kDone
  std::string error;  // empty for kDone and kInterrupted
  int frames = 0, n_ok = 0, n_lost = 0;
  double seconds = 0.0;
  bool has_accuracy = false;
  AccuracySummary accuracy;
  std::string smoothed_output;  // empty: none written
  std::string tum_output;       // empty: none written
  bool has_smoothed_accuracy = false;
  AccuracySummary smoothed_accuracy;
  int frames_without_odometry = 0;  // frames after the first outside the odometry's times
  bool hardware_decoding = false;   // decoded on NVDEC
};

// Localises one input. An input that breaks off, is interrupted or is not
// tracked enough ends in the summary (its rows written). Throws pano::Error,
// leaving no output, when nothing could be done: the input or an output
// could not be used.
VideoSummary LocalizeVideo(const VideoJob& job, const SharedResources& shared, const VideoRunOptions& options);

}  // namespace pano
