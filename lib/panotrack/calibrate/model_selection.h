// The mirror profile, lens distortion and rig faults chosen by
// cross-validation over the boards (`panocalib calibrate --model auto`). A richer profile always fits its own
// boards at least as well; whether it maps other images better is what a
// user needs, and only images it was not fitted to can say. Each candidate
// is fitted to the boards of all folds but one, only each held-out board's
// pose is fitted through it (FitBoardPose, as `panocalib evaluate`), and its
// corners are scored. The simplest profile within a small margin of the best
// held-out error is chosen.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "panotrack/calibrate/calibrate.h"

namespace pano {

// Fits `options` (its model and every other setting) to each fold's training
// boards (board k is held out in fold k mod folds) and scores the held-out
// boards. A fold whose fit fails scores none of its boards (failed_boards);
// so does a held-out board whose pose cannot be fitted through the model.
// on_fold (optional) sees each fold's successful fit.
ModelScore CrossValidateModel(const std::vector<BoardView>& views, const TargetBoard& board, int width, int height,
                              const std::string& units, const CalibrateOptions& options, int folds,
                              const std::function<void(int fold, const CalibrationResult& fit)>& on_fold = {});

// The profiles of the cold cross-validation (CrossValidateModel, each fold
// from its own initialisation; bench/calibrate_compare), simplest first:
// sphere, conic, asphere (a4), asphere (a4, a6); each with the lens
// distortion and rig faults `options` asks for.
std::vector<CalibrateOptions> ModelCandidates(const CalibrateOptions& options);

// One candidate of the model selection: mirror profile, lens distortion and
// rig faults, and the candidate whose fit to all boards starts its own.
struct SelectionCandidate {
  CalibrateOptions options;  // select_model off
  std::string name;          // e.g. "sphere + k1 k2", "conic + k1 k2 + decentre, camera tilt"
  int parameters = 0;        // sensor parameters beyond the plain sphere's (the order of simplicity)
  int start = -1;            // index of the candidate whose fit starts this one; -1: its own initialisation
};

// The candidates, simplest first (fewest parameters): sphere; conic;
// sphere + decentre; sphere + k1 k2; conic + k1 k2; asphere (a4) + k1 k2; asphere
// (a4, a6) + k1 k2; conic + k1 k2 + decentre, camera tilt. Lens distortion
// given in `options` (distortion_terms >= 0) holds for every candidate, and
// so do rig faults given (free_faults_auto or any free fault): then
// candidates that differ only there are one.
std::vector<SelectionCandidate> SelectionCandidates(const CalibrateOptions& options);

// Why a fit's parameters are not determined by the boards, or "" when they
// are: a free parameter of the profile, lens or rig without a standard
// deviation (the covariance is rank-deficient there, or a rig fault's
// deviation is beyond CalibrateOptions::fault_warning_std), the focal
// length's relative deviation above options.selection_max_focal_rel_std, a
// lens term's deviation above 1. The mirror's size is not judged: with
// estimated poses only parallax fixes it, whatever the model.
std::string UndeterminedParameters(const CalibrationResult& fit, const CalibrateOptions& options);

// Whether `boards` boards are enough to choose a model with `folds` folds
// (each fold's training set must still calibrate: 3 boards at least).
bool SelectionPossible(int boards, int folds);

struct ModelSelection {
  std::vector<ModelScore> scores;  // one per candidate, simplest first
  int chosen = -1;                 // index into scores
  CalibrateOptions options;        // the chosen candidate's options
  CalibrationResult fit;           // the chosen candidate fitted to all boards
  std::string reason;              // why it was chosen, one sentence
  std::vector<std::string> warnings;  // a choice made without every held-out board, or without any
};

// Chooses the mirror profile, the lens distortion and the rig faults by
// cross-validation over the boards (options.selection_folds folds, fewer
// when there are fewer boards). Each candidate is fitted to all boards
// (from its own initialisation, or from a simpler candidate's fit, or from
// `start_fit` when its options, `start_options`, fit the candidate's model,
// lens and faults); a
// candidate whose parameters the boards leave undetermined
// (UndeterminedParameters) is refused. Each fold's fit starts from the
// candidate's fit to all boards, without the held-out boards, and only each
// held-out board's pose is fitted through it (FitBoardPose). Among the
// candidates not refused that scored the most held-out boards (every one,
// normally; fewer with a warning), the simplest whose held-out RMS is
// within options.selection_margin (a fraction) of the lowest is chosen;
// when none could be scored, the simplest that fitted all boards, with a
// warning. Throws pano::Error when there are too few boards to hold any out
// or no candidate fits the boards at all.
ModelSelection SelectModel(const std::vector<BoardView>& views, const TargetBoard& board, int width, int height,
                           const std::string& units, const CalibrateOptions& options,
                           const CalibrationResult* start_fit = nullptr,
                           const CalibrateOptions* start_options = nullptr);

// The scores as a small table (one line per candidate, the chosen marked).
std::string ModelSelectionTable(const std::vector<ModelScore>& scores, int chosen);

}  // namespace pano
