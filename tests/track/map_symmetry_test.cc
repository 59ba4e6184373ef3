// Map symmetries: the floor motions under which a robot's view of its
// landmarks repeats elsewhere in the room.
#include <catch2/catch.hpp>

#include <cmath>
#include <numeric>

#include "panotrack/core/angles.h"
#include "panotrack/track/map_symmetry.h"

namespace pano {
namespace {

using Catch::WithinAbs;

MapRectangle Rect(const std::string& id, Eigen::Vector2d from, Eigen::Vector2d to, double z0, double z1) {
  MapRectangle r;
  r.id = id;
  r.from = from;
  r.to = to;
  r.z0 = z0;
  r.z1 = z1;
  return r;
}

// One poster on each wall of a 220 x 220 room, each the point reflection of
// the one opposite through the centre (110, 110).
Map PointSymmetricRoom() {
  Map m;
  m.sensor_height = 20;
  m.rectangles = {Rect("s", {60, 0}, {100, 0}, 40, 90), Rect("n", {160, 220}, {120, 220}, 40, 90),
                  Rect("e", {220, 50}, {220, 90}, 30, 70), Rect("w", {0, 170}, {0, 130}, 30, 70)};
  return m;
}

std::vector<int> All(const std::vector<Landmark>& l) {
  std::vector<int> idx(l.size());
  std::iota(idx.begin(), idx.end(), 0);
  return idx;
}

TEST_CASE("a point-symmetric room has the half turn about its centre", "[map_symmetry]") {
  const std::vector<Landmark> landmarks = LandmarksFromMap(PointSymmetricRoom());
  REQUIRE(landmarks.size() == 16);
  const std::vector<FloorMotion> found = LandmarkSymmetries(landmarks, All(landmarks), 0.5);
  REQUIRE(found.size() == 1);
  CHECK_THAT(std::abs(WrapAngle(found[0].angle)), WithinAbs(M_PI, 1e-12));
  CHECK_THAT(found[0].translation.x(), WithinAbs(220, 1e-9));
  CHECK_THAT(found[0].translation.y(), WithinAbs(220, 1e-9));
  // The twin of a robot at (65, 35) heading 0 stands at (155, 185) heading pi.
  const Pose2 twin = found[0].Apply(Pose2{65, 35, 0});
  CHECK_THAT(twin.x, WithinAbs(155, 1e-9));
  CHECK_THAT(twin.y, WithinAbs(185, 1e-9));
  CHECK_THAT(std::abs(twin.theta), WithinAbs(M_PI, 1e-12));
}

TEST_CASE("a landmark moved by more than the tolerance breaks the symmetry", "[map_symmetry]") {
  Map m = PointSymmetricRoom();
  m.rectangles[2].to.y() += 1.0;
  const std::vector<Landmark> landmarks = LandmarksFromMap(m);
  CHECK(LandmarkSymmetries(landmarks, All(landmarks), 0.5).empty());
  // Within the tolerance it still counts: the bearings could not tell.
  CHECK(LandmarkSymmetries(landmarks, All(landmarks), 1.5).size() == 1);
}

TEST_CASE("a view of part of a room repeats where the map repeats it", "[map_symmetry]") {
  // The same poster on both side walls of a corridor, and a door at one end:
  // seeing one poster alone is ambiguous, seeing the door too is not.
  Map m;
  m.sensor_height = 20;
  m.rectangles = {Rect("poster-a", {0, 100}, {0, 60}, 40, 90), Rect("poster-b", {200, 60}, {200, 100}, 40, 90),
                  Rect("door", {80, 400}, {120, 400}, 0, 200)};
  const std::vector<Landmark> landmarks = LandmarksFromMap(m);
  std::vector<int> poster_a, poster_a_and_door;
  for (size_t i = 0; i < landmarks.size(); ++i) {
    if (landmarks[i].id.rfind("poster-a/", 0) == 0) poster_a.push_back(static_cast<int>(i));
    if (landmarks[i].id.rfind("poster-b/", 0) != 0) poster_a_and_door.push_back(static_cast<int>(i));
  }
  REQUIRE(poster_a.size() == 4);
  // Poster a onto itself turned about its centre (seen from behind the
  // wall), onto poster b turned about the corridor's centre, and onto poster
  // b shifted across (from behind that wall): the localiser keeps the twins
  // that stand in the room.
  const std::vector<FloorMotion> one = LandmarkSymmetries(landmarks, poster_a, 0.5);
  REQUIRE(one.size() == 3);
  int in_corridor = 0;
  for (const FloorMotion& motion : one) {
    const Pose2 twin = motion.Apply(Pose2{50, 80, 0.3});
    if (twin.x > 0 && twin.x < 200) {
      ++in_corridor;
      CHECK_THAT(twin.x, WithinAbs(150, 1e-9));
      CHECK_THAT(twin.y, WithinAbs(80, 1e-9));
      CHECK_THAT(std::abs(WrapAngle(twin.theta - 0.3 - M_PI)), WithinAbs(0, 1e-12));
    }
  }
  CHECK(in_corridor == 1);
  CHECK(LandmarkSymmetries(landmarks, poster_a_and_door, 0.5).empty());
}

}  // namespace
}  // namespace pano
