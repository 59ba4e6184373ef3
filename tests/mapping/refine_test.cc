// Map refinement: the bundle adjustment recovers a surveyed map with errors,
// from exact projections and from a rendered sequence; bad inputs fail with
// one line naming the file.
#include <catch2/catch.hpp>

#include <cmath>
#include <algorithm>
#include <fstream>
#include <map>
#include <random>
#include <string>

#include "expect_error.h"
#include "panotrack/core/atomic_file.h"
#include "panotrack/io/map.h"
#include "panotrack/io/pose_csv.h"
#include "panotrack/lut/radius_table.h"
#include "panotrack/mapping/refine.h"
#include "panotrack/pipeline/panomap.h"
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
  m.surveyed = PerturbedMap(m.truth, m.c.survey.sigma, m.c.survey.seed);
  return m;
}

TEST_CASE("the survey error is seeded and of the size asked", "[refine_perturb]") {
  const MapCase m = MakeMapCase("paper-synthetic-map-error");
  const double rms = CornerRms(m.truth, m.surveyed);
  // 3 coordinates per corner, sigma 1 each: about sqrt(3) (this seed: 1.888).
  CHECK(rms == Approx(1.888).margin(0.001));
  for (size_t k = 0; k < m.truth.rectangles.size(); ++k)
    if (m.truth.rectangles[k].z0 == 0.0) CHECK(m.surveyed.rectangles[k].z0 == 0.0);  // floor contacts
  CHECK(CornerRms(m.surveyed, PerturbedMap(m.truth, 1.0, m.c.survey.seed)) == 0.0);
  CHECK(CornerRms(m.truth, PerturbedMap(m.truth, 1.0, m.c.survey.seed + 1)) > 0.5);
  CHECK(CornerRms(m.truth, PerturbedMap(m.truth, 0.0, 3)) == 0.0);
}

// Exact projections of the true corners (with Gaussian noise: azimuth
// 0.05 deg, radius 0.2 px) from every 5th true pose; the starting poses are
// the truth moved by sigma 0.5 units.
struct Projections {
  std::vector<Pose2> truth, starts;
  std::vector<CornerObservation> obs;
};

Projections Project(const MapCase& m, std::mt19937_64& rng) {
  const Sensor& sensor = m.c.calib.sensor;
  const RadiusTable table = RadiusTable::Build(sensor, RangesForMap(m.truth, sensor));
  const Scene scene = Scene::FromMap(m.truth, false);
  const std::vector<Landmark> landmarks = LandmarksFromMap(m.truth);
  std::normal_distribution<double> az_noise(0.0, 0.05 * M_PI / 180), r_noise(0.0, 0.2), pose_noise(0.0, 0.5);
  Projections p;
  for (size_t i = 0; i < m.c.poses.size(); i += 5) {
    const Pose2& truth = m.c.poses[i];
    for (const PredictedLandmark& l : PredictLandmarks(landmarks, m.truth, scene, sensor, table, truth, {})) {
      const Eigen::Vector3d s = SensorFromWorld(truth, m.truth.sensor_height, l.landmark->corner);
      double radius = 0.0;
      REQUIRE(sensor.image_radius(std::hypot(s.x(), s.y()), s.z(), &radius));
      p.obs.push_back({static_cast<int>(p.starts.size()), l.index,
                       sensor.image_azimuth(std::atan2(s.y(), s.x())) + az_noise(rng), radius + r_noise(rng)});
    }
    p.truth.push_back(truth);
    p.starts.push_back({truth.x + pose_noise(rng), truth.y + pose_noise(rng), truth.theta + 0.002});
  }
  return p;
}

