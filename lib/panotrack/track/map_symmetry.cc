#include "panotrack/track/map_symmetry.h"

#include <Eigen/Geometry>
#include <cmath>

#include "panotrack/core/angles.h"

namespace pano {

Eigen::Vector2d FloorMotion::Apply(const Eigen::Vector2d& p) const {
  return Eigen::Rotation2Dd(angle) * p + translation;
}

Pose2 FloorMotion::Apply(const Pose2& pose) const {
  const Eigen::Vector2d p = Apply(Eigen::Vector2d(pose.x, pose.y));
  return Pose2{p.x(), p.y(), WrapAngle(pose.theta + angle)};
}

namespace {

// Whether `motion` carries landmark `from` onto landmark `to`.
bool Carries(const FloorMotion& motion, const Landmark& from, const Landmark& to, double tolerance) {
  auto same_height = [&](double a, double b) { return std::abs(a - b) <= tolerance; };
  return same_height(from.corner.z(), to.corner.z()) && same_height(from.v_end.z(), to.v_end.z()) &&
         same_height(from.h_end.z(), to.h_end.z()) &&
         (motion.Apply(Eigen::Vector2d(from.corner.head<2>())) - to.corner.head<2>()).norm() <= tolerance &&
         (motion.Apply(Eigen::Vector2d(from.h_end.head<2>())) - to.h_end.head<2>()).norm() <= tolerance;
}

bool CarriesAll(const FloorMotion& motion, const std::vector<Landmark>& landmarks, const std::vector<int>& seen,
                double tolerance) {
  for (int i : seen) {
    bool found = false;
    for (const Landmark& l : landmarks) {
      if (Carries(motion, landmarks[static_cast<size_t>(i)], l, tolerance)) {
        found = true;
        break;
      }
    }
    if (!found) return false;
  }
  return true;
}

// The motion taking corner a to c and the direction a->b to c->d.
FloorMotion MotionFromPairs(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                            const Eigen::Vector2d& d) {
  FloorMotion m;
  const Eigen::Vector2d u = b - a, v = d - c;
  m.angle = std::atan2(v.y(), v.x()) - std::atan2(u.y(), u.x());
  m.translation = c - Eigen::Rotation2Dd(m.angle) * a;
  return m;
}

}  // namespace

std::vector<FloorMotion> LandmarkSymmetries(const std::vector<Landmark>& landmarks,
                                            const std::vector<int>& seen, double tolerance) {
  std::vector<FloorMotion> out;
  if (seen.empty()) return out;
  // Two seen corners far apart fix a motion: each pair of map corners at the
  // same separation proposes one.
  const Landmark& a = landmarks[static_cast<size_t>(seen.front())];
  const Landmark* b = nullptr;
  double widest = 0.0;
  for (int i : seen) {
    const double dist = (landmarks[static_cast<size_t>(i)].corner.head<2>() - a.corner.head<2>()).norm();
    if (dist > widest) widest = dist, b = &landmarks[static_cast<size_t>(i)];
  }
  // One corner, or all seen corners on one vertical line: the horizontal
  // edge's far end gives the direction.
  const bool use_edge = widest <= 2 * tolerance;
  const Eigen::Vector2d a2 = a.corner.head<2>();
  const Eigen::Vector2d b2 = use_edge ? Eigen::Vector2d(a.h_end.head<2>()) : Eigen::Vector2d(b->corner.head<2>());
  const double separation = (b2 - a2).norm();
  auto consider = [&](const FloorMotion& m) {
    const bool identity = std::abs(WrapAngle(m.angle)) * separation <= tolerance && m.translation.norm() <= tolerance;
    if (identity || !CarriesAll(m, landmarks, seen, tolerance)) return;
    for (const FloorMotion& o : out)
      if (std::abs(WrapAngle(o.angle - m.angle)) * separation <= tolerance &&
          (o.translation - m.translation).norm() <= tolerance)
        return;
    out.push_back(m);
  };
  for (const Landmark& c : landmarks) {
    if (std::abs(c.corner.z() - a.corner.z()) > tolerance || std::abs(c.v_end.z() - a.v_end.z()) > tolerance)
      continue;
    const Eigen::Vector2d c2 = c.corner.head<2>();
    if (use_edge) {
      consider(MotionFromPairs(a2, b2, c2, c.h_end.head<2>()));
      continue;
    }
    for (const Landmark& d : landmarks) {
      const Eigen::Vector2d d2 = d.corner.head<2>();
      if (std::abs((d2 - c2).norm() - separation) <= 2 * tolerance) consider(MotionFromPairs(a2, b2, c2, d2));
    }
  }
  return out;
}

}  // namespace pano
