#include "pipeline/localize_video.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>
#include <optional>

#include "core/error.h"
#include "io/pose_csv.h"
#include "pipeline/debug_draw.h"
#include "pipeline/plot.h"
#include "video/frame_source.h"

namespace pano {

const char* video_end_name(VideoEnd end) {
  switch (end) {
    case VideoEnd::kDone: return "done";
    case VideoEnd::kFailed: return "failed";
    case VideoEnd::kIncomplete: return "incomplete";
    case VideoEnd::kInterrupted: return "interrupted";
    case VideoEnd::kNotTracked: return "not tracked";
  }
  return "?";
}

namespace {

std::string SizeText(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

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
         "case.yaml), map shades inverted (dark for light), wrong map units";
}

// The frame's time: the override rate, else the input's timestamp, else its
// frame rate (10 when it has none).
double FrameTime(int frame, double timestamp, double override_fps, double input_fps) {
  if (override_fps > 0) return frame / override_fps;
  if (std::isfinite(timestamp)) return timestamp;
  return frame / (input_fps > 0 ? input_fps : 10.0);
}

// The per-frame loop; fills the counts of `sum` and returns its rows. A
// decode error or a frame of another size ends the input as incomplete.
std::vector<PoseRow> TrackFrames(const VideoJob& job, const SharedResources& res, const VideoRunOptions& opt,
                                 FrameSource* source, VideoSummary* sum) {
  const Sensor& s = res.calib.sensor;
  Localizer loc(res.calib, res.map, res.table, opt.localizer, res.ph_tables);
  if (job.init)
    loc.Reset(*job.init, /*hint=*/true);
  else
    loc.ResetUnknown();
  std::optional<DebugVideo> dbg;
  if (!job.debug_video.empty())
    dbg.emplace(job.debug_video, cv::Size(s.image_width, s.image_height), source->fps() > 0 ? source->fps() : 10.0);
  PoseCsvWriter csv(job.output, {"std_x", "std_y", "std_theta", "quality"}, PoseCsvStaging::kPartial);
  std::vector<PoseRow> rows;
  cv::Mat grey;
  sum->end = VideoEnd::kDone;
  for (int frame = 0;; ++frame) {
    if (opt.cancel && opt.cancel->load()) {
      sum->end = VideoEnd::kInterrupted;
      break;
    }
    double timestamp = std::nan("");
    try {
      if (!source->Read(&grey, &timestamp)) break;
    } catch (const Error& e) {
      sum->end = VideoEnd::kIncomplete;
      sum->error = "decode error at frame " + std::to_string(frame) + ": " + e.what();
      break;
    }
    if (grey.cols != s.image_width || grey.rows != s.image_height) {
      sum->end = VideoEnd::kIncomplete;
      sum->error = "frame " + std::to_string(frame) + " is " + SizeText(grey.cols, grey.rows) +
                   ", the frames before it " + SizeText(s.image_width, s.image_height);
      break;
    }
    const FrameResult fr = loc.Process(grey, frame, FrameTime(frame, timestamp, opt.fps, source->fps()));
    csv.Write(fr.row);
    rows.push_back(fr.row);
    ++sum->frames;
    sum->n_ok += fr.row.status == PoseStatus::kOk;
    sum->n_lost += fr.row.status == PoseStatus::kLost;
    if (dbg) dbg->Write(grey, s, fr);
    if (opt.frames_done) ++*opt.frames_done;
  }
  // The rows written are intact however the loop ended: the outputs are
  // finished with them.
  csv.Close();
  if (dbg) dbg->Commit();
  return rows;
}

void LocalizeInto(const VideoJob& job, const SharedResources& res, const VideoRunOptions& opt,
                  VideoSummary* sum) {
  std::vector<PoseRow> gt;
  if (!job.gt.empty()) gt = ReadPoseCsv(job.gt);
  FrameSource source(job.input);
  const Sensor& s = res.calib.sensor;
  if (source.width() != s.image_width || source.height() != s.image_height)
    throw Error(job.input + ": frame size " + SizeText(source.width(), source.height()) +
                " does not match the calibration's " + SizeText(s.image_width, s.image_height) + " (" +
                res.calib_path + ")");
  const std::vector<PoseRow> rows = TrackFrames(job, res, opt, &source, sum);
  if (!job.plot.empty()) WritePlot(job.plot, res.map, rows, gt);
  if (!gt.empty()) {
    sum->has_accuracy = true;
    sum->accuracy = CompareToGroundTruth(rows, gt, TypicalRange(res.map, gt));
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
  const auto t0 = std::chrono::steady_clock::now();
  try {
    LocalizeInto(job, shared, options, &sum);
  } catch (const Error& e) {
    sum.end = VideoEnd::kFailed;
    sum.error = e.what();
  } catch (const std::exception& e) {  // OpenCV, the file system: name the input
    sum.end = VideoEnd::kFailed;
    sum.error = job.input + ": " + e.what();
  }
  sum.ok = sum.end == VideoEnd::kDone;
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return sum;
}

}  // namespace pano
