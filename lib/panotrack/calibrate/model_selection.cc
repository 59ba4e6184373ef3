#include "panotrack/calibrate/model_selection.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "panotrack/calibrate/evaluate.h"
#include "panotrack/core/error.h"
#include "panotrack/core/parallel.h"

namespace pano {

namespace {

std::string CandidateName(const CalibrateOptions& o) {
  if (o.model != MirrorModel::kAsphere) return MirrorModelName(o.model);
  return o.asphere_terms == 1 ? "asphere (a4)" : "asphere (a4, a6)";
}

void Progress(const CalibrateOptions& o, const std::string& what) {
  if (o.on_progress) o.on_progress(what);
}

// One fold's held-out boards, each with the pose fitted through the fold's
// calibration, into the score: per-board errors, the fold's RMS, and the
// sums of squares and corners over all folds.
void ScoreHeldOutFold(const std::vector<std::pair<std::string, BoardPoseFit>>& fits, ModelScore* score,
                      double* held_s2, size_t* held_n) {
  double fold_s2 = 0.0;
  size_t fold_n = 0;
  for (const auto& [file, f] : fits) {
    if (!f.ok) {
      if (score->failure.empty()) score->failure = file + ": " + f.failure;
      ++score->failed_boards;
      continue;
    }
    const double s2 = f.rms_px * f.rms_px * f.corners_used;
    score->board_errors[file] = {s2, static_cast<size_t>(f.corners_used)};
    fold_s2 += s2;
    fold_n += static_cast<size_t>(f.corners_used);
    ++score->heldout_boards;
  }
  *held_s2 += fold_s2;
  *held_n += fold_n;
  score->fold_heldout_rms_px.push_back(fold_n ? std::sqrt(fold_s2 / fold_n) : NAN);
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
    std::vector<std::pair<std::string, BoardPoseFit>> fold_fits;
    for (const BoardView& v : held) fold_fits.push_back({v.file, FitBoardPose(v, board, fit.calib.sensor, eo)});
    ScoreHeldOutFold(fold_fits, &score, &held_s2, &held_n);
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

namespace {

bool SameFaults(const FreeFaults& a, const FreeFaults& b) {
  return a.decentre == b.decentre && a.camera_tilt == b.camera_tilt && a.tangential == b.tangential &&
         a.k3 == b.k3 && a.sensor_tilt == b.sensor_tilt && a.skew == b.skew;
}

// Whether two option sets fit the same model (profile, lens, faults).
bool SameModel(const CalibrateOptions& a, const CalibrateOptions& b) {
  return a.model == b.model && (a.model != MirrorModel::kAsphere || a.asphere_terms == b.asphere_terms) &&
         a.DistortionTerms() == b.DistortionTerms() && SameFaults(a.Faults(), b.Faults());
}

int FaultParameters(const FreeFaults& f) {
  return 2 * f.decentre + 2 * f.camera_tilt + 2 * f.tangential + f.k3 + 2 * f.sensor_tilt + f.skew;
}

std::string FaultNames(const FreeFaults& f) {
  std::string out;
  auto add = [&](bool on, const char* name) {
    if (on) out += std::string(out.empty() ? "" : ", ") + name;
  };
  add(f.decentre, "decentre");
  add(f.camera_tilt, "camera tilt");
  add(f.tangential, "p1 p2");
  add(f.k3, "k3");
  add(f.sensor_tilt, "sensor tilt");
  add(f.skew, "skew");
  return out;
}

// A fit's start: another fit's sensor (as the candidate's model) and the
// poses of the boards kept (keep[i]: view i).
InitialEstimate StartAt(const CalibrationResult& fit, const CalibrateOptions& o, const std::vector<char>& keep,
                        const std::string& summary) {
  InitialEstimate start;
  start.sensor = fit.calib.sensor;
  start.sensor.model = o.model;
  if (o.model != MirrorModel::kAsphere) {
    start.sensor.params.asphere_a4 = 0.0;
    start.sensor.params.asphere_a6 = 0.0;
  } else if (o.asphere_terms < 2) {
    start.sensor.params.asphere_a6 = 0.0;
  }
  start.summary = summary;
  for (size_t i = 0; i < fit.views.size(); ++i)
    if (keep.empty() || keep[i])
      start.poses.push_back({fit.views[i].rvec.x(), fit.views[i].rvec.y(), fit.views[i].rvec.z(),
                             fit.views[i].tvec.x(), fit.views[i].tvec.y(), fit.views[i].tvec.z()});
  return start;
}

bool PosesKnownFor(const std::vector<BoardView>& views, const CalibrateOptions& o) {
  bool all = !views.empty();
  for (const BoardView& v : views) all = all && v.has_pose;
  return all && !o.ignore_known_poses;
}

}  // namespace

std::vector<SelectionCandidate> SelectionCandidates(const CalibrateOptions& options) {
  const bool lens_given = options.distortion_terms >= 0;
  const bool faults_given = options.selection_fixed_faults || options.free_faults_auto || options.free_faults.Any();
  CalibrateOptions base = options;
  base.select_model = false;
  std::vector<SelectionCandidate> out;
  auto add = [&](MirrorModel model, int asphere_terms, int lens, bool faults) {
    SelectionCandidate c;
    c.options = base;
    c.options.model = model;
    if (model == MirrorModel::kAsphere) c.options.asphere_terms = asphere_terms;
    c.options.distortion_terms = lens_given ? options.distortion_terms : lens;
    if (!faults_given) {
      c.options.free_faults_auto = false;
      c.options.free_faults = faults ? DefaultFreeFaults(model) : FreeFaults();
    }
    for (const SelectionCandidate& o : out)
      if (SameModel(o.options, c.options)) return;
    const FreeFaults f = c.options.Faults();
    const int nd = c.options.DistortionTerms();
    c.name = model == MirrorModel::kAsphere ? CandidateName(c.options) : MirrorModelName(model);
    if (nd > 0) c.name += nd == 1 ? " + k1" : " + k1 k2";
    if (f.Any()) c.name += " + " + FaultNames(f);
    c.parameters = (model != MirrorModel::kSphere ? 1 : 0) +
                   (model == MirrorModel::kAsphere ? c.options.asphere_terms : 0) + nd + FaultParameters(f);
    out.push_back(c);
  };
  add(MirrorModel::kSphere, 0, 0, false);
  add(MirrorModel::kConic, 0, 0, false);
  add(MirrorModel::kSphere, 0, 0, true);
  add(MirrorModel::kSphere, 0, 2, false);
  add(MirrorModel::kConic, 0, 2, false);
  add(MirrorModel::kAsphere, 1, 2, false);
  add(MirrorModel::kAsphere, 2, 2, false);
  add(MirrorModel::kConic, 0, 2, true);
  // The central model as cv::omnidir fits it: with fewer boards than a
  // clean cross-validation needs, its plain form wins folds by chance where
  // the camera's shear and tangential terms are real (imgMei: 1.06 x
  // omnidir's held-out error with both, 1.01 with the full model alone).
  add(MirrorModel::kUnified, 0, 2, true);
  std::stable_sort(out.begin(), out.end(), [](const SelectionCandidate& a, const SelectionCandidate& b) {
    return a.parameters < b.parameters;
  });
  // Starts (each before its candidate, having fewer parameters): a sphere
  // from the simplest sphere; a conic, and the asphere (a4), from the conic
  // with the same lens terms (else the simplest conic); the asphere (a4, a6)
  // from the asphere (a4); the unified model from its own initialisation,
  // then with p1 p2 from it (a mirror fit is no start for a central model).
  auto first = [&](MirrorModel m, int terms, int lens) {
    for (size_t i = 0; i < out.size(); ++i)
      if (out[i].options.model == m && (m != MirrorModel::kAsphere || out[i].options.asphere_terms == terms) &&
          (lens < 0 || (out[i].options.DistortionTerms() == lens && !out[i].options.Faults().Any())))
        return static_cast<int>(i);
    return -1;
  };
  for (size_t i = 0; i < out.size(); ++i) {
    const CalibrateOptions& o = out[i].options;
    int s = -1;
    if (o.model == MirrorModel::kSphere) {
      s = first(MirrorModel::kSphere, 0, -1);
    } else if (o.model == MirrorModel::kUnified) {
      s = first(MirrorModel::kUnified, 0, -1);  // the unified model from its own start
    } else if (o.model == MirrorModel::kConic || o.asphere_terms == 1) {
      s = first(MirrorModel::kConic, 0, o.DistortionTerms());
      if (s < 0 || s >= static_cast<int>(i)) s = first(MirrorModel::kConic, 0, -1);
    } else {
      s = first(MirrorModel::kAsphere, 1, -1);
    }
    out[i].start = s >= 0 && s < static_cast<int>(i) ? s : -1;
  }
  return out;
}

std::string UndeterminedParameters(const CalibrationResult& fit, const CalibrateOptions& options) {
  std::string out;
  auto add = [&](const std::string& what) { out += (out.empty() ? "" : "; ") + what; };
  static const char* kJudged[] = {"focal_px", "conic_constant", "xi", "k1", "k2", "decentre_x", "decentre_y",
                                  "camera_tilt_x_deg", "camera_tilt_y_deg", "p1", "p2", "k3",
                                  "sensor_tilt_x_deg", "sensor_tilt_y_deg", "skew_px", "asphere_a4", "asphere_a6"};
  for (const ParameterEstimate& p : fit.parameters) {
    if (p.fixed) continue;
    bool judged = false;
    for (const char* n : kJudged) judged = judged || p.name == n;
    if (!judged) continue;
    char line[160];
    if (!std::isfinite(p.stddev)) {
      add(p.name + " not determined");
    } else if (p.name == "focal_px" && p.stddev > options.selection_max_focal_rel_std * std::abs(p.value)) {
      std::snprintf(line, sizeof line, "focal_px %.0f +- %.0f", p.value, p.stddev);
      add(line);
    } else if ((p.name == "k1" || p.name == "k2") && p.stddev > 1.0) {
      std::snprintf(line, sizeof line, "%s %.3g +- %.3g", p.name.c_str(), p.value, p.stddev);
      add(line);
    }
  }
  return out;
}

bool SelectionPossible(int boards, int folds) {
  folds = std::min(folds, boards);
  return folds >= 2 && boards - (boards + folds - 1) / folds >= 3;
}

namespace {

// What every candidate's fits share.
struct SelectionContext {
  const std::vector<BoardView>& views;
  const TargetBoard& board;
  int width, height;
  const std::string& units;
  const CalibrateOptions& options;
  bool poses_known;
  int folds, threads;
  const CalibrationResult* start_fit;
  const CalibrateOptions* start_options;
};

// Candidate c's fit to all boards: from the pipeline's fit when that is the
// same model, else from the fit of the candidate it starts from, else from
// its own initialisation. Throws pano::Error when it fails or its RMS is
// above max_rms_px.
CalibrationResult FitToAllBoards(const SelectionContext& x, const std::vector<SelectionCandidate>& cands, size_t c,
                                 const std::vector<CalibrationResult>& full, const std::vector<char>& full_ok) {
  const SelectionCandidate& cand = cands[c];
  CalibrationResult fit;
  if (x.start_fit && x.start_options && SameModel(cand.options, *x.start_options)) {
    fit = FitCalibration(x.views, x.board, StartAt(*x.start_fit, cand.options, {}, "the pipeline's fit"),
                         x.poses_known, cand.options);
  } else if (cand.start >= 0 && full_ok[cand.start]) {
    fit = FitCalibration(x.views, x.board,
                         StartAt(full[cand.start], cand.options, {}, "the " + cands[cand.start].name + " fit"),
                         x.poses_known, cand.options);
  } else {
    fit = CalibrateViews(x.views, x.board, x.width, x.height, x.units, cand.options);
  }
  if (fit.rms_px > x.options.max_rms_px)
    throw Error("RMS " + std::to_string(fit.rms_px) + " px exceeds " + std::to_string(x.options.max_rms_px) + " px");
  return fit;
}

// The folds, in parallel, each from the fit to all boards (board i held out
// in fold i mod folds), only each held-out board's pose fitted through it;
// the held-out figures go into `score`.
void ScoreFolds(const SelectionContext& x, const SelectionCandidate& cand, const CalibrationResult& full,
                ModelScore* score) {
  EvaluateOptions eo;
  eo.huber_px = x.options.huber_px;
  eo.full_weight_px = x.options.full_weight_px;
  eo.num_threads = 1;
  const int folds = x.folds;
  std::vector<std::string> fold_failure(folds);
  std::vector<std::vector<std::pair<std::string, BoardPoseFit>>> held_fits(folds);
  ParallelFor(
      folds,
      [&](int fold) {
        std::vector<BoardView> train, held;
        std::vector<char> keep(x.views.size(), 0);
        for (size_t i = 0; i < x.views.size(); ++i) {
          const bool out = static_cast<int>(i) % folds == fold;
          keep[i] = !out;
          (out ? held : train).push_back(x.views[i]);
        }
        CalibrationResult fit;
        try {
          fit = FitCalibration(train, x.board, StartAt(full, cand.options, keep, "the fit to all boards"),
                               x.poses_known, cand.options, folds > 1 ? 1 : x.threads);
          if (fit.rms_px > x.options.max_rms_px) throw Error("RMS " + std::to_string(fit.rms_px) + " px");
        } catch (const Error& e) {
          fold_failure[fold] = "fold " + std::to_string(fold + 1) + ": " + e.what();
          for (const BoardView& v : held) held_fits[fold].push_back({v.file, BoardPoseFit()});
          return;
        }
        for (const BoardView& v : held) {
          BoardPoseFit f = FitBoardPose(v, x.board, fit.calib.sensor, eo);
          if (!f.ok && f.failure.empty()) f.failure = "pose not fitted";
          held_fits[fold].push_back({v.file, f});
        }
      },
      true, x.threads);
  double held_s2 = 0.0;
  size_t held_n = 0;
  for (int fold = 0; fold < folds; ++fold) {
    if (!fold_failure[fold].empty() && score->failure.empty()) score->failure = fold_failure[fold];
    ScoreHeldOutFold(held_fits[fold], score, &held_s2, &held_n);
  }
  if (held_n) score->heldout_rms_px = std::sqrt(held_s2 / held_n);
}

// None could be scored on held-out boards: the simplest candidate that
// fitted all boards, with a warning. Throws when none fitted.
void ChooseUnscored(const std::vector<char>& full_ok, ModelSelection* sel) {
  for (size_t i = 0; i < sel->scores.size() && sel->chosen < 0; ++i)
    if (full_ok[i]) sel->chosen = static_cast<int>(i);
  if (sel->chosen < 0) {
    std::string why;
    for (const ModelScore& s : sel->scores) why += " " + s.name + ": " + s.failure + ";";
    throw Error("model selection: no candidate model fits the boards;" + why.substr(0, why.size() - 1));
  }
  sel->reason = sel->scores[sel->chosen].name +
                ": the simplest model that fits the boards; no candidate could be scored on boards left out of "
                "the fit (their poses could not be fitted, or the boards do not determine the model)";
  sel->warnings.push_back("model selection: no candidate model could be scored on boards left out of the fit; the " +
                          sel->scores[sel->chosen].name +
                          " model is fitted, unchecked (see the model selection table; the calibration may not "
                          "map images other than these)");
}

// Among the candidates not refused that map the most held-out boards, the
// simplest within selection_margin of the lowest held-out RMS, and why.
void ChooseCandidate(const std::vector<char>& full_ok, const CalibrateOptions& options, ModelSelection* sel) {
  // A candidate that cannot map every held-out board extrapolates badly
  // there: those that map the most held-out boards compete.
  int fewest_failed = std::numeric_limits<int>::max();
  for (const ModelScore& s : sel->scores)
    if (s.refused.empty() && s.heldout_boards > 0 && std::isfinite(s.heldout_rms_px))
      fewest_failed = std::min(fewest_failed, s.failed_boards);
  auto competes = [&](const ModelScore& s) {
    return s.refused.empty() && s.heldout_boards > 0 && std::isfinite(s.heldout_rms_px) &&
           s.failed_boards == fewest_failed;
  };
  double best = std::numeric_limits<double>::infinity();
  for (const ModelScore& s : sel->scores)
    if (competes(s)) best = std::min(best, s.heldout_rms_px);
  if (!std::isfinite(best)) return ChooseUnscored(full_ok, sel);
  int best_index = -1;
  for (size_t i = 0; i < sel->scores.size(); ++i) {
    const ModelScore& s = sel->scores[i];
    if (!competes(s)) continue;
    if (s.heldout_rms_px == best && best_index < 0) best_index = static_cast<int>(i);
    if (sel->chosen < 0 && s.heldout_rms_px <= best * (1.0 + options.selection_margin))
      sel->chosen = static_cast<int>(i);
  }
  const ModelScore& ch = sel->scores[sel->chosen];
  char line[400];
  if (sel->chosen == best_index)
    std::snprintf(line, sizeof line, "%s: the lowest error on boards left out of the fit (%.4f px)", ch.name.c_str(),
                  ch.heldout_rms_px);
  else
    std::snprintf(line, sizeof line,
                  "%s: the simplest model within %.0f %% of the lowest error on boards left out of the fit "
                  "(%.4f px against %s's %.4f px)",
                  ch.name.c_str(), 100.0 * options.selection_margin, ch.heldout_rms_px,
                  sel->scores[best_index].name.c_str(), best);
  sel->reason = line;
  if (fewest_failed > 0) {
    std::snprintf(line, sizeof line,
                  "model selection: no candidate model maps every board left out of the fit (the best %d of "
                  "%d); the %s model maps the most, but may not map images other than these",
                  ch.heldout_boards, ch.heldout_boards + ch.failed_boards, ch.name.c_str());
    sel->warnings.push_back(line);
    sel->reason += "; no candidate maps every board left out";
  }
}

}  // namespace

ModelSelection SelectModel(const std::vector<BoardView>& views, const TargetBoard& board, int width, int height,
                           const std::string& units, const CalibrateOptions& options,
                           const CalibrationResult* start_fit, const CalibrateOptions* start_options) {
  options.Check();
  // Each fold's training set must still calibrate: 3 boards at least.
  const int n = static_cast<int>(views.size());
  if (!SelectionPossible(n, options.selection_folds))
    throw Error("model selection: " + std::to_string(views.size()) +
                " boards found; choosing the model by cross-validation needs 4 at least (give --model)");
  const SelectionContext x{views,   board, width, height, units, options, PosesKnownFor(views, options),
                           std::min(options.selection_folds, n), options.Threads(), start_fit, start_options};
  const std::vector<SelectionCandidate> cands = SelectionCandidates(options);
  ModelSelection sel;
  std::vector<CalibrationResult> full(cands.size());
  std::vector<char> full_ok(cands.size(), 0);
  for (size_t c = 0; c < cands.size(); ++c) {
    const SelectionCandidate& cand = cands[c];
    ModelScore score;
    score.model = cand.options.model;
    score.asphere_terms = cand.options.model == MirrorModel::kAsphere ? cand.options.asphere_terms : 0;
    score.name = cand.name;
    score.parameters = cand.parameters;
    Progress(options, cand.name);
    try {
      full[c] = FitToAllBoards(x, cands, c, full, full_ok);
      full_ok[c] = 1;
    } catch (const Error& e) {
      score.failure = std::string("the fit to all boards failed: ") + e.what();
      score.refused = score.failure;
      score.failed_boards = n;
      sel.scores.push_back(score);
      continue;
    }
    score.training_rms_px = full[c].rms_px;
    score.refused = UndeterminedParameters(full[c], cand.options);
    if (!score.refused.empty()) {
      score.refused = "not determined by the boards: " + score.refused;
      sel.scores.push_back(score);
      continue;
    }
    ScoreFolds(x, cand, full[c], &score);
    sel.scores.push_back(score);
  }
  ChooseCandidate(full_ok, options, &sel);
  int refused = 0;
  for (const ModelScore& s : sel.scores) refused += !s.refused.empty();
  if (refused) sel.reason += "; " + std::to_string(refused) + " refused as not determined by the boards";
  sel.options = cands[sel.chosen].options;
  sel.fit = full[sel.chosen];
  return sel;
}

std::string ModelSelectionTable(const std::vector<ModelScore>& scores, int chosen) {
  std::string out = "model selection (cross-validation over the boards; held-out boards: only their pose fitted):\n";
  char line[300];
  for (size_t i = 0; i < scores.size(); ++i) {
    const ModelScore& s = scores[i];
    std::string train = std::isfinite(s.training_rms_px) ? "" : "      -   ";
    if (std::isfinite(s.heldout_rms_px))
      std::snprintf(line, sizeof line, "  %-42s training %7.4f px  held-out %7.4f px", s.name.c_str(),
                    s.training_rms_px, s.heldout_rms_px);
    else if (std::isfinite(s.training_rms_px))
      std::snprintf(line, sizeof line, "  %-42s training %7.4f px  held-out      -   ", s.name.c_str(),
                    s.training_rms_px);
    else
      std::snprintf(line, sizeof line, "  %-42s training      -     held-out      -   ", s.name.c_str());
    out += line;
    if (!s.refused.empty()) out += "  refused: " + s.refused;
    else if (s.failed_boards) out += "  (" + std::to_string(s.failed_boards) + " held-out boards not mapped)";
    if (static_cast<int>(i) == chosen) out += "  <- chosen";
    out += "\n";
  }
  return out;
}

}  // namespace pano
