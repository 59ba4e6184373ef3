// The per-frame localiser: predict the landmarks in view from the current
// pose estimate and the map, track each one in the frame, and triangulate
// the pose from their azimuths (paper sections 2-4). A second pass re-predicts
// from the solved pose with a narrow search, which centres the linear samples
// and the PH window on the edges.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "panotrack/pose/pose2.h"
#include "panotrack/sensor/calibration.h"
#include "panotrack/scene/map.h"
#include "panotrack/pose/pose_row.h"
#include "panotrack/pose/robust_pose.h"
#include "panotrack/lut/radius_table.h"
#include "panotrack/pose/triangulate.h"
#include "panotrack/track/aligned_view.h"
#include "panotrack/scene/scene.h"
#include "panotrack/track/compass.h"
#include "panotrack/track/junction_tracker.h"
#include "panotrack/track/landmarks.h"
#include "panotrack/track/relocalize.h"
#include "panotrack/track/survey_error.h"
#include "panotrack/track/motion_model.h"
#include "panotrack/track/tracker.h"
#include "panotrack/track/vertex_tracker.h"

namespace pano {

enum class TrackingMethod { kJunction, kVertex };
const char* TrackingMethodName(TrackingMethod m);

struct LocalizerOptions {
  TrackingMethod method = TrackingMethod::kJunction;
  PredictionOptions prediction;
  JunctionOptions junction;
  VertexOptions vertex;
  TriangulationOptions triangulation;
  // The pose from the bearings through a consensus over minimal solutions
  // (3 bearings) before the least-squares refinement: one wrong junction
  // cannot bias the start.
  bool robust_pose = true;
  RobustPoseOptions robust;  // its inlier_threshold is the largest used
  double min_inlier_threshold = 0.15 * M_PI / 180;
  // The motion model (lengths in metres: scaled to the map's units). A pose
  // whose innovation against its prediction exceeds gate_chi2 (squared
  // Mahalanobis distance, 3 dof; 21.1 is the 99.99 % quantile) is not
  // reported: a wrong pose is worse than a lost frame.
  MotionModelOptions motion;
  double gate_chi2 = 21.1;
  // Floors on a triangulated pose's standard deviations for the gate (its
  // covariance comes from a few residuals): heading (radians) and position
  // as a fraction of the mean landmark distance.
  double gate_heading_sigma = 0.1 * M_PI / 180;
  double gate_position_fraction = 0.002;
  // Integrity: the bearing residuals must be consistent (chi-square at
  // integrity_confidence) with the bearing noise seen on recent frames,
  // never taken below min_bearing_sigma (radians).
  double integrity_confidence = 0.9999;
  // ... and its quality figure (IntegrityReport::quality: inliers, spare
  // bearings, consistency, geometry) at least this: below it the evidence is
  // too thin to act on (few inliers of many, a weak geometry).
  double min_quality = 0.15;
  // ... and its error bound (protection_sigmas x its largest position std)
  // within alert_fraction of the distance to its landmarks (0: no bound).
  double protection_sigmas = 5.0;
  double alert_fraction = 0.01;
  // ... or, above 0, this many map units: the accuracy the user needs. At
  // 0 the limit is alert_fraction of the landmarks' distance plus
  // protection_sigmas times the map's error (alert_survey_factor times its
  // survey sigma, or the error the frame's residuals show across the
  // landmarks' distances, whichever is larger): a map measured to a
  // centimetre cannot place the robot to a millimetre, and its poses are
  // still right. A pose may be up to alert_survey_factor times less
  // certain than a corner of the map (landmarks on one side, few in view);
  // a geometry that magnifies the map's error more is refused.
  double alert_limit = 0.0;
  double alert_survey_factor = 2.0;
  // The map's survey error (map units, each corner coordinate). NaN: what
  // the map states (Map::survey_sigma), checked against the residuals of
  // the tracked frames (track/survey_error.h); a bearing's expected error
  // then holds its corner's survey error across the line of sight.
  double survey_sigma = std::nan("");
  SurveyErrorOptions survey;
  // The noise assumed is four times the recent RMS residual (blur and
  // geometry vary from frame to frame; a frame a little worse than the
  // last is still right), within [min_bearing_sigma, max_bearing_sigma]:
  // the cap keeps a drift into biased bearings from widening the test.
  double min_bearing_sigma = 0.05 * M_PI / 180;
  double max_bearing_sigma = 0.3 * M_PI / 180;
  double initial_bearing_sigma = 0.2 * M_PI / 180;  // until good frames have been seen
  double search_px = 8.0;         // half-width of the first pass's linear samples
  // Landmarks tracked per frame: at most this many, spread in azimuth (one
  // per sector, the nearest first). 0: all in view.
  int max_landmarks = 12;
  // ... and this many where the survey error at the typical landmark
  // distance exceeds the image noise: each landmark brings its own map
  // error, and more of them average it down.
  int max_landmarks_uncertain_map = 32;
  // While few edges have had both corners found (the image noise they
  // show does not yet bound the image's share of the residuals: a map
  // stated exact would have its error put down to noisy images), the other
  // corner of this many of the landmarks chosen is measured too, for the
  // survey estimate alone (not in the pose).
  int noise_pairs = 2;
  double refine_search_px = 3.0;  // second pass, around the solved pose
  int refine_passes = 1;
  // The second pass runs only when some landmark was found further than
  // this from its prediction (px): otherwise the windows were centred.
  double refine_threshold_px = 1.0;
  // Where more than this fraction of the recent frames (a running mean over
  // about ten) needed that second pass (fast, uneven turns), the first pass
  // measures only the landmarks' azimuths (the junction tracker's vertical
  // edges, a quarter of the work) and the full pass runs around the pose
  // they give: one full pass a frame instead of two. Above 1: never.
  double coarse_to_fine_rate = 0.5;
  // That first pass measures at most this many landmarks (spread in
  // azimuth, within max_landmarks): it only centres the full pass's
  // windows, which the azimuths of a few spread landmarks fix as well as
  // those of all. 0: as many as max_landmarks.
  int coarse_landmarks = 8;
  bool constant_velocity = true;  // predict with the last frame-to-frame motion
  // A frame whose pose fails the motion gate but fits the motion a frame
  // interval later follows a dropped frame (a camera or recorder losing
  // frames at a constant frame rate leaves no gap in the timestamps): it
  // is accepted, and the motion model's clock moves on by that interval.
  bool dropped_frames = true;
  // After a single lost frame (a hand over the lens) the room-wide search's
  // pose continues the track where the motion model predicted it (within
  // its 99 % gate, on most of what the frame found), though it fits too few
  // of its landmarks to stand on its own before the next frame confirms it.
  bool resume_after_lost_frame = true;
  // A search's pose held for the next frame to confirm, where the motion
  // model (the track's before the loss) predicted it within its 99 % gate,
  // keeps the model's velocity: the robot was not carried off, and the
  // confirming frame is predicted (and its blur expected) from the motion
  // rather than searched for from a standstill at any speed and turn.
  bool hold_keeps_motion = true;
  // A held frame, once confirmed, is verified again as the search found it:
  // with either polarity where the map's found too little there (tracked
  // again with the map's alone, it would fall short of the support it was
  // found with).
  bool held_polarity_as_found = true;
  // A start given as the robot's pose (Localizer::Reset without `hint`) is
  // where the first frames were taken: a first position that leaves it by
  // more than the pose's reported covariance and the motion since allow
  // (the 99 % gate of two degrees of freedom) is not taken, nor taught the
  // survey estimate. A hint bounds nothing.
  bool known_start_bounds_first_pose = true;
  // Tracked on from a pose the sequence vouches for (a tracked frame's, or
  // a start given as the robot's pose), an extra landmark found on the
  // pose counts only for it and one found off it against it (Acceptable's
  // min_inlier_fraction). False: every extra found counts against the
  // pose unless it fits, as for a search's hypotheses.
  bool extras_on_tracked_pose_count_for_it = true;
  // A search's pose held for the next frame to confirm is confirmed only
  // where that frame's bearings fit it under no wider survey error than a
  // few times the one the pose was found under, or than a room-wide search
  // verifies one under: the frame shows nearly the held frame's image,
  // and a wrong pose's misfit would be taken for the map's error.
  bool held_survey_bounded = true;
  // A pose without a velocity to check it against (a search's held frame,
  // the frame confirming it, the first frames after a start or a loss) is
  // reported only where its protection level plus its solution separation
  // (the largest shift of the position when one distinct bearing is left
  // out, SolutionSeparation) is within the alert limit, and within the one
  // the map's stated survey error gives until the residuals have shown the
  // map's error: on five to seven bearings one wrong corner pulls the pose
  // centimetres while the rest absorb its residual, and widens the error
  // its residuals show. Tracking goes on from the pose either way.
  bool separation_without_velocity = true;
  // A pose tracked with a known velocity is reported fused with the motion
  // model's prediction for its frame, each weighed by its covariance (the
  // reported covariance is the fused one): a blurred frame's few bearings
  // are weighed against the motion the frames before it showed. Only where
  // the two agree; where the frame's time is in doubt, and for two frames
  // after (a dropped frame puts the prediction a step behind), the
  // prediction counts no better than that step. Tracking itself goes on
  // from the frame's own pose.
  bool report_fused_with_motion = true;
  bool compass = true;            // predict the heading with the visual compass
  double compass_max_rotation = 60.0 * M_PI / 180;  // per frame
  double compass_min_score = 0.5;
  // The compass measures a turn from the last frame whose heading was
  // measured (or held), not from a lost frame's image (covered, a person in
  // front of the mirror) at the heading the motion model guessed for it.
  bool compass_from_measured = true;
  // The compass's heading is tried before the motion model's when the two
  // differ by more than this (radians; the model's prediction would mostly
  // miss the search windows) and the compass has predicted the solved
  // headings clearly better than the model on recent frames (under half its
  // mean error, over ten frames or more since the start): a fast turn then
  // costs one search instead of a failed one and a retry.
  double compass_first_turn = 3.0 * M_PI / 180;
  // A solution is accepted only with a bearing RMS below this (radians) and
  // at least this fraction of the predicted landmarks as inliers (when at
  // least 8 were predicted): a few wrong junctions can triangulate exactly.
  double max_rms_bearing = 0.5 * M_PI / 180;
  double min_inlier_fraction = 0.5;
  // ... and, where the consensus left found bearings out, at least this
  // many spare distinct bearings among its inliers (beyond the three a pose
  // takes): with one, a single consistency test cannot tell that the rest
  // is off too (a map wrong everywhere lets four bearings agree by chance).
  int min_spare_bearings_with_outliers = 2;
  // After this many consecutive lost frames, search the whole room for the
  // pose (0: never). Relocalisation accepts a pose only with at least
  // relocalize_min_landmarks inliers.
  int relocalize_after = 2;
  // ... and at once (on the first lost frame) when the view is not the
  // predicted one (the robot was carried off: tracking from the prediction
  // will not recover): fewer than this fraction of the landmarks chosen to
  // track were found, or those found fit no acceptable pose but one the
  // motion model rules out. 0: never at once.
  double relocalize_unseen_fraction = 0.25;
  // After three failed relocalisations in a row the next waits 2, 4 ...
  // frames (at most this many): a long loss costs a bounded share of the
  // frames, a short one is searched on every frame.
  int relocalize_max_interval = 8;
  // While no pose is tracked from (before the first, or after a search's
  // pose the next frame did not confirm) the search runs on every frame,
  // for up to this many failed searches in a row, and backs off as above
  // only after them: there is no pose to report until one is found, and a
  // view one search misses is often found on the next frame (a loss of a
  // few frames, not of the 2, 4, 8 ... that waiting costs). 0: back off
  // after three failures, as after a loss while tracking.
  int relocalize_eager_searches = 50;
  // While no pose is tracked from, the search verifies this many of its
  // best hypotheses (0: relocalize.hypotheses, as after a loss while
  // tracking): with nothing else to do, a frame can afford more, and a
  // partly hidden view ranks the true place just below the usual number.
  int relocalize_untracked_hypotheses = 30;
  int relocalize_min_landmarks = 6;
  // A search's hypothesis lies up to a grid step off (a tenth of a metre
  // in a room of four), where a tracker's windows find a few of its
  // landmarks; the pose those few fit is nearer, and is tracked again, up
  // to this many times while each pass finds more (0: never).
  int relocalize_retrack_passes = 2;
  // Where a room-wide search runs on a tracked or held frame (to check it)
  // and chooses a pose at the same place that fits the frame's bearings
  // better, outside the tracked pose's reported 95 % ellipse, the tracked
  // pose gives way to it (Localizer::Refutes).
  bool relocalize_refutes = true;
  // A relocalised pose also needs this fraction of its predicted landmarks
  // as inliers, and must beat every hypothesis elsewhere in the room
  // (further than relocalize_distinct, as a fraction of the room's size) by
  // relocalize_margin inliers and by relocalize_ambiguity of its own:
  // symmetric rooms offer near-copies of a view, and the copy can fit a few
  // more landmarks than the true pose (the half-turned twin of a room laid
  // out nearly point-symmetrically: 16 inliers against the true pose's 12).
  double relocalize_min_fraction = 0.5;
  int relocalize_margin = 2;
  double relocalize_ambiguity = 0.7;
  double relocalize_distinct = 0.05;
  // A search left ambiguous between two places (a room laid out nearly
  // symmetrically, under a survey error's tolerances: the true pose and
  // the half-turned twin both verify, neither clearly ahead) takes the
  // place that led the other in this many consecutive searches, each on
  // its own frame under the same survey sigma: at least as many inliers,
  // among the chosen too, and the other's residuals relocalize_rival_fit
  // times its own, or no smaller on relocalize_margin fewer inliers
  // (0: never).
  int relocalize_rival_searches = 3;
  double relocalize_rival_fit = 1.3;
  // A room-wide search that verifies no pose because the image shows few
  // corners (blur, people, a dim exposure: the true pose finds a fraction
  // of the landmarks it chose, every other place fewer still) holds its
  // best pose as a sparse lead when at least relocalize_min_landmarks
  // bearings fit it, most of those found (relocalize_confirmed_fraction),
  // and it has relocalize_sparse_lead times the inliers of any other place
  // tracked. The lead is reported only after relocalize_sparse_frames
  // frames in a row (its own included) each tracked from the one before
  // with as strong a fit (0: never).
  int relocalize_sparse_frames = 3;
  double relocalize_sparse_lead = 2.0;
  // A map that repeats what a relocalised pose sees (a floor motion carrying
  // its inlier landmarks onto others, within this fraction of the room's
  // size) shows the same image from the moved pose: the last known pose
  // chooses the pose clearly nearest to it, else the search fails.
  double relocalize_symmetry_tolerance = 0.02;
  // A relocalised pose (the first pose, after a kidnap or a loss) is
  // reported at once only with this fraction of its chosen landmarks as
  // inliers; with fewer (a wrong pose fits a few bearings easily) the next
  // frame must track from it first (above 1: every one).
  double relocalize_confirmed_fraction = 2.0 / 3.0;
  // A relocalised pose further from the last known pose than the robot
  // could have gone since (the motion model's max_speed over the time
  // between; a kidnap, or a partial twin of the room found after a loss)
  // is confirmed, where the map's survey error limits the bearings, only
  // by a frame tracked from it with this fraction of its chosen landmarks
  // as inliers (at most 1): within a survey error's tolerances, a twin
  // that half the bearings fit tracks from frame to frame as well as the
  // true pose.
  double relocalize_jump_fraction = 2.0 / 3.0;
  // Before the first pose, while the residuals have not shown the map's
  // error, a room-wide search that verifies nothing under the survey error
  // assumed is tried again under larger ones (1/200, 1/100 and 1/50 of the
  // typical landmark distance; the smallest that verifies a pose becomes
  // the provisional survey sigma): a map stated exact, or stating nothing,
  // but centimetres off hides the true pose from narrow tolerances while a
  // twin of the room may fit a few bearings.
  bool relocalize_survey_probe = true;
  RelocalizeOptions relocalize;
  // The longest exposure expected, as a fraction of the frame interval:
  // motion blur spans at most this fraction of a landmark's image motion
  // between frames, and the edge detectors allow ramps that wide. 1: any.
  double exposure_fraction = 1.0;
  // Until the motion is known (the first frames, after a lost one), edges
  // may be blurred by a turn this fast (radians per frame).
  double unknown_turn_per_frame = 12.0 * M_PI / 180;
  double lost_search_growth = 1.5;  // search widens by this after a lost frame
  double max_search_px = 20.0;
  // Threads of the per-frame parallel loops (landmarks, the PH tables of
  // its own cache); 0: OpenMP's default (all cores unless OMP_NUM_THREADS
  // says otherwise). Set per localiser, never process-wide; the results do
  // not depend on it.
  int num_threads = 0;
  // Threads of the room-wide search (its index, and the hypotheses it
  // verifies, each one tracked on a thread of its own); 0: num_threads.
  // Searches are rare and long: where the frames are tracked on one thread,
  // a search may still use the cores the decoder leaves it.
  int search_threads = 0;
  // Edge polarities learned from the images (where the map's shade is
  // unknown or the images contradict it): a sign is learned after this many
  // tracked frames in a row show it; one not found in polarity_forget_misses
  // tracked frames in a row is searched with either sign again; one learned
  // with a different sign more than polarity_max_flips times stays "either".
  int polarity_learn_frames = 3;
  int polarity_forget_misses = 5;
  int polarity_max_flips = 2;
  void Check() const;
};

// What the tracked frames showed of one edge's polarity (going into the
// landmark's face, +1 brighter inside).
struct EdgePolarityEvidence {
  int learned = 0;        // the sign learned (0: none yet, or forgotten)
  int candidate = 0;      // the sign of the current run of measurements
  int run = 0;            // consecutive tracked frames that showed `candidate`
  int last_learned = 0;   // the last sign learned (to count flips)
  int flips = 0;          // times a learned sign changed
  int misses = 0;         // consecutive tracked frames it was searched for and not found
  int agree = 0;          // measurements agreeing with the map's polarity
  int disagree = 0;       // ... contradicting it
  double contrast = 0.0;  // running mean of the step found (grey levels)
};

struct LandmarkPolarity {
  EdgePolarityEvidence v, h;  // vertical and horizontal edge
};

struct FrameResult {
  PoseRow row;
  Pose2 predicted_pose;
  bool relocalized = false;     // the pose came from the room-wide search
  bool compass_first = false;   // the compass's heading was tried before the motion model's
  bool coarse_to_fine = false;  // tracked azimuths first, then in full around their pose
  bool refined = false;         // measured again around the solved pose (windows or blur off)
  bool unconfirmed = false;     // ... found, but held back for the next frame to confirm
  // Accepted and tracked from, its row withheld: a pose without a velocity
  // that one bearing left out could move beyond the alert limit
  // (LocalizerOptions::separation_without_velocity).
  bool withheld = false;
  double innovation = -1.0;     // squared Mahalanobis distance from the prediction (-1: none)
  bool after_drop = false;      // the pose agrees with the motion only a frame interval later (AfterDroppedFrame)
  IntegrityReport integrity;    // of the reported pose
  // The covariance the pose is reported with (x, y, theta; the row's std
  // columns): Localizer::ReportedCovariance. Zero when not reported.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  // The motion model's step at this frame, for a smoother (FixedLagSmoother);
  // absent before the first pose.
  bool has_motion_step = false;
  MotionStep motion_step;
  std::vector<PredictedLandmark> predicted;
  std::vector<LandmarkMeasurement> measurements;  // one per predicted landmark
  TriangulationResult triangulation;
  // Measured with every edge whose polarity the images have not confirmed
  // taken with either sign (the map's polarities found nothing).
  bool either_polarity = false;
  // The partners of some chosen landmarks were wanted (Measure's
  // `tracking`, PairsWanted): the other corner of their vertical edge,
  // measured for the image noise the difference of the two bearings
  // shows; never in the pose.
  bool with_partners = false;
  // Measured from a prediction (Measure's `tracking`), not a search's
  // hypothesis: the landmarks whose horizontal edges pass near are in.
  bool from_prediction = false;
  std::vector<PredictedLandmark> partners;
  std::vector<LandmarkMeasurement> partner_measurements;  // one per partner
  // The turn over the frame interval (radians) that the measurement's blur
  // allowance came from, when it was a solved one (a first pass's pose);
  // absent: the motion model's.
  std::optional<double> blur_turn;
};

// The threads of the localiser's room-wide search: options.search_threads,
// else num_threads (0: OpenMP's default).
int SearchThreadCount(const LocalizerOptions& options);

// The PH tables the junction tracker uses, built per edge height on first use
// with `num_threads` threads (0: OpenMP's default).
std::shared_ptr<PhTableCache> MakeTrackingPhTables(std::shared_ptr<const RadiusTable> table,
                                                   int num_threads = 0);

// Builds the tracker of `method` (the vertex tracker lives in track/vertex_tracker.h).
// `ph_tables` (built on first use, per edge height) may be shared by every
// localiser of one calibration and map; null: a cache of its own, built with
// options.num_threads threads.
std::unique_ptr<LandmarkTracker> MakeTracker(TrackingMethod method, const Sensor& sensor,
                                             std::shared_ptr<const RadiusTable> table,
                                             const LocalizerOptions& options,
                                             std::shared_ptr<PhTableCache> ph_tables = nullptr);

// The localiser of one input: Reset (or ResetUnknown) once, then Process
// each frame in order. A frame goes through the paper's steps (Process):
//   1. predict: the motion model (or the odometry, or the compass's
//      heading) gives the pose, and the map the landmarks in view from it,
//      as many as the expected error pays for (MaxLandmarks);
//   2. measure: each landmark's edge or junction found near its prediction
//      by the tracker (junctions with the PH transform, or vertices), coarse
//      to fine;
//   3. solve: the pose from their azimuths (Eqns 1-2), a consensus keeping
//      out the outliers;
//   4. check integrity: the residuals against the image noise and the
//      map's survey error; a pose that fails is not reported;
//   5. relocalise: when lost, or where the room-wide search outranks the
//      tracked pose, a pose from the search, held until a frame confirms it.
// The state a frame leaves for the next is in the named objects below
// (Track, Heading, ImageEvidence, ErrorModel, Relocalization, Shades).
class Localizer {
 public:
  Localizer(const Calibration& calib, const Map& map, std::shared_ptr<const RadiusTable> table,
            const LocalizerOptions& options, std::shared_ptr<PhTableCache> ph_tables = nullptr);
  // Starts a sequence at a known pose. With `hint` true the pose is a
  // guess only: tracking starts from it, and the room-wide search takes
  // over at once if the first frame does not confirm it.
  void Reset(const Pose2& initial, bool hint = false);
  // Starts a sequence with no idea of the pose: the first frame is
  // localised by the room-wide search.
  void ResetUnknown();
  // Processes one grey frame (CV_8UC1 of the calibration's size) taken at
  // time_s. `odometry`, when given, is the robot's own measure of its motion
  // since the previous frame (wheel odometry): the prediction uses it
  // instead of the constant-velocity model.
  FrameResult Process(const cv::Mat& grey, int frame, double time_s,
                      const OdometryIncrement* odometry = nullptr);
  // A frame whose pose the room-wide search found but held back (its
  // result `unconfirmed`, its row lost) is reported once a later frame
  // confirms the pose: the frame after it, or for a sparse lead's frames
  // the frame that ends the lead's run (LocalizerOptions::
  // relocalize_sparse_frames). After that frame's Process, this returns the
  // held frames' results with their rows ok, in frame order, once; else
  // none. A caller that writes rows as they come holds back the rows of the
  // last FramesHeld() frames processed: each is written as returned here,
  // else as it was (lost), once the localiser no longer holds it.
  std::vector<FrameResult> TakeConfirmedHolds() { return std::exchange(reloc_.confirmed_holds, {}); }
  // The frames processed last (up to the last) whose poses are held for a
  // later frame to confirm: 0 after a frame that holds nothing.
  int FramesHeld() const {
    return reloc_.held_frame ? 1 + static_cast<int>(reloc_.sparse_chain.size()) : 0;
  }

