// panocalib evaluate: the reprojection error of a fixed calibration on other
// images (only each board's pose fitted).
#include <cstdio>
#include <memory>
#include <string>

#include "commands.h"
#include "panotrack/core/command_line.h"
#include "panotrack/core/error.h"
#include "panotrack/core/output_check.h"
#include "panotrack/io/targets.h"
#include "panotrack/pipeline/panocalib.h"
#include "panotrack/video/logging.h"

namespace pano::app {

void AddEvaluateCommand(CLI::App& app) {
  struct Opts {
    std::string calib, targets, summary_json;
    std::string board, dictionary = "DICT_4X4_50", units = TargetSet().units;
    double square = 0.0, marker = 0.0;
    int every = 0;
    EvaluateOptions eval;
    bool no_refine = false, no_unwarp = false, robust_pose = false, force = false, quiet = false;
  };
  auto o = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "evaluate",
      "Check a calibration on images it was not fitted to: detect the board in each image, fit only "
      "the board's pose through the calibration (which stays fixed) and print each image's corners, "
      "RMS and largest reprojection error, then the RMS over all corners. Run it on held-out images "
      "before trusting a calibration: an RMS well above the calibration's own says it fits only its "
      "images. Fails (exit 1) when no image shows the board.");
  cmd->add_option("--calib", o->calib, "Calibration YAML (not changed)")->required();
  cmd->add_option("targets", o->targets,
                  "Target file (.yaml/.yml; known board poses are not used), or a folder of images or a "
                  "video with --board and --square, as for calibrate")
      ->required();
  CLI::Option* board_opt = cmd->add_option(
      "--board", o->board, "Board for a folder or video: COLSxROWS inner corners, or charuco:COLSxROWS");
  cmd->add_option("--square", o->square, "Square side in the calibration's units (with --board)")->needs(board_opt);
  cmd->add_option("--marker", o->marker, "ChArUco marker side (with --board charuco:...)")->needs(board_opt);
  cmd->add_option("--dictionary", o->dictionary, "ChArUco: OpenCV's ArUco dictionary")->needs(board_opt);
  cmd->add_option("--units", o->units, "Units of --square (with --board)")->needs(board_opt);
  cmd->add_option("--every", o->every, "Video: take every N-th frame (0: about 30 frames)")->needs(board_opt);
  cmd->add_option("--huber", o->eval.huber_px,
                  "Huber loss threshold of the pose fit in pixels (0: least squares); the fit is then finished by "
                  "plain least squares unless --robust-pose");
  cmd->add_option("--full-weight", o->eval.full_weight_px,
                  "Corner weights of the pose fit, as for calibrate (0: uniform)");
  cmd->add_flag("--robust-pose", o->robust_pose,
                "Report the errors at the robust, weighted fit's pose (default: each pose finished by plain least "
                "squares from there, the reprojection error as OpenCV reports it)");
  cmd->add_flag("--no-refine", o->no_refine,
                "Score the detector's corners as found (default: located again through the model, as "
                "calibrate does before its final fit)");
  cmd->add_flag("--no-unwarp", o->no_unwarp,
                "Do not search images without a board in views unwarped through the calibration (calibrate's "
                "step 4; default: searched, so that the boards scored are the ones calibrate used)");
  cmd->add_option("-j,--jobs,--threads", o->eval.num_threads, "Threads for the image searches (0: every core)");
  cmd->add_option("--summary-json", o->summary_json,
                  "Also write the figures (per image and overall) as JSON; - writes it to standard output");
  cmd->add_flag("--force", o->force, "Replace an existing --summary-json file");
  cmd->add_flag("-q,--quiet", o->quiet, "No per-image lines or summary (errors still on stderr)");
  cmd->add_flag("-v,--verbose", o->eval.verbose, "Print the pose fits' reports and the libraries' warnings");
  cmd->parse_complete_callback([o]() {
    CheckPlannedOutputs({{"--calib", o->calib}, {"", o->targets}}, {{"--summary-json", o->summary_json}}, o->force);
  });
  cmd->callback([o]() {
    EvaluateOptions opt = o->eval;
    SetDecoderLogging(opt.verbose);  // a board video's FFmpeg lines only with -v
    if (opt.verbose) opt.on_log = [](const std::string& line) { std::fprintf(stderr, "%s\n", line.c_str()); };
    if (o->no_refine) opt.refine_passes = 0;
    opt.least_squares_pose = !o->robust_pose;
    opt.unwarp_fallback = !o->no_unwarp;
    EvaluateJob job;
    job.calibration = o->calib;
    job.targets = o->targets;
    job.board = BoardInputOf(o->board, o->square, o->marker, o->dictionary, o->units, o->every, "calibration units");
    job.options = opt;
    job.summary_json = o->summary_json;
    job.command_line = CommandLine();
    job.names = {{{"--calib", o->calib}}, {{"--summary-json", o->summary_json}}};
    const EvaluationResult r = RunEvaluate(job);
    if (o->quiet) return;
    std::FILE* text = o->summary_json == "-" ? stderr : stdout;
    std::fprintf(text, "%s", EvaluationSummary(r).c_str());
    for (const std::string& w : r.warnings) std::fprintf(stderr, "panocalib: warning: %s\n", w.c_str());
  });
}

}  // namespace pano::app
