// The mirror profile chosen by cross-validation over the boards
// (`panocalib calibrate --model auto`). A richer profile always fits its own
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

// The candidates, simplest first: sphere, conic, asphere (a4), asphere (a4,
// a6); each with the lens distortion and rig faults `options` asks for.
std::vector<CalibrateOptions> ModelCandidates(const CalibrateOptions& options);

struct ModelSelection {
  std::vector<ModelScore> scores;  // one per candidate, simplest first
  int chosen = -1;                 // index into scores
};

// Cross-validates every candidate (options.selection_folds folds, fewer when
// there are fewer boards) and chooses among those that scored every held-out
// board the simplest whose held-out RMS is within options.selection_margin
// (a fraction) of the lowest. Throws pano::Error when there are too few
// boards to hold any out or no candidate scores every board.
ModelSelection SelectMirrorModel(const std::vector<BoardView>& views, const TargetBoard& board, int width,
                                 int height, const std::string& units, const CalibrateOptions& options);

// The scores as a small table (one line per candidate, the chosen marked).
std::string ModelSelectionTable(const std::vector<ModelScore>& scores, int chosen);

}  // namespace pano