// From exact projections the adjustment takes the surveyed map close to the truth.
TEST_CASE("projections of the true room recover the perturbed map", "[refine_projections]") {
  PANO_SEEDED_RNG(11);
  const MapCase m = MakeMapCase("paper-synthetic-map-error");
  const Projections p = Project(m, rng);
  const std::vector<Pose2>& starts = p.starts;
  REQUIRE(p.obs.size() > 500);
  RefineOptions opt;
  opt.num_threads = 1;
  const RefineResult r = SolveMapRefinement(m.c.calib, m.surveyed, starts, p.obs, opt);
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
  // Gaussian noise alone: next to nothing beyond 4 sigmas.
  CHECK(r.rejected <= 2);
  // The gauge the survey's priors leave (the floor of the raw error): from
  // the map's geometry alone, the same for every run of this map.
  INFO("gauge: shift " << r.gauge_shift_std << " turn " << r.gauge_turn_std << " floor " << r.gauge_corner_rms);
  CHECK(r.gauge_shift_std == Approx(0.2132).epsilon(0.01));
  CHECK(r.gauge_turn_std * 180 / M_PI == Approx(0.1411).epsilon(0.01));
  CHECK(r.gauge_scale_std == 0.0);  // the height is held: no scaling
  CHECK(r.gauge_corner_rms == Approx(0.3693).epsilon(0.01));
  // ... and printed, so that users know it.
  const std::string table = RefineReportTable(r, m.surveyed, opt.map_sigma);
  INFO(table);
  CHECK(table.find("gauge (fixed by the priors alone): shift +- 0.213 units, turn +- 0.141 deg -> corner RMS "
                   "floor 0.369 units") != std::string::npos);
}

// Ceres' threaded Schur elimination sums in an order that varies from run to
// run: the solve keeps to one thread so that the same poses give the same map.
TEST_CASE("a refinement is the same on every run, whatever its thread count", "[refine_repeatable]") {
  PANO_SEEDED_RNG(11);
  const MapCase m = MakeMapCase("paper-synthetic-map-error");
  const Projections p = Project(m, rng);
  RefineOptions opt;
  std::vector<RefineResult> runs;
  for (int threads : {1, 2, 2, 4}) {
    opt.num_threads = threads;
    runs.push_back(SolveMapRefinement(m.c.calib, m.surveyed, p.starts, p.obs, opt));
  }
  auto same = [](double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); };
  for (size_t k = 1; k < runs.size(); ++k) {
    INFO("run " << k);
    REQUIRE(runs[k].map.rectangles.size() == runs[0].map.rectangles.size());
    for (size_t i = 0; i < runs[0].map.rectangles.size(); ++i) {
      const MapRectangle &a = runs[0].map.rectangles[i], &b = runs[k].map.rectangles[i];
      CHECK(a.from == b.from);  // exactly: tolerance zero
      CHECK(a.to == b.to);
      CHECK(a.z0 == b.z0);
      CHECK(a.z1 == b.z1);
      CHECK(same(a.survey_sigma, b.survey_sigma));
    }
    REQUIRE(runs[k].landmarks.size() == runs[0].landmarks.size());
    for (size_t i = 0; i < runs[0].landmarks.size(); ++i) CHECK(runs[k].landmarks[i].std == runs[0].landmarks[i].std);
    CHECK(same(runs[k].map.survey_sigma, runs[0].map.survey_sigma));
    CHECK(runs[k].azimuth_sigma == runs[0].azimuth_sigma);
  }
}

// Poses from an absolute reference (here the truth) with a prior fix the
// gauge: the raw corner error falls to the room's shape error, and the
// reported floor with it.
TEST_CASE("pose priors from a reference fix the gauge", "[refine_pose_prior]") {
  PANO_SEEDED_RNG(11);
  const MapCase m = MakeMapCase("paper-synthetic-map-error");
  const Projections p = Project(m, rng);
  RefineOptions opt;
  opt.num_threads = 1;
  opt.pose_sigma = 0.05;
  const RefineResult r = SolveMapRefinement(m.c.calib, m.surveyed, p.truth, p.obs, opt, &p.starts);
  const double after = CornerRms(m.truth, r.map), shape = CornerRmsAfterGauge(r.map, m.truth);
  INFO("corner RMS " << after << ", after the gauge " << shape << ", floor " << r.gauge_corner_rms);
  CHECK(after == Approx(0.0676).margin(0.005));  // from 0.640 with the survey's gauge
  CHECK(shape < 0.09);
  CHECK(r.gauge_corner_rms == Approx(0.0176).epsilon(0.01));  // from 0.369
  // The priors sit at the given poses, not at the starts.
  double worst = 0.0;
  for (size_t f = 0; f < p.truth.size(); ++f)
    worst = std::max(worst, std::hypot(r.poses[f].x - p.truth[f].x, r.poses[f].y - p.truth[f].y));
  CHECK(worst < 0.1);
  // Poses and starts must match one for one.
  std::vector<Pose2> fewer = p.starts;
  fewer.pop_back();
  test::ExpectError([&] { SolveMapRefinement(m.c.calib, m.surveyed, p.truth, p.obs, opt, &fewer); },
                    "SolveMapRefinement", {"differ in size"});
  opt.pose_sigma = -1.0;
  test::ExpectError([&] { opt.Check(); }, "pose_sigma", {});
}

