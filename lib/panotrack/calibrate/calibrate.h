// Sensor calibration from chessboard images (`panocalib calibrate`).
//
// Pipeline (docs/calibration.md):
//   1. DetectBoards: findChessboardCornersSB on each raw image (the quick
//      search; the exhaustive one where it fails only when too few boards
//      were found for step 4 to take over); images where the board is not
//      found are listed (and retried in step 4). A ChArUco board: detectMarkers and
//      interpolateCornersCharuco (lib/panotrack/charuco), keeping views with
//      enough corners (EnoughCorners), each corner with its id.
//   2. Initialise: a linear central-camera initialisation (after Scaramuzza:
//      per board a 6x6 null vector gives the in-plane pose, then one linear
//      least-squares gives a radial polynomial and the boards' heights), a
//      multi-start fit of the mirror model to that polynomial, and the mirror
//      scale from the boards' heights (known poses) or a few scale guesses
//      (unknown poses). Every step checks its result and throws a pano::Error
//      that says which step failed and why; nothing NaN goes further.
//   3. FitCalibration: Ceres, reprojection error in pixels through the
//      templated sensor model (autodiff through the reflection solve), each
//      corner weighted by its precision (CornerWeights), Huber loss by
//      default, covariance of the sensor parameters (poses marginalised).
//   4. Images without a board are retried in views unwarped through the fitted
//      model (virtual perspective views), corners mapped back and refined with
//      cornerSubPix in the raw image; when any is found the fit is repeated.
//   5. RefineCornersThroughModel: every corner located again on the board
//      plane through the fitted model, then the final fit.
//   6. On request (CalibrateOptions::use_limb, the sphere): the mirror's limb,
//      measured after step 3 (limb.h), fitted with the corners.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "panotrack/io/calibration.h"
#include "panotrack/calibrate/limb.h"
#include "panotrack/core/output_check.h"
#include "panotrack/io/targets.h"
#include "panotrack/sensor/sensor.h"

