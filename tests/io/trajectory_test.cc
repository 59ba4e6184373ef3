// The renderer's trajectory and board-pose files: what they hold, and one
// line naming the file and line for what they must not.
#include <catch2/catch.hpp>

#include <fstream>
#include <string>

#include "panotrack/core/error.h"
#include "panotrack/io/trajectory.h"
#include "test_paths.h"

namespace pano {
namespace {

std::string Write(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

TEST_CASE("trajectory files: x,y,theta or a pose CSV; bad lines named", "[trajectory]") {
  const std::string dir = test::ScratchDir("io_trajectory");
  const std::vector<Pose2> poses = ReadTrajectory(Write(dir, "t.csv", "x,y,theta\r\n1,2,0.5\n\n-3.5,4,1e-3\n"));
  REQUIRE(poses.size() == 2);
  CHECK(poses[0].x == 1.0);
  CHECK(poses[0].theta == 0.5);
  CHECK(poses[1].x == -3.5);
  CHECK(poses[1].theta == 1e-3);
  const std::vector<Pose2> gt =
      ReadTrajectory(Write(dir, "gt.csv", "frame,time_s,x,y,theta_rad,status,n_landmarks,residual\n"
                                          "0,0.000000,175.0000,68.0000,1.570796,ok,49,0.0000\n"));
  REQUIRE(gt.size() == 1);
  CHECK(gt[0].y == 68.0);
  const std::string bad = Write(dir, "bad.csv", "x,y,theta\n1,2,0.5\n1,two,0\n");
  CHECK_THROWS_WITH(ReadTrajectory(bad), bad + ": line 3: 'two' is not a number");
  const std::string extra = Write(dir, "extra.csv", "x,y,theta\n1,2,3,4\n");
  CHECK_THROWS_WITH(ReadTrajectory(extra), extra + ": line 2: expected 3 columns x,y,theta");
  const std::string header = Write(dir, "header.csv", "a,b,c\n1,2,3\n");
  CHECK_THROWS_WITH(ReadTrajectory(header),
                    header + ": line 1: expected the header 'x,y,theta' (radians) or a pose CSV (docs/panoloc.md)");
  const std::string empty = Write(dir, "empty.csv", "x,y,theta\n");
  CHECK_THROWS_WITH(ReadTrajectory(empty), empty + ": no poses in the trajectory file");
}

TEST_CASE("board pose files: six numbers a line after their header", "[trajectory]") {
  const std::string dir = test::ScratchDir("io_board_poses");
  const auto rows = ReadBoardPoseRows(Write(dir, "p.csv", "rx,ry,rz,tx,ty,tz\n0.1,0.2,0.3,1,2,3\n"));
  REQUIRE(rows.size() == 1);
  CHECK(rows[0] == std::array<double, 6>{0.1, 0.2, 0.3, 1, 2, 3});
  const std::string short_row = Write(dir, "short.csv", "rx,ry,rz,tx,ty,tz\n0.1,0.2,0.3,1,2\n");
  CHECK_THROWS_WITH(ReadBoardPoseRows(short_row), short_row + ": line 2: expected 6 numbers rx,ry,rz,tx,ty,tz");
  const std::string none = Write(dir, "none.csv", "rx,ry,rz,tx,ty,tz\n");
  CHECK_THROWS_WITH(ReadBoardPoseRows(none), none + ": no board poses");
}

}  // namespace
}  // namespace pano