// RMS distance between the corners' floor positions (x, y) of two maps.
double FloorRms(const Map& a, const Map& b) {
  double sum = 0.0;
  for (size_t k = 0; k < a.rectangles.size(); ++k)
    sum += (a.rectangles[k].from - b.rectangles[k].from).squaredNorm() +
           (a.rectangles[k].to - b.rectangles[k].to).squaredNorm();
  return std::sqrt(sum / (2.0 * static_cast<double>(a.rectangles.size())));
}

// Image radii with a small error that grows with distance (0.003 px per
// unit, a tenth of a pixel over the room), the same in every frame: counted
// as independent over many frames it pulls corners along their lines of
// sight; weighed as one systematic error per corner it pulls them less.
TEST_CASE("a systematic radius error does not move corners in depth", "[refine_radius_systematic]") {
  PANO_SEEDED_RNG(11);
  const MapCase m = MakeMapCase("paper-synthetic-map-error");
  Projections p = Project(m, rng);
  RefineOptions opt;
  opt.num_threads = 1;
  opt.pose_sigma = 0.05;
  const double floor_unbiased = FloorRms(SolveMapRefinement(m.c.calib, m.surveyed, p.truth, p.obs, opt, &p.starts).map, m.truth);
  // Held here: a reference into the vector returned would dangle after its statement.
  const std::vector<Landmark> landmarks = LandmarksFromMap(m.truth);
  for (CornerObservation& o : p.obs) {
    const Eigen::Vector3d& c = landmarks[static_cast<size_t>(o.landmark)].corner;
    const Pose2& at = p.truth[static_cast<size_t>(o.frame)];
    o.radius += 0.003 * std::hypot(c.x() - at.x, c.y() - at.y);
  }
  const RefineResult weighed = SolveMapRefinement(m.c.calib, m.surveyed, p.truth, p.obs, opt, &p.starts);
  opt.radius_systematic_px = 0.0;
  const RefineResult independent = SolveMapRefinement(m.c.calib, m.surveyed, p.truth, p.obs, opt, &p.starts);
  const double floor_weighed = FloorRms(weighed.map, m.truth), floor_independent = FloorRms(independent.map, m.truth);
  INFO("floor plan RMS: " << floor_unbiased << " unbiased; biased: " << floor_weighed << " weighed as systematic, "
                          << floor_independent << " as independent");
  CHECK(floor_unbiased == Approx(0.054).margin(0.005));
  CHECK(floor_weighed == Approx(0.0995).margin(0.008));      // the bias's pull, bounded
  CHECK(floor_independent == Approx(0.173).margin(0.012));  // 1.7x as far
  CHECK(CornerRms(weighed.map, m.truth) < CornerRms(independent.map, m.truth));
  opt.radius_systematic_px = -0.1;
  test::ExpectError([&] { opt.Check(); }, "radius_systematic_px", {});
}

// --pose-sigma auto: poses without standard deviations (ground truth,
// motion capture) are a reference; panoloc's (with them) are not.
TEST_CASE("reference trajectories are told from localised ones", "[refine_pose_prior]") {
  PoseRow reference;
  reference.pose = {1.0, 2.0, 0.5};
  PoseRow localised = reference;
  localised.extra = {0.01, 0.02, 0.001, 0.4};
  PoseRow lost;
  lost.status = PoseStatus::kLost;
  lost.extra = {std::nan(""), std::nan(""), std::nan(""), 0.0};
  CHECK(IsReferenceTrajectory({reference, reference}));
  CHECK(!IsReferenceTrajectory({reference, localised}));
  CHECK(IsReferenceTrajectory({reference, lost}));  // a lost row's empty stds say nothing
  const RefineVideo ref_video{"a.mp4", "a.csv", {reference}}, loc_video{"b.mp4", "b.csv", {localised}};
  CHECK(AutoPoseSigma({ref_video, ref_video}, 2.0) == Approx(0.2));
  CHECK(AutoPoseSigma({ref_video, loc_video}, 2.0) == 0.0);
  CHECK(AutoPoseSigma({}, 2.0) == 0.0);
}

