#include "panotrack/render/sequence.h"

#include <algorithm>
#include <cmath>
#include <set>

#include "panotrack/core/angles.h"
#include "panotrack/core/error.h"
#include "panotrack/render/split_mix.h"

namespace pano {

namespace {

using Mix = SplitMix;

// One generator per factor, so that turning one factor on changes no other.
Mix MixFor(uint64_t seed, uint64_t salt) {
  Mix m{seed * 0xD1B54A32D192ED03ull ^ (salt * 0x9E3779B97F4A7C15ull + 0x2545F4914F6CDD1Dull)};
  for (int i = 0; i < 4; ++i) m.Next();
  return m;
}

enum Salt : uint64_t { kGainSalt = 11, kDropSalt = 12, kCoverSalt = 13, kPeopleSalt = 14, kSectorSalt = 15,
             kMapSalt = 16, kMapOffsetSalt = 17, kMapGrossSalt = 18 };

// Box-Muller on the seeded uniforms: the same errors on every platform.
double Gauss(Mix* rng, double sigma) {
  const double u1 = rng->Uniform(), u2 = rng->Uniform();
  return sigma * std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

std::vector<int> PickFrames(Mix rng, int count, int n_frames, const std::vector<int>& excluded,
                            const char* option) {
  const int first = 5;
  const int available = std::max(0, n_frames - first);
  if (count > available / 2)
    throw Error(std::string(option) + ": " + std::to_string(count) + " frames do not fit in a sequence of " +
                std::to_string(n_frames) + " frames (at most half of the frames after the first 5)");
  std::set<int> chosen;
  const std::set<int> skip(excluded.begin(), excluded.end());
  while (static_cast<int>(chosen.size()) < count) {
    const int f = first + static_cast<int>(rng.Next() % static_cast<uint64_t>(available));
    if (!skip.count(f)) chosen.insert(f);
  }
  return {chosen.begin(), chosen.end()};
}

double SegmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double l2 = ab.squaredNorm();
  const double t = l2 > 0.0 ? std::clamp((p - a).dot(ab) / l2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

}  // namespace

double AutoExposureGain(const RenderOptions& o, int frame) {
  if (o.auto_exposure <= 0.0) return 1.0;
  Mix rng = MixFor(o.seed, kGainSalt);
  const double period = rng.Uniform(150.0, 300.0);  // frames of the slow drift
  const double phase = rng.Uniform(0.0, 2.0 * M_PI);
  // Steps: segments of 40..80 frames, each at its own level.
  int start = 0;
  double level = rng.Uniform(-1.0, 1.0);
  for (;;) {
    const int length = 40 + static_cast<int>(rng.Next() % 41);
    if (frame < start + length) break;
    start += length;
    level = rng.Uniform(-1.0, 1.0);
  }
  const double drift = std::sin(2.0 * M_PI * frame / period + phase);
  return 1.0 + o.auto_exposure * (0.5 * drift + 0.5 * level);
}

std::vector<int> DroppedFrames(const RenderOptions& o, int n_frames) {
  if (o.dropped_frames == 0) return {};
  return PickFrames(MixFor(o.seed, kDropSalt), o.dropped_frames, n_frames, {}, "dropped-frames");
}

std::vector<int> CoveredFrames(const RenderOptions& o, int n_frames) {
  if (o.covered_frames == 0) return {};
  const std::vector<int> dropped = DroppedFrames(o, n_frames);
  if (o.covered_frames + static_cast<int>(dropped.size()) > std::max(0, n_frames - 5) / 2)
    throw Error("covered-frames: " + std::to_string(o.covered_frames) + " covered and " +
                std::to_string(dropped.size()) + " dropped frames do not fit in a sequence of " +
                std::to_string(n_frames) + " frames");
  return PickFrames(MixFor(o.seed, kCoverSalt), o.covered_frames, n_frames, dropped, "covered-frames");
}

double ExposureOffset(double exposure, int k, int samples) {
  return ((k + 0.5) / samples - 0.5) * exposure;
}

Pose2 PoseAtOffset(const std::vector<Pose2>& poses, int i, double offset,
                   const std::vector<int>& kidnap_frames) {
  const int n = static_cast<int>(poses.size());
  const Pose2& p = poses[static_cast<size_t>(i)];
  if (offset == 0.0) return p;
  auto is_kidnap = [&](int f) { return std::find(kidnap_frames.begin(), kidnap_frames.end(), f) != kidnap_frames.end(); };
  const bool has_prev = i > 0 && !is_kidnap(i);
  const bool has_next = i + 1 < n && !is_kidnap(i + 1);
  // The motion per frame interval on the side of `offset`, else the other side's.
  double dx = 0, dy = 0, dt = 0;
  const bool forward = offset > 0.0 ? has_next || !has_prev : !has_prev && has_next;
  if (forward && has_next) {
    const Pose2& q = poses[static_cast<size_t>(i + 1)];
    dx = q.x - p.x;
    dy = q.y - p.y;
    dt = WrapAngle(q.theta - p.theta);
  } else if (has_prev) {
    const Pose2& q = poses[static_cast<size_t>(i - 1)];
    dx = p.x - q.x;
    dy = p.y - q.y;
    dt = WrapAngle(p.theta - q.theta);
  }
  return {p.x + offset * dx, p.y + offset * dy, WrapAngle(p.theta + offset * dt)};
}

std::vector<Person> MakePeople(const Map& map, int count, uint64_t seed) {
  if (count == 0) return {};
  if (!map.room.present) throw Error("people: the map has no room to walk in");
  Mix rng = MixFor(seed, kPeopleSalt);
  const Eigen::Vector2d lo = map.room.min, hi = map.room.max;
  const double size = std::max(hi.x() - lo.x(), hi.y() - lo.y());
  const double margin = 0.12 * size;
  std::vector<Person> out;
  for (int k = 0; k < count; ++k) {
    Person p;
    p.radius = 0.02 * size;
    p.height = rng.Uniform(0.6, 0.9) * map.room.height;
    p.shade = rng.Uniform(0.12, 0.3);
    p.speed = 0.01 * size;
    // A straight walk at least 40 % of the room long, clear of boxes and free rectangles.
    for (int attempt = 0; attempt < 200; ++attempt) {
      p.from = {rng.Uniform(lo.x() + margin, hi.x() - margin), rng.Uniform(lo.y() + margin, hi.y() - margin)};
      p.to = {rng.Uniform(lo.x() + margin, hi.x() - margin), rng.Uniform(lo.y() + margin, hi.y() - margin)};
      if ((p.to - p.from).norm() < 0.4 * size) continue;
      bool clear = true;
      for (int s = 0; s <= 50 && clear; ++s) {
        const Eigen::Vector2d q = p.from + (p.to - p.from) * (s / 50.0);
        for (const MapBox& b : map.boxes) {
          const double dx = std::max({b.min.x() - q.x(), 0.0, q.x() - b.max.x()});
          const double dy = std::max({b.min.y() - q.y(), 0.0, q.y() - b.max.y()});
          if (std::hypot(dx, dy) < 3.0 * p.radius) clear = false;
        }
        for (const auto* rects : {&map.rectangles, &map.distractors})
          for (const MapRectangle& r : *rects)
            if (SegmentDistance(q, r.from, r.to) < 3.0 * p.radius) clear = false;
      }
      if (clear) break;
    }
    p.start = rng.Uniform(0.0, 2.0 * (p.to - p.from).norm());
    out.push_back(p);
  }
  return out;
}

Eigen::Vector2d PersonPosition(const Person& person, double time, const Eigen::Vector2d& robot,
                               double clearance) {
  const double length = (person.to - person.from).norm();
  Eigen::Vector2d q = person.from;
  if (length > 0.0) {
    // Back and forth: a triangle wave of the distance walked.
    double s = std::fmod(person.start + person.speed * time, 2.0 * length);
    if (s < 0.0) s += 2.0 * length;
    const double along = s <= length ? s : 2.0 * length - s;
    q = person.from + (person.to - person.from) * (along / length);
  }
  const Eigen::Vector2d away = q - robot;
  const double d = away.norm();
  if (d < clearance) q = robot + (d > 1e-9 ? away / d : Eigen::Vector2d(1.0, 0.0)) * clearance;
  return q;
}

std::vector<Surface> PeopleSurfaces(const std::vector<Person>& people, double time,
                                    const Eigen::Vector2d& robot, double clearance) {
  std::vector<Surface> out;
  for (size_t k = 0; k < people.size(); ++k) {
    const Person& p = people[k];
    const Eigen::Vector2d c = PersonPosition(p, time, robot, clearance);
    const double r = p.radius;
    const std::string name = "person-" + std::to_string(k);
    const Eigen::Vector3d up(0, 0, p.height);
    auto wall = [&](Eigen::Vector3d corner, Eigen::Vector3d along, const char* side) {
      Surface s;
      s.corner = corner;
      s.edge_a = along;
      s.edge_b = up;
      s.shade = p.shade;
      s.kind = SurfaceKind::kDistractor;
      s.name = name + ":" + side;
      out.push_back(s);
    };
    wall({c.x() - r, c.y() - r, 0}, {2 * r, 0, 0}, "-y");
    wall({c.x() - r, c.y() + r, 0}, {2 * r, 0, 0}, "+y");
    wall({c.x() - r, c.y() - r, 0}, {0, 2 * r, 0}, "-x");
    wall({c.x() + r, c.y() - r, 0}, {0, 2 * r, 0}, "+x");
    Surface top;
    top.corner = {c.x() - r, c.y() - r, p.height};
    top.edge_a = {2 * r, 0, 0};
    top.edge_b = {0, 2 * r, 0};
    top.shade = p.shade;
    top.kind = SurfaceKind::kDistractor;
    top.name = name + ":top";
    out.push_back(top);
  }
  return out;
}

Map PerturbedMap(const Map& map, double sigma, uint64_t seed) {
  if (!(sigma >= 0.0) || !std::isfinite(sigma)) throw Error("map-sigma: expected a number >= 0");
  Map out = map;
  if (sigma == 0.0) return out;
  Mix rng = MixFor(seed, kMapSalt);
  auto gauss = [&rng, sigma]() { return Gauss(&rng, sigma); };
  for (MapRectangle& r : out.rectangles) {
    r.from.x() += gauss();
    r.from.y() += gauss();
    r.to.x() += gauss();
    r.to.y() += gauss();
    // Standing on the floor is a contact, not a measurement: kept exact.
    const double dz0 = gauss();
    if (r.z0 != 0.0) r.z0 = std::max(0.0, r.z0 + dz0);
    r.z1 = std::max(r.z0 + sigma, r.z1 + gauss());
  }
  // The boxes after every rectangle, so that the rectangles' errors do not
  // depend on whether the map has boxes.
  for (MapBox& b : out.boxes) {
    for (int i = 0; i < 2; ++i) {
      b.min[i] += gauss();
      b.max[i] = std::max(b.min[i] + sigma, b.max[i] + gauss());
    }
    const double dz0 = gauss();
    if (b.min.z() != 0.0) b.min.z() = std::max(0.0, b.min.z() + dz0);
    b.max.z() = std::max(b.min.z() + sigma, b.max.z() + gauss());
  }
  return out;
}

Map OffsetMap(const Map& map, double sigma, uint64_t seed) {
  if (!(sigma >= 0.0) || !std::isfinite(sigma)) throw Error("map-offset-sigma: expected a number >= 0");
  Map out = map;
  if (sigma == 0.0) return out;
  Mix rng = MixFor(seed, kMapOffsetSalt);
  // One draw per statement (y first, as the maps were first written): the
  // order of a call's arguments is the compiler's choice.
  for (MapRectangle& r : out.rectangles) {
    const double dy = Gauss(&rng, sigma), dx = Gauss(&rng, sigma);
    const Eigen::Vector2d d(dx, dy);
    r.from += d;
    r.to += d;
  }
  for (MapBox& b : out.boxes) {
    const double dy = Gauss(&rng, sigma), dx = Gauss(&rng, sigma);
    const Eigen::Vector3d d(dx, dy, 0.0);
    b.min += d;
    b.max += d;
  }
  return out;
}

const char* MapFaultName(MapFaultKind kind) {
  switch (kind) {
    case MapFaultKind::kMoved: return "moved";
    case MapFaultKind::kNotInRoom: return "not-in-room";
    case MapFaultKind::kNotInMap: return "not-in-map";
  }
  return "?";
}

void SurveyError::Check() const {
  auto sigma_ok = [](double s) { return s >= 0.0 && std::isfinite(s); };
  if (!sigma_ok(sigma)) throw Error("map-sigma: expected a number >= 0");
  if (!sigma_ok(offset_sigma)) throw Error("map-offset-sigma: expected a number >= 0");
  if (gross < 0) throw Error("map-gross: expected a count >= 0");
  if (!sigma_ok(gross_offset)) throw Error("map-gross-offset: expected a distance >= 0 (0: 8 cm)");
}

namespace {

// `count` distinct indices below `n`, in the order drawn.
std::vector<size_t> PickDistinct(Mix* rng, int count, size_t n) {
  std::vector<size_t> out;
  while (static_cast<int>(out.size()) < count) {
    const size_t k = static_cast<size_t>(rng->Next() % n);
    if (std::find(out.begin(), out.end(), k) == out.end()) out.push_back(k);
  }
  return out;
}

void RemoveRectangles(const std::vector<std::string>& ids, Map* map) {
  auto gone = [&](const MapRectangle& r) { return std::find(ids.begin(), ids.end(), r.id) != ids.end(); };
  map->rectangles.erase(std::remove_if(map->rectangles.begin(), map->rectangles.end(), gone),
                        map->rectangles.end());
}

// Applies error.gross faults to the surveyed map and the rendered room.
void AddGrossFaults(const SurveyError& error, SurveyedMap* s) {
  if (error.gross == 0) return;
  const size_t n = s->room.rectangles.size();
  if (static_cast<size_t>(error.gross) > n)
    throw Error("map-gross: " + std::to_string(error.gross) + " faults for a map of " + std::to_string(n) +
                " rectangles (at most one per rectangle)");
  const double distance = error.gross_offset > 0.0 ? error.gross_offset : 0.08 * s->room.UnitsPerMetre();
  Mix rng = MixFor(error.seed, kMapGrossSalt);
  std::vector<std::string> not_in_room, not_in_map;
  const std::vector<size_t> picked = PickDistinct(&rng, error.gross, n);
  for (size_t k = 0; k < picked.size(); ++k) {
    MapFault f;
    f.kind = static_cast<MapFaultKind>(k % 3);
    f.id = s->room.rectangles[picked[k]].id;
    // Slid along its own bottom edge (a wall rectangle stays on its wall, as
    // when the tape was read from the wrong mark), either way; drawn for
    // every fault so that the kinds do not shift the stream.
    const double side = rng.Uniform() < 0.5 ? -1.0 : 1.0;
    if (f.kind == MapFaultKind::kMoved) {
      const MapRectangle& stands = s->room.rectangles[picked[k]];
      f.offset = side * distance * (stands.to - stands.from).normalized();
      MapRectangle& r = s->map.rectangles[picked[k]];
      r.from += f.offset;
      r.to += f.offset;
    }
    if (f.kind == MapFaultKind::kNotInRoom) not_in_room.push_back(f.id);
    if (f.kind == MapFaultKind::kNotInMap) not_in_map.push_back(f.id);
    s->faults.push_back(f);
  }
  RemoveRectangles(not_in_room, &s->room);
  RemoveRectangles(not_in_map, &s->map);
}

}  // namespace

SurveyedMap SurveyMap(const Map& truth, const SurveyError& error) {
  error.Check();
  SurveyedMap s;
  s.room = truth;
  s.map = OffsetMap(PerturbedMap(truth, error.sigma, error.seed), error.offset_sigma, error.seed);
  const double sigma = std::hypot(error.sigma, error.offset_sigma);
  if (sigma > 0.0) s.map.survey_sigma = sigma;
  AddGrossFaults(error, &s);
  return s;
}

SequenceRenderer::SequenceRenderer(const SequenceCase& c)
    : case_(c),
      scene_(Scene::FromMap(c.map, c.options.distractors)),
      renderer_(c.calib.sensor, scene_, c.map.sensor_height, c.options),
      people_(MakePeople(c.map, c.options.people, c.options.seed)),
      dropped_(DroppedFrames(c.options, static_cast<int>(c.poses.size()))),
      covered_(CoveredFrames(c.options, static_cast<int>(c.poses.size()))) {
  if (!people_.empty()) {
    const double size = std::max(c.map.room.max.x() - c.map.room.min.x(), c.map.room.max.y() - c.map.room.min.y());
    people_clearance_ = 0.08 * size;
  }
  mask_ = renderer_.MirrorMask();
}

bool SequenceRenderer::Dropped(int i) const { return std::binary_search(dropped_.begin(), dropped_.end(), i); }
bool SequenceRenderer::Covered(int i) const { return std::binary_search(covered_.begin(), covered_.end(), i); }

int SequenceRenderer::BlurSamples(int i) const {
  const RenderOptions& o = case_.options;
  if (o.exposure <= 0.0) return 1;
  if (o.blur_samples > 0) return o.blur_samples;
  // Image motion over the exposure at the rim: the turn, and the translation
  // as seen on the floor about one sensor height away.
  const Pose2& p = case_.poses[static_cast<size_t>(i)];
  double motion = 0.0;
  for (double side : {-1.0, 1.0}) {
    const Pose2 q = PoseAtOffset(case_.poses, i, side, case_.kidnap_frames);
    const double turn = std::abs(WrapAngle(q.theta - p.theta));
    const double shift = std::hypot(q.x - p.x, q.y - p.y) / std::max(1e-9, case_.map.sensor_height);
    motion = std::max(motion, turn + shift);
  }
  const double px = o.exposure * motion * case_.calib.sensor.limb_radius();
  if (px <= 0.0 && people_.empty()) return 1;
  return std::clamp(static_cast<int>(std::ceil(px)), 2, 32);
}

std::vector<Pose2> SequenceRenderer::SubPoses(int i) const {
  const int k_max = BlurSamples(i);
  std::vector<Pose2> out;
  for (int k = 0; k < k_max; ++k)
    out.push_back(PoseAtOffset(case_.poses, i, ExposureOffset(case_.options.exposure, k, k_max),
                               case_.kidnap_frames));
  return out;
}

cv::Mat SequenceRenderer::RenderFrame(int i) const {
  const RenderOptions& o = case_.options;
  const Pose2& pose = case_.poses[static_cast<size_t>(i)];
  const int samples = BlurSamples(i);
  const double gain = Gain(i);
  const bool covered = Covered(i);
  if (samples == 1 && gain == 1.0 && people_.empty() && !covered) return renderer_.Render(pose, i);
  const Sensor& sensor = case_.calib.sensor;
  cv::Mat sum(sensor.image_height, sensor.image_width, CV_32FC1, cv::Scalar(0));
  const bool one_ray = samples >= 4;
  for (int k = 0; k < samples; ++k) {
    const double offset = ExposureOffset(o.exposure, k, samples);
    const Pose2 sub = PoseAtOffset(case_.poses, i, offset, case_.kidnap_frames);
    const std::vector<Surface> extra =
        PeopleSurfaces(people_, i + offset, {sub.x, sub.y}, people_clearance_);
    renderer_.Accumulate(sub, gain, extra, one_ray, &sum);
  }
  if (samples > 1) sum *= 1.0 / samples;
  if (covered) {
    // A dark object just in front of the lens: a sector of 60..100 % of the
    // image around the mirror's centre, at a seeded angle.
    Mix rng = MixFor(o.seed ^ static_cast<uint64_t>(i), kSectorSalt);
    const double width = rng.Uniform(0.6, 1.0) * 2.0 * M_PI, start = rng.Uniform(-M_PI, M_PI);
    const float dark = static_cast<float>(255.0 * std::clamp(0.03 * o.illumination * gain, 0.0, 1.0));
    const double cx = sensor.params.cx, cy = sensor.params.cy;
    for (int v = 0; v < sum.rows; ++v) {
      float* row = sum.ptr<float>(v);
      for (int u = 0; u < sum.cols; ++u) {
        const double a = WrapAnglePositive(std::atan2(v - cy, u - cx) - start);
        if (a <= width && mask_.at<uint8_t>(v, u)) row[u] = dark;
      }
    }
  }
  return FinishImage(sum, o, i, o.noise_sigma > 0.0 ? mask_ : cv::Mat());
}

}  // namespace pano