namespace pano {

// Rig faults (general_model.h) fitted as free parameters. Lens k1, k2 are
// the aligned model's (CalibrateOptions::distortion_terms).
struct FreeFaults {
  bool decentre = false;     // mirror_offset (a sphere: its centre off the axis)
  bool camera_tilt = false;  // camera_tilt
  bool tangential = false;   // p1, p2
  bool k3 = false;
  bool sensor_tilt = false;  // only with known board poses (else the poses absorb it)
  bool skew = false;         // the pixel grid's shear
  bool Any() const { return decentre || camera_tilt || tangential || k3 || sensor_tilt || skew; }
};

// The default free faults: decentre and camera tilt for the conic; decentre
// only for the sphere, whose centre off the axis and a camera tilt are the
// same thing (a sphere has no axis of its own: a tilted camera sees the
// centre off its axis), so only the centre in the camera's frame is
// determined and it is reported as decentre with camera_tilt zero. The
// unified model: tangential distortion (p1 p2), as OpenCV's omnidir.
FreeFaults DefaultFreeFaults(MirrorModel model);
// Parses "auto", "none" or a comma list of decentre, camera-tilt, tangential,
// k3, skew, sensor-tilt (k1 and k2 are accepted and set *distortion_terms to the
// highest named, when it is given). Throws pano::Error naming --free.
FreeFaults ParseFreeFaults(const std::string& list, MirrorModel model, int* distortion_terms = nullptr);

struct CalibrateOptions {
  // kAsphere: the conic with even-asphere terms fitted (started from the
  // conic's initialisation with the terms at zero). kUnified: Mei's central
  // model (its own initialisation; its viewpoint is the sensor frame's origin).
  MirrorModel model = MirrorModel::kSphere;
  // Even-asphere terms fitted with model asphere: 1 (a4) or 2 (a4, a6).
  int asphere_terms = 2;
  // Choose the mirror profile (model, asphere_terms), the lens distortion
  // (unless distortion_terms is given) and the rig faults (unless
  // free_faults_auto or a free fault is given) by cross-validation over the
  // boards found (model_selection.h: SelectModel) instead of taking them as
  // given: the simplest candidate whose held-out RMS is within
  // selection_margin (a fraction) of the best, from selection_folds folds;
  // a candidate whose parameters the boards leave undetermined (the focal
  // length's relative standard deviation above selection_max_focal_rel_std,
  // or a parameter without one) is refused.
  bool select_model = false;
  int selection_folds = 5;
  double selection_margin = 0.01;
  double selection_max_focal_rel_std = 0.2;
  // With select_model: when the boards are too few to hold any out (fewer
  // than 4), fit `model` (with the lens and faults given) and say so in a
  // warning, instead of failing.
  bool selection_fallback = false;
  // With select_model: the rig faults given (free_faults, free_faults_auto)
  // hold for every candidate even when none is free; otherwise they are
  // chosen unless free_faults_auto or a free fault is given.
  bool selection_fixed_faults = false;
  // Progress of the long steps (the model selection's fits), one short line
  // each; empty: none.
  std::function<void(const std::string&)> on_progress;
  // Lens radial distortion terms fitted: -1 automatic (0 for sphere, 2 for
  // conic and asphere), else 0, 1 (k1) or 2 (k1, k2).
  int distortion_terms = -1;
  bool fit_aspect = true;
  // Fitted only when the board poses are known: with unknown poses a turn of
  // the camera about its axis cannot be told from a turn of every board.
  bool fit_azimuth_offset = true;
  // Ignore rvec/tvec of the target file and estimate the poses.
  bool ignore_known_poses = false;
  // Huber loss on each corner's residual (pixels); <= 0: plain least squares.
  double huber_px = 1.0;
  // Retry images without a board in unwarped views through the fitted model.
  bool unwarp_fallback = true;
  // Passes of model-based corner refinement: each corner is located again in
  // a patch of the image resampled on the board plane through the fitted
  // model (where the squares are straight, so the detector's curvature bias
  // goes), then the model is fitted again. 0: off.
  int refine_passes = 1;
  // Measure the mirror's limb (a sphere's silhouette, limb.h) in the images
  // after the first fit and fit it along with the corners in one more refit.
  // Off by default: with estimated poses and k1, k2 free it does not pin the
  // sphere's centre (the boards leave a valley of focal length, mirror size
  // and lens distortion along which the limb fits as well), and it pulls the
  // fit along that valley (faulty-rig, 14 boards, k1 and k2 free: focal
  // +0.5 % -> +3.5 %, the centre's error 0.70 -> 1.20 mm).
  // Skipped (with a warning) where the limb is not clean in enough images.
  bool use_limb = false;
  // Corner weighting (corner_weights.h): corners whose squares are squeezed
  // below this many pixels (near a mirror's limb) count less in the fit, most
  // of all along the bisector of an acute crossing, as their position is less
  // certain there. <= 0: every corner counts the same in pixels.
  double full_weight_px = 10.0;
  int max_iterations = 200;
  // Rig faults fitted (ProjectGeneral in the fit when any is free);
  // free_faults_auto: DefaultFreeFaults(model) instead of free_faults. Off
  // (the aligned model) by default: with estimated board poses a free
  // decentre or camera tilt trades against the principal point, which an
  // aligned rig then loses (paper-real: cx 0.003 -> 0.6 px off).
  bool free_faults_auto = false;
  FreeFaults free_faults;
  // Standard deviation above which a free fault is reported as not
  // determined: offsets relative to the mirror's curvature radius, angles in
  // radians, distortion terms as they are.
  double fault_warning_std = 0.1;
  // A fit whose RMS reprojection error exceeds this is a failure (pixels).
  double max_rms_px = 5.0;
  // Relative standard deviation of the mirror's size above which the user is
  // warned that only the mirror's shape (ratios) is determined.
  double scale_warning_rel_std = 0.05;
  // Threads for Ceres and for the parallel loops over images, starts and
  // corners; 0: every core. Set here rather than through OpenMP's global
  // default, so that calibrations running at once do not disturb each other.
  int num_threads = 0;
  // Ceres' per-iteration progress on stdout (and its warnings about rejected
  // steps through glog); quiet otherwise. The library never changes glog's
  // settings: programs set them up once.
  bool verbose = false;
  // Step timings and each fit's summary, a line at a time (empty: none);
  // the library writes nothing itself. Fits run side by side call it from
  // their threads at once.
  std::function<void(const std::string&)> on_log;

  int DistortionTerms() const {
    return distortion_terms >= 0 ? distortion_terms : (model != MirrorModel::kSphere ? 2 : 0);
  }
  FreeFaults Faults() const { return free_faults_auto ? DefaultFreeFaults(model) : free_faults; }
  // num_threads with 0 resolved to the number of cores.
  int Threads() const;
  // Throws pano::Error naming the bad option.
  void Check() const;
};

// One image's board. Without ids: every corner, in board order (index
// j * cols + i is the board point (i * square, j * square, 0)). With ids (a
// partial view, e.g. a ChArUco board partly outside the mirror): corners[k]
// is the board point ids[k] (the same numbering), in any order.
struct BoardView {
  int image_index = -1;  // index in the target file's image list
  std::string file;
  std::vector<Eigen::Vector2d> corners;
  std::vector<int> ids;  // empty: the full grid in board order
  std::string method = "given";  // "raw", "unwarped" or "given" (tests)
  bool has_pose = false;         // known pose (X_sensor = R(rvec) X_board + tvec)
  Eigen::Vector3d rvec = Eigen::Vector3d::Zero();
  Eigen::Vector3d tvec = Eigen::Vector3d::Zero();

