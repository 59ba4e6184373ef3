// The factors of real cameras and rooms that act per frame of a sequence,
// each with its ground truth: motion blur (an exposure centred on the frame's
// time), auto-exposure gain, moving people that are not in the map, frames
// covered by a dark object in front of the lens, and dropped frames.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

#include "panotrack/pose/pose2.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/render.h"
#include "panotrack/scene/scene.h"

namespace pano {

// Gain of frame `frame` (multiplies the image before clipping): 1 when
// options.auto_exposure is 0, else 1 + A * (0.5 sin(slow phase) + 0.5 level),
// where the level steps to a new seeded value in [-1, 1] every 40..80 frames.
// Always within [1 - A, 1 + A]; deterministic in options.seed.
double AutoExposureGain(const RenderOptions& options, int frame);

// The seeded frames of options.dropped_frames and options.covered_frames:
// distinct, sorted, none of the first 5, covered ones not dropped. Throws
// pano::Error when they do not fit in half of frames 5..n_frames-1.
std::vector<int> DroppedFrames(const RenderOptions& options, int n_frames);
std::vector<int> CoveredFrames(const RenderOptions& options, int n_frames);

// Offset of sub-frame k of `samples` from the frame's time, in frame
// intervals: spread uniformly over an exposure centred on the frame's time.
double ExposureOffset(double exposure, int k, int samples);

// The robot's pose `offset` frame intervals from frame i: position linear and
// heading along the shortest arc towards the neighbouring frame in that
// direction; extrapolated from the other neighbour at the ends of the
// sequence and at a kidnap (no interpolation across a jump: frame k of
// `kidnap_frames` is not a neighbour of frame k - 1).
Pose2 PoseAtOffset(const std::vector<Pose2>& poses, int i, double offset,
                   const std::vector<int>& kidnap_frames);

// A person: a vertical prism of side 2 * radius walking back and forth
// between `from` and `to` at `speed` map units per frame.
struct Person {
  Eigen::Vector2d from{0, 0}, to{0, 0};
  double radius = 1.0, height = 1.0, shade = 0.2;
  double speed = 1.0;  // map units per frame
  double start = 0.0;  // distance walked at frame 0 (along the back-and-forth walk)
};

// `count` people in the map's room (which must be present): radius 2 % of the
// room's larger side, height 60..90 % of the room's, shade 0.12..0.3, speed
// 1 % of the larger side per frame, walks clear of boxes and free-standing
// rectangles. Deterministic in `seed`.
std::vector<Person> MakePeople(const Map& map, int count, uint64_t seed);

// Where the person is at time `time` (frames), pushed radially away from
// `robot` to at least `clearance` so that nobody walks through the sensor.
Eigen::Vector2d PersonPosition(const Person& person, double time, const Eigen::Vector2d& robot,
                               double clearance);

// The people's surfaces at `time` (4 walls and a top each, kind kDistractor,
// named "person-<k>:...").
std::vector<Surface> PeopleSurfaces(const std::vector<Person>& people, double time,
                                    const Eigen::Vector2d& robot, double clearance);

// The map a survey with errors would give: each rectangle's floor end points
// (x and y of `from` and `to`) and heights (z0, z1) moved by independent
// Gaussian errors of standard deviation `sigma` (map units), deterministic in
// `seed`; then each box's six coordinates likewise. A rectangle or box
// standing on the floor (bottom at 0) keeps it there (a survey sees the
// contact); heights stay ordered (top at least sigma above bottom) and
// bottoms at or above the floor; the room and distractors are kept as they
// are (so a rectangle near a wall may be surveyed a little behind it).
Map PerturbedMap(const Map& map, double sigma, uint64_t seed);

// Each rectangle and box of `map` moved as a whole by independent Gaussian
// errors of standard deviation `sigma` in x and in y (heights kept),
// deterministic in `seed`.
Map OffsetMap(const Map& map, double sigma, uint64_t seed);

// A gross error of a survey, on one rectangle.
enum class MapFaultKind {
  kMoved,     // in the map, `offset` away from where it stands, along its bottom edge
  kNotInRoom, // in the map, but not in the room (taken down since)
  kNotInMap,  // in the room, but left out of the map
};
const char* MapFaultName(MapFaultKind kind);  // "moved", "not-in-room", "not-in-map"

struct MapFault {
  MapFaultKind kind = MapFaultKind::kMoved;
  std::string id;               // the rectangle's
  Eigen::Vector2d offset{0, 0}; // kMoved: the map's rectangle minus the room's
};

// The room a survey measured and what it wrote down.
struct SurveyedMap {
  Map room;  // rendered: the true room, without the not-in-room rectangles
  Map map;   // the survey (map.yaml): survey_sigma stated when sigma or offsets
  std::vector<MapFault> faults;  // in the order they were picked
};

// `truth` with the errors of `error`: PerturbedMap (error.sigma), then
// OffsetMap (error.offset_sigma), then error.gross distinct rectangles
// picked by the seed, the k-th given fault k mod 3 (so 3 give one of each).
// map.survey_sigma is sqrt(sigma^2 + offset_sigma^2), the standard deviation
// of each coordinate, when above 0 (the gross faults are blunders, not in
// it). Each kind of error has its own generator: turning one on changes no
// other; the kinds in turn leave the map and the room a landmark each.
// Throws pano::Error naming the option when error is out of range or asks
// for more gross faults than the map has rectangles.
SurveyedMap SurveyMap(const Map& truth, const SurveyError& error);

// Renders the frames of a case with every factor of its options.
class SequenceRenderer {
 public:
  // `c` must outlive the renderer.
  explicit SequenceRenderer(const SequenceCase& c);
  SequenceRenderer(const SequenceRenderer&) = delete;
  SequenceRenderer& operator=(const SequenceRenderer&) = delete;
  int frames() const { return static_cast<int>(case_.poses.size()); }
  // Sub-frames of frame i: options.blur_samples when given, else enough that
  // neighbouring sub-frames are about 1 px apart at the mirror's rim (2..32);
  // 1 without exposure, or when nothing moves.
  int BlurSamples(int i) const;
  // The robot's poses of the sub-frames of frame i.
  std::vector<Pose2> SubPoses(int i) const;
  double Gain(int i) const { return AutoExposureGain(case_.options, i); }
  const std::vector<int>& dropped() const { return dropped_; }
  const std::vector<int>& covered() const { return covered_; }
  bool Dropped(int i) const;
  bool Covered(int i) const;
  // Minimum distance of a person from the robot (map units).
  double people_clearance() const { return people_clearance_; }
  const std::vector<Person>& people() const { return people_; }
  // Frame i (CV_8UC1): the mean of the sub-frame renders (one ray per pixel
  // when 4 or more sub-frames, since they average already), times the gain,
  // the cover, then the 3 x 3 blur and the noise once (FinishImage).
  // Without the per-frame factors it equals renderer().Render(pose i, i).
  cv::Mat RenderFrame(int i) const;
  const Scene& scene() const { return scene_; }
  const Renderer& renderer() const { return renderer_; }

 private:
  const SequenceCase& case_;
  Scene scene_;
  Renderer renderer_;
  std::vector<Person> people_;
  double people_clearance_ = 0.0;
  std::vector<int> dropped_, covered_;
  cv::Mat mask_;
};

}  // namespace pano