  const Map& map() const { return map_; }
  // The sensor the tracking works with: the calibration's, or for a rig
  // with faults its aligned view's (aligned_view.h).
  const Sensor& sensor() const { return calib_.sensor; }
  // For a rig with faults, frames are resampled to this view; null for an
  // aligned rig.
  const AlignedView* aligned_view() const { return view_ ? &*view_ : nullptr; }
  // The robot's pose from a pose of the tracked sensor (the motion model's
  // states, a fixed-lag smoother's): the same for an aligned rig.
  Pose2 RobotPose(const Pose2& tracked) const { return view_ ? view_->RobotPose(tracked) : tracked; }
  const std::vector<Landmark>& landmarks() const { return landmarks_; }
  // The room-wide search's index from `shared` (built by whichever
  // localiser needs it first), for localisers of the same calibration, map
  // and options: the inputs of one run.
  void ShareRelocalizationIndex(std::shared_ptr<SharedRelocalizationIndex> shared) {
    shared_index_ = std::move(shared);
  }
  // Per landmark (as landmarks()): what the tracked frames showed of its
  // edges' polarities.
  const std::vector<LandmarkPolarity>& polarity() const { return shades_.polarity; }
  // The ids of the map's rectangles and boxes whose shade the images
  // contradict (an edge's polarity learned against the map's over
  // polarity_learn_frames or more tracked frames): "map shade looks inverted".
  std::vector<std::string> ContradictedShades() const;
  // The survey sigma the images showed (map units per corner coordinate)
  // where it differs from the map's statement: more than half again a
  // stated one, any for a map stated exact, or the estimate for a map that
  // states none; NaN otherwise (and before the residuals have said enough).
  double ShownSurveySigma() const;
  // The survey sigma the reported covariances hold now (map units): the
  // statement, or what the residuals show with its margin
  // (SurveyErrorOptions::estimate_margin).
  double ReportedSurveySigma() const { return errors_.survey.ReportedSigma(StatedSurveySigma()); }
  // The map's statement as the localiser takes it (--survey-sigma, else the
  // map's survey_sigma; NaN: none).
  double StatedSurveySigma() const;

