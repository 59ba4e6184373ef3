#include "panotrack/calibrate/model_selection.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "panotrack/calibrate/evaluate.h"
#include "panotrack/core/error.h"

namespace pano {

namespace {

std::string CandidateName(const CalibrateOptions& o) {
  if (o.model != MirrorModel::kAsphere) return mirror_model_name(o.model);
  return o.asphere_terms == 1 ? "asphere (a4)" : "asphere (a4, a6)";
}

void Progress(const CalibrateOptions& o, const std::string& what) {
  if (o.on_progress) o.on_progress(what);
}

}  // namespace

ModelScore CrossValidateModel(const std::vector<BoardView>& views, const TargetBoard& board, int width, int height,
                              const std::string& units, const CalibrateOptions& options, int folds,
                              const std::function<void(int, const CalibrationResult&)>& on_fold) {
  if (folds < 2 || static_cast<size_t>(folds) > views.size())
    throw Error("cross-validation: expected 2 to " + std::to_string(views.size()) + " folds (one per board at most), got " +
                std::to_string(folds));
  ModelScore score;
  score.model = options.model;
  score.asphere_terms = options.model == MirrorModel::kAsphere ? options.asphere_terms : 0;
  score.name = CandidateName(options);
  EvaluateOptions eo;
  eo.huber_px = options.huber_px;
  eo.full_weight_px = options.full_weight_px;
  eo.num_threads = options.num_threads;
  double train_s2 = 0.0, held_s2 = 0.0;
  size_t train_n = 0, held_n = 0;
  for (int fold = 0; fold < folds; ++fold) {
    std::vector<BoardView> train, held;
    for (size_t i = 0; i < views.size(); ++i) (static_cast<int>(i) % folds == fold ? held : train).push_back(views[i]);
    Progress(options, score.name + ": fold " + std::to_string(fold + 1) + " of " + std::to_string(folds));
    CalibrationResult fit;
    try {
      fit = CalibrateViews(train, board, width, height, units, options);
    } catch (const Error& e) {
      if (score.failure.empty()) score.failure = "fold " + std::to_string(fold + 1) + ": " + e.what();
      score.failed_boards += static_cast<int>(held.size());
      score.fold_heldout_rms_px.push_back(NAN);
      continue;
    }
    if (on_fold) on_fold(fold, fit);
    size_t train_corners = 0;
    for (const BoardView& v : train) train_corners += v.corners.size();
    train_s2 += fit.rms_px * fit.rms_px * static_cast<double>(train_corners);
    train_n += train_corners;
    double fold_s2 = 0.0;
    size_t fold_n = 0;
    for (const BoardView& v : held) {
      const BoardPoseFit f = FitBoardPose(v, board, fit.calib.sensor, eo);
      if (!f.ok) {
        if (score.failure.empty()) score.failure = v.file + ": " + f.failure;
        ++score.failed_boards;
        continue;
      }
      const double s2 = f.rms_px * f.rms_px * f.corners_used;
      score.board_errors[v.file] = {s2, static_cast<size_t>(f.corners_used)};
      fold_s2 += s2;
      fold_n += static_cast<size_t>(f.corners_used);
      ++score.heldout_boards;
    }
    held_s2 += fold_s2;
    held_n += fold_n;
    score.fold_heldout_rms_px.push_back(fold_n ? std::sqrt(fold_s2 / fold_n) : NAN);
  }
  if (train_n) score.training_rms_px = std::sqrt(train_s2 / train_n);
  if (held_n) score.heldout_rms_px = std::sqrt(held_s2 / held_n);
  return score;
}

std::vector<CalibrateOptions> ModelCandidates(const CalibrateOptions& options) {
  std::vector<CalibrateOptions> out;
  CalibrateOptions o = options;
  o.select_model = false;
  o.model = MirrorModel::kSphere;
  out.push_back(o);
  o.model = MirrorModel::kConic;
  out.push_back(o);
  o.model = MirrorModel::kAsphere;
  o.asphere_terms = 1;
  out.push_back(o);
  o.asphere_terms = 2;
  out.push_back(o);
  return out;
}

ModelSelection SelectMirrorModel(const std::vector<BoardView>& views, const TargetBoard& board, int width,
                                 int height, const std::string& units, const CalibrateOptions& options) {
  options.Check();
  // Each fold's training set must still calibrate: 3 boards at least.
  const int n = static_cast<int>(views.size());
  const int folds = std::min(options.selection_folds, n);
  if (folds < 2 || n - (n + folds - 1) / folds < 3)
    throw Error("model selection: " + std::to_string(views.size()) +
                " boards found; choosing the mirror model by cross-validation needs 4 at least (give --model)");
  ModelSelection sel;
  for (const CalibrateOptions& c : ModelCandidates(options))
    sel.scores.push_back(CrossValidateModel(views, board, width, height, units, c, folds));
  // A profile that cannot map every held-out board extrapolates badly there.
  double best = std::numeric_limits<double>::infinity();
  for (const ModelScore& s : sel.scores)
    if (s.failed_boards == 0 && std::isfinite(s.heldout_rms_px)) best = std::min(best, s.heldout_rms_px);
  if (!std::isfinite(best)) {
    std::string why;
    for (const ModelScore& s : sel.scores) why += " " + s.name + ": " + (s.failure.empty() ? "no score" : s.failure) + ";";
    throw Error("model selection: no mirror model maps every held-out board;" + why.substr(0, why.size() - 1));
  }
  for (size_t i = 0; i < sel.scores.size(); ++i) {
    const ModelScore& s = sel.scores[i];
    if (s.failed_boards == 0 && s.heldout_rms_px <= best * (1.0 + options.selection_margin)) {
      sel.chosen = static_cast<int>(i);
      break;
    }
  }
  return sel;
}

std::string ModelSelectionTable(const std::vector<ModelScore>& scores, int chosen) {
  std::string out = "model selection (cross-validation over the boards; held-out boards: only their pose fitted):\n";
  char line[200];
  for (size_t i = 0; i < scores.size(); ++i) {
    const ModelScore& s = scores[i];
    if (std::isfinite(s.heldout_rms_px))
      std::snprintf(line, sizeof line, "  %-18s training %7.4f px  held-out %7.4f px", s.name.c_str(),
                    s.training_rms_px, s.heldout_rms_px);
    else
      std::snprintf(line, sizeof line, "  %-18s training %7.4f px  held-out      -   ", s.name.c_str(),
                    s.training_rms_px);
    out += line;
    if (s.failed_boards) out += "  (" + std::to_string(s.failed_boards) + " held-out boards not mapped)";
    if (static_cast<int>(i) == chosen) out += "  <- chosen";
    out += "\n";
  }
  return out;
}

}  // namespace pano
