// The scene of a map file as a list of planar quads, with a ray cast and a
// segment occlusion test. Used by panosim (rendering) and by the localiser
// (is a landmark corner hidden by map surfaces?). All coordinates are world
// coordinates (z up, floor at z = 0; README, "Files and conventions").
#pragma once

#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

#include "panotrack/scene/map.h"

namespace pano {

enum class SurfaceKind { kWall, kFloor, kCeiling, kRectangle, kBoxFace, kDistractor };
const char* SurfaceKindName(SurfaceKind k);

// A planar parallelogram (a rectangle for everything built from a map):
// points corner + a * edge_a + b * edge_b with a, b in [0, 1].
struct Surface {
  Eigen::Vector3d corner{0, 0, 0};
  Eigen::Vector3d edge_a{0, 0, 0};
  Eigen::Vector3d edge_b{0, 0, 0};
  double shade = 0.5;  // reflectance 0..1
  SurfaceKind kind = SurfaceKind::kRectangle;
  std::string name;  // the map id, "<box id>:+x" for a box face, "room:..." for the room
  // Room surfaces are background: an object lying in the same plane wins.
  bool background() const {
    return kind == SurfaceKind::kWall || kind == SurfaceKind::kFloor ||
           kind == SurfaceKind::kCeiling;
  }
};

struct RayHit {
  double t = std::numeric_limits<double>::infinity();  // distance along the (unit) direction
  double shade = 0.0;
  int surface = -1;  // index into Scene::surfaces(); -1: nothing hit
  bool hit() const { return surface >= 0; }
};

class Scene {
 public:
  // Room walls, floor and ceiling (when the map has a room), rectangles, box
  // faces and, when `with_distractors`, the distractor panels.
  static Scene FromMap(const Map& map, bool with_distractors = true);

  // Adds a surface; returns its index. Throws pano::Error for a degenerate one.
  int Add(const Surface& s);

  // First surface met by the ray origin + t * direction, 0 < t < max_t.
  // `direction` need not be unit length (t is then in its units).
  RayHit Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                   double max_t = std::numeric_limits<double>::infinity()) const;

  // True when a surface cuts the segment from `from` to `to`, ignoring hits
  // within `tolerance` (map units) of `to`, so that a landmark corner is not
  // hidden by the surfaces it lies on. `plane_tolerance`: nor by a surface
  // whose plane lies within this of `to`, hit within ten times it of `to`
  // along the segment (a corner measured a little behind the wall it is
  // on; a ray at a grazing angle to a nearby surface still stops).
  bool Occluded(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                double tolerance = 1e-6, double plane_tolerance = 0.0) const;

  const std::vector<Surface>& surfaces() const { return surfaces_; }
  // Axis-aligned bounds of all surfaces (zero when empty).
  Eigen::Vector3d min() const { return min_; }
  Eigen::Vector3d max() const { return max_; }

 private:
  struct Plane {  // precomputed per surface; all a ray cast reads, packed together
    Eigen::Vector3d normal;
    double offset;     // normal . corner
    Eigen::Vector3d ua, ub;  // dual edge vectors: a = ua . (p - corner), b = ub . (p - corner)
    Eigen::Vector3d corner;  // the surface's
    double shade;            // the surface's
    bool background;         // the surface's background()
  };
  // The hit of surface i at 0 < t < limit, if any.
  bool HitSurface(int i, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double limit, double* t) const;
  std::vector<Surface> surfaces_;
  std::vector<Plane> planes_;
  Eigen::Vector3d min_{0, 0, 0}, max_{0, 0, 0};
};

}  // namespace pano
