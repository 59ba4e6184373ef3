#include "panotrack/pipeline/localize_video.h"

#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <utility>

#include "panotrack/core/error.h"
#include "panotrack/core/thread_priority.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/io/tum.h"
#include "panotrack/pipeline/debug_draw.h"
#include "panotrack/pipeline/plot.h"
#include "panotrack/video/frame_source.h"

namespace pano {

const char* VideoEndName(VideoEnd end) {
  switch (end) {
    case VideoEnd::kDone: return "done";
    case VideoEnd::kFailed: return "failed";
    case VideoEnd::kIncomplete: return "incomplete";
    case VideoEnd::kInterrupted: return "interrupted";
    case VideoEnd::kNotTracked: return "not tracked";
  }
  return "?";
}


OdometryOptions OdometryOptionsForMap(const Map& map, double map_units_per_odometry_unit) {
  const double scale = map.UnitsPerMetre();
  OdometryOptions o;
  o.map_units_per_odometry_unit = map_units_per_odometry_unit;
  // Variance per distance: length^2 / length for positions, 1 / length for headings.
  o.position_variance_per_distance *= scale;
  o.heading_variance_per_distance /= scale;
  return o;
}

namespace {

std::string SizeText(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

// The ground truth has one row per frame, matched by frame number: a file of
// another length belongs to another video, and its accuracy would compare
// the wrong frames (or few of them).
std::string GtLengthMismatch(const VideoJob& job, size_t gt_rows, int frames) {
  return "--gt " + job.gt + ": " + std::to_string(gt_rows) + " rows for the " + std::to_string(frames) +
         " frames of " + job.input + " (one row per frame expected)";
}

// The size frames are tracked at: as ScaledSensor rounds.
cv::Size TrackedSize(int width, int height, double scale) {
  if (scale == 1.0) return {width, height};
  return {static_cast<int>(std::lround(width * scale)), static_cast<int>(std::lround(height * scale))};
}

bool TooFewTracked(int frames, int n_ok) {
  if (frames == 0) return false;
  return n_ok == 0 || (frames >= kMinFramesJudged && n_ok < kMinTrackedFraction * frames);
}

std::string NotTrackedHint(const std::string& input, int frames, int n_ok) {
  char buf[160];
  std::snprintf(buf, sizeof buf, ": only %d of %d frames tracked (under %.0f %%); ", n_ok, frames,
                100 * kMinTrackedFraction);
  return input + buf +
         "likely causes: a wrong calibration or image size (--calib), a wrong initial pose (--init or "
         "case.yaml), wrong map units, landmarks mis-measured or missing (check the map with panomap check)";
}

// The rate taken for frames that carry no time (image folders).
constexpr double kAssumedFps = 10.0;

// The frame's time: the override rate, else the input's timestamp, else its
// frame rate, else kAssumedFps (then `rate_assumed` is set).
double FrameTime(int frame, double timestamp, double override_fps, double input_fps, bool* rate_assumed) {
  if (override_fps > 0) return frame / override_fps;
  if (std::isfinite(timestamp)) return timestamp;
  if (input_fps > 0) return frame / input_fps;
  *rate_assumed = true;
  return frame / kAssumedFps;
}

// The smoothed pose CSV: the main rows held back until the smoother has
// their frame's state (`lag` frames later), then written in frame order.
class SmoothedCsv {
 public:
  // `keep_rows`: also keep the rows written, without their trailing columns
  // (for the accuracy summary); else memory stays flat however long the input.
  // `loc`: the localiser whose motion steps are smoothed (its poses are
  // those of the sensor it tracks, converted to the robot's).
  SmoothedCsv(const std::string& path, const FixedLagSmootherOptions& options, bool keep_rows, const Localizer& loc)
      : csv_(path, {"std_x", "std_y", "std_theta", "quality"}, PoseCsvStaging::kPartial), smoother_(options),
        keep_rows_(keep_rows), loc_(loc) {}

  void Add(const FrameResult& fr) {
    pending_.push_back({fr.row, fr.has_motion_step});
    if (fr.has_motion_step) Apply(smoother_.Push(fr.motion_step));
    WriteReady();
  }
  // Writes the frames still held back and closes the file (renaming it into place).
  void Finish() {
    Apply(smoother_.Flush());
    WriteReady();
    csv_.Close();
  }
  const std::vector<PoseRow>& rows() const { return rows_; }

 private:
  struct Pending {
    PoseRow row;
    bool awaits_state;  // its frame's step is in the smoother
  };
  // The smoother returns its frames' states oldest first: they belong to the
  // oldest rows awaiting one.
  void Apply(const std::vector<SmoothedState>& states) {
    auto it = pending_.begin();
    for (const SmoothedState& s : states) {
      while (it != pending_.end() && !it->awaits_state) ++it;
      if (it == pending_.end()) throw Error("smoother: more smoothed states than frames");
      // Only a measured pose is reported as such; lost and init rows stay empty.
      if (it->row.status == PoseStatus::kOk) {
        it->row.pose = loc_.RobotPose(s.state.pose());
        const Eigen::Matrix3d cov = s.state.pose_covariance();
        it->row.extra.resize(4, std::nan(""));
        for (int k = 0; k < 3; ++k) it->row.extra[k] = std::sqrt(std::max(0.0, cov(k, k)));
      }
      it->awaits_state = false;
    }
  }
  void WriteReady() {
    while (!pending_.empty() && !pending_.front().awaits_state) {
      csv_.Write(pending_.front().row);
      if (keep_rows_) {
        rows_.push_back(std::move(pending_.front().row));
        rows_.back().extra = std::vector<double>();
      }
      pending_.pop_front();
    }
  }

  PoseCsvWriter csv_;
  FixedLagSmoother smoother_;
  std::deque<Pending> pending_;
  bool keep_rows_;
  const Localizer& loc_;
  std::vector<PoseRow> rows_;
};

// Frame times this close outside the odometry's times count as its ends:
// the two clocks are written with finitely many decimals (299 * 0.1 s is
// not 29.9 s in binary).
constexpr double kOdometryTimeSlack_s = 1e-3;

// The odometry increment from the previous frame's time to this one's; none
// outside the log's times.
std::optional<OdometryIncrement> OdometryBetween(const std::vector<OdometrySample>& samples, double t0,
                                                 double t1, const OdometryOptions& options) {
  if (samples.empty() || !(t1 >= t0)) return std::nullopt;
  const double first = samples.front().time_s, last = samples.back().time_s;
  if (!(t0 >= first - kOdometryTimeSlack_s) || !(t1 <= last + kOdometryTimeSlack_s)) return std::nullopt;
  return Between(samples, std::clamp(t0, first, last), std::clamp(t1, first, last), options);
}

// The tracker's priority while it keeps up with decoding: idle when no
// decoded frame waits, normal from this many waiting frames on (at most half
// the prefetch queue, so that decoding never stops for a full queue while
// the tracker is idle). The backlog absorbs the tracker's costly frames
// (relocalisation); it also bounds what is left to track when decoding ends.
constexpr int kIdleWhileWaiting = 0;
constexpr int kNormalFromWaiting = 32;

// The outputs of one input, written frame by frame in frame order: the pose
// CSV, the smoothed CSV and the TUM trajectory when asked, and the rows the
// plot and the accuracy need (none when the job has neither, so that memory
// stays flat over long inputs; without their trailing columns when only the
// accuracy needs them).
class RunOutputs {
 public:
  RunOutputs(const VideoJob& job, const VideoRunOptions& opt, const Localizer& loc, VideoSummary* sum)
      : csv_(job.output, {"std_x", "std_y", "std_theta", "quality"}, PoseCsvStaging::kPartial),
        keep_rows_(!job.plot.empty() || !job.gt.empty()),
        keep_std_(!job.plot.empty()),  // the plot draws the standard deviations
        sum_(sum) {
    if (!job.smoothed_output.empty()) smoothed_.emplace(job.smoothed_output, opt.smoother, !job.gt.empty(), loc);
    if (!job.tum.empty()) tum_.emplace(job.tum, opt.tum, PoseCsvStaging::kPartial);
  }
  void Report(const FrameResult& fr) {
    csv_.Write(fr.row);
    if (smoothed_) smoothed_->Add(fr);
    if (tum_) tum_->Write(fr.row);
    if (keep_rows_) {
      rows_.push_back(fr.row);
      if (!keep_std_) rows_.back().extra = std::vector<double>();
    }
    ++sum_->frames;
    sum_->n_ok += fr.row.status == PoseStatus::kOk;
    sum_->n_lost += fr.row.status == PoseStatus::kLost;
  }
  // The rows written are intact however the run ended: the outputs are
  // finished with them. Returns the rows kept; the smoothed CSV's in
  // `smoothed_rows`.
  std::vector<PoseRow> Close(std::vector<PoseRow>* smoothed_rows) {
    csv_.Close();
    if (tum_) tum_->Close();
    if (smoothed_) {
      smoothed_->Finish();
      *smoothed_rows = smoothed_->rows();
    }
    return std::move(rows_);
  }

 private:
  PoseCsvWriter csv_;
  std::optional<SmoothedCsv> smoothed_;
  std::optional<TumWriter> tum_;
  std::vector<PoseRow> rows_;
  bool keep_rows_, keep_std_;
  VideoSummary* sum_;
};

// The next decoded frame; false at the end, when stopped, or on a decode
// error (the input then incomplete).
bool ReadFrame(const VideoRunOptions& opt, int frame, FrameSource* source, cv::Mat* decoded, double* timestamp,
               VideoSummary* sum) {
  if (opt.cancel && opt.cancel->load()) {
    sum->end = VideoEnd::kInterrupted;
    return false;
  }
  *timestamp = std::nan("");
  try {
    return source->Read(decoded, timestamp);
  } catch (const Error& e) {
    sum->end = VideoEnd::kIncomplete;
    sum->error = "decode error at frame " + std::to_string(frame) + ": " + e.what();
    return false;
  }
}

// The frame as tracked (resized by area averaging when opt.scale asks);
// null when its size is not the sensor's (the input then incomplete).
const cv::Mat* TrackedFrame(const VideoRunOptions& opt, const Sensor& s, int frame, const FrameSource& source,
                            const cv::Mat& decoded, cv::Mat* resized, VideoSummary* sum) {
  const cv::Size tracked = TrackedSize(decoded.cols, decoded.rows, opt.scale);
  if (tracked.width != s.image_width || tracked.height != s.image_height) {
    sum->end = VideoEnd::kIncomplete;
    sum->error = "frame " + std::to_string(frame) + " is " + SizeText(decoded.cols, decoded.rows) +
                 ", the frames before it " + SizeText(source.width(), source.height());
    return nullptr;
  }
  if (opt.scale == 1.0) return &decoded;
  cv::resize(decoded, *resized, tracked, 0, 0, cv::INTER_AREA);
  return resized;
}

// The notes a run leaves on stderr: frames outside the odometry, frame
// times assumed, a first pose searched on a measured map, the survey error
// the residuals show, shades that look inverted.
void PrintRunNotes(const VideoJob& job, const SharedResources& res, const Localizer& loc, const VideoSummary& sum,
                   bool rate_assumed) {
  if (sum.frames_without_odometry > 0)
    std::fprintf(stderr,
                 "panoloc: note: %s: %d of %d frames lie outside the odometry's times [%.3f, %.3f] s: "
                 "predicted without it\n",
                 job.input.c_str(), sum.frames_without_odometry, std::max(0, sum.frames - 1),
                 job.odometry->front().time_s, job.odometry->back().time_s);
  // The motion model's limits (speed, turn rate, how far a relocalised
  // pose may lie from the last) are per second: a rate that is not the
  // camera's makes the robot look faster or slower than it was.
  if (rate_assumed)
    std::fprintf(stderr,
                 "panoloc: note: %s: the frames carry no times: taken as 10 frames/s (the motion model's speed "
                 "limits depend on it; --fps RATE gives the camera's)\n",
                 job.input.c_str());
  // A measured map (one that does not claim to be exact, or whose
  // residuals overruled the claim) and no start pose: the room-wide search
  // chose the first pose, and in a room laid out nearly symmetrically it
  // can take a twin (docs/maps.md).
  const bool measured_map = !(loc.StatedSurveySigma() == 0.0) || !std::isnan(loc.ShownSurveySigma());
  if (!job.init && measured_map && sum.n_ok > 0)
    std::fprintf(stderr,
                 "panoloc: note: %s: no start pose was given (--init, or initial_pose in a case.yaml beside the "
                 "input): the first pose was found by searching the room, which on a measured map can take a "
                 "twin of a room laid out nearly symmetrically; give a start pose (docs/maps.md)\n",
                 job.input.c_str());
  if (!std::isnan(loc.ShownSurveySigma())) {
    // The residuals overruled the map's survey_sigma, or estimated it.
    const double stated = loc.StatedSurveySigma();
    char statement[64] = "the map does not state it";
    if (!std::isnan(stated)) std::snprintf(statement, sizeof statement, "the map states %.2g", stated);
    std::fprintf(stderr,
                 "panoloc: note: %s: the map's corners look measured to about %.2g %s per coordinate (%s): poses "
                 "are weighed by that and reported with covariances of %.2g (an estimate from the residuals can "
                 "fall short); state survey_sigma in the map (docs/maps.md)\n",
                 job.input.c_str(), loc.ShownSurveySigma(), res.map.units.c_str(), statement,
                 loc.ReportedSurveySigma());
  }
  for (const std::string& id : loc.ContradictedShades())
    std::fprintf(stderr, "panoloc: note: %s: landmark %s: map shade looks inverted (polarity learned from the images)\n",
                 job.input.c_str(), id.c_str());
}

// The per-frame loop; fills the counts of `sum` and returns the rows that
// the plot and the accuracy summary need (the smoothed CSV's in
// `smoothed_rows`, when the job asks for one and its accuracy): none when
// the job has neither, so that memory stays flat over long inputs; without
// their trailing columns when only the accuracy needs them. A decode error
// or a frame of another size ends the input as incomplete.
std::vector<PoseRow> TrackFrames(const VideoJob& job, const SharedResources& res, const VideoRunOptions& opt,
                                 FrameSource* source, VideoSummary* sum, std::vector<PoseRow>* smoothed_rows) {
  const Sensor& s = res.calib.sensor;
  const TrackingTables tables =
      res.pending_tables.valid() ? res.pending_tables.get() : TrackingTables{res.table, res.ph_tables};
  Localizer loc(res.calib, res.map, tables.table, opt.localizer, tables.ph_tables);
  if (res.relocalization_index) loc.ShareRelocalizationIndex(res.relocalization_index);
  if (job.init)
    loc.Reset(*job.init, /*hint=*/true);
  else
    loc.ResetUnknown();
  std::optional<DebugVideo> dbg;
  if (!job.debug_video.empty())
    dbg.emplace(job.debug_video, cv::Size(s.image_width, s.image_height), source->fps() > 0 ? source->fps() : kAssumedFps);
  RunOutputs outputs(job, opt, loc, sum);
  double previous_time = 0.0;
  cv::Mat decoded, resized;
  std::optional<LagPriority> priority;
  if (opt.track_in_decoding_gaps && !FrameSource::IsLive(job.input)) {
    if (opt.localizer.num_threads != 1) throw Error("track_in_decoding_gaps: expects localizer.num_threads 1");
    // (The per-landmark loops then run on this thread alone; the room-wide
    // search starts its threads for each search, at this thread's priority.)
    priority.emplace(kIdleWhileWaiting, std::min(kNormalFromWaiting, source->prefetch_frames() / 2));
  }
  // A frame's outputs go in frame order; the frames held for confirmation
  // wait until the localiser holds them no more (Localizer::TakeConfirmedHolds).
  std::deque<FrameResult> waiting;
  sum->end = VideoEnd::kDone;
  bool rate_assumed = false;  // some frame had no time: FrameTime took kAssumedFps
  for (int frame = 0;; ++frame) {
    double timestamp;
    if (!ReadFrame(opt, frame, source, &decoded, &timestamp, sum)) break;
    if (priority) priority->Update(source->frames_waiting());
    const cv::Mat* tracked = TrackedFrame(opt, s, frame, *source, decoded, &resized, sum);
    if (!tracked) break;
    const cv::Mat& grey = *tracked;
    const double time_s = FrameTime(frame, timestamp, opt.fps, source->fps(), &rate_assumed);
    std::optional<OdometryIncrement> odometry;
    if (job.odometry && frame > 0) {
      odometry = OdometryBetween(*job.odometry, previous_time, time_s, opt.odometry);
      sum->frames_without_odometry += !odometry;
    }
    previous_time = time_s;
    FrameResult fr = loc.Process(grey, frame, time_s, odometry ? &*odometry : nullptr);
    if (dbg) dbg->Write(grey, s, fr);
    waiting.push_back(std::move(fr));
    for (FrameResult& confirmed : loc.TakeConfirmedHolds())
      for (FrameResult& w : waiting)
        if (w.row.frame == confirmed.row.frame) w = std::move(confirmed);
    while (waiting.size() > static_cast<size_t>(loc.FramesHeld())) {
      outputs.Report(waiting.front());
      waiting.pop_front();
    }
    if (opt.frames_done) ++*opt.frames_done;
  }
  // No frame came to confirm them.
  for (const FrameResult& w : waiting) outputs.Report(w);
  std::vector<PoseRow> rows = outputs.Close(smoothed_rows);
  if (dbg) dbg->Commit();
  if (!opt.quiet) PrintRunNotes(job, res, loc, *sum, rate_assumed);
  return rows;
}

void LocalizeInto(const VideoJob& job, const SharedResources& res, const VideoRunOptions& opt,
                  VideoSummary* sum) {
  std::vector<PoseRow> gt;
  if (!job.gt.empty()) gt = ReadPoseCsv(job.gt);
  FrameSourceOptions source_options;
  source_options.decoder_threads = opt.decoder_threads;
  source_options.gop_parallel_bytes = opt.gop_parallel_bytes;
  source_options.hardware = opt.hardware;
  FrameSource source(job.input, source_options);
  sum->hardware_decoding = source.hardware_decoding();
  const Sensor& s = res.calib.sensor;
  const cv::Size tracked = TrackedSize(source.width(), source.height(), opt.scale);
  if (tracked.width != s.image_width || tracked.height != s.image_height)
    throw Error(job.input + ": frame size " + SizeText(source.width(), source.height()) +
                (opt.scale != 1.0 ? " scaled by " + std::to_string(opt.scale) + " (" +
                                        SizeText(tracked.width, tracked.height) + ")"
                                  : std::string()) +
                " does not match the calibration's " + SizeText(s.image_width, s.image_height) + " (" +
                res.calib_path + (opt.scale != 1.0 ? " scaled" : "") + ")");
  // Checked before any output where the input states its length; after
  // tracking where it does not (streams, live inputs).
  if (!job.gt.empty() && source.frame_count() > 0 && gt.size() != static_cast<size_t>(source.frame_count()))
    throw Error(GtLengthMismatch(job, gt.size(), source.frame_count()));
  std::vector<PoseRow> smoothed;
  const std::vector<PoseRow> rows = TrackFrames(job, res, opt, &source, sum, &smoothed);
  if (!job.gt.empty() && sum->end == VideoEnd::kDone && gt.size() != static_cast<size_t>(sum->frames)) {
    if (!opt.quiet)
      std::fprintf(stderr, "panoloc: note: %s: no accuracy\n", GtLengthMismatch(job, gt.size(), sum->frames).c_str());
    gt.clear();
  }
  if (!job.plot.empty()) WritePlot(job.plot, res.map, rows, gt);
  if (!gt.empty()) {
    sum->has_accuracy = true;
    sum->accuracy = CompareToGroundTruth(rows, gt, TypicalRange(res.map, gt));
    if (!job.smoothed_output.empty()) {
      sum->has_smoothed_accuracy = true;
      sum->smoothed_accuracy = CompareToGroundTruth(smoothed, gt, TypicalRange(res.map, gt));
    }
  }
  if (sum->end == VideoEnd::kDone && TooFewTracked(sum->frames, sum->n_ok)) {
    sum->end = VideoEnd::kNotTracked;
    sum->error = NotTrackedHint(job.input, sum->frames, sum->n_ok);
  }
}

}  // namespace

VideoSummary LocalizeVideo(const VideoJob& job, const SharedResources& shared, const VideoRunOptions& options) {
  VideoSummary sum;
  sum.input = job.input;
  sum.output = job.output;
  sum.smoothed_output = job.smoothed_output;
  sum.tum_output = job.tum;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    LocalizeInto(job, shared, options, &sum);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {  // OpenCV, the file system: name the input
    throw Error(job.input + ": " + e.what());
  }
  sum.ok = sum.end == VideoEnd::kDone;
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return sum;
}

}  // namespace pano
