// A small closed-form ray tracer for Panoramic Hough tests and benchmarks: a
// box room (floor, ceiling, four walls of alternating shade) with vertical
// rectangles hung on its walls, seen through the catadioptric sensor
// (pano::Sensor::backproject, then plane intersections), 2 x 2 supersampled.
// Independent of lib/panotrack/render on purpose (the truth here is analytic).
#pragma once

#include <opencv2/core.hpp>

#include <cmath>
#include <limits>
#include <vector>

#include "panotrack/pose/pose2.h"
#include "panotrack/sensor/sensor.h"

namespace pano::test {

struct WallRect {
  Eigen::Vector2d a, b;  // bottom edge end points (world x, y), on or near a wall
  double z0, z1;         // bottom and top heights (world)
  double shade;
};

struct RoomScene {
  double x0 = 0, y0 = 0, x1 = 200, y1 = 200, height = 120;
  double wall_shade[2] = {0.55, 0.68};  // walls x = const, y = const
  double floor_shade = 0.3, ceiling_shade = 0.85;
  std::vector<WallRect> rects;
  double sensor_height = 30.0;
  Pose2 pose{80.0, 110.0, 0.3};
};

// A horizontal 3-D edge of the scene (world end points).
struct HSegment {
  Eigen::Vector3d a, b;
};

// The room of the paper's synthetic scene: about 200 x 200 units, posters and
// a door on the walls (paper section 3.1: "uniformly shaded rectangular
// polygons").
inline RoomScene PaperRoom() {
  RoomScene s;
  const double e = 0.3;  // rectangles hang e in front of their wall
  s.rects.push_back({{e, 40.0}, {e, 90.0}, 10.0, 100.0, 0.12});                  // door, wall x = 0
  s.rects.push_back({{120.0, 200.0 - e}, {170.0, 200.0 - e}, 40.0, 85.0, 0.1});  // poster, y = 200
  s.rects.push_back({{200.0 - e, 60.0}, {200.0 - e, 100.0}, 20.0, 60.0, 0.95});  // x = 200
  s.rects.push_back({{30.0, e}, {90.0, e}, 25.0, 70.0, 0.15});                   // y = 0
  s.rects.push_back({{140.0, e}, {175.0, e}, 45.0, 95.0, 0.97});                 // y = 0
  return s;
}

inline std::vector<HSegment> HorizontalEdges(const RoomScene& s) {
  std::vector<HSegment> out;
  const Eigen::Vector2d c[4] = {{s.x0, s.y0}, {s.x1, s.y0}, {s.x1, s.y1}, {s.x0, s.y1}};
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d& p = c[i];
    const Eigen::Vector2d& q = c[(i + 1) % 4];
    out.push_back({{p.x(), p.y(), 0.0}, {q.x(), q.y(), 0.0}});
    out.push_back({{p.x(), p.y(), s.height}, {q.x(), q.y(), s.height}});
  }
  for (const WallRect& r : s.rects) {
    out.push_back({{r.a.x(), r.a.y(), r.z0}, {r.b.x(), r.b.y(), r.z0}});
    out.push_back({{r.a.x(), r.a.y(), r.z1}, {r.b.x(), r.b.y(), r.z1}});
  }
  return out;
}

// Shade seen along the world ray o + t d (nearest hit).
inline double TraceShade(const RoomScene& s, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  double best = std::numeric_limits<double>::infinity(), shade = 0.0;
  auto consider = [&](double t, double sh) {
    if (t > 1e-9 && t < best) {
      best = t;
      shade = sh;
    }
  };
  // Floor and ceiling.
  if (d.z() != 0) {
    consider((0.0 - o.z()) / d.z(), s.floor_shade);
    consider((s.height - o.z()) / d.z(), s.ceiling_shade);
  }
  // Walls (the ray starts inside the room: the hit within the box is the wall).
  if (d.x() != 0) {
    for (double x : {s.x0, s.x1}) {
      const double t = (x - o.x()) / d.x();
      const Eigen::Vector3d p = o + t * d;
      if (p.y() >= s.y0 && p.y() <= s.y1 && p.z() >= 0 && p.z() <= s.height) consider(t, s.wall_shade[0]);
    }
  }
  if (d.y() != 0) {
    for (double y : {s.y0, s.y1}) {
      const double t = (y - o.y()) / d.y();
      const Eigen::Vector3d p = o + t * d;
      if (p.x() >= s.x0 && p.x() <= s.x1 && p.z() >= 0 && p.z() <= s.height) consider(t, s.wall_shade[1]);
    }
  }
  for (const WallRect& r : s.rects) {
    const Eigen::Vector2d ab = r.b - r.a;
    const Eigen::Vector2d n(-ab.y(), ab.x());
    const double den = n.x() * d.x() + n.y() * d.y();
    if (den == 0) continue;
    const double t = n.dot(r.a - o.head<2>()) / den;
    const Eigen::Vector3d p = o + t * d;
    const double u = (p.head<2>() - r.a).dot(ab) / ab.squaredNorm();
    if (u >= 0 && u <= 1 && p.z() >= r.z0 && p.z() <= r.z1) consider(t, r.shade);
  }
  return shade;
}

// 8-bit grey panorama; pixels beyond the mirror's limb are black.
inline cv::Mat RenderRoom(const Sensor& sensor, const RoomScene& s, int ss = 2) {
  cv::Mat img(sensor.image_height, sensor.image_width, CV_8UC1, cv::Scalar(0));
#pragma omp parallel for schedule(dynamic, 4)
  for (int v = 0; v < img.rows; ++v) {
    for (int u = 0; u < img.cols; ++u) {
      double sum = 0;
      int n = 0;
      for (int a = 0; a < ss; ++a)
        for (int b = 0; b < ss; ++b) {
          const Eigen::Vector2d px(u - 0.5 + (a + 0.5) / ss, v - 0.5 + (b + 0.5) / ss);
          Eigen::Vector3d o, d;
          ++n;
          if (!sensor.backproject(px, &o, &d)) continue;
          const Eigen::Vector3d ow = WorldFromSensor(s.pose, s.sensor_height, o);
          const Eigen::Vector3d dw = WorldDirection(s.pose, d);
          sum += TraceShade(s, ow, dw);
        }
      img.at<uint8_t>(v, u) = static_cast<uint8_t>(std::lround(255.0 * sum / n));
    }
  }
  return img;
}

}  // namespace pano::test
