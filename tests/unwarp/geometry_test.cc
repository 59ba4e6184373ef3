// Unwarped views of rendered rooms: in the panorama the vertical edges of
// the landmarks are columns at their bearings (azimuth offset and heading
// included) and vertical; in a perspective view of a wall at the view's
// distance the straight edges stay straight and the corners land where the
// virtual pinhole puts them.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

#include "panotrack/render/presets.h"
#include "panotrack/render/render.h"
#include "panotrack/scene/scene.h"
#include "panotrack/unwarp/unwarp.h"
#include "view_measure.h"

namespace pano {
namespace {

using test::FitLine;
using test::LineFit;
using test::StepOffset;

struct Shot {
  cv::Mat raw;  // CV_8UC1
  cv::Mat ids;  // CV_32SC1, the scene's surface index per pixel
  std::vector<std::string> names;
};

Shot Render(const Sensor& sensor, const Map& map, const Pose2& pose, int supersample) {
  const Scene scene = Scene::FromMap(map, false);
  RenderOptions o;
  o.supersample = supersample;
  o.distractors = false;
  const Renderer r(sensor, scene, map.sensor_height, o);
  Shot s;
  s.raw = r.Render(pose);
  s.ids = r.SurfaceIds(pose);
  for (const Surface& f : scene.surfaces()) s.names.push_back(f.name);
  return s;
}

int SurfaceIndex(const Shot& s, const std::string& name) {
  const auto it = std::find(s.names.begin(), s.names.end(), name);
  REQUIRE(it != s.names.end());
  return static_cast<int>(it - s.names.begin());
}

struct EdgeStats {
  int edges = 0;
  int rows = 0;
  double worst_offset = 0.0;  // |mean measured column - bearing's column|
  // Change of the fitted column from the edge's first row to its last, for
  // edges that run along the raw image's pixel rows or columns (within 5 deg)
  // and the others: the renderer quantises an edge's position across such an
  // edge to 1/supersample px, which a slightly tilted edge turns into a jump.
  double worst_drift_aligned = 0.0;
  double worst_drift = 0.0;
  double worst_rms = 0.0;     // RMS of the measured columns about that fit
};

// Every vertical edge of the map's rectangles measured row by row in the
// panorama of `options`.
EdgeStats MeasurePanorama(const Sensor& sensor, const Map& map, const Pose2& pose, const Shot& shot,
                          const UnwarpOptions& options) {
  const UnwarpView view(sensor, options);
  const cv::Mat pano = view.Unwarp(shot.raw);
  const cv::Mat ids = test::UnwarpIds(shot.ids, sensor, options);
  EdgeStats st;
  for (const MapRectangle& rect : map.rectangles) {
    const int surface = SurfaceIndex(shot, rect.id);
    for (const Eigen::Vector2d& foot : {rect.from, rect.to}) {
      const Eigen::Vector3d bottom = SensorFromWorld(pose, map.sensor_height, {foot.x(), foot.y(), rect.z0});
      const Eigen::Vector3d top = SensorFromWorld(pose, map.sensor_height, {foot.x(), foot.y(), rect.z1});
      const double sign = options.clockwise ? -1.0 : 1.0;
      double expected = sign * std::atan2(bottom.y(), bottom.x()) * view.width() / (2 * M_PI);
      if (expected < 0) expected += view.width();
      Eigen::Vector2d pb, pt;
      REQUIRE(view.PixelOfPoint(bottom, &pb));
      REQUIRE(view.PixelOfPoint(top, &pt));
      CHECK(pb.x() == Approx(expected).margin(1e-9));
      if (expected < 8 || expected > view.width() - 8) continue;  // across the seam
      std::vector<Eigen::Vector2d> pts;  // (row, column)
      const int r0 = std::max(0, static_cast<int>(std::ceil(std::min(pb.y(), pt.y()) + 4)));
      const int r1 = std::min(view.height() - 1, static_cast<int>(std::floor(std::max(pb.y(), pt.y()) - 4)));
      for (int r = r0; r <= r1; ++r) {
        const double off = StepOffset(pano, ids, surface, {expected, double(r)}, {1, 0});
        if (!std::isnan(off)) pts.push_back({double(r), expected + off});
      }
      if (pts.size() < 5) continue;
      // column = mean + slope (row - mean row), least squares.
      Eigen::Vector2d mean(0, 0);
      for (const auto& p : pts) mean += p;
      mean /= pts.size();
      double sxy = 0, sxx = 0;
      for (const auto& p : pts) {
        sxy += (p.x() - mean.x()) * (p.y() - mean.y());
        sxx += (p.x() - mean.x()) * (p.x() - mean.x());
      }
      const double slope = sxx > 0 ? sxy / sxx : 0.0;
      double sum = 0;
      for (const auto& p : pts) sum += std::pow(p.y() - mean.y() - slope * (p.x() - mean.x()), 2);
      ++st.edges;
      st.rows += static_cast<int>(pts.size());
      st.worst_offset = std::max(st.worst_offset, std::abs(mean.y() - expected));
      const double drift = std::abs(slope) * (pts.back().x() - pts.front().x());
      const double image_azimuth = std::atan2(bottom.y(), bottom.x()) + sensor.params.azimuth_offset;
      const double from_axis = std::abs(std::remainder(image_azimuth, M_PI / 2));
      double& worst = from_axis < 5 * M_PI / 180 ? st.worst_drift_aligned : st.worst_drift;
      worst = std::max(worst, drift);
      st.worst_rms = std::max(st.worst_rms, std::sqrt(sum / pts.size()));
    }
  }
  return st;
}

TEST_CASE("panorama: vertical edges are columns at their bearings", "[panorama]") {
  const SequenceCase c = MakePreset("paper-synthetic");
  Sensor sensor = c.calib.sensor;
  sensor.params.azimuth_offset = 0.3;  // a camera turned about its axis: columns stay bearings
  const Pose2 pose = c.poses[20];
  const Shot shot = Render(sensor, c.map, pose, 3);

  UnwarpOptions o;
  SECTION("infinitely far, counter-clockwise") {}
  SECTION("clockwise") { o.clockwise = true; }
  SECTION("cylinder of radius 70") { o.distance = 70.0; }
  SECTION("2000 x 400, elevation -30..30") {
    o.width = 2000;
    o.height = 400;
    o.min_elevation_deg = -30;
    o.max_elevation_deg = 30;
  }
  const EdgeStats st = MeasurePanorama(sensor, c.map, pose, shot, o);
  INFO("edges " << st.edges << " rows " << st.rows << " worst offset " << st.worst_offset << " px, drift "
                << st.worst_drift << " px (along the pixel grid " << st.worst_drift_aligned << " px), rms "
                << st.worst_rms << " px");
  // In pixels of the default view (1272 columns, about the raw image's
  // resolution at the horizon); the 2000-column view magnifies everything.
  const double scale = (o.width > 0 ? o.width : 1272) / 1272.0;
  CHECK(st.edges == 21);
  CHECK(st.worst_offset < 0.08 * scale);
  CHECK(st.worst_drift < 0.1 * scale);
  CHECK(st.worst_drift_aligned < 0.6 * scale);
  CHECK(st.worst_rms < 0.2 * scale);
}

// A room with one dark panel on the north wall, 70 units in front of the sensor.
Map PanelRoom() {
  Map m;
  m.units = "units";
  m.sensor_height = 30;
  m.room.present = true;
  m.room.min = {0, 0};
  m.room.max = {200, 200};
  m.room.height = 120;
  MapRectangle panel;
  panel.id = "panel";
  panel.from = {80, 199.5};
  panel.to = {120, 199.5};
  panel.z0 = 18;
  panel.z1 = 52;
  panel.shade = 0.1;
  m.rectangles = {panel};
  return m;
}

struct PanelFit {
  LineFit edge[4];           // left, right, bottom, top
  double corner_error = 0;   // largest distance of a fitted corner from its expected pixel
};

// The panel's four edges in the perspective view, each fitted with a line.
PanelFit MeasurePanel(const Sensor& sensor, const Map& map, const Pose2& pose, const Shot& shot,
                      const UnwarpOptions& options) {
  const UnwarpView view(sensor, options);
  const cv::Mat img = view.Unwarp(shot.raw);
  const cv::Mat ids = test::UnwarpIds(shot.ids, sensor, options);
  const MapRectangle& r = map.rectangles[0];
  const int surface = SurfaceIndex(shot, r.id);
  // Corners: bottom-from, bottom-to, top-to, top-from.
  const Eigen::Vector3d world[4] = {{r.from.x(), r.from.y(), r.z0}, {r.to.x(), r.to.y(), r.z0},
                                    {r.to.x(), r.to.y(), r.z1}, {r.from.x(), r.from.y(), r.z1}};
  Eigen::Vector2d px[4];
  for (int k = 0; k < 4; ++k) REQUIRE(view.PixelOfPoint(SensorFromWorld(pose, map.sensor_height, world[k]), &px[k]));
  // Edges as corner pairs; search across them (x for the vertical ones).
  const int ends[4][2] = {{0, 3}, {1, 2}, {0, 1}, {3, 2}};
  PanelFit fit;
  for (int e = 0; e < 4; ++e) {
    const Eigen::Vector2d a = px[ends[e][0]], b = px[ends[e][1]];
    const Eigen::Vector2d across = e < 2 ? Eigen::Vector2d(1, 0) : Eigen::Vector2d(0, 1);
    const double len = (b - a).norm();
    std::vector<Eigen::Vector2d> pts;
    for (double s = 5.0; s <= len - 5.0; s += 1.0) {
      const Eigen::Vector2d q = a + (b - a) * (s / len);
      const double off = StepOffset(img, ids, surface, q, across);
      if (!std::isnan(off)) pts.push_back(q + off * across);
    }
    fit.edge[e] = FitLine(pts);
  }
  const int corner_edges[4][2] = {{0, 2}, {1, 2}, {1, 3}, {0, 3}};
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d x = test::Intersect(fit.edge[corner_edges[k][0]], fit.edge[corner_edges[k][1]]);
    fit.corner_error = std::max(fit.corner_error, (x - px[k]).norm());
  }
  return fit;
}

TEST_CASE("perspective: a wall at the view's distance is rectified exactly", "[perspective]") {
  const Map map = PanelRoom();
  Sensor sensor = MakeSphereSensor(500, 500, 590, 249.5, 249.5, 1.0, 4.9, 15.1, -0.4);
  // Facing the north wall: bearing 90 deg - heading; the panel 70 units away.
  const Pose2 pose{100, 129.5, 0.35};
  const Shot shot = Render(sensor, map, pose, 4);
  UnwarpOptions o;
  o.kind = UnwarpKind::kPerspective;
  o.width = 240;
  o.height = 180;
  o.fov_deg = 50;
  o.yaw_deg = 90.0 - pose.theta * 180 / M_PI;
  o.distance = 199.5 - pose.y;
  const PanelFit fit = MeasurePanel(sensor, map, pose, shot, o);
  for (int e = 0; e < 4; ++e) {
    INFO("edge " << e << ": " << fit.edge[e].n << " points, rms " << fit.edge[e].rms << " max "
                 << fit.edge[e].max_abs);
    CHECK(fit.edge[e].n >= 20);
    CHECK(fit.edge[e].rms < 0.25);
    CHECK(fit.edge[e].max_abs < 0.6);
  }
  INFO("corner error " << fit.corner_error << " px");
  CHECK(fit.corner_error < 0.15);

  SECTION("infinitely far: vertical edges still straight, the corners shifted by parallax") {
    o.distance = 0.0;
    const PanelFit far = MeasurePanel(sensor, map, pose, shot, o);
    INFO("rms " << far.edge[0].rms << " " << far.edge[1].rms << " px, corner error " << far.corner_error << " px");
    CHECK(far.edge[0].rms < 0.25);
    CHECK(far.edge[1].rms < 0.25);
    CHECK(far.corner_error > 0.8);  // the mirror's parallax at 70 units
    CHECK(far.corner_error < 1.4);
  }
}

}  // namespace
}  // namespace pano