// A tracker that locked onto a neighbouring edge for a run of frames: one
// corner's azimuths all off by 0.5 deg (10 noise sigmas) on a third of its
// views. The Huber loss alone lets the run pull the corner; the outliers
// are dropped and the corner comes back.
TEST_CASE("a run of biased measurements is dropped", "[refine_outliers]") {
  PANO_SEEDED_RNG(11);
  const MapCase m = MakeMapCase("paper-synthetic-map-error");
  Projections p = Project(m, rng);
  std::map<int, int> views;
  for (const CornerObservation& o : p.obs) ++views[o.landmark];
  const int target = std::max_element(views.begin(), views.end(), [](auto& a, auto& b) {
                       return a.second < b.second;
                     })->first;  // the corner seen most
  std::vector<size_t> run;  // every 3rd view of it
  for (size_t i = 0, seen = 0; i < p.obs.size(); ++i)
    if (p.obs[i].landmark == target && seen++ % 3 == 0) run.push_back(i);
  const int biased = static_cast<int>(run.size());
  REQUIRE(biased > 10);
  RefineOptions opt;
  opt.num_threads = 1;
  const RefineResult clean = SolveMapRefinement(m.c.calib, m.surveyed, p.starts, p.obs, opt);
  for (size_t i : run) p.obs[i].azimuth += 0.5 * M_PI / 180;
  const RefineResult r = SolveMapRefinement(m.c.calib, m.surveyed, p.starts, p.obs, opt);
  opt.reject_sigmas = 1e6;  // keep everything: the Huber loss alone
  const RefineResult kept = SolveMapRefinement(m.c.calib, m.surveyed, p.starts, p.obs, opt);
  // The corner against where the clean measurements put it.
  const auto corner = [&](const RefineResult& x) {
    return LandmarksFromMap(x.map)[static_cast<size_t>(target)].corner;
  };
  const double moved = (corner(r) - corner(clean)).norm(), pulled = (corner(kept) - corner(clean)).norm();
  INFO("landmark " << target << ": biased " << biased << "; rejected " << r.rejected << " (clean "
                   << clean.rejected << "); moved " << moved << " (kept: " << pulled << ")");
  CHECK(r.rejected >= biased);
  CHECK(r.rejected <= biased + clean.rejected + 2);
  CHECK(kept.rejected == 0);
  CHECK(moved < 0.008);  // measured 0.0045
  CHECK(pulled == Approx(0.0265).margin(0.003));  // 6x as far
}

// Renders every `stride`th frame of a map-error case as PNG frames (no video
// codec needed), with the preset's survey error unless `survey` is given.
std::string RenderShort(const std::string& preset, int stride, int count, SequenceCase* out,
                        const SurveyError* survey = nullptr) {
  SequenceCase c = MakePreset(preset);
  if (survey) c.survey = *survey;
  std::vector<Pose2> poses;
  for (int i = 0; i < count; ++i) poses.push_back(c.poses[static_cast<size_t>(i * stride)]);
  c.poses = poses;
  const std::string dir = test::ScratchDir("refine") + "/seq";
  SequenceWriteOptions wo;
  wo.frames = true;
  wo.video = false;
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
  // Measured 1.888 -> 0.644, as from exact projections: what is left is the
  // gauge the survey's priors fix (reported floor 0.369). The room's shape:
  // 1.766 -> 0.104 on these 40 frames (0.084 on all 300 of the sequence).
  CHECK(before == Approx(1.888).margin(0.001));
  CHECK(after == Approx(0.644).margin(0.02));
  CHECK(shape == Approx(0.089).margin(0.01));
  CHECK(r.gauge_corner_rms == Approx(0.3693).epsilon(0.01));
  // Views of a corner next to another landmark's edge are skipped, and the
  // measurements beyond 4 noise sigmas dropped: a few percent of each.
  INFO("crowded " << r.crowded << ", rejected " << r.rejected << " of " << 2 * r.measurements);
  CHECK(r.crowded > 0);
  CHECK(r.crowded < r.measurements / 4);
  CHECK(r.rejected > 0);
  CHECK(r.rejected < r.measurements / 5);
}

