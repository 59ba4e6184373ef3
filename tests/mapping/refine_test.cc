// Map refinement: the bundle adjustment recovers a surveyed map with errors,
// from exact projections and from a rendered sequence; bad inputs fail with
// one line naming the file.
#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <random>
#include <string>

#include "expect_error.h"
#include "panotrack/io/map.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/lut/radius_table.h"
#include "panotrack/mapping/refine.h"
#include "panotrack/render/presets.h"
#include "panotrack/render/sequence.h"
#include "panotrack/render/writers.h"
#include "panotrack/scene/scene.h"
#include "run_command.h"
#include "test_paths.h"
#include "test_rng.h"

namespace pano {
namespace {

// Every 5th pose of a preset with map error, its true and surveyed maps.
struct MapCase {
  SequenceCase c;
  Map truth, surveyed;
};

MapCase MakeMapCase(const std::string& preset) {
  MapCase m{MakePreset(preset), {}, {}};
  m.truth = m.c.map;
  m.truth.distractors.clear();
  m.surveyed = PerturbedMap(m.truth, m.c.map_sigma, m.c.map_seed);
  return m;
}

TEST_CASE("the survey error is seeded and of the size asked", "[refine_perturb]") {
  const MapCase m = MakeMapCase("paper-synthetic-map-error");
  const double rms = CornerRms(m.truth, m.surveyed);
  // 3 coordinates per corner, sigma 1 each: about sqrt(3) (this seed: 1.888).
  CHECK(rms == Approx(1.888).margin(0.001));
  for (size_t k = 0; k < m.truth.rectangles.size(); ++k)
    if (m.truth.rectangles[k].z0 == 0.0) CHECK(m.surveyed.rectangles[k].z0 == 0.0);  // floor contacts
  CHECK(CornerRms(m.surveyed, PerturbedMap(m.truth, 1.0, m.c.map_seed)) == 0.0);
  CHECK(CornerRms(m.truth, PerturbedMap(m.truth, 1.0, m.c.map_seed + 1)) > 0.5);
  CHECK(CornerRms(m.truth, PerturbedMap(m.truth, 0.0, 3)) == 0.0);
}

// Exact projections of the true corners (with small Gaussian noise) from
// every 5th pose: the adjustment takes the surveyed map close to the truth.
TEST_CASE("projections of the true room recover the perturbed map", "[refine_projections]") {
  PANO_SEEDED_RNG(11);
  const MapCase m = MakeMapCase("paper-synthetic-map-error");
  const Sensor& sensor = m.c.calib.sensor;
  const RadiusTable table = RadiusTable::Build(sensor, RangesForMap(m.truth, sensor));
  const Scene scene = Scene::FromMap(m.truth, false);
  const std::vector<Landmark> landmarks = LandmarksFromMap(m.truth);
  std::normal_distribution<double> az_noise(0.0, 0.05 * M_PI / 180), r_noise(0.0, 0.2), pose_noise(0.0, 0.5);
  std::vector<Pose2> starts;
  std::vector<CornerObservation> obs;
  for (size_t i = 0; i < m.c.poses.size(); i += 5) {
    const Pose2& truth = m.c.poses[i];
    for (const PredictedLandmark& p : PredictLandmarks(landmarks, m.truth, scene, sensor, table, truth, {})) {
      const Eigen::Vector3d s = sensor_from_world(truth, m.truth.sensor_height, p.landmark->corner);
      double radius = 0.0;
      REQUIRE(sensor.image_radius(std::hypot(s.x(), s.y()), s.z(), &radius));
      obs.push_back({static_cast<int>(starts.size()), p.index,
                     sensor.image_azimuth(std::atan2(s.y(), s.x())) + az_noise(rng), radius + r_noise(rng)});
    }
    starts.push_back({truth.x + pose_noise(rng), truth.y + pose_noise(rng), truth.theta + 0.002});
  }
  REQUIRE(obs.size() > 500);
  RefineOptions opt;
  opt.num_threads = 1;
  const RefineResult r = SolveMapRefinement(m.c.calib, m.surveyed, starts, obs, opt);
  const double before = CornerRms(m.truth, m.surveyed), after = CornerRms(m.truth, r.map);
  INFO("corner RMS " << before << " -> " << after);
  CHECK(before == Approx(1.888).margin(0.001));
  // Measured 0.640: the gauge (a shift and turn the images cannot see) is
  // fixed by the survey's priors, whose mean error this map inherits. The
  // shape of the room, the rest, comes out to 0.073 (from 1.766).
  CHECK(after == Approx(0.640).margin(0.02));
  CHECK(CornerRmsAfterGauge(m.surveyed, m.truth) == Approx(1.766).margin(0.002));
  CHECK(CornerRmsAfterGauge(r.map, m.truth) < 0.09);
  CHECK(r.covariance_ok);
  CHECK(r.frames_used == static_cast<int>(starts.size()));
  // Noise estimates near the noise added (robust scale of the residuals).
  CHECK(r.azimuth_sigma * 180 / M_PI == Approx(0.05).epsilon(0.2));
  CHECK(r.radius_sigma == Approx(0.2).epsilon(0.2));
  for (const LandmarkCorrection& l : r.landmarks) {
    CHECK(l.observations > 0);
    for (double s : l.std) CHECK((s >= 0.0 && s < opt.map_sigma));  // 0: z0 held on the floor
  }
}

// Renders every 3rd frame of a map-error case as PNG frames (no video codec needed).
std::string RenderShort(const std::string& preset, int stride, int count, SequenceCase* out) {
  SequenceCase c = MakePreset(preset);
  std::vector<Pose2> poses;
  for (int i = 0; i < count; ++i) poses.push_back(c.poses[static_cast<size_t>(i * stride)]);
  c.poses = poses;
  const std::string dir = test::ScratchDir("refine") + "/seq";
  SequenceWriteOptions wo;
  wo.frames = true;
  wo.video = false;
  wo.quiet = true;
  WriteSequence(c, dir, wo);
  *out = c;
  return dir;
}

TEST_CASE("a rendered sequence recovers the perturbed map", "[refine_rendered]") {
  SequenceCase c;
  const std::string dir = RenderShort("paper-synthetic-map-error", 5, 40, &c);
  const Map surveyed = ReadMap(dir + "/map.yaml"), truth = ReadMap(dir + "/map_true.yaml");
  RefineVideo v{dir + "/frames/frame_%04d.png", dir + "/gt.csv", ReadPoseCsv(dir + "/gt.csv")};
  // Start from poses a little off the truth, as a localiser gives them.
  for (PoseRow& row : v.poses) {
    row.pose.x += 0.3;
    row.pose.theta -= 0.002;
  }
  RefineOptions opt;
  opt.num_threads = 2;
  opt.tracking.num_threads = 2;
  const RefineResult r = RefineMap(c.calib, surveyed, {v}, opt);
  const double before = CornerRms(truth, surveyed), after = CornerRms(truth, r.map);
  const double shape = CornerRmsAfterGauge(r.map, truth);
  INFO("corner RMS " << before << " -> " << after << ", after the gauge " << shape);
  CHECK(r.frames_used == 40);
  // Measured 1.888 -> 0.641, as from exact projections: what is left is the
  // gauge the survey's priors fix. The room's shape: 1.766 -> 0.077.
  CHECK(before == Approx(1.888).margin(0.001));
  CHECK(after == Approx(0.641).margin(0.02));
  CHECK(shape < 0.09);
}

TEST_CASE("bad inputs fail with one line naming the file", "[refine_bad_input]") {
  SequenceCase c;
  const std::string dir = RenderShort("paper-synthetic-map-error", 10, 8, &c);
  const Map surveyed = ReadMap(dir + "/map.yaml");
  const std::string frames = dir + "/frames/frame_%04d.png";
  RefineOptions opt;
  opt.num_threads = 1;
  // A pose CSV with a row missing.
  RefineVideo v{frames, dir + "/gt.csv", ReadPoseCsv(dir + "/gt.csv")};
  v.poses.pop_back();
  test::ExpectError([&] { RefineMap(c.calib, surveyed, {v}, opt); }, dir + "/gt.csv",
                    {"7 pose rows for the 8 frames"});
  // A map whose only rectangle has no contrast with the wall: nothing in view.
  Map blank = surveyed;
  blank.rectangles.resize(1);
  blank.rectangles[0].shade = blank.room.wall_shade;
  v.poses = ReadPoseCsv(dir + "/gt.csv");
  test::ExpectError([&] { RefineMap(c.calib, blank, {v}, opt); }, frames, {"no landmark of the map was found"});
  // The program refuses to write over its input map, even with --force.
  for (const char* force : {"", " --force"}) {
    const test::CommandRun run = test::RunProgram("panomap refine --map " + dir + "/map.yaml --calib " + dir +
                                                  "/calib.yaml --poses " + dir + "/gt.csv " + frames + " -o " +
                                                  dir + "/map.yaml" + force);
    CHECK(run.code == 1);
    CHECK(test::CountLines(run.out) == 1);
    CHECK(run.out.find(dir + "/map.yaml") != std::string::npos);
  }
  // One pose CSV per video.
  const test::CommandRun run = test::RunProgram("panomap refine --map " + dir + "/map.yaml --calib " + dir +
                                                "/calib.yaml --poses " + dir + "/gt.csv " + frames + " " + frames +
                                                " -o " + dir + "/out.yaml");
  CHECK(run.code == 1);
  CHECK(run.out.find("--poses: 1 pose CSVs for 2 videos") != std::string::npos);
}

}  // namespace
}  // namespace pano