  // Board point index of corners[k].
  int PointId(size_t k) const { return ids.empty() ? static_cast<int>(k) : ids[k]; }
  bool Partial() const { return !ids.empty(); }
};

// Fewest corners a partial view may have, on at least 2 board rows and 2
// board columns (fewer cannot fix the board's pose in the initialisation).
constexpr int kMinPartialCorners = 8;
// Throws pano::Error (naming the view's file) when a view's corners do not
// fit the board: a full grid of the wrong size, ids out of range, repeated
// or not one per corner, or a partial view below the minimum.
void CheckBoardView(const BoardView& view, const TargetBoard& board);
// True when a partial view has enough corners spread over the board
// (kMinPartialCorners on 2 rows and 2 columns at least).
bool EnoughCorners(const std::vector<int>& ids, const TargetBoard& board);

struct DetectionResult {
  int image_width = 0;
  int image_height = 0;
  std::vector<BoardView> views;          // images where the board was found
  std::vector<int> not_found;            // indices of images without a board
  std::vector<std::string> not_found_files;
  // Searches that failed with an error rather than finding no board (file
  // and reason); those images are in not_found too.
  std::vector<std::string> warnings;
  // The exhaustive search was left to after the unwarped views
  // (FindBoardsExhaustive then covers the images they miss).
  bool exhaustive_deferred = false;
  double seconds = 0.0;
};

// One fitted parameter as reported: value and standard deviation
// (NaN: not determined by the data; 0 with fixed = true: held fixed).
struct ParameterEstimate {
  std::string name;
  double value = 0.0;
  double stddev = 0.0;
  bool fixed = false;
};

// One mirror profile's cross-validation over the boards (model_selection.h).
struct ModelScore {
  MirrorModel model = MirrorModel::kSphere;
  int asphere_terms = 0;              // fitted even-asphere terms (asphere only)
  std::string name;                   // "sphere", "conic", "asphere (a4)", "asphere (a4, a6)"
  double training_rms_px = NAN;       // pooled over the folds' fits
  double heldout_rms_px = NAN;        // pooled over the held-out boards scored
  int heldout_boards = 0;             // held-out boards scored
  int failed_boards = 0;              // held-out boards not scored (fit or pose failed)
  std::vector<double> fold_heldout_rms_px;  // per fold; NaN where its fit failed
  // Held-out board file -> (sum of squared corner errors in px^2, corners).
  std::map<std::string, std::pair<double, size_t>> board_errors;
  std::string failure;                // the first failure, when any
  // Model selection (SelectModel): sensor parameters beyond the plain
  // sphere's, and why the candidate was refused ("": it was not).
  int parameters = 0;
  std::string refused;
};

struct CalibrationResult {
  Calibration calib;  // sensor, units, extras (stddevs, RMS, per-image RMS)
  bool poses_known = false;
  std::vector<BoardView> views;  // boards used, with their fitted poses
  std::vector<double> image_rms;  // per view, pixels
  std::vector<std::vector<Eigen::Vector2d>> residuals;  // per view, per corner (projected - observed)
  // Euclidean RMS over all corners. From Calibrate(): what `panocalib
  // evaluate` gives on the calibration's images with the same corner option
  // (the detector's corners refined through the final model at each board's
  // pose fitted to them, each pose fitted again; with refine_passes 0 the
  // detector's corners), the fit's own in fit_rms_px. From CalibrateViews and
  // FitCalibration: the fit's.
  double rms_px = 0.0;
  double fit_rms_px = NAN;  // the final fit's own RMS (Calibrate(); NaN otherwise)
  int boards_scored = 0;    // with fit_rms_px: the boards rms_px is over (their poses fitted)
  bool corners_refined = true;  // whether the corners were refined through the model (refine_passes > 0)
  // The final model on the detector's corners as found (before their
  // refinement through the model; the unwarped boards' as mapped back), only
  // each board's pose refitted (FitBoardPose): what `panocalib evaluate
  // --no-refine` gives on these images. NaN when not computed (CalibrateViews).
  double rms_raw_px = NAN;
  int raw_boards = 0;             // boards scored for rms_raw_px
  double fit_cost = 0.0;          // the fit's objective at the end (weighted, robust)
  std::vector<ParameterEstimate> parameters;
  std::vector<int> not_found;  // images without a board (target file indices)
  std::vector<std::string> not_found_files;
  // What the user should know: poorly determined parameters, outlying
  // images, and steps that failed and were skipped (a refit, a search).
  std::vector<std::string> warnings;
  std::string init_summary;  // how the initialisation went
  LimbObservation limb;      // the limb fitted (empty: none)
  double limb_rms_px = NAN;  // the limb points' RMS distance from the fitted limb
  int iterations = 0;
  // With CalibrateOptions::select_model: every candidate's score, the
  // chosen one's index (-1: no selection was made) and why it was chosen.
  std::vector<ModelScore> model_scores;
  int model_chosen = -1;
  std::string model_reason;
  double seconds_detect = 0.0;
  double seconds_fit = 0.0;
};

// Board points (z = 0) in board order.
std::vector<Eigen::Vector3d> BoardPoints(const TargetBoard& board);

// Step 1: raw-image detection (in parallel over images, options.Threads()):
// the quick search, then the exhaustive one where it fails. defer_to_unwarped
// (the pipeline's choice): no exhaustive search when the quick one found half
// the boards (4 at least) and options.unwarp_fallback is on, as step 4 finds
// the rest faster. Throws when an image cannot be read or the images differ
// in size.
DetectionResult DetectBoards(const TargetSet& targets, const std::vector<cv::Mat>& images,
                             const CalibrateOptions& options, bool defer_to_unwarped = false);

// The exhaustive raw search (step 1's, where DetectBoards deferred it) on the
// images `missing` (target file indices), in parallel over images: the boards
// that neither the quick search nor the unwarped views found, such as a board
// squeezed towards the image centre. Returns them as raw boards; none for a
// ChArUco board (its detector has one search).
std::vector<BoardView> FindBoardsExhaustive(const TargetSet& targets, const std::vector<cv::Mat>& images,
                                            const std::vector<int>& missing, int threads);

// Detection in virtual perspective views unwarped through `sensor`, corners
// mapped back to the raw image and refined there. `distance` is a typical
// board distance (for the virtual view's depth). False when not found; then
// `failure` (when given) gets the first error a view's search raised, if any.
// num_threads: views searched at once (0: OpenMP's default). A ChArUco
// board's corners come with their ids (required then; EnoughCorners).
bool DetectBoardUnwarped(const cv::Mat& image, const TargetBoard& board, const Sensor& sensor,
                         double distance, double height, std::vector<Eigen::Vector2d>* corners,
                         int num_threads = 0, std::string* failure = nullptr, std::vector<int>* ids = nullptr);

// Matches the corners of chessboard views with known poses to the board frame
// (OpenCV may start at any of the board's corners): the order whose image
// azimuths follow the bearings and whose image radii grow with elevation. A
// full grid is reordered; a partial view's ids (counted in the detector's
// order) are rewritten. ChArUco views, whose ids are their own, are left.
void OrderCornersByKnownPose(const TargetBoard& board, double cx, double cy,
                             std::vector<BoardView>* views);

// Initial sensor and board poses (angle-axis + translation, 6 per view).
struct InitialEstimate {
  Sensor sensor;
  std::vector<std::array<double, 6>> poses;
  std::string summary;
  // Other starts worth refining (the conic's hyperboloid basin); the better
  // final fit is kept.
  std::vector<InitialEstimate> alternatives;
  // The mirror's limb, fitted along with the corners when not empty.
  LimbObservation limb;
};
// Throws pano::Error with the reason when the initialisation fails.
InitialEstimate Initialize(const std::vector<BoardView>& views, const TargetBoard& board,
                           int width, int height, bool poses_known, const CalibrateOptions& options);

// Step 3: the Ceres fit from an initial estimate, with covariance. Throws on
// failure (non-finite values, no convergence, RMS above options.max_rms_px).
// threads: for the covariance's Jacobian (0: options.Threads()); the fit
// itself runs on one thread (repeatable).
CalibrationResult FitCalibration(const std::vector<BoardView>& views, const TargetBoard& board,
                                 const InitialEstimate& init, bool poses_known,
                                 const CalibrateOptions& options, int threads = 0);

// Steps 2-3 on detected (or synthetic) corners.
CalibrationResult CalibrateViews(const std::vector<BoardView>& views, const TargetBoard& board,
                                 int width, int height, const std::string& units,
                                 const CalibrateOptions& options);

// Step 5: locates every corner of every view again in a patch resampled on
// the board plane through `sensor` and the view's fitted pose, where the
// squares are straight (so the detector's curvature bias goes), and moves it
// to the projection of the junction found there. Corners whose patch leaves
// the image or the mirror keep their position. Returns the number refined.
// num_threads: corners refined at once (0: OpenMP's default).
int RefineCornersThroughModel(const std::vector<cv::Mat>& images, const TargetBoard& board,
                              const Sensor& sensor, std::vector<BoardView>* views, int num_threads = 0);

// The whole pipeline on a target file's images (steps 1-4), loaded one per
// target image (pipeline/target_input.h: LoadTargetImages).
CalibrationResult Calibrate(const TargetSet& targets, const std::vector<cv::Mat>& images,
                            const CalibrateOptions& options);

}  // namespace pano
