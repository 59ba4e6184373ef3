#include "panotrack/render/presets.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <sstream>

#include "panotrack/core/error.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/io/trajectory.h"
#include "panotrack/render/sequence.h"

namespace pano {

namespace {

Calibration MakeCalibration(int w, int h, double cx, double cy, const std::string& units,
                            const std::string& comment) {
  Calibration c;
  c.sensor = MakeSphereSensor(w, h, 590.0, cx, cy, 1.0, 4.9, 15.1);
  c.units = units;
  c.comment = comment;
  return c;
}

// Rectangle flat against a wall of the room, `gap` in front of it.
// wall: 'S' (y = min), 'N' (y = max), 'W' (x = min), 'E' (x = max);
// a0..a1 along the wall (x for S/N, y for W/E).
MapRectangle WallRect(const Map& m, char wall, double a0, double a1, double z0, double z1,
                      double shade, const std::string& id, double gap = 0.5) {
  MapRectangle r;
  r.id = id;
  r.z0 = z0;
  r.z1 = z1;
  r.shade = shade;
  const double x0 = m.room.min.x() + gap, x1 = m.room.max.x() - gap;
  const double y0 = m.room.min.y() + gap, y1 = m.room.max.y() - gap;
  switch (wall) {
    case 'S': r.from = {a0, y0}; r.to = {a1, y0}; break;
    case 'N': r.from = {a1, y1}; r.to = {a0, y1}; break;
    case 'W': r.from = {x0, a1}; r.to = {x0, a0}; break;
    default: r.from = {x1, a0}; r.to = {x1, a1}; break;
  }
  return r;
}

MapRectangle FreeRect(const std::string& id, Eigen::Vector2d from, Eigen::Vector2d to, double z0,
                      double z1, double shade) {
  MapRectangle r;
  r.id = id;
  r.from = from;
  r.to = to;
  r.z0 = z0;
  r.z1 = z1;
  r.shade = shade;
  return r;
}

void SetRoom(Map* m, double w, double d, double h, double sensor_height, const std::string& units) {
  m->units = units;
  m->sensor_height = sensor_height;
  m->survey_sigma = 0.0;  // the rendered room is the map: exact
  m->room.present = true;
  m->room.min = {0, 0};
  m->room.max = {w, d};
  m->room.height = h;
  m->room.wall_shade = 0.55;
  m->room.floor_shade = 0.35;
  m->room.ceiling_shade = 0.8;
}

constexpr double kDark = 0.12, kDark2 = 0.18, kLight = 0.88, kLight2 = 0.85;

// The synthetic room (paper section 3.1): 170 x 160 units, landmarks typically
// about 70 units from a path near its middle.
Map SyntheticMap() {
  Map m;
  SetRoom(&m, 170, 160, 120, 30, "units");
  m.rectangles = {
      WallRect(m, 'W', 30, 60, 0, 90, kDark, "door-w"),
      WallRect(m, 'W', 100, 130, 40, 80, kLight, "poster-w"),
      WallRect(m, 'N', 20, 48, 20, 65, kDark2, "panel-n1"),
      WallRect(m, 'N', 75, 105, 0, 90, 0.9, "door-n"),
      WallRect(m, 'N', 130, 155, 35, 75, kDark2, "panel-n2"),
      WallRect(m, 'E', 105, 135, 25, 70, kLight2, "panel-e1"),
      WallRect(m, 'E', 30, 62, 0, 55, kDark, "cabinet-e"),
      WallRect(m, 'S', 100, 135, 30, 75, kLight, "panel-s1"),
      WallRect(m, 'S', 25, 55, 0, 50, 0.15, "panel-s2"),
      FreeRect("screen", {128, 128}, {148, 118}, 0, 70, 0.2),
      FreeRect("banner", {28, 118}, {45, 132}, 45, 85, kLight2),
  };
  return m;
}

// L-shaped path with a rounded corner, `n` poses `step` apart, heading along it.
std::vector<Pose2> LPath(Eigen::Vector2d start, double leg_a, double radius, int n, double step) {
  std::vector<Pose2> out;
  const double arc = 0.5 * M_PI * radius;
  for (int i = 0; i < n; ++i) {
    const double s = i * step;
    Pose2 p;
    if (s <= leg_a) {
      p = {start.x() + s, start.y(), 0.0};
    } else if (s <= leg_a + arc) {
      const double a = (s - leg_a) / radius;  // turning left around (start.x + leg_a, start.y + radius)
      p = {start.x() + leg_a + radius * std::sin(a), start.y() + radius * (1.0 - std::cos(a)), a};
    } else {
      p = {start.x() + leg_a + radius, start.y() + radius + (s - leg_a - arc), 0.5 * M_PI};
    }
    out.push_back(p);
  }
  return out;
}

SequenceCase PaperSynthetic() {
  SequenceCase c;
  c.name = "paper-synthetic";
  c.description =
      "Fiala & Basu synthetic experiment: 66 ray-traced 500x500 frames, uniformly shaded "
      "rectangles about 70 units away, a smooth curved path (cf. Fig. 8)";
  c.calib = PaperSyntheticCalibration();
  c.map = SyntheticMap();
  c.poses = SmoothPath({{55, 62}, {72, 72}, {88, 84}, {104, 90}, {118, 86}}, 66);
  c.fps = 10.0;
  c.options.supersample = 3;
  c.options.seed = 66;
  return c;
}

SequenceCase PaperReal() {
  SequenceCase c;
  c.name = "paper-real";
  c.description =
      "Fiala & Basu real experiment: 57 frames 5 cm apart (L-shaped path) in a 220 x 220 cm "
      "room of measured light and dark rectangles; f 590 px, sphere r 4.9 cm at 15.1 cm; "
      "Gaussian noise sigma 3 and 3x3 averaging";
  c.calib = PaperRealCalibration();
  Map& m = c.map;
  SetRoom(&m, 220, 220, 200, 35, "cm");
  m.rectangles = {
      WallRect(m, 'S', 20, 50, 10, 60, kDark, "s1"),
      WallRect(m, 'S', 80, 115, 30, 80, kLight, "s2"),
      WallRect(m, 'S', 150, 180, 0, 50, kDark, "s3"),
      WallRect(m, 'E', 20, 50, 20, 70, kLight, "e1"),
      WallRect(m, 'E', 90, 125, 0, 60, kDark, "e2"),
      WallRect(m, 'E', 160, 195, 30, 85, kLight, "e3"),
      WallRect(m, 'N', 170, 200, 10, 60, kDark, "n1"),
      WallRect(m, 'N', 100, 135, 40, 90, kLight, "n2"),
      WallRect(m, 'N', 30, 60, 0, 70, kDark, "n3"),
      WallRect(m, 'W', 170, 200, 20, 75, kLight, "w1"),
      WallRect(m, 'W', 100, 130, 10, 55, kDark, "w2"),
      WallRect(m, 'W', 30, 60, 35, 85, kLight, "w3"),
      FreeRect("board", {80, 130}, {110, 145}, 0, 60, kDark),
  };
  // 57 poses, 5 cm apart: 280 cm = 124.3 + quarter circle of radius 20 + 124.3.
  const double arc = 0.5 * M_PI * 20.0;
  c.poses = LPath({40, 35}, 0.5 * (280.0 - arc), 20.0, 57, 5.0);
  c.fps = 5.0;
  c.options.supersample = 3;
  c.options.noise_sigma = 3.0;
  c.options.blur = true;
  c.options.gradient = 0.1;
  c.options.gradient_angle = 0.6;
  c.options.camera_radius_px = 30.0;
  c.options.seed = 57;
  return c;
}

SequenceCase Cluttered() {
  SequenceCase c;
  c.name = "cluttered";
  c.description =
      "Harder case: a loop around a crate that hides landmarks for part of the path, "
      "distractor panels that are not in the map, fast motion (about 5.6 units and 4.5 "
      "degrees per frame), illumination gradient and noise";
  c.calib = PaperSyntheticCalibration();
  Map& m = c.map;
  SetRoom(&m, 280, 220, 130, 30, "units");
  m.rectangles = {
      WallRect(m, 'S', 30, 65, 0, 80, kDark, "s1"),
      WallRect(m, 'S', 120, 160, 30, 75, kLight, "s2"),
      WallRect(m, 'S', 210, 245, 10, 60, kDark, "s3"),
      WallRect(m, 'N', 25, 60, 35, 80, kLight, "n1"),
      WallRect(m, 'N', 110, 150, 0, 90, kDark, "n2"),
      WallRect(m, 'N', 200, 240, 25, 70, kLight, "n3"),
      WallRect(m, 'W', 40, 80, 20, 70, kLight, "w1"),
      WallRect(m, 'W', 130, 170, 0, 85, kDark, "w2"),
      WallRect(m, 'E', 35, 75, 0, 70, kDark, "e1"),
      WallRect(m, 'E', 140, 180, 30, 80, kLight, "e2"),
  };
  MapBox crate;
  crate.id = "crate";
  crate.min = {110, 90, 0};
  crate.max = {150, 130, 50};
  crate.shade = 0.9;
  m.boxes = {crate};
  m.distractors = {
      WallRect(m, 'S', 80, 100, 20, 60, 0.7, "d-s", 0.4),
      WallRect(m, 'N', 165, 185, 40, 85, 0.3, "d-n", 0.4),
      FreeRect("d-corner-nw", {20, 200}, {40, 185}, 0, 50, 0.75),
      FreeRect("d-corner-se", {250, 30}, {265, 45}, 0, 60, 0.25),
      WallRect(m, 'E', 95, 120, 45, 75, 0.7, "d-e", 0.4),
  };
  const int n = 80;
  for (int i = 0; i < n; ++i) {
    const double a = -0.5 * M_PI + 2.0 * M_PI * i / n;
    const double x = 130 + 80 * std::cos(a), y = 110 + 62 * std::sin(a);
    const double heading = std::atan2(62 * std::cos(a), -80 * std::sin(a));
    c.poses.push_back({x, y, WrapAngle(heading)});
  }
  c.fps = 10.0;
  c.options.supersample = 3;
  c.options.noise_sigma = 2.0;
  c.options.gradient = 0.2;
  c.options.gradient_angle = 2.0;
  c.options.seed = 80;
  return c;
}

SequenceCase Kidnap() {
  SequenceCase c;
  c.name = "kidnap";
  c.description =
      "Kidnapped robot: the paper-synthetic room; at frame 30 the pose jumps by about 40 "
      "units and 100 degrees without warning";
  c.calib = PaperSyntheticCalibration();
  c.map = SyntheticMap();
  c.poses = SmoothPath({{50, 62}, {62, 72}, {76, 80}, {90, 84}}, 30);
  const std::vector<Pose2> b = SmoothPath({{120, 58}, {112, 75}, {100, 90}, {86, 100}}, 30);
  c.poses.insert(c.poses.end(), b.begin(), b.end());
  c.fps = 10.0;
  c.options.supersample = 3;
  c.options.noise_sigma = 1.5;
  c.options.seed = 30;
  c.kidnap_frames = {30};
  return c;
}

// Largest heading change between consecutive poses, skipping `skip` frames (kidnaps).
double MaxTurn(const std::vector<Pose2>& poses, const std::vector<int>& skip = {}) {
  double m = 0.0;
  for (size_t i = 1; i < poses.size(); ++i)
    if (std::find(skip.begin(), skip.end(), static_cast<int>(i)) == skip.end())
      m = std::max(m, std::abs(WrapAngle(poses[i].theta - poses[i - 1].theta)));
  return m;
}

// The paper-real room and sensor, 300 frames 1.2..2.5 cm apart along a smooth
// loop (an ellipse, radius of curvature 25 cm and more); the heading follows
// the path plus an offset that wiggles, at times fast enough for turns of up
// to 8 degrees per frame.
SequenceCase FastTurns() {
  SequenceCase c = PaperReal();
  c.name = "fast-turns";
  c.description =
      "The paper-real room and sensor (noise 4, 3x3 blur): 300 frames 1.2..2.5 cm apart along a "
      "smooth loop, the heading wiggling about the path at up to 8 degrees per frame";
  const int n = 300;
  auto curve = [](double u) {
    return Eigen::Vector2d(110.0 + 65.0 * std::cos(u), 68.0 + 40.0 * std::sin(u));
  };
  // Arc length of the curve, densely sampled.
  const int dense = 20000;
  std::vector<double> len(dense + 1, 0.0);
  for (int k = 1; k <= dense; ++k)
    len[static_cast<size_t>(k)] = len[static_cast<size_t>(k - 1)] +
                                  (curve(2.0 * M_PI * k / dense) - curve(2.0 * M_PI * (k - 1) / dense)).norm();
  const double loop = len.back();
  std::vector<Eigen::Vector2d> pos;
  std::vector<double> direction;
  double s = 0.0;
  size_t j = 0;
  for (int i = 0; i < n; ++i) {
    const double in_loop = std::fmod(s, loop);
    if (i > 0 && in_loop < len[j]) j = 0;
    while (j + 1 < len.size() && len[j + 1] < in_loop) ++j;
    const double f = (in_loop - len[j]) / std::max(1e-12, len[j + 1] - len[j]);
    const double u = 2.0 * M_PI * (static_cast<double>(j) + f) / dense;
    pos.push_back(curve(u));
    const Eigen::Vector2d d = curve(u + 1e-4) - curve(u - 1e-4);
    direction.push_back(std::atan2(d.y(), d.x()));
    s += 1.85 + 0.65 * std::sin(2.0 * M_PI * i / 97.0 + 0.3);  // 1.2..2.5 cm per frame
  }
  auto poses_for = [&](double amplitude) {
    std::vector<Pose2> out;
    for (int i = 0; i < n; ++i) {
      const double envelope = 0.5 - 0.5 * std::cos(2.0 * M_PI * i / 150.0);
      const double offset = amplitude * envelope * std::sin(2.0 * M_PI * i / 40.0);
      out.push_back({pos[static_cast<size_t>(i)].x(), pos[static_cast<size_t>(i)].y(),
                     WrapAngle(direction[static_cast<size_t>(i)] + offset)});
    }
    return out;
  };
  // The wiggle's amplitude that makes the fastest turn 8 degrees per frame.
  double lo = 0.0, hi = 2.0;
  for (int it = 0; it < 50; ++it) {
    const double mid = 0.5 * (lo + hi);
    (MaxTurn(poses_for(mid)) > 8.0 * M_PI / 180.0 ? hi : lo) = mid;
  }
  c.poses = poses_for(lo);
  c.fps = 10.0;
  c.options.noise_sigma = 4.0;
  c.options.seed = 300;
  return c;
}

SequenceCase MotionBlur() {
  SequenceCase c = FastTurns();
  c.name = "motion-blur";
  c.description = "fast-turns with motion blur: the shutter open for half the frame interval";
  c.options.exposure = 0.5;
  return c;
}

SequenceCase RealConditions() {
  SequenceCase c = FastTurns();
  c.name = "real-conditions";
  c.description =
      "fast-turns with every factor of a real camera and room: exposure 0.5, auto-exposure +-20 %, "
      "surface texture 0.1, 2 people walking, 3 covered frames, 3 dropped frames";
  c.options.exposure = 0.5;
  c.options.auto_exposure = 0.2;
  c.options.texture = 0.1;
  c.options.people = 2;
  c.options.covered_frames = 3;
  c.options.dropped_frames = 3;
  return c;
}

// The paper-synthetic room, 3000 frames of a seeded random walk (1..2 units
// per frame, turns up to 10 degrees per frame, turning on the spot where the
// way ahead is not clear), kidnapped at frames 1000 and 2000.
SequenceCase LongRun() {
  SequenceCase c;
  c.name = "long-run";
  c.description =
      "The paper-synthetic room, 3000 frames of a random walk (1..2 units and up to 10 degrees per "
      "frame, bouncing off the walls), kidnapped at frames 1000 and 2000 (jumps of 40+ units and "
      "about 100 degrees)";
  c.calib = PaperSyntheticCalibration();
  c.map = SyntheticMap();
  const int n = 3000;
  const double max_turn = 10.0 * M_PI / 180.0, clearance = 27.0;
  auto valid = [&](const Eigen::Vector2d& p) {
    try {
      CheckPose(c.map, {p.x(), p.y(), 0.0}, "long-run", clearance);
      return true;
    } catch (const Error&) {
      return false;
    }
  };
  // Portable draws (the standard distributions differ between libraries).
  std::mt19937_64 engine(3000);
  auto uniform = [&](std::mt19937_64&) { return (static_cast<double>(engine() >> 11) + 0.5) / 9007199254740992.0; };
  auto normal = [&](std::mt19937_64& e) {
    return std::sqrt(-2.0 * std::log(uniform(e))) * std::cos(2.0 * M_PI * uniform(e));
  };
  std::mt19937_64& rng = engine;
  Eigen::Vector2d p(85.0, 75.0);
  double theta = 0.3, turn = 0.0, bounce = 1.0;
  c.kidnap_frames = {1000, 2000};
  for (int i = 0; i < n; ++i) {
    if (i == 1000 || i == 2000) {
      Eigen::Vector2d q = p;
      while (!valid(q) || (q - p).norm() < 40.0)
        q = {c.map.room.min.x() + uniform(rng) * (c.map.room.max.x() - c.map.room.min.x()),
             c.map.room.min.y() + uniform(rng) * (c.map.room.max.y() - c.map.room.min.y())};
      p = q;
      // One draw per statement: the order of an expression's operands is
      // the compiler's choice.
      const double side = uniform(rng) < 0.5 ? -1.0 : 1.0;
      const double turn_deg = 90.0 + 20.0 * uniform(rng);
      theta = WrapAngle(theta + side * turn_deg * M_PI / 180.0);
      turn = 0.0;
    } else if (i > 0) {
      // A smoothly varying turn rate, clamped to the maximum.
      turn = std::clamp(0.9 * turn + 0.35 * max_turn * normal(rng), -max_turn, max_turn);
      const double speed = 1.5 + 0.5 * std::sin(2.0 * M_PI * i / 211.0);
      const double heading = theta + turn;
      const Eigen::Vector2d next = p + speed * Eigen::Vector2d(std::cos(heading), std::sin(heading));
      if (valid(next)) {
        p = next;
        theta = WrapAngle(heading);
        if (turn != 0.0) bounce = turn > 0.0 ? 1.0 : -1.0;
      } else {
        // The way ahead is blocked: turn on the spot, keeping the sense of turning.
        theta = WrapAngle(theta + bounce * max_turn);
        turn = bounce * max_turn;
      }
    }
    c.poses.push_back({p.x(), p.y(), theta});
  }
  c.fps = 10.0;
  c.options.supersample = 3;
  c.options.noise_sigma = 1.5;
  c.options.seed = 3000;
  return c;
}

SequenceCase LongRunBlur() {
  SequenceCase c = LongRun();
  c.name = "long-run-blur";
  c.description = "long-run with motion blur: the shutter open for half the frame interval";
  c.options.exposure = 0.5;
  return c;
}

// The paper-real case seen through a rig built as real rigs are: the sphere's
// centre 1.4 mm off the camera's axis, the camera tilted 0.6 degrees, lens
// distortion k1 -0.03 k2 0.005, the mirror's axis 0.4 degrees off the
// vertical; `scale` multiplies every fault. calib.yaml carries them.
SequenceCase FaultyRig(double scale) {
  SequenceCase c = PaperReal();
  const bool twice = scale == 2.0;
  c.name = twice ? "faulty-rig-2x" : "faulty-rig";
  c.description = twice ? "faulty-rig with every fault doubled: sphere centre 2.8 mm off axis, camera tilted "
                          "1.2 deg, k1 -0.06 k2 0.01, sensor tilted 0.8 deg"
                        : "paper-real through an imperfect rig: sphere centre 1.4 mm off axis, camera tilted "
                          "0.6 deg, k1 -0.03 k2 0.005, sensor tilted 0.4 deg";
  Sensor& s = c.calib.sensor;
  const double deg = M_PI / 180.0;
  s.faults.mirror_offset[0] = 0.14 * scale;  // cm
  s.faults.camera_tilt[0] = 0.6 * deg * scale;
  s.params.k1 = -0.03 * scale;
  s.params.k2 = 0.005 * scale;
  s.faults.sensor_tilt[0] = 0.4 * deg * scale;
  c.calib.comment = "The seed paper's real sensor with the faults of preset '" + c.name + "'.";
  return c;
}

}  // namespace

Calibration PaperRealCalibration() {
  return MakeCalibration(640, 480, 319.5, 239.5, "cm",
                         "The seed paper's real sensor (panosim preset): f 590 px, sphere r 4.9 cm, "
                         "centre 15.1 cm above the pinhole, 640 x 480.");
}

Calibration PaperSyntheticCalibration() {
  return MakeCalibration(500, 500, 249.5, 249.5, "units",
                         "The seed paper's synthetic sensor (panosim preset): 500 x 500, horizon "
                         "radius 157.2 px.");
}

namespace {

// 300 poses around an ellipse (centre c, semi-axes a, b), 1.6 turns, heading
// along the path plus a slow wiggle of `wiggle` radians.
std::vector<Pose2> EllipseLoop(Eigen::Vector2d c, double a, double b, double wiggle) {
  const int n = 300;
  std::vector<Pose2> out;
  for (int i = 0; i < n; ++i) {
    const double u = 2.0 * M_PI * 1.6 * i / n;
    const double heading = std::atan2(b * std::cos(u), -a * std::sin(u));
    out.push_back({c.x() + a * std::cos(u), c.y() + b * std::sin(u),
                   WrapAngle(heading + wiggle * std::sin(2.0 * M_PI * i / 75.0))});
  }
  return out;
}

// The map-refinement cases (panomap refine): map.yaml is the room as a
// survey with 1 map unit of error per coordinate measured it, map_true.yaml
// the room rendered.
SequenceCase PaperRealMapError() {
  SequenceCase c = PaperReal();
  c.name = "paper-real-map-error";
  c.description =
      "The paper-real room and sensor (noise 3, 3x3 blur), 300 frames around an ellipse; map.yaml "
      "has every rectangle's end points and heights off by sigma 1 cm (map_true.yaml: the truth)";
  c.poses = EllipseLoop({120, 80}, 55, 30, 20.0 * M_PI / 180);
  c.fps = 10.0;
  c.options.seed = 301;
  c.survey.sigma = 1.0;
  c.survey.seed = 7;
  return c;
}

SequenceCase PaperSyntheticMapError() {
  SequenceCase c = PaperSynthetic();
  c.name = "paper-synthetic-map-error";
  c.description =
      "The paper-synthetic room and sensor, 300 frames around an ellipse; map.yaml has every "
      "rectangle's end points and heights off by sigma 1 unit (map_true.yaml: the truth)";
  c.poses = EllipseLoop({85, 75}, 45, 28, 20.0 * M_PI / 180);
  c.options.seed = 302;
  c.survey.sigma = 1.0;
  c.survey.seed = 8;
  return c;
}

}  // namespace

std::vector<std::string> PresetNames() {
  return {"paper-synthetic", "paper-real",      "cluttered", "kidnap",       "fast-turns",
          "motion-blur",     "real-conditions", "long-run",  "long-run-blur",
          "faulty-rig",      "faulty-rig-2x",   "paper-real-map-error",
          "paper-synthetic-map-error"};
}

SequenceCase MakePreset(const std::string& name) {
  SequenceCase c;
  if (name == "paper-synthetic") c = PaperSynthetic();
  else if (name == "paper-real") c = PaperReal();
  else if (name == "cluttered") c = Cluttered();
  else if (name == "kidnap") c = Kidnap();
  else if (name == "fast-turns") c = FastTurns();
  else if (name == "motion-blur") c = MotionBlur();
  else if (name == "real-conditions") c = RealConditions();
  else if (name == "long-run") c = LongRun();
  else if (name == "long-run-blur") c = LongRunBlur();
  else if (name == "faulty-rig") c = FaultyRig(1.0);
  else if (name == "faulty-rig-2x") c = FaultyRig(2.0);
  else if (name == "paper-real-map-error") c = PaperRealMapError();
  else if (name == "paper-synthetic-map-error") c = PaperSyntheticMapError();
  else {
    std::string list;
    for (const std::string& n : PresetNames()) list += (list.empty() ? "" : ", ") + n;
    throw Error("--preset: unknown preset '" + name + "' (expected one of " + list + ")");
  }
  CheckCase(c, "preset '" + name + "'", 25.0);
  return c;
}

void CheckCase(const SequenceCase& c, const std::string& what, double clearance) {
  c.calib.sensor.Check(what + ": calibration");
  CheckMap(c.map, what + ": map");
  c.options.Check(what);
  if (c.poses.empty()) throw Error(what + ": no poses (an empty trajectory)");
  if (!(c.fps > 0.0) || !std::isfinite(c.fps)) throw Error(what + ": fps: expected a positive frame rate");
  for (size_t i = 0; i < c.poses.size(); ++i)
    CheckPose(c.map, c.poses[i], what + ": frame " + std::to_string(i), clearance);
  const int n = static_cast<int>(c.poses.size());
  for (size_t k = 0; k < c.kidnap_frames.size(); ++k) {
    const int f = c.kidnap_frames[k];
    if (f < 1 || f >= n || (k > 0 && f <= c.kidnap_frames[k - 1]))
      throw Error(what + ": kidnap frames: expected ascending frames in 1.." + std::to_string(n - 1) +
                  ", got " + std::to_string(f));
  }
  if (c.options.people > 0 && !c.map.room.present)
    throw Error(what + ": people: the map has no room for people to walk in");
  try {
    CoveredFrames(c.options, n);  // also checks the dropped frames
    DroppedFrames(c.options, n);
    SurveyMap(c.map, c.survey);   // the survey's options and whether its faults fit the map
  } catch (const Error& e) {
    throw Error(what + ": " + e.what());
  }
}

std::vector<Pose2> SmoothPath(const std::vector<Eigen::Vector2d>& wp, int n, double heading_offset) {
  if (wp.size() < 2 || n < 2) throw Error("SmoothPath: expected at least 2 waypoints and 2 poses");
  // Catmull-Rom through the waypoints (end points duplicated), densely sampled.
  const int per = 400;
  std::vector<Eigen::Vector2d> dense;
  const int segs = static_cast<int>(wp.size()) - 1;
  for (int s = 0; s < segs; ++s) {
    const Eigen::Vector2d p0 = wp[static_cast<size_t>(std::max(s - 1, 0))];
    const Eigen::Vector2d p1 = wp[static_cast<size_t>(s)], p2 = wp[static_cast<size_t>(s + 1)];
    const Eigen::Vector2d p3 = wp[static_cast<size_t>(std::min(s + 2, segs))];
    for (int k = 0; k < per + (s == segs - 1 ? 1 : 0); ++k) {
      const double t = static_cast<double>(k) / per, t2 = t * t, t3 = t2 * t;
      dense.push_back(0.5 * ((2.0 * p1) + (-p0 + p2) * t + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t2 +
                             (-p0 + 3.0 * p1 - 3.0 * p2 + p3) * t3));
    }
  }
  std::vector<double> len(dense.size(), 0.0);
  for (size_t i = 1; i < dense.size(); ++i) len[i] = len[i - 1] + (dense[i] - dense[i - 1]).norm();
  std::vector<Pose2> out;
  size_t j = 0;
  for (int i = 0; i < n; ++i) {
    const double target = len.back() * i / (n - 1);
    while (j + 2 < dense.size() && len[j + 1] < target) ++j;
    const double seg = len[j + 1] - len[j];
    const double f = seg > 0 ? std::clamp((target - len[j]) / seg, 0.0, 1.0) : 0.0;
    const Eigen::Vector2d p = dense[j] + f * (dense[j + 1] - dense[j]);
    const size_t a = j > 0 ? j - 1 : j, b = std::min(j + 2, dense.size() - 1);
    const Eigen::Vector2d d = dense[b] - dense[a];
    out.push_back({p.x(), p.y(), WrapAngle(std::atan2(d.y(), d.x()) + heading_offset)});
  }
  return out;
}

SequenceCase MakeCase(const std::string& map_path, const std::string& calib_path,
                      const std::string& trajectory_path, double fps) {
  SequenceCase c;
  c.name = "custom";
  c.map = ReadMap(map_path);
  c.calib = ReadCalibration(calib_path);
  c.poses = ReadTrajectory(trajectory_path);
  c.fps = fps;
  c.description = "panosim sequence of " + map_path + " along " + trajectory_path;
  if (!(fps > 0.0) || !std::isfinite(fps)) throw Error("--fps: expected a positive frame rate");
  for (size_t i = 0; i < c.poses.size(); ++i)
    CheckPose(c.map, c.poses[i], trajectory_path + ": pose " + std::to_string(i + 1));
  return c;
}

}  // namespace pano
