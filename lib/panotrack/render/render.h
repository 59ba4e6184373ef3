// panosim's ray tracer: for each pixel (s x s subsamples) the camera ray, its
// reflection in the mirror (Sensor::backproject, closed form; the general
// model of sensor/general_model.h for a rig with faults) and the first scene
// surface it meets. Pixels that miss the mirror are black.
//
// Intensity: value = 255 * clamp(shade * illumination), then optional 3 x 3
// box blur (optics), Gaussian noise (sensor) and rounding to 8 bits.
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "panotrack/pose/pose2.h"
#include "panotrack/scene/map.h"
#include "panotrack/scene/scene.h"
#include "panotrack/sensor/sensor.h"

namespace pano {

struct RenderOptions {
  int supersample = 3;             // s: s x s rays per pixel (1..8)
  double noise_sigma = 0.0;        // Gaussian noise, grey levels (0..255 scale)
  bool blur = false;               // 3 x 3 box blur before the noise
  double illumination = 1.0;       // overall gain on shade
  double gradient = 0.0;           // smooth illumination change: +-gradient across the scene
  double gradient_angle = 0.0;     // its direction in the world (radians from +x)
  bool distractors = true;         // render the map's distractor panels
  double background = 0.0;         // shade of rays that meet no surface (no room)
  double camera_radius_px = 0.0;   // dark disc of this image radius: the camera's own reflection
  uint64_t seed = 1;               // noise seed; frame i uses (seed, i)
  // Factors of real cameras and rooms (all off by default). The per-frame ones
  // (exposure, auto_exposure, people, covered and dropped frames) act in a
  // sequence (SequenceRenderer); texture acts on every render.
  double exposure = 0.0;           // motion blur: open shutter, fraction of the frame interval (0..1)
  int blur_samples = 0;            // sub-frames per blurred frame (0: automatic, 1..64)
  double auto_exposure = 0.0;      // per-frame gain drift and steps, +-amplitude (0..0.9)
  double texture = 0.0;            // world-fixed surface texture: shade * (1 + texture * t), t in [-1, 1] (0..1)
  int people = 0;                  // moving cylinders (people) not in the map (0..50)
  int covered_frames = 0;          // frames where a dark object covers most of the mirror
  int dropped_frames = 0;          // frames left out of the video and gt.csv
  // Rows rendered at once (0: every core, ThreadCount); the images are the
  // same for every count.
  int num_threads = 0;
  // Throws pano::Error naming `what` (an option or file) and the problem.
  void Check(const std::string& what) const;
};

// Throws pano::Error when the pose is not a place the sensor can be: outside
// the room, inside a box, closer than `clearance` to a rectangle or a box, or
// not finite. `what` names the option or file.
void CheckPose(const Map& map, const Pose2& pose, const std::string& what,
               double clearance = 0.0);

// Per-subsample reflected rays in the sensor frame, computed once per sensor
// (they do not depend on the pose). Shared by the scene and board renderers.
class RayTable {
 public:
  // Rows traced on `num_threads` threads (0: every core).
  RayTable(const Sensor& sensor, int supersample, double camera_radius_px = 0.0, int num_threads = 0);
  // Direction azimuth phi (c, s = its cosine and sine); origin
  // (ps c - e s, ps s + e c, pz), direction (ds c, ds s, dz). e, the ray's
  // horizontal miss of the axis, is 0 for an aligned sensor (meridian rays).
  struct Ray {
    float phi, c, s, ps, pz, ds, dz, e;
  };
  const Sensor& sensor() const { return sensor_; }
  int supersample() const { return ss_; }
  // Rays of pixel (u, v): rays()[start(u, v) .. start(u, v + 1)).
  const std::vector<Ray>& rays() const { return rays_; }
  const std::vector<int>& starts() const { return starts_; }  // width * height + 1 entries
  // Largest |e| over the rays: 0 for an aligned sensor.
  double max_axis_miss() const { return max_axis_miss_; }