 private:
  // `motion`: this frame's motion when better known than the prediction
  // (after a first solve); it sets the expected blur of each edge.
  // `either`: edges whose map polarity no tracked frame has confirmed are
  // searched with either sign.
  // `azimuth_only`: the tracker's MeasureAzimuth (a first estimate).
  // `tracking`: the frame is tracked from a prediction (not a search's
  // hypothesis verified): where PairsWanted, partners of the chosen
  // landmarks are measured too (FrameResult::partners).
  void Measure(const Pose2& pose, double search_px, FrameResult* out, const Pose2* motion = nullptr,
               bool either = false, bool azimuth_only = false, bool tracking = false) const;
  // The polarity to search an edge for: the map's while the images do not
  // contradict it, else the one learned, else 0 (either).
  int SearchPolarity(const EdgePolarityEvidence& e, int map_polarity, int object, bool either) const;
  // Whether a frame tracked now measures the other corner of some chosen
  // edges (LocalizerOptions::noise_pairs): the survey estimate wants them.
  bool PairsWanted() const;
  // Whether this frame confirms a held pose or a survey probe tries a
  // level: what is measured then must not lean on the map's least known parts.
  bool ConfirmingOrProbing() const { return reloc_.held || reloc_.probe_sigma != 0.0; }
  // Whether retrying with `either` could find what the map's polarities did
  // not: some shade is known and the images have not confirmed the map yet.
  bool EitherFallbackUseful() const;
  // Learns the edges' polarities from an accepted frame's inliers.
  void LearnPolarity(const FrameResult& fr, const TriangulationResult& tri);
  // The motion over one frame interval from the previous frame's pose to
  // `pose` (over track_.frame_intervals of them), when that pose was measured.
  std::optional<Pose2> SolvedMotion(const Pose2& pose) const;
  // The pose from the found landmarks' bearings (consensus, then least
  // squares); its rms_bearing in units of each bearing's spread.
  TriangulationResult Solve(const FrameResult& fr, const Pose2& prior) const;
  TriangulationResult SolveBearings(const std::vector<BearingObservation>& obs, const Pose2& prior) const;
  // The inliers (indices into obs) whose residual changed suddenly since
  // the previous frame: the pose from bearings corrected by their previous
  // residuals (which hold the map's error) leaves them out. Empty when too
  // few were tracked then, or when most changed.
  std::vector<int> SuddenResiduals(const FrameResult& fr, const std::vector<BearingObservation>& obs,
                                   const TriangulationResult& tri) const;
  // With a surveyed map: `tri` solved again without those.
  void DropSuddenResiduals(const FrameResult& fr, const std::vector<BearingObservation>& obs, const Pose2& prior,
                           TriangulationResult* tri) const;
  // `tri` solved again from obs without those marked in `drop` (indices
  // kept as obs's). False, `tri` unchanged, where no pose is left.
  bool SolveWithout(const std::vector<BearingObservation>& obs, const std::vector<char>& drop, const Pose2& prior,
                    TriangulationResult* tri) const;
  // A bearing that pulled the pose towards itself: its residual, for the
  // leverage it had on the fit, beyond what the integrity test's noise and
  // its corner's survey error allow (Baarda's w-test at 0.001). `tri`
  // solved again without it, at most two a frame, while enough are left to
  // test what remains. A bearing the pose rests on nearly alone cannot be
  // tested this way (the protection level bounds it). Only where the map's
  // survey error dominates (SurveyLimits: its tolerances can hide such a
  // pull; with an exact map the consensus's narrow threshold does not), and
  // on frames tracked from a pose already reported: a search's hypothesis
  // must fit its bearings as they are.
  void DropPulledBearings(const FrameResult& fr, TriangulationResult* tri) const;
  // The image noise the integrity test assumes (radians).
  double IntegritySigma() const;
  bool Acceptable(const FrameResult& fr, const TriangulationResult& tri) const;
  // The found landmarks' bearings, each with its spread: its expected error
  // (the image noise `reference_sigma`, radians, and its corner's survey
  // error across the line of sight) relative to `reference_sigma`. The
  // default reference is the consensus's (ReferenceSigma).
  std::vector<BearingObservation> Observations(const FrameResult& fr, double reference_sigma) const;
  std::vector<BearingObservation> Observations(const FrameResult& fr) const {
    return Observations(fr, ReferenceSigma());
  }
  // The image noise the consensus assumes (radians): a third of its inlier
  // threshold, from the recent noise.
  double InlierThreshold() const;
  double ReferenceSigma() const { return InlierThreshold() / 3.0; }
  // The half-width of a landmark's linear samples: `search_px`, widened by
  // where its corner's survey error may put its edges.
  double SearchWidth(const PredictedLandmark& p, double search_px) const;
  // The RMS bearing residual of the inliers in units of their spread
  // (radians of image noise): what max_rms_bearing bounds.
  static double NormalizedRms(const std::vector<BearingObservation>& obs, const TriangulationResult& tri);
  // The survey sigma of a landmark's corner now (map units), and the mean
  // over the map's landmarks.
  double SurveySigma(const Landmark& l) const;
  // The survey error stated for `l`: the option's, else the map's for it
  // (NaN: none stated).
  double StatedSurveySigma(const Landmark& l) const;
  double MeanSurveySigma() const;
  double LargestSurveySigma() const;
  // Landmarks to track per frame (0: all): max_landmarks, or more where
  // the survey error dominates (max_landmarks_uncertain_map).
  int MaxLandmarks() const { return errors_.max_landmarks; }
  // Whether the map's survey error limits the bearings (more landmarks
  // are tracked for it).
  bool SurveyLimits() const { return errors_.max_landmarks != opt_.max_landmarks; }
  // Sets errors_.max_landmarks and errors_.prediction from the noise and survey estimates.
  void UpdateLandmarkBudget();
  // Sets errors_.prediction's surface tolerance from the survey error assumed.
  void UpdatePrediction();
  // The recent bearing noise and the survey estimate, from an accepted frame.
  void UpdateNoiseEstimates(const FrameResult& fr, const TriangulationResult& tri);
  // Its first part: the recent bearing noise (errors_.bearing_sigma).
  void UpdateBearingNoise(const std::vector<BearingObservation>& obs, const TriangulationResult& tri);
  // The survey estimate from the inlier bearings of a solution.
  void UpdateSurveyEstimate(const FrameResult& fr, const TriangulationResult& tri);
  // Whether a solution that was not reported still shows the survey error:
  // many inliers agreeing (Acceptable) on a pose the motion allows.
  bool SurveyEvidence(const FrameResult& fr, const TriangulationResult& tri) const;
  // A frame that fails before the survey error is known, tried again from
  // `pred` under a ladder of larger survey errors: the smallest under which
  // its bearings agree (a consensus of most found, consistent, agreeing
  // with the motion) becomes the provisional survey sigma; no level above
  // `widest` is tried. True if one did; `found`: the pose that level was
  // tracked from (the frame is tracked again from there).
  bool ProbeSurveyError(const Pose2& pred, double widest = std::numeric_limits<double>::infinity(),
                        Pose2* found = nullptr);
  // An accepted frame before the survey error is known whose own residuals
  // show a clearly larger one than assumed (1.5x): that error becomes the
  // provisional sigma and the frame is tracked again under it around its
  // pose, the new solution taken where it is accepted. True if it was.
  bool RetrackUnderShownSurvey(FrameResult* fr, TriangulationResult* tri);
  // The survey error the estimate shows (SurveyErrorEstimate::Early) once
  // the solution's residuals are added, learned once (without keeping what
  // it taught).
  double SurveyShownBy(const FrameResult& fr, const TriangulationResult& tri);
  // The widest survey error a frame tracked from a held pose confirms it
  // under: three times the one the pose was found under (one frame's
  // residuals scatter), or the widest a room-wide search verifies one
  // under (WidestSearchSurveySigma).
  double HeldSurveyBound() const;
  // The survey and bearing-noise estimates as learned (put aside for the
  // map's statement alone, a fresh estimate, and put back).
  struct LearnedSurvey {
    SurveyErrorEstimate survey;
    double bearing_sigma;
  };
  // A tracked frame while a provisional survey sigma well above the map's
  // statement holds (learned on earlier frames by a probe or a search):
  // tracked again under the statement alone (a fresh estimate). Where its
  // bearings agree there as well, the wider error was those frames'
  // images', not the map's: the estimate starts again from the statement
  // and the frame takes that solution. True if it did. Where clearly more
  // agree there on a pose apart (SurveyErrorOptions::statement_outvotes),
  // the frame takes that solution too, and the estimates go back to
  // `at_begin`, as they were before the frame.
  bool RetrackUnderStatedSurvey(FrameResult* fr, TriangulationResult* tri, const LearnedSurvey& at_begin);
  // Whether a provisional survey sigma beyond StatementBound holds (and
  // the statement is to be tried again).
  bool StatementInDoubt() const;
  LearnedSurvey AssumeStatementOnly();
  void RestoreSurvey(const LearnedSurvey& learned);
  // `fr`, solved as `tri`, measured again under the survey error now
  // assumed (into `again`, `solved`): whether its bearings agree there as
  // well, as large a share of those found and enough of them; `apart`: how
  // far apart the two poses lie, in their combined standard deviations.
  bool AgreesUnderStatement(const FrameResult& fr, const TriangulationResult& tri, FrameResult* again,
                            TriangulationResult* solved, double* apart);
  // The largest provisional survey sigma the map's statement allows:
  // kStatementDoubt times the sigma it gives alone, at least
  // SurveyErrorOptions::doubt_fraction of the typical landmark distance.
  double StatementBound() const;
  // Before the survey error is known, a frame whose pose leaves found
  // bearings out: the first frame from a start given as a guess that
  // leaves most of them out; on a map stated exact (not a search's pose
  // held), the first frame from a start the user gave that leaves more
  // than a sixth of them out, or any without the support a relocalised
  // pose needs (Corroborated), and a later frame that does both on fewer
  // inliers than max_landmarks. Under too small a survey error a subset of
  // well-measured corners agrees on a pose off by the error of the rest: 8
  // of 10 found, 5 cm off, on a map stated exact but measured to 2 cm; 6
  // of 10, 3.9 cm off, at 0.5 cm. A tracker's odd outlier (a cluttered
  // room's 1 of 11) is not a map's error; nor is a pose on 21 - 26 inliers
  // that leaves a few out (within a centimetre at 2 cm), nor a twin of the
  // room that finds 20 of the 32 landmarks it chose and leaves 2 out (the
  // survey probe would fit it under a wider error). Not accepted as it is:
  // the survey probe then tries it under larger errors.
  bool PartialBeforeSurvey(const FrameResult& fr, const TriangulationResult& tri) const;
  // The indices into fr.predicted of the solution's inlier observations.
  std::vector<int> InlierPredictions(const FrameResult& fr, const TriangulationResult& tri) const;
  // The integrity test of an acceptable solution (fills fr->integrity).
  bool Consistent(FrameResult* fr, const TriangulationResult& tri) const;
  // A frame's pose as the motion model's measurement, with the gate's
  // floors on its deviations (gate_position_fraction, gate_heading_sigma);
  PoseMeasurement MotionMeasurement(const FrameResult& fr, const TriangulationResult& tri) const;
  // the 99 % gate of a pose's three degrees of freedom, or gate_chi2 if
  // narrower: where a prediction vouches for a pose that nothing else does.
  double StrictGate() const;
  // The innovation gate against the motion model (fills fr->innovation),
  // or against it a frame interval later (fills fr->after_drop);
  bool AgreesWithMotion(FrameResult* fr, const TriangulationResult& tri) const;
  // Before the motion model starts: the first position against a start
  // given as known (known_start_bounds_first_pose), within the 99 % gate
  // under the reported covariance and the motion model's speed over the
  // time since the first frame.
  bool AgreesWithStart(const FrameResult& fr, const TriangulationResult& tri) const;
  // whether the sequence started at a pose given as the robot's (Reset
  // without `hint`), not unknown or a guess;
  bool StartGivenAsPose() const { return track_.known_start && !track_.start_is_hint; }
  // the motion model predicted one frame interval beyond this frame's time,
  // where a frame may have been dropped before it without a gap in the
  // timestamps (a camera or a recorder losing frames at a constant frame
  // rate); none without a velocity, after a lost frame or with odometry.
  std::optional<MotionModel> AfterDroppedFrame() const;
  // A timestamp on the motion model's clock (track_.dropped_s).
  double MotionClock(double time_s) const { return time_s + track_.dropped_s; }
  // Tracks from `pose` (first a wide, then a narrow search); true if accepted.
  bool TrackFrom(const Pose2& pose, double search_px, FrameResult* fr, TriangulationResult* tri,
                 bool either = false) const;
  // A hypothesis whose tracking failed, tracked again from the pose that
  // what it found fits (relocalize_retrack_passes).
  bool RetrackFromFound(bool either, FrameResult* fr, TriangulationResult* tri) const;
  // A hypothesis of the room-wide search that tracking verified.
  struct VerifiedPose {
    Pose2 pose;
    int inliers = 0;
    int chosen_inliers = 0;  // ChosenInliers
    double residual = 0.0;   // TriangulationResult::residual (map units)
  };
  // The inliers among the landmarks chosen to track (the first of the
  // predictions, within either budget): a count comparable between poses
  // that tracked different numbers of extra landmarks.
  int ChosenInliers(const FrameResult& fr, const TriangulationResult& tri) const;
  // `near_last`: the robot is likely still near the last pose it had (a
  // short loss, the view as predicted), not carried off. `verified`
  // (optional): every hypothesis the search verified, whatever it then
  // decided.
  // `settle_rivalry`: a lost frame's own search, whose ambiguity between
  // two places counts towards the place that keeps leading (Rivalry).
  bool Relocalize(const cv::Mat& grey, bool near_last, FrameResult* fr, TriangulationResult* tri,
                  std::vector<VerifiedPose>* verified = nullptr, bool settle_rivalry = false) const;
  // Among a relocalised pose and its twins under the map's symmetries, the
  // one clearly nearest the last known pose (tracked from); false when
  // there are twins and none is.
  bool ChooseAmongTwins(bool either, bool near_last, FrameResult* fr, TriangulationResult* tri) const;
  // A pose and its twins under the map's symmetries of the landmarks it
  // fits (those in free space), the pose first.
  std::vector<Pose2> TwinPoses(const FrameResult& fr, const TriangulationResult& tri) const;
  // `collect_sparse`: the poses that verified too few bearings are kept in
  // reloc_.sparse_candidates (SparseLead).
  bool RelocalizeWith(const std::vector<PoseHypothesis>& hyps, bool either, bool near_last, FrameResult* fr,
                      TriangulationResult* tri, std::vector<VerifiedPose>* verified_out, bool settle_rivalry = false,
                      bool collect_sparse = false) const;
  // Of a lost frame's search that verified nothing, the pose clearly ahead
  // of every other place on a sparse image (relocalize_sparse_lead); false
  // when there is none.
  bool SparseLead(FrameResult* fr, TriangulationResult* tri) const;
  // whether most of what a pose found fits it, on at least
  // relocalize_min_landmarks bearings: a sparse lead's evidence.
  bool SparselySupported(const FrameResult& fr, const TriangulationResult& tri) const;
  // whether a search's pose on the frame after a single lost one (a hand
  // over the lens) continues the track: the motion model predicted it.
  bool ResumesTrack(const FrameResult& fr, const TriangulationResult& tri, bool under_probe) const;
  // whether the motion model, with a velocity learned over two frames or
  // more, predicted a pose within its 99 % gate (StrictGate): it then
  // vouches for a pose too thinly supported to stand alone, or one a
  // search took in place of a tracked pose it refuted;
  bool ModelVouchesFor(const FrameResult& fr, const TriangulationResult& tri) const;
  // whether, in a room-wide search (`either`: with either polarity), pose
  // `a` outranks pose `b` at another place;
  bool SearchOutranks(const VerifiedPose& a, const VerifiedPose& b, bool either) const;
  // A search no pose of which outranks every other (`ranked`: its poses,
  // the best supported first): whether its best supported pose has led the
  // one rival place long enough to be taken (LedRivalLongEnough).
  bool SettlesRivalry(const std::vector<VerifiedPose>& ranked, bool either) const;
  // An ambiguous search's leading place `leader` and its rival: whether
  // the leader led as relocalize_rival_searches consecutive searches have
  // (recorded in reloc_.rivalries; a search that shows no such lead, or
  // one under another survey sigma, starts them again).
  bool LedRivalLongEnough(const Pose2& leader, const Pose2& rival, bool leads) const;
  // The covariance a pose is reported with: the solution's, or where
  // larger the one its geometry predicts from what the weights assume (the
  // image noise of the consensus, each corner's reported survey sigma
  // across its line of sight). A map error that the pose absorbs leaves
  // small residuals exactly where the pose is off by it, and an estimate
  // of the survey error from the residuals can fall short of it.
  // `obs`: the frame's observations (Observations).
  Eigen::Matrix3d ReportedCovariance(const FrameResult& fr, const std::vector<BearingObservation>& obs,
                                     const TriangulationResult& tri) const;
  // Whether a frame not reported failed only its alert limit: consistent,
  // of enough quality, agreeing with the motion, its error bound wider
  // than the accuracy asked for (a weak geometry on a measured map).
  bool BeyondAlertLimitOnly(FrameResult* fr, const TriangulationResult& tri) const;
  // Whether an accepted frame's pose has no velocity to check it against
  // (before the motion model takes it): the model not started or started
  // again by it, one update only, or its velocity lost over a loss.
  bool WithoutVelocity(const FrameResult& fr) const;
  // Whether the pose's protection level plus its solution separation is
  // within its alert limit and StatedAlertLimit (always, where no alert
  // limit is asked for or separation_without_velocity is off).
  bool SeparationWithinAlertLimit(const FrameResult& fr, const TriangulationResult& tri) const;
  // The alert limit under the survey error the map states for the pose's
  // inliers (infinite where it states none for one of them, the survey
  // estimate is confident, or the limit is a length the user gave).
  double StatedAlertLimit(const FrameResult& fr, const std::vector<BearingObservation>& obs,
                          const TriangulationResult& tri) const;
  // An accepted frame's row made a lost one: the pose is not reported.
  void WithholdReport(FrameResult* fr) const;
  // The steps of Process:
  void CheckFrame(const cv::Mat& grey, int frame) const;
  // the motion model's prediction for time t (started at the first frame);
  Pose2 PredictMotion(double time_s, const OdometryIncrement* odometry);
  // tracking from that prediction, then from the visual compass's heading
  // (CompassPose), then with wider searches until accepted;
  void TrackPredictions(Pose2 pred, FrameResult* fr, TriangulationResult* tri) const;
  // The compass's heading for this frame (from the heading of the last
  // frame that measured or held one and this frame's azimuthal
  // `signature`), when its score is good enough.
  std::optional<double> CompassHeading(const std::vector<float>& signature) const;
  // `pred` turned to this frame's compass heading, when it differs.
  std::optional<Pose2> CompassPose(const Pose2& pred) const;
  // Whether the compass's heading goes before the prediction `pred`.
  bool CompassFirst(const Pose2& pred, const Pose2& by_compass) const;
  // Running mean heading errors of the two predictions against accepted
  // poses (radians; -1: none yet).
  void UpdatePredictionErrors(const Pose2& model_pred, const FrameResult& fr, const TriangulationResult& tri);
  // A new start: the previous frame's compass signature and the running
  // heading errors no longer apply.
  void ForgetCompassHistory();
  // ... the running heading errors alone (a held search pose keeps its
  // frame's signature: the confirming frame's turn is measured from it).
  void ForgetCompassRecord();
  // or, where most recent frames needed a second pass, coarse to fine: the
  // landmarks' azimuths alone from the prediction, then the full
  // measurement around the pose they give; false when either fails;
  bool TrackCoarseToFine(Pose2 pred, FrameResult* fr, TriangulationResult* tri, bool* recentred) const;
  bool CoarseToFineUseful() const;
  // The largest distance (px) of a found landmark from its prediction.
  static double MaxShiftPx(const FrameResult& fr);
  // narrow passes around the solved pose when landmarks were off-centre
  // (returns whether they were);
  bool RefineAroundSolution(FrameResult* fr, TriangulationResult* tri) const;
  // the room-wide search again under the ladder of survey errors of
  // relocalize_survey_probe; true if one verified a pose;
  bool RelocalizeUnderProbe(const cv::Mat& grey, bool near_last, FrameResult* fr, TriangulationResult* tri);
  // the widest survey error that ladder tries;
  double WidestSearchSurveySigma() const;
  // the room-wide search after relocalize_after lost frames;
  // `at_once`: the view is not the predicted one (ViewUnlikePrediction).
  // `under_probe`: the pose was verified only under a survey error wider
  // than the map's (RelocalizeUnderProbe). `sparse_lead`: the pose is a
  // sparse image's lead (SparseLead).
  bool RelocalizeIfLost(const cv::Mat& grey, int frame, bool at_once, FrameResult* fr, TriangulationResult* tri,
                        bool* under_probe, bool* sparse_lead);
  // whether a frame's tracking says the robot is not near the prediction;
  bool ViewUnlikePrediction(const FrameResult& fr, const TriangulationResult& tri) const;
  // whether a relocalised pose stands on its own evidence (`fraction` of
  // the chosen landmarks as inliers);
  bool Corroborated(const FrameResult& fr, const TriangulationResult& tri) const {
    return Corroborated(fr, tri, opt_.relocalize_confirmed_fraction);
  }
  bool Corroborated(const FrameResult& fr, const TriangulationResult& tri, double fraction) const;
  // whether, before the residuals have shown the map's error, fewer than
  // `fraction` of the landmarks chosen to track are inliers (a pose resting
  // on extra landmarks: a wrong one fits a few of them anywhere);
  bool FewChosenBeforeSurvey(const FrameResult& fr, const TriangulationResult& tri, double fraction) const;
  // the landmarks chosen to track at this frame (max_landmarks of those predicted);
  double ChosenLandmarks(const FrameResult& fr) const;
  // ... and with those the map's survey error adds (MaxLandmarks);
  double SurveyChosenLandmarks(const FrameResult& fr) const;
  // the larger of the two: the landmarks a pose is expected to find;
  double ChosenToTrack(const FrameResult& fr) const {
    return std::max(ChosenLandmarks(fr), SurveyChosenLandmarks(fr));
  }
  // the frame before which no room-wide search runs after the recent failures;
  int BackedOffRelocalizeFrame(int frame) const;
  // whether a relocalised pose has the inliers a room-wide search requires;
  bool EnoughForRelocalized(const FrameResult& fr, const TriangulationResult& tri) const;
  // whether two poses lie further apart than relocalize_distinct of the
  // room, or 10 degrees in heading (the search counts them as different
  // places);
  bool DistinctPlaces(const Pose2& a, const Pose2& b) const;
  // whether a pose with `a` inliers is clearly better supported than one
  // with `b`: by relocalize_margin, and `b` below relocalize_ambiguity of
  // `a` (the room-wide search's test of ambiguity);
  bool ClearlyBetterSupported(int a, int b) const;
  // whether a pose with `a` inliers and RMS residual `a_residual` (map
  // units) fits clearly better than one with `b` and `b_residual`: about as
  // well supported (not below relocalize_ambiguity of it, both on enough
  // bearings to compare their fits) and the other's residuals several
  // times its own (or the image noise's at the typical distance): the
  // other fits only under a map error several times larger, which the same
  // map cannot have at one place and not at another (the half-turned twin
  // of a nearly symmetric room, fitted under a wide tolerance);
  bool FitsClearlyBetter(int a, double a_residual, int b, double b_residual) const;
  // whether a pose outranks another in the room-wide search: clearly
  // better supported, or about as well supported and fitting clearly better;
  bool Outranks(int a, double a_residual, int b, double b_residual) const {
    return ClearlyBetterSupported(a, b) || FitsClearlyBetter(a, a_residual, b, b_residual);
  }
  // the room-wide search on this frame against a pose being checked: the
  // poses it verified away from it, the support of the best near it (at
  // least its own), whether the search's choice refutes it, and that
  // choice where it made one;
  using SearchResult = std::pair<FrameResult, TriangulationResult>;
  struct RoomSearch {
    int own = 0;
    int own_chosen = 0;
    double own_residual = 0.0;  // of the best near it (at most its own)
    std::vector<VerifiedPose> elsewhere;
    // The search's choice Refutes the pose checked.
    bool refuted = false;
    std::optional<SearchResult> chosen;
  };
  RoomSearch SearchRoomAgainst(const cv::Mat& grey, const FrameResult& fr, const TriangulationResult& tri) const;
  // whether that search verified no pose away from the one checked that
  // rivals the best near it;
  bool NoRivalElsewhere(const RoomSearch& search) const;
  // whether the search's choice, at the same place as the pose checked,
  // fits the frame's bearings better (as many inliers or more, of those
  // chosen too, and a smaller residual) and lies outside the checked
  // pose's reported 95 % ellipse: the checked pose rests on edges a wrong
  // prediction led to (a held pose tracked without a velocity, a turn
  // mispredicted), and its covariance does not hold it;
  bool Refutes(const SearchResult& chosen, const FrameResult& fr, const TriangulationResult& tri) const;
  // takes a room-wide search's pose as this frame's (relocalised);
  void AdoptSearchResult(SearchResult&& found, FrameResult* fr, TriangulationResult* tri);
  // whether a relocalised pose lies beyond where the robot could have gone
  // since its last accepted pose (the motion model's largest speed over the
  // time since, plus the search's distinct-pose tolerance): a jump;
  bool BeyondReach(const Pose2& pose, double time_s) const;
  // whether a frame tracked from a relocalised pose BeyondReach (reloc_.held_jump)
  // carries it: where the survey error limits the bearings, with
  // relocalize_jump_fraction of its chosen landmarks as inliers;
  bool ConfirmsJump(const FrameResult& fr, const TriangulationResult& tri) const;
  // tracking restarts from a relocalised pose that the next frame must
  // confirm (`jump`: one BeyondReach, which its own evidence must carry);
  void HoldForConfirmation(const Pose2& pose, int frame, bool jump);
  // A held pose where the model predicted it (hold_keeps_motion) while the
  // loss left the velocity known (its spread within half the top speed):
  // the model from before the hold (`before`, `updates`) goes on with it.
  bool VelocityStillKnown() const;
  void KeepMotion(MotionModel&& before, int updates, const FrameResult& fr, const TriangulationResult& tri);
  // A held sparse lead's frames (SparseLead) feed a motion model from the
  // lead's pose on (`lead_motion`, `lead_updates`: the one before this
  // frame's hold): the frames that follow must agree with the motion they show.
  void FollowSparseLead(MotionModel&& lead_motion, int lead_updates, const FrameResult& fr,
                        const TriangulationResult& tri);
  // the output row and the motion model's state.
  void RecordOutcome(FrameResult* fr, const TriangulationResult& tri, bool accepted, int n_found);
  // The row of a reported pose: the pose, its inliers, residual, covariance
  // and integrity quality (`obs`: the frame's Observations).
  void FillReportedRow(FrameResult* fr, const std::vector<BearingObservation>& obs,
                       const TriangulationResult& tri) const;
  // Whether a tracked frame's pose (of the motion model's measurement
  // `covariance`) fits the prediction for its time (`prior`) at least as
  // well as the one a frame interval later (`one_frame_later`, where a
  // dropped frame is possible): else its time, and the velocity after it,
  // are in doubt.
  bool FitsItsOwnTime(const FrameResult& fr, const Pose2& pose, const Eigen::Matrix3d& covariance,
                      const MotionState& prior, const std::optional<MotionState>& one_frame_later) const;
  // The reported pose and covariance fused with the motion model's
  // prediction for the frame (with LocalizerOptions::report_fused_with_motion),
  // where the two agree under their covariances. Unless `time_settled`,
  // the prediction's spread holds the step to `one_frame_later` too.
  void FuseReportWithMotion(FrameResult* fr, const MotionState& prior, const std::optional<MotionState>& one_frame_later,
                            bool time_settled) const;
  // A frame held for confirmation: its image (as tracked), row, pose and
  // the pose's covariance as it would be reported; whether it was held as a
  // sparse lead's frame (confirmed on a sparse lead's support).
  struct HeldFrame {
    cv::Mat grey;
    PoseRow row;
    Pose2 pose;
    Eigen::Matrix3d covariance;
    bool sparse = false;
    bool either = false;  // found with either polarity (FrameResult::either_polarity)
  };
  // Whether the frame confirming a held one found a pose the robot can
  // have reached from the held pose: no farther than max_speed for the
  // time between them, beyond that within the two poses' combined error.
  bool WithinReachOfHeld(const FrameResult& fr, const TriangulationResult& tri) const;
  // The held frame's result once a later frame has confirmed its pose:
  // tracked again from it with what that frame taught (the survey error
  // its residuals showed, the learned blur), reported where it is accepted
  // as a relocalised frame is (a sparse lead's frame: as it was held);
  // else none.
  std::optional<FrameResult> ReportConfirmedHold(const HeldFrame& held);
  // A held frame's report of `tri`: the row filled in, in the robot's frame.
  void FinishHeldReport(FrameResult* fr, const TriangulationResult& tri) const;

