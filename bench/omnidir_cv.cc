// omnidir_cv INPUT [--board COLSxROWS --square S [--units U]] [--folds K] [--json FILE]
//            [--fix-skew] [--fix-tangential]
//
// The peer's half of tools/compare_omnidir.sh: system-level K-fold
// cross-validation of OpenCV's cv::omnidir (Mei's unified model) as a user
// would run it. The board is detected in every image with
// findChessboardCornersSB (panotrack's raw detection: the quick search, the
// exhaustive one where it fails); image i (in the input's order: a target
// file's list, or a folder's natural order) is held out in fold i mod K.
// Each fold calibrates omnidir on the boards of its training images
// (cv::omnidir::calibrate, every term free), then fits only the pose of each
// held-out board through it (OmnidirHeldOut) and scores its corners
// (Euclidean RMS in pixels, cv::omnidir::projectPoints). Prints one line per
// fold and the overall held-out RMS; --json also writes every held-out
// image's figures, for the comparison on the boards both tools scored.
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <string>
#include <vector>

#include "panotrack/calibrate/calibrate.h"
#include "panotrack/calibrate/omnidir_peer.h"
#include "panotrack/core/error.h"
#include "panotrack/io/targets.h"
#include "panotrack/pipeline/target_input.h"

namespace {

[[noreturn]] void Usage(const std::string& why) {
  std::fprintf(stderr,
               "omnidir_cv: %s\nusage: omnidir_cv INPUT [--board COLSxROWS --square S [--units U]] [--folds K] "
               "[--json FILE] [--fix-skew] [--fix-tangential]\n",
               why.c_str());
  std::exit(1);
}

}  // namespace

namespace {

// The command line.
struct Args {
  std::string input_path, board_spec, units = "cm", json_path;
  double square = 0.0;
  int folds = 5, flags = 0;
};

Args ParseArgs(int argc, char** argv) {
  Args r;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) Usage(a + ": expected a value");
      return argv[++i];
    };
    if (a == "--board") r.board_spec = value();
    else if (a == "--square") r.square = std::atof(value().c_str());
    else if (a == "--units") r.units = value();
    else if (a == "--folds") r.folds = std::atoi(value().c_str());
    else if (a == "--json") r.json_path = value();
    else if (a == "--fix-skew") r.flags |= cv::omnidir::CALIB_FIX_SKEW;
    else if (a == "--fix-tangential") r.flags |= cv::omnidir::CALIB_FIX_P1 | cv::omnidir::CALIB_FIX_P2;
    else if (!a.empty() && a[0] == '-') Usage("unknown option " + a);
    else if (r.input_path.empty()) r.input_path = a;
    else Usage("one input expected");
  }
  if (r.input_path.empty()) Usage("no input");
  if (r.folds < 2) Usage("--folds: expected 2 or more");
  return r;
}

// What the folds add up.
struct Totals {
  double s2 = 0.0;
  size_t n = 0;
  int failed_folds = 0;
  nlohmann::ordered_json per_image = nlohmann::ordered_json::array();
};

