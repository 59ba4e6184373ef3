// Ray casts and occlusion tests against hand-made scenes.
#include <catch2/catch.hpp>

#include <cmath>

#include "panotrack/scene/scene.h"

namespace pano {
namespace {

Map TestMap() {
  Map m;
  m.units = "units";
  m.sensor_height = 30;
  m.room.present = true;
  m.room.min = {0, 0};
  m.room.max = {200, 100};
  m.room.height = 120;
  MapRectangle poster;  // flat on the wall x = 200
  poster.id = "poster";
  poster.from = {200, 40};
  poster.to = {200, 60};
  poster.z0 = 20;
  poster.z1 = 60;
  poster.shade = 0.1;
  MapRectangle screen;  // free-standing, facing -x at x = 150
  screen.id = "screen";
  screen.from = {150, 70};
  screen.to = {150, 90};
  screen.z0 = 0;
  screen.z1 = 50;
  screen.shade = 0.9;
  m.rectangles = {poster, screen};
  MapBox crate;
  crate.id = "crate";
  crate.min = {60, 10, 0};
  crate.max = {80, 30, 40};
  crate.shade = 0.7;
  m.boxes = {crate};
  MapRectangle d;
  d.id = "d";
  d.from = {10, 100};
  d.to = {30, 100};
  d.z0 = 10;
  d.z1 = 40;
  d.shade = 0.3;
  m.distractors = {d};
  return m;
}

int Find(const Scene& s, const std::string& name) {
  for (size_t i = 0; i < s.surfaces().size(); ++i)
    if (s.surfaces()[i].name == name) return static_cast<int>(i);
  return -2;
}

TEST_CASE("ray casts meet walls, floor, rectangles and boxes", "[intersect]") {
  const Scene s = Scene::FromMap(TestMap());
  REQUIRE(s.surfaces().size() == 6 + 2 + 5 + 1);  // crate on the floor: no bottom face
  CHECK(Scene::FromMap(TestMap(), false).surfaces().size() == 13);
  const Eigen::Vector3d o(100, 50, 30);
  // Towards +x at poster height: the poster (flat on the wall) beats the wall.
  RayHit h = s.Intersect(o, {1, 0, 0});
  REQUIRE(h.hit());
  CHECK(h.t == Approx(100.0));
  CHECK(h.surface == Find(s, "poster"));
  CHECK(h.shade == Approx(0.1));
  // Higher: the wall.
  h = s.Intersect({100, 50, 80}, {1, 0, 0});
  CHECK(s.surfaces()[static_cast<size_t>(h.surface)].kind == SurfaceKind::kWall);
  CHECK(h.shade == Approx(0.55));
  // Straight down: the floor, straight up: the ceiling.
  h = s.Intersect(o, {0, 0, -1});
  CHECK(h.surface == Find(s, "room:floor"));
  CHECK(h.t == Approx(30.0));
  h = s.Intersect(o, {0, 0, 2});  // direction need not be unit: t in its units
  CHECK(h.surface == Find(s, "room:ceiling"));
  CHECK(h.t == Approx(45.0));
  // The free-standing screen, from its front.
  h = s.Intersect({100, 80, 10}, {1, 0, 0});
  CHECK(h.surface == Find(s, "screen"));
  CHECK(h.t == Approx(50.0));
  // The crate: its +x face, its top.
  h = s.Intersect({100, 20, 20}, {-1, 0, 0});
  CHECK(h.surface == Find(s, "crate:+x"));
  CHECK(h.t == Approx(20.0));
  h = s.Intersect({70, 20, 60}, {0, 0, -1});
  CHECK(h.surface == Find(s, "crate:+z"));
  CHECK(h.t == Approx(20.0));
  // An oblique ray to a known point of the floor.
  const Eigen::Vector3d target(130, 20, 0);
  h = s.Intersect(o, (target - o).normalized());
  CHECK(h.surface == Find(s, "room:floor"));
  CHECK(h.t == Approx((target - o).norm()));
  // max_t stops short; the distractor is there unless left out.
  CHECK_FALSE(s.Intersect(o, {1, 0, 0}, 99.0).hit());
  h = s.Intersect({20, 50, 20}, {0, 1, 0});
  CHECK(h.surface == Find(s, "d"));
  // No room: rays that miss everything report no hit.
  Map open = TestMap();
  open.room.present = false;
  const Scene so = Scene::FromMap(open);
  CHECK_FALSE(so.Intersect(o, {0, 0, 1}).hit());
  CHECK(so.Intersect(o, {1, 0, 0}).surface == Find(so, "poster"));
  // A degenerate surface is refused.
  Scene bad;
  Surface z;
  z.name = "flat";
  z.edge_a = {1, 0, 0};
  z.edge_b = {2, 0, 0};
  CHECK_THROWS(bad.Add(z));
}

TEST_CASE("segment occlusion ignores the surfaces a corner lies on", "[occluded]") {
  const Scene s = Scene::FromMap(TestMap());
  const Eigen::Vector3d eye(100, 50, 40);
  // Corners of the poster (on the wall) and the screen (on the floor): visible.
  CHECK_FALSE(s.Occluded(eye, {200, 40, 20}));
  CHECK_FALSE(s.Occluded(eye, {200, 60, 60}));
  CHECK_FALSE(s.Occluded(eye, {150, 70, 0}));
  CHECK_FALSE(s.Occluded(eye, {150, 90, 50}));
  // The crate's near top corner is visible, its far bottom corner is hidden.
  CHECK_FALSE(s.Occluded(eye, {80, 30, 40}));
  CHECK(s.Occluded(eye, {60, 10, 0}));
  // Behind the screen.
  CHECK(s.Occluded({100, 80, 10}, {200, 80, 10}));
  // The distractor hides what is behind it; without distractors it does not.
  CHECK(s.Occluded({20, 50, 20}, {20, 100, 20}) == false);  // ends on the distractor's plane
  CHECK(s.Occluded({20, 50, 20}, {20, 101, 20}));
  CHECK_FALSE(Scene::FromMap(TestMap(), false).Occluded({20, 50, 20}, {20, 99.5, 20}));
}

TEST_CASE("a corner measured a little behind its wall is hidden only without a plane tolerance",
          "[occluded_measured]") {
  const Scene s = Scene::FromMap(TestMap());
  const Eigen::Vector3d eye(100, 50, 40);
  // The poster's corner surveyed 1.5 units behind the wall x = 200.
  const Eigen::Vector3d behind(201.5, 40, 20);
  CHECK(s.Occluded(eye, behind, 1e-3 * (behind - eye).norm()));
  CHECK_FALSE(s.Occluded(eye, behind, 1e-3 * (behind - eye).norm(), 4.5));
  // Further behind than the plane tolerance: hidden.
  CHECK(s.Occluded(eye, {206, 40, 20}, 1e-3, 4.5));
  // A surface between, not the one the corner is on, still hides it: the
  // screen's plane x = 150 is far from a corner behind the wall x = 200.
  CHECK(s.Occluded({100, 80, 10}, {201, 80, 10}, 1e-3, 4.5));
  // A ray at a grazing angle to the corner's wall meets it far from the
  // corner (more than ten plane tolerances along the ray): hidden.
  const Eigen::Vector3d grazing_eye(100, 99, 40);
  const Eigen::Vector3d near_wall(190, 100.5, 40);  // 0.5 behind the wall y = 100
  CHECK(s.Occluded(grazing_eye, near_wall, 1e-3, 0.6));
  // ... and near it, within the tolerance: seen.
  CHECK_FALSE(s.Occluded({185, 99, 40}, near_wall, 1e-3, 0.6));
}

}  // namespace
}  // namespace pano