 private:
  Sensor sensor_;
  int ss_;
  std::vector<Ray> rays_;
  std::vector<int> starts_;
  double max_axis_miss_ = 0.0;
};

// World-fixed texture pattern t(p) in [-1, 1]: a few sines of the world point
// with wavelengths near `wavelength` (map units), smooth and not periodic along
// any plane's axes.
double SurfaceTexture(const Eigen::Vector3d& world, double wavelength);

class Renderer {
 public:
  // `scene` must outlive the renderer. sensor_height: the pinhole's world height.
  Renderer(const Sensor& sensor, const Scene& scene, double sensor_height,
           const RenderOptions& options);
  // The frame seen from `pose` (CV_8UC1); `frame_index` selects the noise.
  cv::Mat Render(const Pose2& pose, int frame_index = 0) const;
  // Adds to `sum` (CV_32FC1, image size) the grey levels (0..255) seen from
  // `pose`, before blur and noise, with `gain` on the illumination and
  // `extra` surfaces (moving objects; vertical or horizontal quads only, ids
  // after the scene's). `one_ray`: one ray per pixel instead of s x s.
  void Accumulate(const Pose2& pose, double gain, const std::vector<Surface>& extra, bool one_ray,
                  cv::Mat* sum) const;
  // Pixels that see the mirror (CV_8UC1, 255), where noise is added.
  cv::Mat MirrorMask() const;
  // Surface index seen by each pixel's centre (CV_32SC1; -1 outside the
  // mirror or nothing met; scene surfaces first, then `extra`). For tests and debugging.
  cv::Mat SurfaceIds(const Pose2& pose, const std::vector<Surface>& extra = {}) const;
  const RenderOptions& options() const { return options_; }
  const Scene& scene() const { return scene_; }
  double sensor_height() const { return sensor_height_; }
  const Sensor& sensor() const { return table_.sensor(); }

 private:
  struct Cand;
  struct Frame;
  struct AzimuthBins;
  // The frame's candidate surfaces by azimuth and its illumination.
  void BuildFrame(const Pose2& pose, const std::vector<Surface>& extra, Frame* f) const;
  // A vertical or horizontal quad as a candidate, binned by the azimuths it
  // covers from `position`; false for a surface that is neither.
  bool AddCandidate(const Surface& s, int id, const Eigen::Vector2d& position, Frame* f, AzimuthBins* bins) const;
  void SetIllumination(Frame* f) const;
  const Scene& scene_;
  double sensor_height_;
  RenderOptions options_;
  RayTable table_;
  RayTable centre_table_;  // one ray per pixel, for SurfaceIds and fast sub-frames
  double axis_miss_ = 0.0;  // largest |e| of both tables: widens the azimuth bins' candidate lists
  double texture_wavelength_ = 1.0;
};

// One still: builds the scene (with distractors unless options say not) and renders.
cv::Mat RenderStill(const Sensor& sensor, const Map& map, const Pose2& pose,
                    const RenderOptions& options);

// Adds Gaussian noise (grey levels) and applies the blur of `options` to a
// float image in grey levels, then rounds to CV_8UC1. Deterministic in (seed, frame).
// Only pixels where `mask` (CV_8UC1, may be empty: everywhere) is non-zero get noise.
cv::Mat FinishImage(const cv::Mat& grey_float, const RenderOptions& options, int frame_index,
                    const cv::Mat& mask = cv::Mat());

// A landmark corner (rectangle or box corner) and whether the sensor sees it.
struct MapCorner {
  std::string id;  // "<rectangle id>:<0..3>" (0 bottom-from, 1 bottom-to, 2 top-to, 3 top-from), "<box id>:<0..7>"
  Eigen::Vector3d world{0, 0, 0};
};
std::vector<MapCorner> MapCorners(const Map& map);

struct CornerView {
  MapCorner corner;
  Eigen::Vector2d pixel{0, 0};
  double bearing = 0.0;  // sensor frame, radians
};
// Corners in view from `pose`: projected inside the image (margin px) and
// inside the mirror's limb, not hidden by any surface of `scene` (tested from
// the mirror point that reflects them).
std::vector<CornerView> VisibleCorners(const Sensor& sensor, const Map& map, const Scene& scene,
                                       const Pose2& pose, double margin_px = 3.0);

}  // namespace pano