TEST_CASE("floor contacts left free may go below the floor and refine on", "[refine_floor]") {
  // With the contacts free, a rectangle standing on the floor is estimated a
  // little above or below it; the next pass predicts and tracks it there.
  SequenceCase c;
  SurveyError survey;
  survey.sigma = 0.5;
  survey.seed = 3;
  const std::string dir = RenderShort("paper-real-map-error", 10, 30, &c, &survey);
  const Map surveyed = ReadMap(dir + "/map.yaml"), truth = ReadMap(dir + "/map_true.yaml");
  RefineVideo v{dir + "/frames/frame_%04d.png", dir + "/gt.csv", ReadPoseCsv(dir + "/gt.csv")};
  RefineOptions opt;
  opt.map_sigma = 0.5;
  opt.hold_floor_contacts = false;
  opt.passes = 3;
  opt.num_threads = 2;
  opt.tracking.num_threads = 2;
  RefineResult r;
  REQUIRE_NOTHROW(r = RefineMap(c.calib, surveyed, {v}, opt));
  double lowest = 0.0;
  for (const MapRectangle& rect : r.map.rectangles) lowest = std::min(lowest, rect.z0);
  INFO("lowest corner " << lowest << ", corner RMS " << CornerRms(truth, surveyed) << " -> "
                        << CornerRms(truth, r.map));
  CHECK(lowest < 0.0);    // the case this test is about
  CHECK(lowest > -1.0);   // a hair, not a fault
  CHECK(CornerRms(truth, r.map) < CornerRms(truth, surveyed));
  CheckMap(r.map, "refined");
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
  // --pose-sigma is auto or a number.
  const test::CommandRun sigma = test::RunProgram("panomap refine --map " + dir + "/map.yaml --calib " + dir +
                                                  "/calib.yaml --poses " + dir + "/gt.csv " + frames +
                                                  " -o " + dir + "/out.yaml --pose-sigma often");
  CHECK(sigma.code == 1);
  CHECK(sigma.out.find("--pose-sigma: expected auto or a number of 0 or more, got 'often'") != std::string::npos);
}

TEST_CASE("refine job: the map's own sigma, the refined map and report written, the survey kept",
          "[refine_job]") {
  SequenceCase c;
  const std::string dir = RenderShort("paper-synthetic-map-error", 10, 8, &c);
  const std::string map_before = ReadFile(dir + "/map.yaml");
  const Map surveyed = ReadMap(dir + "/map.yaml");
  REQUIRE(surveyed.survey_sigma > 0.0);
  MapRefineJob job;
  job.map_path = dir + "/map.yaml";
  job.calib_path = dir + "/calib.yaml";
  job.videos = {dir + "/frames/frame_%04d.png"};
  job.poses = {dir + "/gt.csv"};
  job.output = dir + "/refined.yaml";
  job.report_csv = dir + "/refined.csv";
  job.options.num_threads = job.options.tracking.num_threads = 2;
  const MapRefineRun run = RunMapRefine(job);
  // No --map-sigma: the map's statement; gt.csv is a reference trajectory
  // (no standard deviations), so its positions are held (AutoPoseSigma).
  CHECK(run.options.map_sigma == surveyed.survey_sigma);
  CHECK(run.options.pose_sigma > 0.0);
  CHECK(run.result.frames_used >= 7);  // measured 7 of the 8
  CHECK(CornerRms(ReadMap(job.output), run.result.map) < 1e-4);  // as written: 4 decimals
  CHECK(std::ifstream(job.report_csv).good());
  CHECK(ReadFile(job.map_path) == map_before);

  // Given sigmas are used as given.
  job.map_sigma = 2.5;
  job.pose_sigma = 0.0;
  job.overwrite = true;
  const MapRefineRun given = RunMapRefine(job);
  CHECK(given.options.map_sigma == 2.5);
  CHECK(given.options.pose_sigma == 0.0);

  // One pose CSV per video, and the outputs kept unless overwriting.
  job.poses.clear();
  test::ExpectError([&] { RunMapRefine(job); }, "--poses", {"0 pose CSVs for 1 videos"});
  job.poses = {dir + "/gt.csv"};
  job.overwrite = false;
  test::ExpectError([&] { RunMapRefine(job); }, job.output, {"exists"});
}

}  // namespace
}  // namespace pano
