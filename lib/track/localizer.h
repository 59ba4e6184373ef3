// The per-frame localiser: predict the landmarks in view from the current
// pose estimate and the map, track each one in the frame, and triangulate
// the pose from their azimuths (paper sections 2-4). A second pass re-predicts
// from the solved pose with a narrow search, which centres the linear samples
// and the PH window on the edges.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "sensor/calibration.h"
#include "scene/map.h"
#include "pose/pose_row.h"
#include "lut/radius_table.h"
#include "pose/triangulate.h"
#include "scene/scene.h"
#include "track/compass.h"
#include "track/junction_tracker.h"
#include "track/landmarks.h"
#include "track/relocalize.h"
#include "track/tracker.h"
#include "track/vertex_tracker.h"

namespace pano {

enum class TrackingMethod { kJunction, kVertex };
const char* tracking_method_name(TrackingMethod m);

struct LocalizerOptions {
  TrackingMethod method = TrackingMethod::kJunction;
  PredictionOptions prediction;
  JunctionOptions junction;
  VertexOptions vertex;
  TriangulationOptions triangulation;
  double search_px = 8.0;         // half-width of the first pass's linear samples
  // Landmarks tracked per frame: at most this many, spread in azimuth (one
  // per sector, the nearest first). 0: all in view.
  int max_landmarks = 12;
  double refine_search_px = 3.0;  // second pass, around the solved pose
  int refine_passes = 1;
  // The second pass runs only when some landmark was found further than
  // this from its prediction (px): otherwise the windows were centred.
  double refine_threshold_px = 1.0;
  bool constant_velocity = true;  // predict with the last frame-to-frame motion
  bool compass = true;            // predict the heading with the visual compass
  double compass_max_rotation = 60.0 * M_PI / 180;  // per frame
  double compass_min_score = 0.5;
  // A solution is accepted only with a bearing RMS below this (radians) and
  // at least this fraction of the predicted landmarks as inliers (when at
  // least 8 were predicted): a few wrong junctions can triangulate exactly.
  double max_rms_bearing = 0.5 * M_PI / 180;
  double min_inlier_fraction = 0.35;
  // After this many consecutive lost frames, search the whole room for the
  // pose (0: never). Relocalisation accepts a pose only with at least
  // relocalize_min_landmarks inliers.
  int relocalize_after = 2;
  int relocalize_min_landmarks = 6;
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
  // Threads of the per-frame parallel loops (landmarks, relocalisation
  // hypotheses, the PH tables of its own cache); 0: OpenMP's default (all
  // cores unless OMP_NUM_THREADS says otherwise). Set per localiser, never
  // process-wide; the results do not depend on it.
  int num_threads = 0;
  void Check() const;
};

struct FrameResult {
  PoseRow row;
  Pose2 predicted_pose;
  std::vector<PredictedLandmark> predicted;
  std::vector<LandmarkMeasurement> measurements;  // one per predicted landmark
  TriangulationResult triangulation;
};

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

class Localizer {
 public:
  Localizer(const Calibration& calib, const Map& map, std::shared_ptr<const RadiusTable> table,
            const LocalizerOptions& options, std::shared_ptr<PhTableCache> ph_tables = nullptr);
  // Starts a sequence at a known pose.
  void Reset(const Pose2& initial);
  // Processes one grey frame (CV_8UC1 of the calibration's size).
  FrameResult Process(const cv::Mat& grey, int frame, double time_s);

  const Map& map() const { return map_; }
  const Sensor& sensor() const { return calib_.sensor; }
  const std::vector<Landmark>& landmarks() const { return landmarks_; }

 private:
  void Measure(const Pose2& pose, double search_px, FrameResult* out) const;
  TriangulationResult Solve(const FrameResult& fr, const Pose2& prior) const;
  bool Acceptable(const FrameResult& fr, const TriangulationResult& tri) const;
  // Tracks from `pose` (first a wide, then a narrow search); true if accepted.
  bool TrackFrom(const Pose2& pose, double search_px, FrameResult* fr, TriangulationResult* tri) const;
  bool Relocalize(const cv::Mat& grey, FrameResult* fr, TriangulationResult* tri) const;
  // The steps of Process:
  void CheckFrame(const cv::Mat& grey, int frame) const;
  // the last pose moved on by the last frame-to-frame motion;
  Pose2 ConstantVelocityPrediction() const;
  // that prediction, then the visual compass's heading (fills `signature`);
  std::vector<Pose2> CandidatePoses(const cv::Mat& grey, const Pose2& pred,
                                    std::vector<float>* signature) const;
  // tracking from each candidate, then with wider searches until accepted;
  void TrackPredictions(const std::vector<Pose2>& predictions, FrameResult* fr,
                        TriangulationResult* tri) const;
  // narrow passes around the solved pose when landmarks were off-centre;
  void RefineAroundSolution(FrameResult* fr, TriangulationResult* tri) const;
  // the room-wide search after relocalize_after lost frames;
  void RelocalizeIfLost(const cv::Mat& grey, FrameResult* fr, TriangulationResult* tri);
  // the output row and the motion model's state.
  void RecordOutcome(const FrameResult& fr, const TriangulationResult& tri, int n_found, PoseRow* row);

  Calibration calib_;
  Map map_;
  Scene scene_;
  std::shared_ptr<const RadiusTable> table_;
  LocalizerOptions opt_;
  std::vector<Landmark> landmarks_;
  std::unique_ptr<LandmarkTracker> tracker_;
  AzimuthCompass compass_;
  std::vector<float> last_signature_;
  Pose2 initial_;
  Pose2 last_, previous_;
  // The camera's motion over the last frame interval (world frame), for the
  // landmarks' expected motion blur; kept while lost.
  Pose2 frame_motion_;
  // The exposure as a fraction of the frame interval, estimated from the
  // widths of the tracked edges against their image motion; and the width
  // of an edge the camera does not move across (the optics' blur, px).
  double blur_fraction_ = 1.0;
  double still_edge_width_px_ = 1.5;
  void UpdateBlurEstimate(const FrameResult& fr);
  int n_good_ = 0;   // consecutive good frames (for the velocity model)
  int n_lost_ = 0;   // consecutive lost frames
  bool started_ = false;
};

}  // namespace pano