  // One frame's work in progress, handed from one step of Process to the next.
  struct FrameWork {
    FrameResult fr;
    TriangulationResult tri;
    bool accepted = false;
    Pose2 model_pred;        // the motion model's prediction (the last pose before one)
    bool recentred = false;  // the landmarks lay off their predictions
    bool was_held = false;   // the frame confirms, or not, a held hypothesis
    // The survey estimate before this frame taught or probed it from a held
    // pose: a pose not confirmed leaves no trace in it.
    std::optional<SurveyErrorEstimate> survey_before_hold;
    // The survey estimate and bearing noise before this frame taught them.
    LearnedSurvey survey_at_begin{};
    // The widest survey error a held pose is confirmed under (HeldSurveyBound).
    double held_survey_bound = std::numeric_limits<double>::infinity();
    bool after_search = false;  // tracked from a search's pose, the map's error not yet shown
    bool gave_way = false;      // the tracked pose gave way to the room-wide search
    bool refuted = false;       // ... whose choice beside it refuted it (Refutes)
    std::optional<SearchResult> searched;
    // A search's sparse lead (held), or a frame that tracked a held one with
    // as strong a fit, not yet relocalize_sparse_frames long (held again).
    bool sparse_lead = false;
    bool sparse_continues = false;
    int n_found = 0;  // what tracking from the prediction found
    std::vector<float> signature;  // the compass's, of this frame (for the next one too)
    // The tracked pose gives way to the room-wide search's `chosen` pose
    // (none: to nothing), refuted by it or not.
    void GiveWay(std::optional<SearchResult>&& chosen, bool by_refutation) {
      accepted = false;
      gave_way = true;
      refuted = by_refutation;
      searched = std::move(chosen);
    }
  };
  // Process's steps, in order: begin the frame; track from the prediction
  // (motion model, compass, coarse to fine, integrity); confirm a held pose
  // (learning the survey error from a rejected frame); check a pose against
  // the room-wide search; relocalise when lost; record the outcome and the
  // hold.
  const cv::Mat& BeginFrame(const cv::Mat& frame_image, int frame, double time_s, FrameWork* w);
  void ConfirmHeldPose(const cv::Mat& grey, FrameWork* w);
  void TrackFromPrediction(double time_s, const OdometryIncrement* odometry, const std::vector<float>& signature,
                           FrameWork* w);
  void LearnSurveyFromRejected(FrameWork* w);
  void CheckAgainstRoomSearch(const cv::Mat& grey, FrameWork* w);
  void RelocalizeWhenLost(const cv::Mat& grey, int frame, FrameWork* w);
  void FinishFrame(const cv::Mat& grey, int frame, double time_s, std::vector<float>&& signature, FrameWork* w);

