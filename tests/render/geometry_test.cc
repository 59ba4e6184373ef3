// The rendered intensity edges of every visible rectangle corner lie where
// the sensor model projects them: measured along the radial direction across
// the horizontal edge and along the tangential direction across the vertical
// edge, a few pixels from the corner.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

#include "panotrack/render/presets.h"
#include "panotrack/render/render.h"

namespace pano {
namespace {

double Bilinear(const cv::Mat& img, const Eigen::Vector2d& p) {
  const int u0 = static_cast<int>(std::floor(p.x())), v0 = static_cast<int>(std::floor(p.y()));
  const double fu = p.x() - u0, fv = p.y() - v0;
  auto at = [&](int u, int v) {
    u = std::clamp(u, 0, img.cols - 1);
    v = std::clamp(v, 0, img.rows - 1);
    return static_cast<double>(img.at<uint8_t>(v, u));
  };
  return (1 - fv) * ((1 - fu) * at(u0, v0) + fu * at(u0 + 1, v0)) +
         fv * ((1 - fu) * at(u0, v0 + 1) + fu * at(u0 + 1, v0 + 1));
}

int IdAt(const cv::Mat& ids, const Eigen::Vector2d& p) {
  const int u = static_cast<int>(std::lround(p.x())), v = static_cast<int>(std::lround(p.y()));
  if (u < 0 || v < 0 || u >= ids.cols || v >= ids.rows) return -3;
  return ids.at<int>(v, u);
}

// Offset (px) along `dir` from `p` of the 50% crossing between the plateaus at
// -3 and +3 px; NaN when the profile is not a clean step of the expected
// surface against another.
double EdgeOffset(const cv::Mat& img, const cv::Mat& ids, int surface, const Eigen::Vector2d& p,
                  const Eigen::Vector2d& dir) {
  const double reach = 3.0;
  // Both plateaus uniform in surface id over 2..4 px, one of them the rectangle.
  int side_id[2];
  for (int side = 0; side < 2; ++side) {
    const double sg = side == 0 ? -1.0 : 1.0;
    side_id[side] = IdAt(ids, p + sg * 2.0 * dir);
    for (double d : {2.5, 3.0, 3.5, 4.0})
      if (IdAt(ids, p + sg * d * dir) != side_id[side]) return std::nan("");
  }
  if (side_id[0] == side_id[1] || (side_id[0] != surface && side_id[1] != surface)) return std::nan("");
  if (side_id[0] < 0 || side_id[1] < 0) return std::nan("");
  // Exactly one change of surface along the profile (no sliver of a third surface).
  int changes = 0;
  for (double d = -4.0 + 0.25; d <= 4.0 + 1e-9; d += 0.25)
    if (IdAt(ids, p + d * dir) != IdAt(ids, p + (d - 0.25) * dir)) ++changes;
  if (changes != 1) return std::nan("");
  const double lo = Bilinear(img, p - reach * dir), hi = Bilinear(img, p + reach * dir);
  if (std::abs(hi - lo) < 30.0) return std::nan("");
  const double mid = 0.5 * (lo + hi);
  double best = std::nan("");
  const double step = 0.02;
  double prev = Bilinear(img, p - 2.5 * dir) - mid;
  for (double t = -2.5 + step; t <= 2.5 + 1e-9; t += step) {
    const double cur = Bilinear(img, p + t * dir) - mid;
    if ((prev <= 0 && cur > 0) || (prev >= 0 && cur < 0)) {
      const double x = t - step + step * prev / (prev - cur);
      if (std::isnan(best) || std::abs(x) < std::abs(best)) best = x;
    }
    prev = cur;
  }
  return best;
}

struct EdgeStats {
  int n = 0;
  double worst = 0.0;
  double sum = 0.0;
};

void MeasureCase(const SequenceCase& c, const std::vector<int>& frames, EdgeStats* st) {
  RenderOptions o;
  o.supersample = 3;
  o.distractors = true;
  const Sensor& s = c.calib.sensor;
  const Scene scene = Scene::FromMap(c.map, true);
  const Renderer r(s, scene, c.map.sensor_height, o);
  const Eigen::Vector2d centre(s.params.cx, s.params.cy);
  for (int f : frames) {
    const Pose2 pose = c.poses[static_cast<size_t>(f)];
    const cv::Mat img = r.Render(pose, f);
    const cv::Mat ids = r.SurfaceIds(pose);
    const std::vector<CornerView> vis = VisibleCorners(s, c.map, scene, pose, 8.0);
    for (const CornerView& view : vis) {
      // Rectangle corners only: "<id>:<k>".
      const std::string& cid = view.corner.id;
      const std::string rid = cid.substr(0, cid.rfind(':'));
      const int k = std::stoi(cid.substr(cid.rfind(':') + 1));
      const MapRectangle* rect = nullptr;
      for (const MapRectangle& m : c.map.rectangles)
        if (m.id == rid) rect = &m;
      if (!rect) continue;
      int surface = -1;
      for (size_t i = 0; i < scene.surfaces().size(); ++i)
        if (scene.surfaces()[i].name == rid) surface = static_cast<int>(i);
      REQUIRE(surface >= 0);
      const Eigen::Vector3d C = view.corner.world;
      const Eigen::Vector2d a = (k == 0 || k == 3) ? rect->from : rect->to;
      const Eigen::Vector2d b = (k == 0 || k == 3) ? rect->to : rect->from;
      const Eigen::Vector3d hdir((b - a).x(), (b - a).y(), 0.0);
      const Eigen::Vector3d vdir(0, 0, (k <= 1) ? 1.0 : -1.0);
      const double hlen = hdir.norm(), vlen = rect->z1 - rect->z0;
      auto project = [&](const Eigen::Vector3d& w, Eigen::Vector2d* px) {
        return s.project(SensorFromWorld(pose, c.map.sensor_height, w), px);
      };
      // A point on each edge about 6 px from the corner in the image.
      auto along = [&](const Eigen::Vector3d& unit, double len, Eigen::Vector2d* px) {
        Eigen::Vector2d p1;
        if (!project(C + 0.01 * len * unit, &p1)) return false;
        const double px_per_unit = (p1 - view.pixel).norm() / (0.01 * len);
        const double d = std::min(6.0 / px_per_unit, 0.45 * len);
        if (d * px_per_unit < 4.0) return false;  // edge too short in the image
        return project(C + d * unit, px);
      };
      Eigen::Vector2d ph, pv;
      if (along(hdir / hlen, hlen, &ph)) {
        const Eigen::Vector2d radial = (ph - centre).normalized();
        const double e = EdgeOffset(img, ids, surface, ph, radial);
        if (!std::isnan(e)) {
          ++st->n;
          st->worst = std::max(st->worst, std::abs(e));
          st->sum += std::abs(e);
          INFO(c.name << " frame " << f << " corner " << cid << " horizontal edge at " << ph.transpose());
          CHECK(std::abs(e) < 0.5);
        }
      }
      if (along(vdir, vlen, &pv)) {
        const Eigen::Vector2d radial = (pv - centre).normalized();
        const Eigen::Vector2d tangential(-radial.y(), radial.x());
        const double e = EdgeOffset(img, ids, surface, pv, tangential);
        if (!std::isnan(e)) {
          ++st->n;
          st->worst = std::max(st->worst, std::abs(e));
          st->sum += std::abs(e);
          INFO(c.name << " frame " << f << " corner " << cid << " vertical edge at " << pv.transpose());
          CHECK(std::abs(e) < 0.5);
        }
      }
    }
  }
}

TEST_CASE("rendered edges lie within 0.5 px of the sensor model's projection", "[geometry]") {
  EdgeStats st;
  MeasureCase(MakePreset("paper-synthetic"), {0, 33, 65}, &st);
  MeasureCase(MakePreset("paper-real"), {0, 28}, &st);
  MeasureCase(MakePreset("cluttered"), {10}, &st);
  WARN("geometry: " << st.n << " edges measured, worst " << st.worst << " px, mean " << st.sum / std::max(st.n, 1)
                    << " px");
  CHECK(st.n >= 60);
  CHECK(st.worst < 0.5);
}

}  // namespace
}  // namespace pano
