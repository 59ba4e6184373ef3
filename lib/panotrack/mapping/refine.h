// Map refinement (panomap refine): a bundle adjustment of the landmark
// rectangles, the robot poses and, optionally, the sensor height from the
// junctions tracked in one or more videos.
//
// Each rectangle keeps its shape: vertical, six parameters (the floor end
// points from (x, y), to (x, y) and the heights z0, z1) shared by its four
// corners. Each found corner gives two measurements: the image azimuth of
// its vertical edge (a bearing) and the image radius of the junction, which
// through the sensor model E(D, Z) carries the corner's distance and height.
// Every parameter has a Gaussian prior at its surveyed value (sigma
// map_sigma): the priors fix the gauge (the measurements are blind to a
// rigid motion of the whole room and trajectory), so no pose need be held.
// Optional priors on the poses (pose_sigma) fix it from an absolute
// reference instead.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "panotrack/pose/pose2.h"
#include "panotrack/pose/pose_row.h"
#include "panotrack/scene/map.h"
#include "panotrack/sensor/calibration.h"
#include "panotrack/track/landmarks.h"
#include "panotrack/track/localizer.h"

namespace pano {

struct RefineOptions {
  double map_sigma = 1.0;     // prior sigma of each surveyed coordinate (map units)
  // Prior sigma of each pose's position at its CSV value (map units); 0: no
  // pose prior. Poses from an absolute reference (motion capture, ground
  // truth) fix the gauge far better than the survey; poses localised on the
  // surveyed map only repeat the survey's gauge, with the map's errors in
  // them, so the default leaves them free.
  double pose_sigma = 0.0;
  bool free_height = false;   // estimate the sensor height too (no prior; it is measured)
  bool fix_first_pose = false;  // hold the first used pose (the priors fix the gauge anyway)
  // Rectangles surveyed standing on the floor (z0 = 0) keep z0 = 0: the
  // contact is known exactly, and with the sensor height it fixes the one
  // gauge the priors alone hold only weakly (a scaling of the room and the
  // trajectory about the sensor's height, which no bearing or elevation sees).
  bool hold_floor_contacts = true;
  // Measure-and-solve rounds: the first measures at the poses of the CSV
  // and the surveyed map, each later one at the last solution (narrower
  // search), which re-centres the trackers' windows.
  int passes = 2;
  double search_px = 6.0;         // half-width of the first round's search
  double refine_search_px = 3.0;  // ... and of the later rounds'
  // Frames need this many found corners to enter the adjustment.
  int min_corners_per_frame = 4;
  // Huber loss on each measurement, in units of its noise sigma; the noise
  // sigmas are estimated from the residuals (robust scale) between solves.
  double loss_sigmas = 2.0;
  // Measurements whose residual exceeds this many noise sigmas are dropped
  // and the adjustment solved again (until none changes): a tracker that
  // locked onto a neighbouring edge for a few frames is biased, not noisy,
  // and even a Huber loss lets such runs pull a corner.
  double reject_sigmas = 4.0;
  // Corners whose vertical edge passes within this many pixels (across the
  // edge, where the edges overlap in radius) of another landmark's edge are
  // not measured: the tracker cannot tell the two apart.
  double min_edge_gap_px = 10.0;
  // Systematic error of a corner's image radius (px): a bias that repeats
  // over its frames (edge location, interpolation). A corner's radius
  // measurements then weigh at most like one of this sigma, so that many
  // frames do not turn a small bias into a depth error. 0: none.
  double radius_systematic_px = 0.04;
  double initial_azimuth_sigma = 0.1 * M_PI / 180;  // radians
  double initial_radius_sigma = 0.5;                // px
  int max_iterations = 100;
  int num_threads = 0;  // 0: every core
  LocalizerOptions tracking;  // prediction and junction-tracker settings
  void Check() const;
};

// One found corner in one frame.
struct CornerObservation {
  int frame = 0;     // index into the frames of the adjustment
  int landmark = 0;  // index into LandmarksFromMap(map)
  double azimuth = 0.0;  // image azimuth (radians)
  double radius = 0.0;   // image radius of the junction (px)
};

// The rectangle parameters in the order of the adjustment.
constexpr int kRectangleParams = 6;
extern const std::array<const char*, kRectangleParams> kRectangleParamNames;  // from_x ... z1
std::array<double, kRectangleParams> RectangleParams(const MapRectangle& r);
void SetRectangleParams(const std::array<double, kRectangleParams>& p, MapRectangle* r);

struct LandmarkCorrection {
  std::string id;
  int observations = 0;  // measurements of its corners
  std::array<double, kRectangleParams> surveyed{}, refined{}, std{};
  // Largest move of one of its four corners (map units).
  double max_corner_shift = 0.0;
  // Some parameter moved more than 3 prior sigmas: the survey was wrong there.
  bool flagged = false;
};

struct RefineResult {
  Map map;  // the refined map
  double sensor_height_std = 0.0;  // 0 when the height was held
  std::vector<LandmarkCorrection> landmarks;  // one per rectangle, in map order
  std::vector<Pose2> poses;        // per adjusted frame
  int frames_used = 0;
  int measurements = 0;            // corner observations in the last solve
  int rejected = 0;                // azimuth or radius measurements dropped as outliers
  int crowded = 0;                 // corner predictions not measured (another edge too near)
  // The gauge left to the priors (the transform the images cannot see):
  // its standard deviations, from the survey's priors and the pose priors
  // alone. shift: of the corners' centroid, each axis (map units); turn:
  // about it (radians); scale: about the sensor height (free height only).
  // gauge_corner_rms is the RMS corner error it alone gives: the floor of
  // the refined map's error against the truth.
  double gauge_shift_std = 0.0, gauge_turn_std = 0.0, gauge_scale_std = 0.0;
  double gauge_corner_rms = 0.0;
  double azimuth_sigma = 0.0;      // robust noise estimates of the last solve (radians, px)
  double radius_sigma = 0.0;
  double rms_azimuth_before = 0.0, rms_azimuth_after = 0.0;  // radians, first and last solve
  bool covariance_ok = false;
};

// The adjustment itself from corner observations: `poses` are the poses of
// the frames the observations index (the CSV's: the pose priors sit there),
// `start` where the adjustment starts them (null: at `poses`). Throws
// pano::Error when there are no observations.
RefineResult SolveMapRefinement(const Calibration& calib, const Map& surveyed,
                                const std::vector<Pose2>& poses,
                                const std::vector<CornerObservation>& observations,
                                const RefineOptions& options, const std::vector<Pose2>* start = nullptr);

// One video and its trajectory (one pose CSV row per video frame; rows
// whose status is not ok are skipped).
struct RefineVideo {
  std::string video;
  std::string poses_path;  // named in messages
  std::vector<PoseRow> poses;
};

// Whether a pose CSV is a reference trajectory (ground truth, motion
// capture): its ok rows carry no standard deviations, which panoloc always
// writes. Poses panoloc localised on the surveyed map repeat its gauge;
// those of a reference can fix it.
bool IsReferenceTrajectory(const std::vector<PoseRow>& rows);

// The pose prior of `--pose-sigma auto`: a tenth of map_sigma when every
// video's poses are a reference trajectory, else 0 (none).
double AutoPoseSigma(const std::vector<RefineVideo>& videos, double map_sigma);

// Tracks every corner of `surveyed` in every ok frame of each video from its
// pose (the junction tracker at the predicted position), solves, and repeats
// for options.passes rounds. Throws pano::Error naming the files when a pose
// CSV does not match its video's frame count or no corner is found anywhere.
RefineResult RefineMap(const Calibration& calib, const Map& surveyed, const std::vector<RefineVideo>& videos,
                       const RefineOptions& options);

// The per-landmark report for people.
std::string RefineReportTable(const RefineResult& r, const Map& surveyed, double map_sigma);

// RMS over every rectangle corner of the distance between two maps with the
// same rectangles (matched by id); throws if they differ.
double CornerRms(const Map& a, const Map& b);
// The same after moving `estimate` by the transform no image can see and
// only the survey's priors fix (the gauge): a shift and turn on the floor
// and a scaling about the sensor's height (least squares). What is left is
// the error of the room's shape.
double CornerRmsAfterGauge(const Map& estimate, const Map& truth);

}  // namespace pano