  Calibration calib_;  // with a rig's faults, its aligned view's sensor
  Map map_;
  std::optional<AlignedView> view_;
  cv::Mat view_frame_;  // this frame, resampled to the view
  Scene scene_;
  std::shared_ptr<const RadiusTable> table_;
  LocalizerOptions opt_;
  std::vector<Landmark> landmarks_;
  std::unique_ptr<LandmarkTracker> tracker_;
  // Built on the first room-wide search (a tracked run never needs it).
  mutable std::shared_ptr<const RelocalizationIndex> relocalization_index_;
  std::shared_ptr<SharedRelocalizationIndex> shared_index_;  // null: the localiser's own
  MotionModel motion_;
  MotionModelOptions motion_options_;  // in map units
  AzimuthCompass compass_;
  void UpdateBlurEstimate(const FrameResult& fr);

  // The state that outlives a frame, by what it is about.

  // Where the robot is and how the sequence started.
  struct Track {
    Pose2 initial;
    Pose2 last;  // the last good pose
    // The camera's motion over the last frame interval (world frame), for
    // the landmarks' expected motion blur; kept while lost.
    Pose2 frame_motion;
    Pose2 frame_pose;  // the estimate at the previous frame
    int n_good = 0;    // consecutive good frames (for the velocity model)
    int n_lost = 0;    // consecutive lost frames
    bool started = false;
    bool known_start = true;     // initial is a pose to track from (not unknown)
    bool start_is_hint = false;  // ... but only a guess
    bool ever_tracked = false;
    std::optional<double> start_time;  // the first frame's since the start (AgreesWithStart)
    // The last accepted pose and its time (never a held one): where the
    // robot was last known to be, for BeyondReach.
    std::optional<std::pair<Pose2, double>> last_known;
    double last_dt = 0.0;         // seconds between the last two frames
    // The motion model before this frame's prediction (for AfterDroppedFrame),
    // whether the prediction used odometry, and the frame intervals dropped
    // without a gap in the timestamps so far (the motion model's clock is
    // the timestamps' plus these).
    MotionModel before_prediction;
    bool odometry_predicted = false;
    double dropped_s = 0.0;
    int frame_intervals = 1;  // since the previous frame (2 once the frame is taken to follow a dropped one)
    int motion_updates = 0;       // poses fused since the motion model (re)started
    int steady_updates = 0;       // ... of them, the last in a row whose time was not in doubt (FitsItsOwnTime; counted while fusing reports)
    bool motion_stepped = false;  // the motion model took a step at this frame
    int frame = -1;               // the frame being processed
    double time_s = 0.0;          // ... and its time
  };
  Track track_;

