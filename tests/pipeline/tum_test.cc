// panoloc's --tum: the ok rows as a TUM trajectory in metres, whose position
// RMS against panosim's gt.tum (paired by time, as evo pairs them) is the
// accuracy panoloc reports; and the options it is refused with.
#include <catch2/catch.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "panotrack/core/error.h"
#include "panotrack/io/map.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/io/tum.h"
#include "panotrack/pipeline/panoloc.h"
#include "pipeline_fixture.h"

namespace pano {
namespace {

using test::FilesIn;
using test::Scratch;

struct TumPose {
  double t, x, y, z, qx, qy, qz, qw;
};

std::vector<TumPose> ReadTum(const std::string& path) {
  std::ifstream in(path);
  REQUIRE(in);
  std::vector<TumPose> poses;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    TumPose p;
    s >> p.t >> p.x >> p.y >> p.z >> p.qx >> p.qy >> p.qz >> p.qw;
    REQUIRE(s);
    std::string rest;
    CHECK(!(s >> rest));
    poses.push_back(p);
  }
  return poses;
}

// The position RMS of `est` against `truth`, each estimate paired with the
// truth nearest in time (within 5 ms; the frames are 100 ms apart).
double PositionRms(const std::vector<TumPose>& est, const std::vector<TumPose>& truth, int* paired) {
  double sum2 = 0;
  *paired = 0;
  for (const TumPose& e : est) {
    const TumPose* best = nullptr;
    for (const TumPose& g : truth)
      if (!best || std::abs(g.t - e.t) < std::abs(best->t - e.t)) best = &g;
    if (!best || std::abs(best->t - e.t) > 0.005) continue;
    sum2 += std::pow(e.x - best->x, 2) + std::pow(e.y - best->y, 2) + std::pow(e.z - best->z, 2);
    ++*paired;
  }
  return *paired ? std::sqrt(sum2 / *paired) : NAN;
}

TEST_CASE("--tum: the ok rows in metres; their RMS against gt.tum is panoloc's accuracy", "[tum]") {
  const test::SmallCase& c = test::GetSmallCase();
  const std::string dir = Scratch("pipeline_tum");
  PanolocOptions o = test::OneInput(c.video, dir + "/est.csv");
  o.gt = c.gt;
  o.tum = dir + "/est.tum";
  const std::vector<VideoSummary> s = RunPanoloc(o);
  REQUIRE(s.size() == 1);
  INFO(s[0].error);
  REQUIRE(s[0].ok);
  REQUIRE(s[0].has_accuracy);
  CHECK(s[0].tum_output == o.tum);
  CHECK(FilesIn(dir) == std::vector<std::string>{"est.csv", "est.tum"});

  // The map's units are "units": about 5 m across the room (Map::UnitsPerMetre).
  const Map map = ReadMap(c.map);
  const TumConversion conv = TumConversionForMap(map);
  const std::vector<TumPose> est = ReadTum(o.tum);
  const std::vector<TumPose> truth = ReadTum(c.dir + "/gt.tum");
  const std::vector<PoseRow> rows = ReadPoseCsv(o.output);
  REQUIRE(static_cast<int>(est.size()) == s[0].n_ok);
  REQUIRE(static_cast<int>(truth.size()) == c.n_frames);
  // One line per ok row, in order, at its time; z is the sensor's height.
  size_t k = 0;
  for (const PoseRow& r : rows) {
    if (r.status != PoseStatus::kOk) continue;
    REQUIRE(k < est.size());
    CHECK(est[k].t == Approx(r.time_s).margin(1e-6));
    CHECK(est[k].x == Approx(r.pose.x * conv.metres_per_unit).margin(1e-4 * conv.metres_per_unit));
    CHECK(est[k].z == Approx(map.sensor_height * conv.metres_per_unit).epsilon(1e-9));
    CHECK(2 * std::atan2(est[k].qz, est[k].qw) == Approx(r.pose.theta).margin(2e-6));
    ++k;
  }
  // Against gt.csv in metres, the truth panoloc compares with: its RMS.
  std::vector<TumPose> truth_csv;
  for (const PoseRow& g : ReadPoseCsv(c.gt))
    truth_csv.push_back({g.time_s, g.pose.x * conv.metres_per_unit, g.pose.y * conv.metres_per_unit,
                         map.sensor_height * conv.metres_per_unit, 0, 0, 0, 1});
  int paired = 0;
  const double rms_m = PositionRms(est, truth_csv, &paired);
  CHECK(paired == s[0].accuracy.compared);
  // Measured: 0.00777 map units (the smoothing test's figure).
  CHECK(s[0].accuracy.rms == Approx(0.00777).margin(0.0004));
  CHECK(rms_m == Approx(s[0].accuracy.rms * conv.metres_per_unit).epsilon(1e-6));
  // Against gt.tum, as evo computes it: the same (gt.tum holds gt.csv's values).
  int paired_tum = 0;
  const double rms_tum = PositionRms(est, truth, &paired_tum);
  CHECK(paired_tum == paired);
  CHECK(rms_tum == Approx(s[0].accuracy.rms * conv.metres_per_unit).epsilon(1e-6));

  // --tum-scale overrides the map's units.
  PanolocOptions scaled = o;
  scaled.output = dir + "/scaled.csv";
  scaled.tum = dir + "/scaled.tum";
  scaled.tum_scale = 0.01;
  const std::vector<VideoSummary> s2 = RunPanoloc(scaled);
  REQUIRE(s2.size() == 1);
  REQUIRE(s2[0].ok);
  const std::vector<TumPose> est2 = ReadTum(scaled.tum);
  REQUIRE(est2.size() == est.size());
  CHECK(est2[0].x == Approx(est[0].x / conv.metres_per_unit * 0.01).epsilon(1e-6));
  CHECK(est2[0].z == Approx(map.sensor_height * 0.01).epsilon(1e-9));
}

TEST_CASE("--tum: one input, a file, a valid scale; printed after the run", "[tum]") {
  const test::SmallCase& c = test::GetSmallCase();
  const std::string dir = Scratch("pipeline_tum_bad");
  PanolocOptions two = test::OneInput(c.video, "");
  two.inputs.push_back(c.frames);
  two.out_dir = dir + "/out";
  two.tum = dir + "/est.tum";
  CHECK_THROWS_WITH(two.Check(), "--tum (tum): takes one input");
  PanolocOptions o = test::OneInput(c.video, dir + "/est.csv");
  o.tum = "-";
  CHECK_THROWS_WITH(o.Check(),
                    "--tum (tum): expected a file name (the TUM file cannot go to standard output)");
  o.tum = dir + "/est.tum";
  o.tum_scale = -1;
  CHECK_THROWS_WITH(o.Check(), "--tum-scale (tum_scale): expected a positive number of metres per map unit up "
                               "to 1e+06, or 0 for the map's units, got -1");
  o.tum_scale = 1e300;  // coordinates beyond any double once scaled
  CHECK_THROWS_WITH(o.Check(), "--tum-scale (tum_scale): expected a positive number of metres per map unit up "
                               "to 1e+06, or 0 for the map's units, got 1e+300");
  // The TUM file may not overwrite the pose CSV.
  o.tum_scale = 0;
  o.tum = o.output;
  CHECK_THROWS_AS(RunPanoloc(o), Error);
  CHECK(FilesIn(dir).empty());

  std::vector<std::string> argv = {test::Program("panoloc")};
  const std::string out = dir + "/cli";
  std::filesystem::create_directories(out);
  for (const std::string& w :
       test::Words(c.video + " -o " + out + "/cli.csv --tum " + out + "/cli.tum " + c.Args()))
    argv.push_back(w);
  const test::RunResult r = test::Run(argv, dir);
  INFO(r.err);
  CHECK(r.code == 0);
  CHECK(r.out.find("\n  TUM -> " + out + "/cli.tum\n") != std::string::npos);
  CHECK(FilesIn(out) == std::vector<std::string>{"cli.csv", "cli.tum"});
}

}  // namespace
}  // namespace pano
