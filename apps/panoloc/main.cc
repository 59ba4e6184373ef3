// panoloc: localise a robot through whole videos of a catadioptric camera
// against a map of landmarks, writing pose CSV files.
#include <CLI/CLI.hpp>
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "cli_errors.h"
#include "panotrack/core/error.h"
#include "panotrack/config.h"
#include "panotrack/pipeline/panoloc.h"
#include "panotrack/pipeline/summary_json.h"
#include "panotrack/video/logging.h"

namespace {

// Set by SIGINT/SIGTERM; the pipeline checks it before every frame.
std::atomic<bool> g_cancel{false};
std::atomic<int> g_signal{0};
static_assert(std::atomic<bool>::is_always_lock_free && std::atomic<int>::is_always_lock_free,
              "signal handlers may only touch lock-free atomics");

extern "C" void OnStopSignal(int sig) {
  g_signal = sig;
  g_cancel = true;
}

// The first SIGINT/SIGTERM stops the run after the frames in progress; a
// second one (the handler is reset) ends the program at once.
void InstallStopHandlers() {
  struct sigaction sa = {};
  sa.sa_handler = OnStopSignal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESETHAND | SA_RESTART;  // blocking calls of the decoders carry on
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

void ShowProgress(const pano::Progress& p) {
  if (p.frames_total >= 0) {
    const double eta = p.frames_per_s > 0 ? (p.frames_total - p.frames_done) / p.frames_per_s : 0.0;
    std::fprintf(stderr, "\rpanoloc: %ld/%ld frames, %.1f frames/s, ETA %.0f s   ", p.frames_done,
                 p.frames_total, p.frames_per_s, eta);
  } else {
    std::fprintf(stderr, "\rpanoloc: %ld frames, %.1f frames/s   ", p.frames_done, p.frames_per_s);
  }
}

void ClearProgress() { std::fprintf(stderr, "\r%*s\r", 70, ""); }

// One line per input on `out` (unless quiet); failures (an input that
// failed, broke off or was hardly tracked) on stderr. Returns
// whether the input was done completely.
bool Report(const pano::VideoSummary& s, bool quiet, std::FILE* out) {
  using pano::VideoEnd;
  if (s.end == VideoEnd::kFailed) {
    std::fprintf(stderr, "panoloc: %s\n", s.error.c_str());
    return false;
  }
  if (s.end == VideoEnd::kInterrupted && s.frames == 0 && s.seconds == 0) {
    if (!quiet) std::fprintf(out, "%s: not started (interrupted)\n", s.input.c_str());
    return false;
  }
  std::string why;  // how the input ended early
  if (s.end == VideoEnd::kIncomplete) why = "incomplete: " + s.error;
  if (s.end == VideoEnd::kInterrupted) why = "interrupted";
  if (!quiet) {
    const std::string note = why.empty() ? "" : " (" + why + ")";
    std::fprintf(out, "%s: %d frames, %d ok, %d lost, %.1f frames/s -> %s%s\n", s.input.c_str(), s.frames,
                 s.n_ok, s.n_lost, s.seconds > 0 ? s.frames / s.seconds : 0.0, s.output.c_str(), note.c_str());
    if (!s.smoothed_output.empty()) std::fprintf(out, "  smoothed -> %s\n", s.smoothed_output.c_str());
    if (!s.tum_output.empty()) std::fprintf(out, "  TUM -> %s\n", s.tum_output.c_str());
    if (s.has_accuracy) std::fprintf(out, "  %s\n", pano::FormatAccuracy(s.accuracy, "units").c_str());
    if (s.has_smoothed_accuracy)
      std::fprintf(out, "  smoothed: %s\n", pano::FormatAccuracy(s.smoothed_accuracy, "units").c_str());
    std::fflush(out);
  }
  // An input that broke off is an error: on stderr too, quiet or not.
  if (s.end == VideoEnd::kIncomplete || (quiet && !why.empty()))
    std::fprintf(stderr, "panoloc: %s: %s\n", s.input.c_str(), why.c_str());
  if (s.end == VideoEnd::kNotTracked) std::fprintf(stderr, "panoloc: %s\n", s.error.c_str());
  return s.ok;
}

// What the command line holds: the run's options and the flags that
// become options once parsed.
struct CommandLine {
  pano::PanolocOptions o;
  std::vector<double> init;
  std::string method = "junction";
  std::string table_cache;
  bool no_table_cache = false;
  std::string hwaccel = "none";
  bool verbose = false;
  CLI::Option* smooth_lag = nullptr;
};

const char* const kInputsOutputs = "Inputs and outputs";
const char* const kTracking = "Tracking";
const char* const kRun = "Run";

void AddInputOutputOptions(CLI::App* app, CommandLine* c) {
  app->add_option("inputs", c->o.inputs,
                 "Video files (H.264 mp4...), image folders, printf patterns (frames/f_%04d.png), or live "
                 "inputs: - (standard input), /dev/video0, rtsp://..., udp://...")
      ->required()
      ->default_str("")  // no default to show
      ->group(kInputsOutputs);
  app->add_option("--calib", c->o.calib_path, "Calibration YAML (panocalib's output)")->required()->group(kInputsOutputs);
  app->add_option("--map", c->o.map_path, "Map YAML of the room's landmarks")->required()->group(kInputsOutputs);
  app->add_option("-o,--output", c->o.output, "Output pose CSV (one input); - writes it to standard output")
      ->group(kInputsOutputs);
  app->add_option("--out-dir", c->o.out_dir, "Output folder: one <input>.csv per input")->group(kInputsOutputs);
  app->add_flag("--force", c->o.overwrite, "Replace existing output files (otherwise the run refuses to start)")
      ->group(kInputsOutputs);
  app->add_option("--gt", c->o.gt,
                 "Ground-truth pose CSV: print the accuracy summary. 'auto': gt.csv beside each input")
      ->group(kInputsOutputs);
  app->add_option("--summary-json", c->o.summary_json,
                 "Also write the summary (per input: outputs, frames, ok, lost, frames/s, end, error, "
                 "accuracy) as JSON; - writes it to standard output")
      ->group(kInputsOutputs);
  app->add_option("--debug-video", c->o.debug_video,
                 "Annotated video: predicted edges, found edge points, junctions, landmark ids")
      ->group(kInputsOutputs);
  app->add_option("--plot", c->o.plot, "PNG of the map from above with the trajectory (and ground truth)")
      ->group(kInputsOutputs);
  app->add_option("--tum", c->o.tum,
                 "Also write the ok frames as a TUM trajectory (t x y z qx qy qz qw, metres; one input), "
                 "for evo: evo_ape tum gt.tum OUT.tum")
      ->group(kInputsOutputs);
  app->add_option("--tum-scale", c->o.tum_scale, "Metres per map unit in the TUM file (0: from the map's units)")
      ->group(kInputsOutputs);
  app->add_flag("--smooth", c->o.smooth,
               "Also write <output stem>.smoothed.csv: the poses smoothed over the following frames "
               "(fixed-lag Rauch-Tung-Striebel); needs a file output")
      ->group(kInputsOutputs);
  c->smooth_lag = app->add_option("--smooth-lag", c->o.smooth_lag,
                                     "Frames of the future that smooth each pose (implies --smooth)")
                        ->group(kInputsOutputs);
}

void AddTrackingOptions(CLI::App* app, CommandLine* c) {
  pano::app::AddPoseOption(app, "--init", &c->init,
                           "A guess of the initial pose x,y,theta (map units, radians) to start tracking from; "
                           "default: initial_pose of the case.yaml beside the input; without either, the first "
                           "frame is localised by searching the whole room")
      ->group(kTracking);
  app->add_option("--fps", c->o.fps,
                 "Frame rate for time_s, overriding the input's timestamps (0: the timestamps; "
                 "image folders: 10)")
      ->group(kTracking);
  app->add_option("--scale", c->o.scale,
                 "Track frames resized by this factor (0 < S <= 1, area averaging), with the calibration "
                 "scaled to match: large frames (1600x1200 and above) tracked at a resolution the accuracy "
                 "needs, for less work per frame (1: as decoded)")
      ->group(kTracking);
  app->add_option("--odometry", c->o.odometry,
                 "Wheel odometry CSV (time,x,y,theta on the video's clock; one input): the motion "
                 "between frames that the prediction uses instead of constant velocity")
      ->group(kTracking);
  app->add_option("--odometry-scale", c->o.odometry_scale, "Map units per unit of the odometry's positions")
      ->group(kTracking);
  app->add_option("--method", c->method,
                 "Tracking method: junction (PH line junctions) or vertex (corner templates in the "
                 "quasi-cylindrical view)")
      ->check(CLI::IsMember({"junction", "vertex"}))
      ->group(kTracking);
  app->add_option("--search-px", c->o.localizer.search_px,
                 "Half-width of the linear samples: the largest expected image motion per frame (px)")
      ->group(kTracking);
  app->add_option("--min-step", c->o.localizer.junction.min_step,
                 "Smallest intensity step that counts as an edge (grey levels)")
      ->group(kTracking);
  app->add_option("--alert-fraction", c->o.localizer.alert_fraction,
                 "A frame is ok only when its error bound (5 sigma of its position covariance) is within "
                 "this fraction of the distance to its landmarks; 0: no bound")
      ->check(CLI::Range(0.0, 1.0))
      ->group(kTracking);
  app->add_option("--alert-limit", c->o.localizer.alert_limit,
                 "The error bound a frame must be within (map units), instead of --alert-fraction of the "
                 "distance plus 5 times the map's error (its survey sigma, or what the residuals show); 0: that "
                 "automatic limit")
      ->check(CLI::NonNegativeNumber)
      ->group(kTracking);
  app->add_option("--max-speed", c->o.localizer.motion.max_speed,
                 "The robot's top speed (m/s): a pose the room-wide search found is confirmed only by a next "
                 "frame within this reach of it (beyond it, within their errors); also the velocity's spread "
                 "while it is unknown")
      ->check(CLI::PositiveNumber)
      ->capture_default_str()
      ->group(kTracking);
  app->add_option("--survey-sigma", c->o.localizer.survey_sigma,
                 "How well the map was measured: the standard deviation of each corner coordinate (map "
                 "units); default: the map's survey_sigma, checked against the images (docs/maps.md)")
      ->check(CLI::NonNegativeNumber)
      ->default_str("the map's")
      ->group(kTracking);
  app->add_flag_callback("--frame-poses-only", [c] { c->o.localizer.report_fused_with_motion = false; },
               "Report each frame's pose from its own image alone; by default a pose tracked with a known "
               "velocity is reported fused with the motion's prediction for its frame, each weighed by its "
               "covariance")
      ->group(kTracking);
}

void AddRunOptions(CLI::App* app, CommandLine* c) {
  app->add_option("--table-cache", c->table_cache,
                 "Folder where the E(D,Z) lookup tables built for a calibration and map are kept between runs "
                 "(default: $XDG_CACHE_HOME/panotrack, else ~/.cache/panotrack)")
      ->default_str("")
      ->group(kRun);
  app->add_flag("--no-table-cache", c->no_table_cache, "Build the lookup table on every run; read and write no cache")
      ->group(kRun);
  app->add_option("-j,--jobs", c->o.jobs, "Inputs processed in parallel (0: as many as --threads allows)")
      ->group(kRun);
  app->add_option("--threads", c->o.num_threads, "Threads of the whole run (0: all cores)")->group(kRun);
  app->add_option("--decode-memory", c->o.decode_memory_mib,
                 "MiB of decoded frames that may wait per input so that two groups of pictures of an MP4 "
                 "(H.264, HEVC) decode at once, for less CPU than FFmpeg's frame threads (0: never)")
      ->capture_default_str()
      ->group(kRun);
  app->add_option("--hwaccel", c->hwaccel,
                 "Where videos are decoded: none (the CPU), cuda (an NVIDIA GPU's NVDEC through FFmpeg; an error "
                 "where it cannot), auto (NVDEC where a GPU and FFmpeg allow, else the CPU)")
      ->check(CLI::IsMember({"none", "cuda", "auto"}))
      ->capture_default_str()
      ->group(kRun);
  app->add_flag("-q,--quiet", c->o.quiet, "No progress line, notes or summary (errors still on stderr)")
      ->group(kRun);
  app->add_flag("-v,--verbose", c->verbose,
               "The decoding libraries' (FFmpeg, OpenCV) messages, the table cache's use and the run's timing")
      ->group(kRun);
  app->set_version_flag("--version", "panoloc " PANO_VERSION, "Print the version and exit")->group(kRun);
  app->set_help_flag("-h,--help", "Print this help and exit")->group(kRun);
}

// The run's options from the parsed command line; throws pano::Error for
// flags that contradict each other.
pano::PanolocOptions ResolveOptions(const CommandLine& c) {
  pano::PanolocOptions o = c.o;
  if (c.smooth_lag->count() > 0) o.smooth = true;
  if (c.no_table_cache && !c.table_cache.empty())
    throw pano::Error("--table-cache and --no-table-cache: give one of them, not both");
  o.table_cache_dir = c.no_table_cache ? "" : c.table_cache.empty() ? pano::DefaultTableCacheDir() : c.table_cache;
  o.verbose = c.verbose;
  if (!c.init.empty()) o.init = pano::Pose2{c.init[0], c.init[1], c.init[2]};
  o.localizer.method = c.method == "vertex" ? pano::TrackingMethod::kVertex : pano::TrackingMethod::kJunction;
  o.hardware = pano::ParseHardwareDecoding(c.hwaccel);
  o.cancel = &g_cancel;
  return o;
}

// Runs panoloc (RunPanoloc), prints each input's summary and writes the
// JSON summary; returns the exit status.
int RunAndReport(pano::PanolocOptions o, const std::vector<std::string>& command_line) {
  const auto t0 = std::chrono::steady_clock::now();
  const bool show_progress = !o.quiet && ::isatty(2);
  if (show_progress) o.on_progress = ShowProgress;
  InstallStopHandlers();
  const std::vector<pano::VideoSummary> results = pano::RunPanoloc(o);
  if (show_progress) ClearProgress();
  // With the CSV or the JSON on standard output, everything else goes to stderr.
  std::FILE* out = o.output == "-" || o.summary_json == "-" ? stderr : stdout;
  bool all_done = true;
  for (const pano::VideoSummary& s : results) all_done = Report(s, o.quiet, out) && all_done;
  pano::WritePanolocSummaryJson(o, results, command_line);
  if (o.verbose && !o.quiet)
    std::fprintf(out, "panoloc: %zu input%s in %.2f s\n", results.size(), results.size() == 1 ? "" : "s",
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  if (g_signal) return 128 + g_signal;
  return all_done ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "panoloc: localise a robot through videos of a catadioptric panoramic camera.\n"
      "Tracks map landmarks (corners of rectangles and boxes) frame by frame with the Panoramic\n"
      "Hough Transform (line junctions) and triangulates the pose (x, y, heading) from their\n"
      "azimuths. Writes one pose CSV per input (frame,time_s,x,y,theta_rad,status,n_landmarks,\n"
      "residual,std_x,std_y,std_theta), row by row, as OUT.csv.partial until the input ends.\n"
      "Existing output files are kept unless --force is given.",
      "panoloc"};
  app.footer(
      "Exit status: 0 success (every input done); 1 bad options or files, an existing output\n"
      "without --force, or an input failed, broke off or was hardly tracked; 2 unexpected internal\n"
      "error; 130/143 stopped by SIGINT/SIGTERM (the rows so far are kept).");
  app.option_defaults()->always_capture_default();
  CommandLine c;
  AddInputOutputOptions(&app, &c);
  AddTrackingOptions(&app, &c);
  AddRunOptions(&app, &c);
  try {
    app.parse(argc, argv);
    pano::app::RefuseNonFiniteNumbers(app);
  } catch (const CLI::ParseError& e) {
    return pano::app::ExitOnParseError(app, e, "panoloc");
  }
  pano::SetDecoderLogging(c.verbose);
  try {
    return RunAndReport(ResolveOptions(c), std::vector<std::string>(argv, argv + argc));
  } catch (const pano::Error& e) {
    std::fprintf(stderr, "panoloc: %s\n", e.what());
    return g_signal ? 128 + g_signal : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "panoloc: unexpected error: %s\n", e.what());
    return 2;
  }
}