  // The heading from the panorama's azimuth signature, and how well it and
  // the motion model predicted the headings found (UpdatePredictionErrors).
  struct Heading {
    std::vector<float> last_signature;  // of the last frame with a measured or held heading
    double signature_heading = 0.0;     // ... and that heading
    std::optional<double> compass_heading;  // this frame's (CompassHeading)
    double model_error = -1.0;
    double compass_error = -1.0;
    int error_frames = 0;  // accepted frames in those means
  };
  Heading heading_;

  // What the tracked edges showed of the images: the exposure as a fraction
  // of the frame interval, estimated from the widths of the tracked edges
  // against their image motion; the width of an edge the camera does not
  // move across (the optics' blur, px); and the running mean over the
  // tracked frames of whether the landmarks lay off their predictions (a
  // second pass was due): CoarseToFineUseful.
  struct ImageEvidence {
    double blur_fraction = 1.0;
    double still_edge_width_px = 1.5;
    double recentre_rate = 0.0;
  };
  ImageEvidence images_;

  // What the measurements' errors are taken to be.
  struct ErrorModel {
    // The bearing noise of recent good frames (radians, in units of each
    // bearing's spread), for the integrity test.
    double bearing_sigma = 0.0;
    // The landmarks' typical distance the survey error is scaled by.
    double typical_distance = 1.0;
    // The map's larger floor extent (map units): the scale of the
    // relocalisation's distinct-pose and symmetry tolerances.
    double room_size = 1.0;
    // The map's survey error as the residuals show it.
    SurveyErrorEstimate survey;
    // The survey estimate before the pose tracked from was found by a
    // room-wide search that the residuals had not yet shown the map's error
    // to: that pose is checked against the search on every frame until they
    // have, and what its frames taught is forgotten if it gives way.
    std::optional<SurveyErrorEstimate> survey_before_search;
    int max_landmarks = 0;  // MaxLandmarks
    // opt_.prediction, with the surface tolerance of the survey error now
    // assumed (tracking) and of the map's statement (the relocalisation
    // index, built once and shared between inputs).
    PredictionOptions prediction, index_prediction;
    // Per landmark: its bearing residual on the last accepted frame that
    // had it as an inlier, and that frame (SuddenResiduals).
    std::vector<double> residual_memory;
    std::vector<int> residual_frame;
    // RetrackUnderStatedSurvey's schedule: the next frame it may try, and
    // the gap after the next failure (doubled each time, to a cap).
    int next_statement_check = 0;
    int statement_check_gap = 1;
    int statement_agreements = 0;  // tracked frames in a row that agreed under it
    // This frame agreed under the statement closely enough to report the
    // frame held before it as measured under the statement.
    bool statement_supports_hold = false;
    // A tracked frame agreed under the statement alone: frames that do not
    // are the images' fault (blur, a person), and teach no survey error
    // beyond StatementBound.
    bool statement_verified = false;
  };
  ErrorModel errors_;

