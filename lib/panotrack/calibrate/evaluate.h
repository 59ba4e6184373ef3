// Held-out check of a fixed calibration (`panocalib evaluate`): the board is
// detected in other images, only each board's pose (6 degrees of freedom) is
// fitted through the calibration's sensor, which is not changed, and the
// reprojection error of the corners is reported per image and over all.
// A calibration that only fits its own images shows here as an RMS well
// above the one `panocalib calibrate` reported.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <functional>
#include <string>
#include <vector>

#include "panotrack/calibrate/calibrate.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/targets.h"
#include "panotrack/sensor/sensor.h"

namespace pano {

struct EvaluateOptions {
  // The pose fit's objective, as in the calibration's fit (CalibrateOptions):
  // Huber threshold (pixels; <= 0: least squares) and corner weights
  // (<= 0: uniform). The reported errors are plain pixels either way.
  double huber_px = CalibrateOptions().huber_px;
  double full_weight_px = CalibrateOptions().full_weight_px;
  // Each board's pose then finished by plain least squares on its corners
  // from the robust fit's, so that the RMS reported is that of the
  // least-squares pose (the reprojection error as OpenCV's calibrations
  // report it); false: the errors at the robust, weighted fit's pose.
  bool least_squares_pose = true;
  // Passes of corner refinement through the fixed model (as calibrate's
  // step 5, so that the figures compare with its RMS); 0: the detector's corners.
  int refine_passes = CalibrateOptions().refine_passes;
  // Images where the raw search finds no board are searched again in views
  // unwarped through the calibration, as calibrate does (its step 4).
  bool unwarp_fallback = true;
  int max_iterations = 100;
  int num_threads = 0;  // detection and refinement; 0: every core
  bool verbose = false;  // the libraries' warnings (FFmpeg's, through the programs)
  // Each pose fit's summary, a line at a time (empty: none).
  std::function<void(const std::string&)> on_log;
  // Throws pano::Error naming the bad option.
  void Check() const;
};

// One board's pose through a fixed sensor and its corners' errors.
struct BoardPoseFit {
  bool ok = false;
  std::string failure;  // why not, when !ok
  Eigen::Vector3d rvec = Eigen::Vector3d::Zero();  // X_sensor = R(rvec) X_board + tvec
  Eigen::Vector3d tvec = Eigen::Vector3d::Zero();
  // The robust, weighted fit's pose (rvec, tvec before the least-squares
  // finish): the one a stray corner cannot pull, where corners are refined.
  Eigen::Vector3d robust_rvec = Eigen::Vector3d::Zero();
  Eigen::Vector3d robust_tvec = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector2d> residuals;  // projected - observed; NaN where not visible
  int corners_used = 0;                    // visible through the fitted pose
  double rms_px = NAN;
  double max_px = NAN;
};

// Fits only the pose of `view`'s board (from the linear pose through the
// sensor, then Ceres on the reprojection error); the sensor stays as given.
// A view's known pose (has_pose) is not used.
BoardPoseFit FitBoardPose(const BoardView& view, const TargetBoard& board, const Sensor& sensor,
                          const EvaluateOptions& options);

struct ImageEvaluation {
  int image_index = -1;
  std::string file;
  bool found = false;   // board detected
  BoardPoseFit fit;     // when found
  int corners = 0;      // detected corners
};

struct EvaluationResult {
  std::string model;  // the calibration's mirror model
  std::vector<ImageEvaluation> images;  // one per image, in the target file's order
  int boards_found = 0;
  int boards_fitted = 0;
  int corners = 0;        // corners scored (visible, over fitted boards)
  double rms_px = NAN;    // Euclidean RMS over every scored corner
  double max_px = NAN;
  std::vector<std::string> warnings;
  double seconds_detect = 0.0;
  double seconds_fit = 0.0;
};

// Scores given views (corners already found, e.g. held-out boards) through
// `sensor`. Throws pano::Error when no view's pose can be fitted.
EvaluationResult EvaluateViews(const std::vector<BoardView>& views, const TargetBoard& board,
                               const Sensor& sensor, const EvaluateOptions& options);

// The views whose board pose `r` (EvaluateViews' result on `views`)
// fitted, each at its robust fit's pose (robust_rvec, robust_tvec).
std::vector<BoardView> ViewsAtFittedPoses(const std::vector<BoardView>& views, const EvaluationResult& r);

// options.refine_passes passes over `views`, whose score `r` is: the fitted
// boards' corners refined through `sensor` at their robust poses (`threads`
// threads), then every pose fitted again (EvaluateViews). Returns the last
// score (r itself when there is no pass).
EvaluationResult RefineAndEvaluate(const std::vector<cv::Mat>& images, const TargetBoard& board,
                                   const Sensor& sensor, const EvaluateOptions& options, int threads,
                                   std::vector<BoardView>* views, EvaluationResult r);

// Detects the board in every image as calibrate does (the raw search, then
// the images without a board in views unwarped through `calib`, with
// options.unwarp_fallback), fits each board's pose through `calib`, refines the corners through the model
// (options.refine_passes) and scores them. Throws pano::Error when the
// units or image size differ from the calibration's, or when no board is
// found in any image (or none can be fitted).
EvaluationResult EvaluateCalibration(const TargetSet& targets, const std::vector<cv::Mat>& images,
                                     const Calibration& calib, const EvaluateOptions& options);

// Text: one line per image (found or not, corners, RMS, max), then the overall RMS.
std::string EvaluationSummary(const EvaluationResult& result);
// JSON: {"tool": "panocalib evaluate", "version", "command_line", "model",
// "boards_found", "boards_fitted", "images", "corners", "rms_px", "max_px",
// "per_image": [{"file", "found", "corners", "rms_px", "max_px", "failure"?}],
// "warnings", "seconds": {"detection", "fit"}}; unknown figures are null.
std::string EvaluationSummaryJson(const EvaluationResult& result, const std::vector<std::string>& command_line);

}  // namespace pano