// One fold: omnidir on the training boards, only each held-out board's
// pose fitted through it; its line printed, its JSON returned.
nlohmann::ordered_json RunFold(const std::vector<pano::BoardView>& views, const pano::TargetBoard& board,
                               const cv::Size& size, const Args& args, int fold, Totals* t) {
  const std::vector<Eigen::Vector3d> pts = pano::BoardPoints(board);
  std::vector<pano::BoardView> train, held;
  for (const pano::BoardView& v : views) (v.image_index % args.folds == fold ? held : train).push_back(v);
  nlohmann::ordered_json f = {{"fold", fold}, {"training_boards", train.size()}, {"heldout_boards", held.size()}};
  pano::OmnidirFit fit;
  std::string failure;
  try {
    if (train.size() < 3) throw pano::Error("fewer than 3 training boards");
    fit = pano::FitOmnidir(train, board, size, args.flags);
    if (fit.images_used < 3 || !std::isfinite(fit.rms_px))
      throw pano::Error("omnidir kept " + std::to_string(fit.images_used) + " boards");
  } catch (const std::exception& e) {
    failure = e.what();
  }
  double s2 = 0.0;
  size_t n = 0;
  int not_fitted = 0;
  if (failure.empty()) {
    for (const pano::BoardView& v : held) {
      double s2b = 0.0;
      size_t nb = 0;
      const bool ok = pano::OmnidirHeldOut(fit, v, pts, &s2b, &nb) && nb > 0 && std::isfinite(s2b);
      nlohmann::ordered_json im = {{"file", v.file}, {"fold", fold}, {"fitted", ok}};
      if (ok) {
        im["corners"] = nb;
        im["rms_px"] = std::sqrt(s2b / nb);
        s2 += s2b;
        n += nb;
      } else {
        ++not_fitted;
      }
      t->per_image.push_back(im);
    }
  }
  const double rms = n ? std::sqrt(s2 / n) : NAN;
  t->s2 += s2;
  t->n += n;
  if (!failure.empty()) {
    ++t->failed_folds;
    std::printf("  fold %d: %zu training boards: omnidir failed (%s)\n", fold, train.size(), failure.c_str());
    f["failure"] = failure;
    return f;
  }
  std::printf("  fold %d: %zu training boards (training RMS %.4f px over %d kept), held out %.4f px over %zu "
              "boards%s\n",
              fold, train.size(), fit.rms_px, fit.images_used, rms, held.size() - not_fitted,
              not_fitted ? (" (" + std::to_string(not_fitted) + " not fitted)").c_str() : "");
  f["training_rms_px"] = fit.rms_px;
  f["training_boards_kept"] = fit.images_used;
  nlohmann::ordered_json kept = nlohmann::ordered_json::array();
  for (int i : fit.kept) kept.push_back(train[static_cast<size_t>(i)].file);
  f["kept_files"] = kept;
  const pano::OmnidirIntrinsics k(fit);
  f["intrinsics"] = {{"fx", k.fx}, {"fy", k.fy}, {"skew", k.s}, {"cx", k.cx}, {"cy", k.cy}, {"xi", k.xi},
                     {"k1", k.k1},  {"k2", k.k2}, {"p1", k.p1},  {"p2", k.p2}};
  f["heldout_rms_px"] = std::isfinite(rms) ? nlohmann::ordered_json(rms) : nlohmann::ordered_json(nullptr);
  return f;
}

}  // namespace

int main(int argc, char** argv) {
  const Args args = ParseArgs(argc, argv);
  try {
    pano::TargetInputBoard tb;
    tb.board_given = !args.board_spec.empty();
    if (tb.board_given) {
      if (!(args.square > 0)) Usage("--square: required with --board");
      tb.board = pano::ParseBoardSpec(args.board_spec, args.square, 0.0, "DICT_4X4_50");
      tb.units = args.units;
    }
    const pano::TargetSet targets = pano::ReadTargetInput(args.input_path, tb);
    const std::vector<cv::Mat> images = pano::LoadTargetImages(targets);
    pano::CalibrateOptions detect;
    const pano::DetectionResult det = pano::DetectBoards(targets, images, detect);
    const cv::Size size(det.image_width, det.image_height);
    const int n_images = static_cast<int>(targets.images.size());
    std::printf("omnidir_cv: %zu boards found in %d images; %d folds (image i held out in fold i mod %d)\n",
                det.views.size(), n_images, args.folds, args.folds);
    Totals t;
    nlohmann::ordered_json per_fold = nlohmann::ordered_json::array();
    for (int fold = 0; fold < args.folds; ++fold) per_fold.push_back(RunFold(det.views, targets.board, size, args, fold, &t));
    const double overall = t.n ? std::sqrt(t.s2 / t.n) : NAN;
    std::printf("omnidir held-out RMS %.4f px over %zu corners; %d failed folds\n", overall, t.n, t.failed_folds);
    if (!args.json_path.empty()) {
      const nlohmann::ordered_json j = {
          {"tool", "omnidir_cv"},
          {"boards_found", det.views.size()},
          {"images", n_images},
          {"not_found", det.not_found_files},
          {"folds", per_fold},
          {"per_image", t.per_image},
          {"heldout_rms_px", std::isfinite(overall) ? nlohmann::ordered_json(overall) : nlohmann::ordered_json(nullptr)},
          {"failed_folds", t.failed_folds}};
      std::ofstream(args.json_path) << j.dump(2) << "\n";
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "omnidir_cv: %s\n", e.what());
    return 1;
  }
  return 0;
}
