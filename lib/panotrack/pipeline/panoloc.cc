#include "panotrack/pipeline/panoloc.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <future>
#include <mutex>
#include <thread>

#include "panotrack/core/error.h"
#include "panotrack/core/output_check.h"
#include "panotrack/core/parallel.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/case_file.h"
#include "panotrack/io/map.h"
#include "panotrack/pipeline/output_names.h"
#include "panotrack/pipeline/plot.h"
#include "panotrack/video/frame_source.h"

namespace pano {

namespace fs = std::filesystem;

namespace {

// The largest --tum-scale, metres per map unit: a map in kilometres is 1000.
constexpr double kMaxTumScale = 1e6;

std::string ShortNumber(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", v);
  return text;
}

// The localiser's options that panoloc's flags set, checked under the flags'
// names: LocalizerOptions::Check names the fields of the library's struct.
void CheckTrackingFlags(const LocalizerOptions& l) {
  if (!(l.search_px > 0 && l.search_px <= l.max_search_px))
    throw Error("--search-px: expected a half-width above 0 and at most " + ShortNumber(l.max_search_px) +
                " px, got " + ShortNumber(l.search_px));
  if (!(l.junction.min_step > 0 && l.junction.min_step < 256))
    throw Error("--min-step: expected an intensity step above 0 and below 256 grey levels, got " +
                ShortNumber(l.junction.min_step));
}

}  // namespace

void PanolocOptions::Check() const {
  if (inputs.empty()) throw Error("inputs: no input video given");
  if (calib_path.empty()) throw Error("--calib (calib_path): required");
  if (map_path.empty()) throw Error("--map (map_path): required");
  if (!output.empty() && !out_dir.empty())
    throw Error("-o (output) and --out-dir (out_dir): give one of them, not both");
  if (inputs.size() == 1 && output.empty() && out_dir.empty())
    throw Error("-o (output) or --out-dir (out_dir): give -o OUT.csv (one input) or --out-dir DIR");
  if (inputs.size() > 1 && out_dir.empty())
    throw Error("--out-dir (out_dir): several inputs need --out-dir DIR (one CSV per input)");
  if (inputs.size() > 1 && (!debug_video.empty() || !plot.empty() || (!gt.empty() && gt != "auto")))
    throw Error("--debug-video (debug_video), --plot (plot) and --gt FILE (gt) take one input "
                "(use --gt auto for several)");
  if (jobs < 0) throw Error("--jobs (jobs): expected 0 (as many as the threads allow) or more");
  CheckThreadCount(num_threads, "--threads (num_threads)");
  if (decode_memory_mib < 0 || decode_memory_mib > (1 << 20))
    throw Error("--decode-memory (decode_memory_mib): expected 0 to 1048576 MiB");
  // From a frame every few hours (time-lapse) to a high-speed camera's rate.
  if (!(fps == 0 || (fps >= 1e-4 && fps <= 1e5)))
    throw Error("--fps (fps): expected 0 (the input's timestamps) or a frame rate from 0.0001 to 100000 "
                "frames/s, got " + ShortNumber(fps));
  if (!(scale > 0 && scale <= 1)) throw Error("--scale (scale): expected a factor in (0, 1]");
  if (smooth && out_dir.empty() && PoseCsvWriter::WritesDirectly(output))
    throw Error("--smooth (smooth): needs a file output (-o FILE.csv or --out-dir DIR) beside which to "
                "write the smoothed CSV");
  if (smooth && (smooth_lag < 0 || smooth_lag > 10000))
    throw Error("--smooth-lag (smooth_lag): expected 0 to 10000 frames, got " + std::to_string(smooth_lag));
  if (!odometry.empty() && inputs.size() > 1)
    throw Error("--odometry (odometry): takes one input");
  if (!(odometry_scale > 0) || !std::isfinite(odometry_scale))
    throw Error("--odometry-scale (odometry_scale): expected a positive number");
  if (!tum.empty() && inputs.size() > 1)
    throw Error("--tum (tum): takes one input");
  if (summary_json == "-" && output == "-")
    throw Error("--summary-json (summary_json): standard output already carries the pose CSV (-o -)");
  if (tum == "-")
    throw Error("--tum (tum): expected a file name (the TUM file cannot go to standard output)");
  if (!(tum_scale >= 0) || !(tum_scale <= kMaxTumScale))
    throw Error("--tum-scale (tum_scale): expected a positive number of metres per map unit up to " +
                ShortNumber(kMaxTumScale) + ", or 0 for the map's units, got " + ShortNumber(tum_scale));
  if (init && (!std::isfinite(init->x) || !std::isfinite(init->y) || !std::isfinite(init->theta)))
    throw Error("--init (init): expected finite x,y,theta");
  CheckTrackingFlags(localizer);
  localizer.Check();
}

std::shared_ptr<const RadiusTable> TableForMap(const Calibration& calib, const Map& map, bool quiet,
                                               const TableCacheOptions& cache, int num_threads) {
  const LutRanges need = RangesForMap(map, calib.sensor);
  if (!calib.lut_resolved.empty()) {
    try {
      auto t = std::make_shared<RadiusTable>(RadiusTable::Load(calib.lut_resolved, &calib.sensor));
      if (t->Covers(need)) return t;
      if (!quiet)
        std::fprintf(stderr, "panoloc: note: %s does not cover the map's distances and heights; "
                             "building a table for this map\n", calib.lut_resolved.c_str());
    } catch (const Error& e) {
      if (!quiet) std::fprintf(stderr, "panoloc: note: %s; building a table instead\n", e.what());
    }
  }
  return std::make_shared<RadiusTable>(
      LoadOrBuildRadiusTable(calib.sensor, need, LutSize(), cache, /*outcome=*/nullptr, num_threads));
}

std::string SmoothedOutputPath(const std::string& output) {
  return fs::path(output).replace_extension(".smoothed.csv").string();
}

// The case.yaml files whose initial_pose an input may start from: beside
// it, then one folder up.
std::vector<std::string> CaseFilesBeside(const std::string& input) {
  if (FrameSource::IsLive(input)) return {};
  fs::path dir = fs::is_directory(input) ? fs::path(input) : fs::path(input).parent_path();
  if (dir.empty()) dir = ".";  // a file in the current folder
  std::vector<std::string> files;
  for (int up = 0; up < 2; ++up) {
    const fs::path p = dir / "case.yaml";
    if (fs::exists(p)) files.push_back(p.string());
    // One folder up: a relative folder's parent is the current folder
    // ("frames" of a sequence run from inside it), the root has none.
    fs::path parent = dir.parent_path();
    if (parent.empty() && dir != ".") parent = ".";
    if (parent.empty() || parent == dir) break;
    dir = parent;
  }
  return files;
}

std::optional<Pose2> InitialPoseBeside(const std::string& input) {
  for (const std::string& p : CaseFilesBeside(input))
    if (std::optional<Pose2> pose = ReadCaseInitialPose(p)) return pose;
  return std::nullopt;
}

namespace {

struct PlannedJob {
  VideoJob job;
  std::string error;  // set-up failure of this input alone
};

std::string GtBeside(const std::string& input) {
  if (FrameSource::IsLive(input)) return "";
  fs::path dir = fs::is_directory(input) ? fs::path(input) : fs::path(input).parent_path();
  if (dir.empty()) dir = ".";
  const fs::path g = dir / "gt.csv";
  return fs::exists(g) ? g.string() : "";
}

// --init, else the case.yaml's initial_pose, else none (the first frame is
// localised by searching the room).
std::optional<Pose2> InitialPoseOf(const std::string& input, const PanolocOptions& opt, const Map& map) {
  if (opt.init) return opt.init;
  const std::optional<Pose2> p = InitialPoseBeside(input);
  if (!p) return std::nullopt;
  if (!map.IsFree(p->x, p->y))
    throw Error(input + ": the initial pose in case.yaml lies outside the room of " + opt.map_path);
  return *p;
}

// Each input's outputs and initial pose; an input whose set-up fails keeps
// its error and is reported without stopping the others.
std::vector<PlannedJob> PlanJobs(const PanolocOptions& opt, const Map& map) {
  const std::vector<std::string> outputs =
      opt.out_dir.empty() ? std::vector<std::string>{opt.output} : OutputPathsInDir(opt.inputs, opt.out_dir);
  std::vector<PlannedJob> jobs(opt.inputs.size());
  for (size_t i = 0; i < jobs.size(); ++i) {
    VideoJob& j = jobs[i].job;
    j.input = opt.inputs[i];
    j.output = outputs[i];
    j.gt = opt.gt == "auto" ? GtBeside(j.input) : opt.gt;
    if (opt.gt == "auto" && j.gt.empty() && !opt.quiet)
      std::fprintf(stderr, "panoloc: note: %s: --gt auto: no gt.csv beside it, no accuracy\n", j.input.c_str());
    j.debug_video = opt.debug_video;
    j.plot = opt.plot;
    j.tum = opt.tum;
    if (opt.smooth) j.smoothed_output = SmoothedOutputPath(j.output);
    try {
      j.init = InitialPoseOf(j.input, opt, map);
    } catch (const std::exception& e) {
      jobs[i].error = e.what();
    }
  }
  return jobs;
}

// No output may overwrite a file the run reads, or another output; none
// replaces an existing file unless the options allow it.
void CheckOutputs(const PanolocOptions& opt, const std::vector<PlannedJob>& jobs) {
  NamedPaths reads = {{"--calib", opt.calib_path}, {"--map", opt.map_path}, {"--odometry", opt.odometry}};
  NamedPaths writes;
  const std::string out_option = opt.out_dir.empty() ? "-o" : "--out-dir";
  for (const PlannedJob& p : jobs) {
    for (const auto& read : FrameSource::InputReads(p.job.input)) reads.push_back(read);
    reads.push_back({"--gt", p.job.gt});
    if (!opt.init)
      for (const std::string& c : CaseFilesBeside(p.job.input)) reads.push_back({"the case.yaml of " + p.job.input, c});
    writes.push_back({out_option, p.job.output});
    writes.push_back({"--debug-video", p.job.debug_video});
    writes.push_back({"--plot", p.job.plot});
    if (!p.job.plot.empty() && !p.job.gt.empty()) writes.push_back({"--plot", ErrorPlotPath(p.job.plot)});
    writes.push_back({"--smooth", p.job.smoothed_output});
    writes.push_back({"--tum", p.job.tum});
  }
  writes.push_back({"--summary-json", opt.summary_json});
  CheckPlannedOutputs(reads, writes, opt.overwrite);
}

// Calls the progress callback about four times a second on a thread of its
// own, after counting the frames of the inputs that are files.
class ProgressReporter {
 public:
  ProgressReporter(const ProgressCallback& callback, const std::vector<PlannedJob>& jobs,
                   const std::atomic<long>& done)
      : callback_(callback), done_(done) {
    for (const PlannedJob& p : jobs) inputs_.push_back(p.job.input);
    if (callback_) thread_ = std::thread([this] { Run(); });
  }
  ~ProgressReporter() {
    {
      std::lock_guard<std::mutex> lock(mu_);
      stop_ = true;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

 private:
  void Run() {
    try {
      const auto t0 = std::chrono::steady_clock::now();
      const long total = CountFrames();
      std::unique_lock<std::mutex> lock(mu_);
      while (!cv_.wait_for(lock, std::chrono::milliseconds(250), [this] { return stop_; })) {
        const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        Progress p;
        p.frames_done = done_;
        p.frames_total = total;
        p.frames_per_s = elapsed > 0 ? p.frames_done / elapsed : 0.0;
        callback_(p);
      }
    } catch (const std::exception&) {
      // A display that fails (a closed terminal) must not end the run: no more reports.
    }
  }
  // Total frames of the inputs; -1 when one is live or cannot be counted.
  // Never for live inputs or FIFOs: counting would consume the stream or
  // wait on a camera.
  long CountFrames() {
    long total = 0;
    for (const std::string& in : inputs_) {
      if (Stopped()) return -1;  // the run ended while counting
      std::error_code ec;
      const fs::file_status st = fs::status(in, ec);
      if (FrameSource::IsLive(in) || (fs::exists(st) && !fs::is_regular_file(st) && !fs::is_directory(st)))
        return -1;
      int n = -1;
      try {
        n = FrameSource::FrameCount(in);
      } catch (const std::exception&) {
      }
      if (n < 0) return -1;
      total += n;
    }
    return total;
  }

  bool Stopped() {
    std::lock_guard<std::mutex> lock(mu_);
    return stop_;
  }

  ProgressCallback callback_;
  const std::atomic<long>& done_;
  std::vector<std::string> inputs_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::thread thread_;
};

VideoSummary Unstarted(const VideoJob& job, VideoEnd end, const std::string& error) {
  VideoSummary s;
  s.input = job.input;
  s.output = job.output;
  s.end = end;
  s.error = error;
  return s;
}

}  // namespace

std::vector<VideoSummary> RunPanoloc(const PanolocOptions& opt) {
  opt.Check();
  SharedResources res;
  res.calib = ReadCalibration(opt.calib_path);
  res.calib_path = opt.calib_path;
  if (opt.scale != 1.0) {
    const Sensor& full = res.calib.sensor;
    if (!(std::lround(full.image_width * opt.scale) >= 1 && std::lround(full.image_height * opt.scale) >= 1))
      throw Error("--scale " + ShortNumber(opt.scale) + ": no pixel left of the " + std::to_string(full.image_width) +
                  "x" + std::to_string(full.image_height) + " frames of " + opt.calib_path);
    res.calib.sensor = ScaledSensor(full, opt.scale);
    // The calibration's own table is for full-size frames.
    res.calib.lut.clear();
    res.calib.lut_resolved.clear();
  }
  res.map = ReadMap(opt.map_path);
  res.relocalization_index = std::make_shared<SharedRelocalizationIndex>();
  if (res.calib.units != res.map.units)
    throw Error(opt.map_path + ": units '" + res.map.units + "' differ from the calibration's '" +
                res.calib.units + "' (" + opt.calib_path + ")");
  if (opt.init && !res.map.IsFree(opt.init->x, opt.init->y))
    throw Error("--init: (" + std::to_string(opt.init->x) + ", " + std::to_string(opt.init->y) +
                ") is outside the room or inside a box of " + opt.map_path);
  std::vector<PlannedJob> jobs = PlanJobs(opt, res.map);
  CheckOutputs(opt, jobs);
  if (!opt.odometry.empty()) {
    // Read before any output is created: a bad log leaves nothing behind.
    auto samples = std::make_shared<const std::vector<OdometrySample>>(ReadOdometryCsv(opt.odometry));
    for (PlannedJob& p : jobs) p.job.odometry = samples;
  }
  if (!opt.out_dir.empty()) CreateOutputFolder(opt.out_dir, "--out-dir");
  // What the table build would refuse, refused here, before any input starts.
  res.calib.sensor.Check(opt.calib_path);
  RangesForMap(res.map, res.calib.sensor).Check(opt.map_path + ": lookup table ranges");
  const int threads = ThreadCount(opt.num_threads);
  const int n_jobs = std::clamp(opt.jobs > 0 ? opt.jobs : threads, 1, static_cast<int>(jobs.size()));
  VideoRunOptions run;
  run.localizer = opt.localizer;
  // Parallel across inputs, or across landmarks within one. Each input has
  // a decoding thread of its own: leave it a core, since OpenMP's spinning
  // barriers collapse when the cores are oversubscribed.
  if (run.localizer.num_threads == 0) run.localizer.num_threads = std::max(1, threads / n_jobs - 1);
  // FFmpeg's frame threads: as many as the input's share of the cores (one
  // more, FFmpeg's choice, makes them wait on each other: 12 % slower on
  // 2 cores). Where the tracker has a single thread it runs in the gaps
  // that decoding leaves.
  run.decoder_threads = std::max(1, threads / n_jobs);
  run.gop_parallel_bytes = static_cast<size_t>(opt.decode_memory_mib) << 20;
  run.hardware = opt.hardware;
  // A room-wide search holds up its input's frames (the decoder stops once
  // its queue is full): as many threads as the per-frame loops, and both of
  // an input's two cores where those have one.
  if (run.localizer.search_threads == 0)
    run.localizer.search_threads = std::max(run.localizer.num_threads, std::min(2, threads / n_jobs));
  run.track_in_decoding_gaps = run.localizer.num_threads == 1;
  // The E(D,Z) table (from the cache, or built) and one set of PH tables for
  // every input (they depend on the sensor and the map's edge heights only),
  // made while the inputs open and start decoding (LocalizeVideo waits).
  TableCacheOptions cache;
  cache.dir = opt.table_cache_dir;
  if (!opt.quiet) cache.on_note = [](const std::string& s) { std::fprintf(stderr, "panoloc: note: %s\n", s.c_str()); };
  if (!opt.quiet && opt.verbose)
    cache.on_trace = [](const std::string& s) { std::fprintf(stderr, "panoloc: %s\n", s.c_str()); };
  const int ph_threads = run.localizer.num_threads;
  res.pending_tables = std::async(std::launch::async, [&res, &opt, cache, ph_threads] {
                         TrackingTables t;
                         t.table = TableForMap(res.calib, res.map, opt.quiet, cache, opt.num_threads);
                         t.ph_tables = MakeTrackingPhTables(t.table, ph_threads);
                         return t;
                       }).share();
  run.fps = opt.fps;
  run.scale = opt.scale;
  run.cancel = opt.cancel;
  run.quiet = opt.quiet;
  run.smoother.lag = opt.smooth_lag;
  run.odometry = OdometryOptionsForMap(res.map, opt.odometry_scale);
  run.tum = TumConversionForMap(res.map, opt.tum_scale);
  std::atomic<long> done{0};
  run.frames_done = &done;

  std::vector<VideoSummary> out(jobs.size());
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (size_t i; (i = next++) < jobs.size();) {
      const PlannedJob& p = jobs[i];
      try {
        if (!p.error.empty()) out[i] = Unstarted(p.job, VideoEnd::kFailed, p.error);
        else if (opt.cancel && opt.cancel->load()) out[i] = Unstarted(p.job, VideoEnd::kInterrupted, "");
        else out[i] = LocalizeVideo(p.job, res, run);
      } catch (const Error& e) {
        out[i] = Unstarted(p.job, VideoEnd::kFailed, e.what());
      } catch (const std::exception& e) {
        out[i] = Unstarted(p.job, VideoEnd::kFailed, p.job.input + ": " + e.what());
      }
    }
  };
  ProgressReporter progress(opt.on_progress, jobs, done);
  std::vector<std::thread> workers;
  for (int w = 0; w < n_jobs; ++w) workers.emplace_back(work);
  for (auto& t : workers) t.join();
  return out;
}

}  // namespace pano
