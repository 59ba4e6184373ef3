// The programs as users run them: what they print, their exit codes, and
// their one-line errors.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "panotrack/io/calibration.h"
#include "panotrack/io/map.h"
#include "panotrack/io/pose_csv.h"
#include "run_command.h"
#include "test_paths.h"

namespace pano {
namespace {

using Run = test::CommandRun;
Run Exec(const std::string& args) { return test::RunProgram(args); }
int Lines(const std::string& s) { return test::CountLines(s); }

TEST_CASE("panocalib project/backproject agree with the sensor model; bad input fails cleanly",
          "[panocalib_project]") {
  const std::string calib = test::SourcePath("calib/paper-real.yaml");
  const Sensor s = ReadCalibration(calib).sensor;
  // A point 100 cm ahead, 20 cm left, 10 cm below the pinhole.
  Run r = Exec("panocalib project --calib " + calib + " --point 100,20,-10");
  INFO(r.out);
  REQUIRE(r.code == 0);
  double u, v;
  REQUIRE(std::sscanf(r.out.c_str(), "%lf %lf", &u, &v) == 2);
  Eigen::Vector2d px;
  REQUIRE(s.project({100, 20, -10}, &px));
  // Printed with 6 decimals: rounding of at most 5e-7 px.
  CHECK(std::abs(u - px.x()) < 1e-6);
  CHECK(std::abs(v - px.y()) < 1e-6);
  // The ray of that pixel passes through the point.
  r = Exec("panocalib backproject --calib " + calib + " --pixel " + std::to_string(u) + "," +
           std::to_string(v));
  REQUIRE(r.code == 0);
  double o[3], d[3];
  REQUIRE(std::sscanf(r.out.c_str(), "%lf %lf %lf %lf %lf %lf", &o[0], &o[1], &o[2], &d[0], &d[1], &d[2]) == 6);
  const Eigen::Vector3d to_point = Eigen::Vector3d(100, 20, -10) - Eigen::Vector3d(o[0], o[1], o[2]);
  const Eigen::Vector3d ray(d[0], d[1], d[2]);
  // The pixel passed back with 6 decimals and the ray printed with 9: measured 2.8e-7 cm.
  CHECK((to_point - to_point.dot(ray) * ray).norm() < 1e-6);
  // Not visible; no mirror.
  r = Exec("panocalib project --calib " + calib + " --point 0,0,100");
  CHECK(r.code == 0);
  CHECK(r.out == "not visible\n");
  r = Exec("panocalib backproject --calib " + calib + " --pixel 5,5");
  CHECK(r.out == "no mirror\n");
  // Bad input: one line naming the file or option, non-zero exit.
  r = Exec("panocalib project --calib /nonexistent/c.yaml --point 1,2,3");
  CHECK(r.code != 0);
  CHECK(Lines(r.out) == 1);
  CHECK(r.out.find("/nonexistent/c.yaml") != std::string::npos);
  r = Exec("panocalib project --calib " + calib + " --point 1,nan,3");
  CHECK(r.code == 1);
  CHECK(r.out.find("--point") != std::string::npos);
  r = Exec("panocalib project --calib " + calib + " --point 1,2");
  CHECK(r.code == 1);
  CHECK(r.out.find("--point") != std::string::npos);
  r = Exec("panocalib backproject --calib " + calib + " --pixel 1,2,3");
  CHECK(r.code == 1);
  CHECK(r.out.find("--pixel") != std::string::npos);
  const std::string dir = test::ScratchDir("apps_cli");
  std::ofstream(dir + "/bad.yaml") << "model: sphere\nunits: cm\nimage_width: 640\n";
  r = Exec("panocalib project --calib " + dir + "/bad.yaml --point 1,2,3");
  CHECK(r.code != 0);
  CHECK(Lines(r.out) == 1);
  CHECK(r.out.find("image_height") != std::string::npos);
}

TEST_CASE("a unified (central) camera end to end: panosim renders it, panoloc tracks through it",
          "[unified_end_to_end]") {
  const std::string dir = test::ScratchDir("apps_unified");
  // The paper-synthetic room and path, seen by a parabolic mirror behind a
  // telecentric lens (xi 1): the horizon at 120 px, the disc's edge 31
  // degrees above it.
  std::ofstream(dir + "/unified.yaml") << "model: unified\nunits: units\nimage_width: 640\nimage_height: 480\n"
                                          "focal_px: 120\ncx: 319.5\ncy: 239.5\nxi: 1.0\nrim_radius: 1.9\n";
  Run r = Exec("panosim sequence --preset paper-synthetic --no-video --frames -q -o " + dir + "/preset");
  REQUIRE(r.code == 0);
  r = Exec("panosim sequence --map " + dir + "/preset/map.yaml --calib " + dir + "/unified.yaml --trajectory " +
           dir + "/preset/gt.csv -q -o " + dir + "/seq");
  INFO(r.out);
  REQUIRE(r.code == 0);
  r = Exec("panoloc " + dir + "/seq/video.mp4 --calib " + dir + "/seq/calib.yaml --map " + dir +
           "/seq/map.yaml -o " + dir + "/est.csv --gt " + dir + "/seq/gt.csv -q --summary-json -");
  REQUIRE(r.code == 0);
  const nlohmann::json in = nlohmann::json::parse(r.out).at("inputs")[0];
  CHECK(in.at("ok") == in.at("frames"));
  // Measured 0.029 units (the preset's own sphere: 0.010 on lossless frames).
  CHECK(in.at("accuracy").at("rms").get<double>() < 0.06);
}

TEST_CASE("panoloc: a map and calibration in millimetres track as in centimetres", "[map_units]") {
  const std::string dir = test::ScratchDir("apps_map_units");
  Run r = Exec("panosim sequence --preset paper-real -q -o " + dir + "/cm");
  REQUIRE(r.code == 0);
  // The same room and sensor in millimetres: every length times ten.
  Map map = ReadMap(dir + "/cm/map.yaml");
  map.units = "mm";
  map.sensor_height *= 10.0;
  map.survey_sigma *= 10.0;
  map.room.min *= 10.0;
  map.room.max *= 10.0;
  map.room.height *= 10.0;
  for (MapRectangle& rect : map.rectangles) {
    rect.from *= 10.0;
    rect.to *= 10.0;
    rect.z0 *= 10.0;
    rect.z1 *= 10.0;
  }
  for (MapBox& box : map.boxes) {
    box.min *= 10.0;
    box.max *= 10.0;
  }
  WriteMap(dir + "/map_mm.yaml", map);
  std::ofstream(dir + "/calib_mm.yaml") << "model: sphere\nunits: mm\nimage_width: 640\nimage_height: 480\n"
                                           "focal_px: 590.0\ncx: 319.5\ncy: 239.5\naspect: 1.0\n"
                                           "mirror_radius: 49.0\nmirror_distance: 151.0\n";
  const std::vector<PoseRow> truth = ReadPoseCsv(dir + "/cm/gt.csv");
  REQUIRE_FALSE(truth.empty());
  const Pose2 start = truth.front().pose;
  r = Exec("panoloc " + dir + "/cm/video.mp4 --calib " + dir + "/cm/calib.yaml --map " + dir + "/cm/map.yaml --init " +
           std::to_string(start.x) + "," + std::to_string(start.y) + "," + std::to_string(start.theta) + " -o " +
           dir + "/cm.csv -q");
  REQUIRE(r.code == 0);
  r = Exec("panoloc " + dir + "/cm/video.mp4 --calib " + dir + "/calib_mm.yaml --map " + dir + "/map_mm.yaml --init " +
           std::to_string(10.0 * start.x) + "," + std::to_string(10.0 * start.y) + "," +
           std::to_string(start.theta) + " -o " + dir + "/mm.csv -q");
  INFO(r.out);
  REQUIRE(r.code == 0);
  const std::vector<PoseRow> cm = ReadPoseCsv(dir + "/cm.csv"), mm = ReadPoseCsv(dir + "/mm.csv");
  REQUIRE(cm.size() == truth.size());
  REQUIRE(mm.size() == truth.size());
  // Measured: every frame of both, 0.0134 cm RMS in millimetres and 0.0136
  // in centimetres (in millimetres 19 of 57 frames were tracked while the
  // pose solver's geometry test depended on the units).
  int ok = 0;
  double worst = 0.0;
  for (size_t i = 0; i < truth.size(); ++i) {
    if (cm[i].status != PoseStatus::kOk || mm[i].status != PoseStatus::kOk) continue;
    ++ok;
    worst = std::max(worst, std::hypot(mm[i].pose.x / 10.0 - truth[i].pose.x, mm[i].pose.y / 10.0 - truth[i].pose.y));
  }
  CHECK(ok == static_cast<int>(truth.size()));
  CHECK(worst < 0.06);  // cm; measured 0.034
}

TEST_CASE("panoloc: exit codes and errors of the command", "[panoloc_cli]") {
  const std::string dir = test::ScratchDir("apps_panoloc");
  // A tiny sequence from panosim.
  Run r = Exec("panosim sequence --preset paper-synthetic -o " + dir + "/seq --quiet --force");
  INFO(r.out);
  REQUIRE(r.code == 0);
  // Every input fine: exit 0 and a CSV per input.
  r = Exec("panoloc " + dir + "/seq/video.mp4 --calib " + dir + "/seq/calib.yaml --map " + dir +
           "/seq/map.yaml -o " + dir + "/est.csv --gt " + dir + "/seq/gt.csv");
  CHECK(r.code == 0);
  CHECK(r.out.find("66 frames, 66 ok") != std::string::npos);
  const size_t at = r.out.find("position error: RMS");
  REQUIRE(at != std::string::npos);
  const double printed_rms = std::stod(r.out.substr(at + 20));
  // Again: the CSV exists, so nothing is done without --force.
  const std::string again = "panoloc " + dir + "/seq/video.mp4 --calib " + dir + "/seq/calib.yaml --map " + dir +
                            "/seq/map.yaml -o " + dir + "/est.csv --gt " + dir + "/seq/gt.csv";
  r = Exec(again);
  CHECK(r.code == 1);
  CHECK(r.out == "panoloc: " + dir + "/est.csv exists (use --force to replace it)\n");
  // With --force; the summary as JSON on standard output, the same figures as printed.
  r = Exec(again + " --force -q --summary-json -");
  INFO(r.out);
  CHECK(r.code == 0);
  const nlohmann::json j = nlohmann::json::parse(r.out);
  REQUIRE(j.at("inputs").size() == 1);
  const nlohmann::json& in = j.at("inputs")[0];
  CHECK(in.at("frames") == 66);
  CHECK(in.at("ok") == 66);
  CHECK(in.at("lost") == 0);
  CHECK(in.at("end") == "done");
  CHECK(in.at("outputs").at("poses") == dir + "/est.csv");
  CHECK(in.at("decoder") == "cpu");
  CHECK(std::abs(in.at("accuracy").at("rms").get<double>() - printed_rms) <= 0.0005);
  CHECK(j.at("command_line").back() == "-");
  // NVDEC: the same poses where a device decodes, else one line naming the input and no CSV.
  r = Exec("panoloc " + dir + "/seq/video.mp4 --calib " + dir + "/seq/calib.yaml --map " + dir + "/seq/map.yaml -o " +
           dir + "/nvdec.csv --hwaccel cuda -q");
  const auto read = [](const std::string& path) {
    std::ostringstream text;
    text << std::ifstream(path).rdbuf();
    return text.str();
  };
  if (r.code == 0) {
    CHECK(read(dir + "/nvdec.csv") == read(dir + "/est.csv"));
  } else {
    CHECK(r.code == 1);
    CHECK(Lines(r.out) == 1);
    CHECK(r.out.rfind("panoloc: " + dir + "/seq/video.mp4: cannot decode (NVDEC: ", 0) == 0);
    CHECK_FALSE(std::filesystem::exists(dir + "/nvdec.csv"));
  }
  r = Exec(again + " --force --hwaccel gpu");
  CHECK(r.code == 1);
  CHECK(r.out.find("--hwaccel: gpu not in {none,cuda,auto}") != std::string::npos);
  // One input missing: the other is done, the exit code says not all succeeded.
  r = Exec("panoloc " + dir + "/seq/video.mp4 " + dir + "/none.mp4 --calib " + dir +
           "/seq/calib.yaml --map " + dir + "/seq/map.yaml --out-dir " + dir + "/out -q");
  CHECK(r.code == 1);
  CHECK(Lines(r.out) == 1);
  CHECK(r.out.find("none.mp4") != std::string::npos);
  CHECK(std::filesystem::exists(dir + "/out/seq_video.csv"));
  // Initial pose outside the room.
  r = Exec("panoloc " + dir + "/seq/video.mp4 --calib " + dir + "/seq/calib.yaml --map " + dir +
           "/seq/map.yaml -o " + dir + "/x.csv --init -40,10,0");
  CHECK(r.code == 1);
  CHECK(r.out.find("outside the room") != std::string::npos);
  // A malformed --init.
  r = Exec("panoloc " + dir + "/seq/video.mp4 --calib " + dir + "/seq/calib.yaml --map " + dir +
           "/seq/map.yaml -o " + dir + "/x.csv --init 1,2");
  CHECK(r.code == 1);
  CHECK(r.out.find("--init") != std::string::npos);
}

}  // namespace
}  // namespace pano