  // Relocalised poses held until a frame confirms them, and the room-wide
  // search's schedule.
  struct Relocalization {
    bool held = false;  // this frame must confirm a relocalised pose (HoldForConfirmation)
    // The pose tracked from is a relocalised one beyond the robot's reach
    // (BeyondReach) that no frame has corroborated yet.
    bool held_jump = false;
    // The frame held for confirmation, and before it the frames of the
    // sparse lead it continues (oldest first); their reports once a frame
    // confirmed them (TakeConfirmedHolds).
    std::optional<HeldFrame> held_frame;
    std::vector<HeldFrame> sparse_chain;
    std::vector<FrameResult> confirmed_holds;
    int next_frame = 0;  // no room-wide search before this frame
    // Searches (and held poses) that failed since the last accepted frame
    // or the last search that found a pose: the searches back off after two.
    int failures = 0;
    // A room-wide search's best pose, unambiguous but inconsistent with the
    // survey error assumed: evidence of it while the estimate is not yet
    // confident (Relocalize is const; RelocalizeIfLost learns from it).
    mutable std::optional<std::pair<FrameResult, TriangulationResult>> survey_evidence;
    // The survey sigma a probe assumes (ProbeSurveyError; 0 otherwise).
    double probe_sigma = 0.0;
    // The consecutive ambiguous searches in which one place led its rival
    // (LedRivalLongEnough).
    struct Rivalry {
      double time_s;
      Pose2 leader, rival;
      double survey_sigma;
    };
    mutable std::vector<Rivalry> rivalries;
    // A lost frame's search: the poses tracked from its hypotheses that
    // verified too few bearings (SparseLead: leads and rivals), whether any
    // verified enough, and whether the pose it returned is such a lead.
    struct SparseCandidate {
      FrameResult fr;
      TriangulationResult tri;
      bool supported = false;  // SparselySupported
    };
    mutable std::vector<SparseCandidate> sparse_candidates;
    mutable bool any_verified = false;
    mutable bool sparse_lead = false;
    // The frames a sparse lead has been held in a row (0: the hold is not one).
    int sparse_holds = 0;
  };
  Relocalization reloc_;

  // Polarities learned from the images, per landmark; per map object
  // (rectangle, box) whether the images contradict its shade; whether they
  // contradict most of the map (then no map polarity is trusted) or have
  // confirmed it (then no frame is retried with either polarity).
  struct Shades {
    std::vector<LandmarkPolarity> polarity;
    std::vector<char> object_contradicted;
    bool map_contradicted = false;
    bool map_confirmed = false;
    bool any_known = false;
  };
  Shades shades_;
};

}  // namespace pano
