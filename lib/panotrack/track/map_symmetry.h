// Symmetries of a map: motions of the floor plane that carry the landmarks a
// robot sees onto other landmarks of the same map. A robot at pose P and one
// at the moved pose see the same image, so a room-wide search cannot tell
// them apart from one frame (a room with a poster on each wall, laid out
// point-symmetrically, fools any bearing-only method).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "panotrack/pose/pose2.h"
#include "panotrack/sensor/sensor.h"
#include "panotrack/track/landmarks.h"

namespace pano {

// A rotation about the vertical by `angle` followed by a translation.
struct FloorMotion {
  double angle = 0.0;
  Eigen::Vector2d translation{0, 0};

  Eigen::Vector2d Apply(const Eigen::Vector2d& p) const;
  // The pose of a robot moved with the floor: it sees the moved landmarks
  // at the bearings the original saw the originals.
  Pose2 Apply(const Pose2& pose) const;
};

// The motions other than the identity that carry every landmark of `seen`
// (indices into `landmarks`) onto a landmark of the same heights whose
// corner and horizontal edge's far end lie within `tolerance` (map units)
// of the moved ones. Motions closer than `tolerance` to each other are
// reported once.
std::vector<FloorMotion> LandmarkSymmetries(const std::vector<Landmark>& landmarks,
                                            const std::vector<int>& seen, double tolerance);

}  // namespace pano
