// Robust pose: the minimal solvers are exact and report degenerate
// configurations, the consensus loop recovers the pose among gross outliers
// where the plain least-squares solve does not, the chi-square functions
// match the tables, and the integrity check passes consistent solutions and
// fails biased ones.
#include <catch2/catch.hpp>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

#include "panotrack/core/angles.h"
#include "panotrack/pose/robust_pose.h"
#include "observe.h"
#include "test_rng.h"

namespace pano {
namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr double kDeg = M_PI / 180;

using test::Observe;

double PositionError(const Pose2& a, const Pose2& b) { return std::hypot(a.x - b.x, a.y - b.y); }
double HeadingError(const Pose2& a, const Pose2& b) { return std::abs(WrapAngle(a.theta - b.theta)); }

// Random landmarks in a 200 x 200 room, at least 10 units from the camera.
std::vector<Eigen::Vector2d> RandomLandmarks(std::mt19937_64& rng, const Pose2& pose, int n) {
  std::uniform_real_distribution<double> room(0.0, 200.0);
  std::vector<Eigen::Vector2d> lms;
  while (static_cast<int>(lms.size()) < n) {
    const double ly = room(rng), lx = room(rng);  // (drawn in a set order: a call's argument order is the compiler's)
    const Eigen::Vector2d l(lx, ly);
    if (std::hypot(l.x() - pose.x, l.y() - pose.y) > 10.0) lms.push_back(l);
  }
  return lms;
}

Pose2 RandomPose(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> inner(40.0, 160.0), heading(-M_PI, M_PI);
  return {inner(rng), inner(rng), heading(rng)};
}

// How far (relative to its radius) the camera is from the circle through
// the three landmarks: the resection's one degenerate locus.
double DangerCircleMargin(const Pose2& pose, const Eigen::Vector2d l[3]) {
  const Eigen::Vector2d a = l[1] - l[0], b = l[2] - l[0];
  const double d = 2 * (a.x() * b.y() - a.y() * b.x());
  const Eigen::Vector2d centre =
      l[0] + Eigen::Vector2d(b.y() * a.squaredNorm() - a.y() * b.squaredNorm(),
                             a.x() * b.squaredNorm() - b.x() * a.squaredNorm()) / d;
  const double radius = (l[0] - centre).norm();
  return std::abs((Eigen::Vector2d(pose.x, pose.y) - centre).norm() - radius) / radius;
}

TEST_CASE("three bearings give the exact pose", "[minimal]") {
  PANO_SEEDED_RNG(7);
  const int trials = 20000;
  int solved = 0, well_posed = 0;
  double worst_position = 0.0, worst_heading = 0.0, worst_vs_long_double = 0.0;
  for (int t = 0; t < trials; ++t) {
    const Pose2 truth = RandomPose(rng);
    const auto lms = RandomLandmarks(rng, truth, 3);
    const auto obs = Observe(truth, lms);
    const Eigen::Vector2d l[3] = {lms[0], lms[1], lms[2]};
    const std::vector<Pose2> poses = SolvePoseFrom3Bearings(obs.data());
    REQUIRE(poses.size() <= 1);
    // Away from the danger circle (1 % of its radius) a solution must come
    // back, exact to rounding of the room's size (position) and heading.
    const bool posed = DangerCircleMargin(truth, l) > 0.01;
    well_posed += posed;
    if (posed) REQUIRE(poses.size() == 1);
    if (poses.empty()) continue;
    ++solved;
    if (!posed) continue;
    worst_position = std::max(worst_position, PositionError(poses[0], truth) / 200.0);
    worst_heading = std::max(worst_heading, HeadingError(poses[0], truth));
    // The same template in long double agrees with the double solve.
    const Eigen::Matrix<long double, 2, 1> ll[3] = {l[0].cast<long double>(), l[1].cast<long double>(),
                                                    l[2].cast<long double>()};
    const long double lb[3] = {obs[0].bearing, obs[1].bearing, obs[2].bearing};
    Eigen::Matrix<long double, 3, 1> pl;
    REQUIRE(SolvePoseFrom3BearingsT<long double>(ll, lb, &pl) == 1);
    worst_vs_long_double = std::max(
        worst_vs_long_double,
        double(std::hypot(pl.x() - (long double)poses[0].x, pl.y() - (long double)poses[0].y)) / 200.0);
  }
  WARN("3-bearing resection, " << trials << " random configurations: " << well_posed
                               << " well posed, " << solved << " solved; worst relative position error "
                               << worst_position << ", heading " << worst_heading
                               << " rad; double vs long double " << worst_vs_long_double);
  CHECK(well_posed > 0.95 * trials);
  // Measured near 2e-13 and 4e-13 (about 1000 ulps): well inside 1e-9.
  CHECK(worst_position < 1e-11);
  CHECK(worst_heading < 1e-11);
  CHECK(worst_vs_long_double < 1e-11);
}

TEST_CASE("the resection in float is exact to float precision", "[minimal]") {
  const Pose2 truth{100, 80, 2.0};
  const std::vector<Eigen::Vector2d> lms = {{10, 20}, {180, 40}, {90, 190}};
  const auto obs = Observe(truth, lms);
  Eigen::Vector2f l[3];
  float b[3];
  for (int i = 0; i < 3; ++i) {
    l[i] = lms[i].cast<float>();
    b[i] = float(obs[i].bearing);
  }
  Eigen::Vector3f p;
  REQUIRE(SolvePoseFrom3BearingsT<float>(l, b, &p, 1e-5f) == 1);
  const float feps = std::numeric_limits<float>::epsilon();
  CHECK(std::hypot(p.x() - 100.0, p.y() - 80.0) < 1000 * feps * 200);
  CHECK(std::abs(WrapAngle(p.z() - 2.0)) < 1000 * feps);
}

TEST_CASE("two bearings and a known heading give the exact position", "[minimal]") {
  PANO_SEEDED_RNG(8);
  double worst = 0.0;
  int solved = 0;
  for (int t = 0; t < 20000; ++t) {
    const Pose2 truth = RandomPose(rng);
    const auto obs = Observe(truth, RandomLandmarks(rng, truth, 2));
    Pose2 pose;
    // Lines at least 1 degree from parallel.
    if (std::abs(std::sin(obs[1].bearing - obs[0].bearing)) < std::sin(1 * kDeg)) continue;
    REQUIRE(SolvePoseFrom2Bearings(obs.data(), truth.theta, &pose));
    ++solved;
    worst = std::max(worst, PositionError(pose, truth) / 200.0);
    CHECK(pose.theta == truth.theta);
  }
  WARN("2-bearing with heading: " << solved << " solved, worst relative position error " << worst);
  CHECK(worst < 1e-12);  // measured 3e-14
}

TEST_CASE("degenerate minimal configurations give no solution", "[minimal_degenerate]") {
  // Camera on the circle through the three landmarks (centre (100, 100),
  // radius 50): every point of that circle sees the same angles.
  const Pose2 on_circle{100 + 50 * std::cos(0.3), 100 + 50 * std::sin(0.3), 0.4};
  const std::vector<Eigen::Vector2d> circle = {{150, 100}, {100, 150}, {50, 100}};
  CHECK(SolvePoseFrom3Bearings(Observe(on_circle, circle).data()).empty());
  // Off the circle by 5 % of its radius the same landmarks are fine.
  const Pose2 off_circle{100 + 47.5 * std::cos(0.3), 100 + 47.5 * std::sin(0.3), 0.4};
  const auto off = SolvePoseFrom3Bearings(Observe(off_circle, circle).data());
  REQUIRE(off.size() == 1);
  CHECK(PositionError(off[0], off_circle) < 1e-9 * 200);
  // Landmarks on one line through the camera.
  const Pose2 on_line{100, 100, 0.0};
  CHECK(SolvePoseFrom3Bearings(Observe(on_line, {{20, 20}, {50, 50}, {150, 150}}).data()).empty());
  // Coincident landmarks.
  CHECK(SolvePoseFrom3Bearings(Observe(on_line, {{20, 20}, {20, 20}, {20, 20}}).data()).empty());
  // Inconsistent bearings: one ray reversed (the same lines) has no pose
  // with every landmark in front.
  auto reversed = Observe(on_line, {{20, 180}, {180, 150}, {120, 10}});
  REQUIRE(SolvePoseFrom3Bearings(reversed.data()).size() == 1);
  reversed[1].bearing = WrapAngle(reversed[1].bearing + M_PI);
  CHECK(SolvePoseFrom3Bearings(reversed.data()).empty());
  // Two bearings: parallel lines, or a landmark behind.
  Pose2 pose;
  auto pair = Observe(on_line, {{150, 100}, {50, 100}});
  CHECK_FALSE(SolvePoseFrom2Bearings(pair.data(), 0.0, &pose));
  pair = Observe(on_line, {{150, 120}, {60, 160}});
  CHECK(SolvePoseFrom2Bearings(pair.data(), 0.0, &pose));
  CHECK_FALSE(SolvePoseFrom2Bearings(pair.data(), M_PI, &pose));
}

TEST_CASE("the bearing residual's Jacobian matches finite differences", "[jacobian]") {
  PANO_SEEDED_RNG(9);
  double worst = 0.0;
  for (int t = 0; t < 1000; ++t) {
    const Pose2 pose = RandomPose(rng);
    auto obs = Observe(pose, RandomLandmarks(rng, pose, 1));
    obs[0].bearing += 0.01;
    Eigen::Vector3d j;
    const double r = BearingResidual(obs[0], pose, &j);
    CHECK(r == Approx(-0.01).epsilon(1e-9));
    const double h = 1e-6;
    for (int k = 0; k < 3; ++k) {
      Pose2 plus = pose, minus = pose;
      (&plus.x)[k] += h;
      (&minus.x)[k] -= h;
      const double fd = (BearingResidual(obs[0], plus) - BearingResidual(obs[0], minus)) / (2 * h);
      worst = std::max(worst, std::abs(fd - j[k]) / std::max(std::abs(j[k]), 1e-3));
    }
  }
  WARN("bearing Jacobian vs central differences: worst relative difference " << worst);
  CHECK(worst < 1e-6);
}


// Bearings with Gaussian noise and `outliers` of them off by 5 to 40
// degrees (either sign): wrong junctions. Returns the outliers' indices.
std::vector<int> Corrupt(std::mt19937_64& rng, double sigma, int outliers,
                         std::vector<BearingObservation>* obs) {
  std::normal_distribution<double> noise(0.0, sigma);
  std::uniform_real_distribution<double> gross(5 * kDeg, 40 * kDeg);
  for (auto& o : *obs) o.bearing += noise(rng);
  std::vector<int> bad;
  while (static_cast<int>(bad.size()) < outliers) {
    const int i = static_cast<int>(rng() % obs->size());
    if (std::find(bad.begin(), bad.end(), i) != bad.end()) continue;
    (*obs)[i].bearing = WrapAngle((*obs)[i].bearing + (rng() % 2 ? 1 : -1) * gross(rng));
    bad.push_back(i);
  }
  std::sort(bad.begin(), bad.end());
  return bad;
}

double MsacCostOf(const std::vector<BearingObservation>& obs, const Pose2& pose) {
  const double tau2 = std::pow(RobustPoseOptions().inlier_threshold, 2);
  double cost = 0.0;
  for (const auto& o : obs) cost += std::min(std::pow(BearingResidual(o, pose), 2), tau2);
  return cost;
}

std::vector<int> Complement(int n, const std::vector<int>& bad) {
  std::vector<int> good;
  for (int i = 0; i < n; ++i)
    if (std::find(bad.begin(), bad.end(), i) == bad.end()) good.push_back(i);
  return good;
}

TEST_CASE("gross outliers: the consensus loop finds the inliers, the plain solve does not",
          "[robust]") {
  PANO_SEEDED_RNG(10);
  const double sigma = 0.05 * kDeg;
  const int trials = 600;
  int weak_geometry = 0, posed = 0;
  int robust_exact_inliers = 0, robust_at_oracle = 0, plain_ok = 0, plain_far = 0, plain_failed = 0;
  double worst_robust_vs_oracle = 0.0, sum_oracle_err2 = 0.0, sum_robust_err2 = 0.0;
  double worst_robust_err = 0.0;
  for (int t = 0; t < trials; ++t) {
    const Pose2 truth = RandomPose(rng);
    const int n = 6 + static_cast<int>(rng() % 7);          // 6 to 12 landmarks
    // 1 to 3 outliers, at least 4 inliers: with 3 only, any triple fits as
    // well as the true one and the pose is not identifiable.
    const int outliers = std::min(1 + static_cast<int>(rng() % 3), n - 4);
    auto obs = Observe(truth, RandomLandmarks(rng, truth, n));
    const std::vector<int> bad = Corrupt(rng, sigma, outliers, &obs);
    // The tracker's prediction 30 degrees off in heading.
    const Pose2 prior{truth.x, truth.y, truth.theta + 30 * kDeg};
    // The oracle: the plain solve on the true inliers, started at the truth.
    // Where even it finds the geometry degenerate (by its eigenvalue
    // test) the trial says nothing about robustness.
    std::vector<BearingObservation> clean;
    for (int i : Complement(n, bad)) clean.push_back(obs[i]);
    const TriangulationResult oracle = Triangulate(clean, truth);
    if (!oracle.ok) {
      ++weak_geometry;
      continue;
    }
    ++posed;
    const RobustTriangulationResult r = RobustTriangulate(obs, prior);
    INFO("trial " << t << ": " << r.failure);
    REQUIRE(r.ok);
    robust_exact_inliers += r.inliers == Complement(n, bad);
    // Where the inliers found are not the true ones, the consensus found
    // fits the bearings better than the truth's (an outlier that happens to
    // agree with a wrong pose): the search did not miss the true set.
    CHECK(r.best_cost <= (1 + 1e-9) * MsacCostOf(obs, oracle.pose));
    const double vs_oracle = PositionError(r.pose, oracle.pose);
    robust_at_oracle += vs_oracle < 1e-9 * 200;
    worst_robust_vs_oracle = std::max(worst_robust_vs_oracle, vs_oracle);
    sum_oracle_err2 += std::pow(PositionError(oracle.pose, truth), 2);
    sum_robust_err2 += std::pow(PositionError(r.pose, truth), 2);
    worst_robust_err = std::max(worst_robust_err, PositionError(r.pose, truth));
    const TriangulationResult plain = Triangulate(obs, prior);
    if (!plain.ok) {
      ++plain_failed;
    } else {
      ++plain_ok;
      plain_far += PositionError(plain.pose, truth) > 1.0;  // > 1 map unit
    }
  }
  const double oracle_rms = std::sqrt(sum_oracle_err2 / posed);
  const double robust_rms = std::sqrt(sum_robust_err2 / posed);
  CHECK(posed - robust_exact_inliers <= 2);  // measured 1 in 600
  CHECK(robust_at_oracle == robust_exact_inliers);
  CHECK(oracle_rms < 0.12);  // measured 0.111 map units: the noise level
  CHECK(plain_far + plain_failed >= 100);  // measured 134 + 3
  WARN(trials << " trials (" << weak_geometry << " too weak for the oracle), 6-12 landmarks, 1-3 outliers of 5-40 deg, 0.05 deg noise, prior 30 deg off:"
              << "\n  robust: exact inlier set " << robust_exact_inliers << ", at the oracle's pose "
              << robust_at_oracle << ", position RMS " << robust_rms << " (oracle " << oracle_rms
              << "), worst " << worst_robust_err << ", worst vs oracle " << worst_robust_vs_oracle
              << "\n  plain Triangulate: failed " << plain_failed << ", ok " << plain_ok
              << " of which > 1 unit off " << plain_far);
}


// Corners of rectangles around a 200 x 200 room (as triangulate_test.cc).
const std::vector<Eigen::Vector2d> kLandmarks = {{0, 60},   {0, 95},   {40, 200}, {75, 200},
                                                 {200, 130}, {200, 90}, {150, 0},  {110, 0}};

TEST_CASE("a prior 30 degrees off and two outliers: the plain solve is biased, the robust one exact",
          "[robust]") {
  const Pose2 truth{100, 100, 0.3};
  auto obs = Observe(truth, kLandmarks);
  // Both corners of one rectangle mistracked.
  obs[2].bearing += 20 * kDeg;
  obs[3].bearing += 30 * kDeg;
  const Pose2 prior{truth.x, truth.y, truth.theta + 30 * kDeg};
  const TriangulationResult plain = Triangulate(obs, prior);
  const RobustTriangulationResult robust = RobustTriangulate(obs, prior);
  REQUIRE(robust.ok);
  WARN("plain: ok " << plain.ok << " '" << plain.failure << "' position error "
                    << PositionError(plain.pose, truth) << ", heading error "
                    << HeadingError(plain.pose, truth) / kDeg << " deg, inliers " << plain.inliers.size()
                    << "; robust: position error " << PositionError(robust.pose, truth)
                    << ", inliers " << robust.inliers.size() << ", hypotheses " << robust.hypotheses
                    << ", refinements " << robust.refinements);
  // The plain solve keeps a wrong pose (measured 21.2 units off): Newton
  // from 30 degrees off settles in the minimum the outliers pull to, and
  // its rejection then drops good bearings.
  REQUIRE(plain.ok);
  CHECK(PositionError(plain.pose, truth) > 20.0);
  CHECK(robust.inliers == std::vector<int>{0, 1, 4, 5, 6, 7});
  CHECK(PositionError(robust.pose, truth) < 100 * kEps * 200);
  CHECK(HeadingError(robust.pose, truth) < 100 * kEps * M_PI);
  CHECK(robust.samples == 56);  // every triple of 8
  CHECK(std::abs(robust.bearing_residuals[2]) == Approx(20 * kDeg).epsilon(1e-12));
  CHECK(std::abs(robust.bearing_residuals[3]) == Approx(30 * kDeg).epsilon(1e-12));
}

TEST_CASE("many landmarks: random triples, deterministic, seed independent", "[robust_sampling]") {
  PANO_SEEDED_RNG(11);
  const double sigma = 0.05 * kDeg;
  const Pose2 truth{90, 120, -2.0};
  auto obs = Observe(truth, RandomLandmarks(rng, truth, 24));
  const std::vector<int> bad = Corrupt(rng, sigma, 8, &obs);  // a third
  const Pose2 prior{truth.x + 20, truth.y - 20, truth.theta + 45 * kDeg};
  const RobustTriangulationResult a = RobustTriangulate(obs, prior);
  const RobustTriangulationResult b = RobustTriangulate(obs, prior);
  REQUIRE(a.ok);
  REQUIRE(b.ok);
  // Deterministic: the same input gives bit-identical output.
  CHECK(a.pose.x == b.pose.x);
  CHECK(a.pose.y == b.pose.y);
  CHECK(a.pose.theta == b.pose.theta);
  CHECK(a.samples == b.samples);
  CHECK(a.inliers == Complement(24, bad));
  // Adaptive: at 2/3 inliers 0.9999 needs ceil(log(1e-4) / log(1 - 8/27)) = 27
  // triples, below the minimum of 50.
  CHECK(a.samples == RobustPoseOptions().min_samples);
  // Another seed draws other triples but finds the same consensus.
  RobustPoseOptions other;
  other.seed = 12345;
  const RobustTriangulationResult c = RobustTriangulate(obs, prior, other);
  REQUIRE(c.ok);
  CHECK(c.inliers == a.inliers);
  CHECK(PositionError(c.pose, a.pose) < 1e-9 * 200);
  WARN("24 landmarks, 8 outliers: " << a.samples << " triples, " << a.hypotheses << " hypotheses, position error "
                                    << PositionError(a.pose, truth) << " units");
}

TEST_CASE("heading-prior pairs and the prior gate", "[robust_sampling]") {
  const Pose2 truth{100, 100, 0.3};
  auto obs = Observe(truth, kLandmarks);
  obs[2].bearing += 25 * kDeg;
  obs[5].bearing -= 15 * kDeg;
  // Pairs with the prior heading are hypotheses too: 56 triples + 28 pairs.
  RobustPoseOptions pairs;
  pairs.prior_heading_sigma = 2 * kDeg;
  const RobustTriangulationResult p = RobustTriangulate(obs, {0, 0, truth.theta + 1 * kDeg}, pairs);
  REQUIRE(p.ok);
  CHECK(p.samples == 56 + 28);
  CHECK(p.inliers == std::vector<int>{0, 1, 3, 4, 6, 7});
  CHECK(PositionError(p.pose, truth) < 100 * kEps * 200);
  // Gate around the right prior: the outliers' hypotheses are discarded.
  RobustPoseOptions gate;
  gate.gate_with_prior = true;
  gate.prior_covariance = Eigen::Vector3d(25, 25, std::pow(5 * kDeg, 2)).asDiagonal();
  const Pose2 near{truth.x + 3, truth.y - 3, truth.theta + 2 * kDeg};
  const RobustTriangulationResult g = RobustTriangulate(obs, near, gate);
  REQUIRE(g.ok);
  CHECK(g.hypotheses_gated > 0);
  CHECK(g.hypotheses + g.hypotheses_gated == 53);  // 3 triples have no pose in front
  CHECK(PositionError(g.pose, truth) < 100 * kEps * 200);
  WARN("gate around the right prior: " << g.hypotheses_gated << " of 53 hypotheses gated");
  // Gate around a wrong prior (50 units off, 5 sigma): nothing passes.
  const RobustTriangulationResult w = RobustTriangulate(obs, {150, 150, truth.theta}, gate);
  CHECK_FALSE(w.ok);
  CHECK(w.hypotheses_gated == 53);
  CHECK(w.failure.find("gated") != std::string::npos);
}

TEST_CASE("robust solve: bad options and inputs", "[robust_bad_input]") {
  const Pose2 truth{100, 100, 0.0};
  auto obs = Observe(truth, kLandmarks);
  RobustPoseOptions bad;
  bad.inlier_threshold = 0.0;
  CHECK_THROWS_WITH(RobustTriangulate(obs, truth, bad), Catch::Contains("inlier_threshold"));
  bad = RobustPoseOptions();
  bad.max_samples = bad.min_samples - 1;
  CHECK_THROWS_WITH(RobustTriangulate(obs, truth, bad), Catch::Contains("max_samples"));
  bad = RobustPoseOptions();
  bad.local_optimisations = 0;
  CHECK_THROWS_WITH(RobustTriangulate(obs, truth, bad), Catch::Contains("local_optimisations"));
  CHECK_FALSE(RobustTriangulate(Observe(truth, {{0, 60}, {0, 95}}), truth).ok);
  obs[3].landmark.x() = std::nan("");
  const RobustTriangulationResult r = RobustTriangulate(obs, truth);
  CHECK_FALSE(r.ok);
  CHECK(r.failure.find("non-finite") != std::string::npos);
}

// Chi-square quantiles from the standard tables (3 decimals).
struct TableRow {
  double p;
  int dof;
  double quantile;
};
const TableRow kChiSquareTable[] = {
    {0.95, 1, 3.841},   {0.95, 2, 5.991},   {0.95, 3, 7.815},   {0.95, 5, 11.070},  {0.95, 10, 18.307},
    {0.95, 20, 31.410}, {0.95, 30, 43.773}, {0.99, 1, 6.635},   {0.99, 2, 9.210},   {0.99, 3, 11.345},
    {0.99, 5, 15.086},  {0.99, 10, 23.209}, {0.99, 20, 37.566}, {0.99, 30, 50.892}, {0.999, 1, 10.828},
    {0.999, 2, 13.816}, {0.999, 3, 16.266}, {0.999, 4, 18.467}, {0.999, 5, 20.515}, {0.999, 10, 29.588},
    {0.999, 20, 45.315}, {0.999, 30, 59.703}, {0.05, 2, 0.103}, {0.05, 5, 1.145},  {0.05, 10, 3.940},
    {0.05, 30, 18.493}};

TEST_CASE("chi-square quantiles match the tables", "[chi2]") {
  double worst_wh = 0.0, worst_wh_from20 = 0.0;
  for (const TableRow& row : kChiSquareTable) {
    INFO("p " << row.p << " dof " << row.dof);
    const double q = ChiSquareQuantile(row.p, row.dof);
    // Exact to the table's rounding (half a unit of the third decimal).
    CHECK(std::abs(q - row.quantile) <= 0.0005 + 1e-12);
    // The CDF inverts it.
    CHECK(ChiSquareCdf(q, row.dof) == Approx(row.p).epsilon(1e-12));
    CHECK(ChiSquareSurvival(q, row.dof) == Approx(1 - row.p).epsilon(1e-10));
    // Wilson-Hilferty alone, in the upper tail that the tests use.
    if (row.p < 0.5) continue;
    const double wh = std::abs(ChiSquareQuantileWilsonHilferty(row.p, row.dof) / q - 1);
    worst_wh = std::max(worst_wh, wh);
    if (row.dof >= 20) worst_wh_from20 = std::max(worst_wh_from20, wh);
  }
  WARN("Wilson-Hilferty relative error in the upper tail: worst " << worst_wh << ", from 20 dof "
                                                                   << worst_wh_from20);
  CHECK(worst_wh < 0.031);         // measured 3.04e-2 (1 dof, 0.999)
  CHECK(worst_wh_from20 < 0.003);  // measured 2.76e-3 (20 dof, 0.999)
  // dof 1 at 0.999 is 10.828 exactly the square of the normal 0.9995 quantile.
  CHECK(ChiSquareQuantile(0.999, 1) == Approx(std::pow(NormalQuantile(0.9995), 2)).epsilon(1e-12));
  CHECK(NormalQuantile(0.975) == Approx(1.959963984540054).epsilon(1e-14));
  CHECK(NormalQuantile(0.001) == Approx(-3.090232306167813).epsilon(1e-14));
  CHECK(NormalQuantile(0.5) == 0.0);
  // dof 2: the CDF is 1 - exp(-x / 2) in closed form.
  for (double x : {0.01, 0.5, 2.0, 7.0, 30.0})
    CHECK(ChiSquareSurvival(x, 2) == Approx(std::exp(-x / 2)).epsilon(1e-13));
  CHECK_THROWS_WITH(ChiSquareQuantile(0.9, 0), Catch::Contains("dof"));
  CHECK_THROWS_WITH(ChiSquareQuantile(1.0, 3), Catch::Contains("p:"));
}


struct IntegrityStats {
  int trials = 0, solved = 0, consistent = 0;
  double sum_chi2_per_dof = 0.0, sum_quality = 0.0;
};

// Robust solves of noisy bearings from 12 random landmarks, `bias(b)` added
// to each bearing b (an unmodelled error), checked for integrity.
template <typename Bias>
IntegrityStats RunIntegrity(uint64_t seed, double sigma, Bias bias, int trials) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  IntegrityStats st;
  IntegrityOptions iopt;
  iopt.sigma_bearing = sigma;
  for (int t = 0; t < trials; ++t) {
    const Pose2 truth = RandomPose(rng);
    auto obs = Observe(truth, RandomLandmarks(rng, truth, 12));
    for (auto& o : obs) o.bearing += noise(rng) + bias(o.bearing);
    const RobustTriangulationResult r = RobustTriangulate(obs, truth);
    ++st.trials;
    if (!r.ok) continue;
    ++st.solved;
    const IntegrityReport rep = IntegrityCheck(r, obs, iopt);
    st.consistent += rep.consistent;
    st.sum_chi2_per_dof += rep.chi2 / rep.dof;
    st.sum_quality += rep.quality;
  }
  return st;
}

TEST_CASE("integrity: consistent solutions pass, unmodelled bias fails", "[integrity]") {
  const double sigma = 0.05 * kDeg;
  const int trials = 500;
  const IntegrityStats good = RunIntegrity(13, sigma, [](double) { return 0.0; }, trials);
  // Mirror decentring: a bearing error varying with the azimuth, 0.15
  // degrees (3 sigma) at most; no pose absorbs it and no single bearing is
  // an outlier at the 0.5 degree threshold.
  const IntegrityStats biased =
      RunIntegrity(13, sigma, [](double b) { return 0.15 * kDeg * std::sin(2 * b); }, trials);
  WARN("integrity at 0.999, " << trials << " trials of 12 landmarks, 0.05 deg noise:\n  consistent: "
                              << good.consistent << " of " << good.solved << " pass, mean chi2/dof "
                              << good.sum_chi2_per_dof / good.solved << ", mean quality "
                              << good.sum_quality / good.solved << "\n  0.15 deg sin(2b) bias: "
                              << biased.consistent << " of " << biased.solved << " pass, mean chi2/dof "
                              << biased.sum_chi2_per_dof / biased.solved << ", mean quality "
                              << biased.sum_quality / biased.solved);
  REQUIRE(good.solved == trials);
  REQUIRE(biased.solved == trials);
  // At 0.999 one in a thousand consistent solutions fails by chance.
  CHECK(good.consistent >= trials - 3);
  // chi2 / dof is 1 on average for the right sigma (the standard error of
  // the mean over 500 trials of 9 dof is about 0.02).
  CHECK(good.sum_chi2_per_dof / good.solved == Approx(1.0).epsilon(0.08));
  CHECK(biased.consistent <= trials / 4);  // measured 101
  CHECK(biased.sum_quality < 0.5 * good.sum_quality);

  // One case, noise free: the bias alone gives chi2 far beyond the quantile.
  const Pose2 truth{95, 110, 0.8};
  auto obs = Observe(truth, kLandmarks);
  for (auto& o : obs) o.bearing += 0.15 * kDeg * std::sin(2 * o.bearing);
  const RobustTriangulationResult r = RobustTriangulate(obs, truth);
  REQUIRE(r.ok);
  IntegrityOptions iopt;
  iopt.sigma_bearing = sigma;
  const IntegrityReport rep = IntegrityCheck(r, obs, iopt);
  WARN("8 landmarks, bias only: chi2 " << rep.chi2 << " (threshold " << rep.chi2_threshold << ", dof "
                                       << rep.dof << "), p " << rep.p_value << ", quality "
                                       << rep.quality << ", position error "
                                       << PositionError(r.pose, truth));
  CHECK(rep.inliers == 8);
  CHECK(rep.dof == 5);
  CHECK(rep.chi2_threshold == Approx(20.515).margin(5e-4));
  CHECK_FALSE(rep.consistent);
  CHECK(rep.p_value < 1e-3);
  CHECK(rep.quality < 0.1);
}

TEST_CASE("integrity: predicted position std matches the scatter; quality follows the evidence",
          "[integrity_geometry]") {
  PANO_SEEDED_RNG(14);
  const double sigma = 0.05 * kDeg;
  std::normal_distribution<double> noise(0.0, sigma);
  const Pose2 truth{95, 110, 0.8};
  IntegrityOptions iopt;
  iopt.sigma_bearing = sigma;
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  double predicted = 0.0, condition = 0.0;
  const int trials = 2000;
  for (int t = 0; t < trials; ++t) {
    auto obs = Observe(truth, kLandmarks);
    for (auto& o : obs) o.bearing += noise(rng);
    const RobustTriangulationResult r = RobustTriangulate(obs, truth);
    REQUIRE(r.ok);
    const IntegrityReport rep = IntegrityCheck(r, obs, iopt);
    const Eigen::Vector2d e(r.pose.x - truth.x, r.pose.y - truth.y);
    scatter += e * e.transpose() / trials;
    predicted = rep.position_std;
    condition = rep.condition;
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(scatter);
  const double empirical = std::sqrt(es.eigenvalues().maxCoeff());
  WARN("8 landmarks, 0.05 deg: position std predicted " << predicted << ", empirical " << empirical
                                                         << "; condition " << condition);
  // The standard error of a std from 2000 samples is about 1.6 %.
  CHECK(empirical == Approx(predicted).epsilon(0.05));

  // Quality: more inliers raise it, an outlier among the observations and
  // weaker geometry lower it, a failed solve gives 0.
  const auto obs = Observe(truth, kLandmarks);
  const RobustTriangulationResult all = RobustTriangulate(obs, truth);
  const std::vector<BearingObservation> five(obs.begin(), obs.begin() + 5);
  const RobustTriangulationResult fewer = RobustTriangulate(five, truth);
  auto with_outlier = obs;
  with_outlier[4].bearing += 10 * kDeg;
  const RobustTriangulationResult outlier = RobustTriangulate(with_outlier, truth);
  REQUIRE(all.ok);
  REQUIRE(fewer.ok);
  REQUIRE(outlier.ok);
  const IntegrityReport q_all = IntegrityCheck(all, obs, iopt);
  const IntegrityReport q_fewer = IntegrityCheck(fewer, five, iopt);
  const IntegrityReport q_outlier = IntegrityCheck(outlier, with_outlier, iopt);
  WARN("quality: 8 of 8 " << q_all.quality << ", 5 of 5 " << q_fewer.quality << ", 7 of 8 "
                          << q_outlier.quality);
  CHECK(q_all.consistent);
  CHECK(q_all.chi2 < 1e-20);
  CHECK(q_all.p_value == 1.0);
  CHECK(q_outlier.inliers == 7);
  CHECK(q_outlier.observations == 8);
  CHECK(q_fewer.quality < q_all.quality);
  CHECK(q_outlier.quality < q_all.quality);
  CHECK(q_fewer.position_std > q_all.position_std);
  // 8 inliers, no residual: fraction 1, redundancy 5 / (5 + 3), consistency
  // 1, geometry 1 / (1 + std^2).
  CHECK(q_all.quality == Approx(5.0 / 8.0 / (1 + std::pow(q_all.position_std, 2))).epsilon(1e-12));
  CHECK(IntegrityCheck(TriangulationResult(), obs, iopt).quality == 0.0);
  IntegrityOptions bad;
  bad.confidence = 1.0;
  CHECK_THROWS_WITH(IntegrityCheck(all, obs, bad), Catch::Contains("confidence"));
}

TEST_CASE("integrity: two corners of one edge count as one bearing", "[integrity_groups]") {
  const Pose2 truth{95, 110, 0.8};
  auto obs = Observe(truth, kLandmarks);  // 8 landmarks
  CHECK(DistinctBearings(obs, {0, 1, 2, 3, 4, 5, 6, 7}) == 8);
  // Landmarks 0 and 1 seen again (the edges' other corners): 10
  // observations, 8 distinct bearings.
  auto doubled = obs;
  for (int k : {0, 1}) {
    BearingObservation o = obs[static_cast<size_t>(k)];
    o.group = o.id;
    doubled[static_cast<size_t>(k)].group = o.id;
    doubled.push_back(o);
  }
  CHECK(DistinctBearings(doubled, {0, 1, 2, 3, 4, 5, 6, 7, 8, 9}) == 8);
  CHECK(DistinctBearings(doubled, {0, 8}) == 1);
  CHECK(DistinctBearings(doubled, {}) == 0);
  for (auto& o : doubled) o.bearing += 0.02 * kDeg * std::sin(3 * o.bearing);
  const TriangulationResult r = Triangulate(doubled, truth);
  REQUIRE(r.ok);
  REQUIRE(r.inliers.size() == 10);
  IntegrityOptions iopt;
  iopt.sigma_bearing = 0.05 * kDeg;
  const IntegrityReport rep = IntegrityCheck(r, doubled, iopt);
  CHECK(rep.inliers == 10);
  CHECK(rep.dof == 5);  // 8 distinct bearings - 3
}

TEST_CASE("integrity: the protection level against the alert limit", "[integrity_protection]") {
  const Pose2 truth{95, 110, 0.8};
  auto obs = Observe(truth, kLandmarks);
  for (size_t i = 0; i < obs.size(); ++i) obs[i].bearing += (i % 2 ? 0.03 : -0.03) * kDeg;
  const TriangulationResult r = Triangulate(obs, truth);
  REQUIRE(r.ok);
  IntegrityOptions iopt;
  iopt.sigma_bearing = 0.05 * kDeg;
  const IntegrityReport rep = IntegrityCheck(r, obs, iopt);
  // protection_sigmas x the largest position std of the solution's own
  // covariance; alert_fraction x the mean inlier distance.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(r.covariance.topLeftCorner<2, 2>());
  double distance = 0.0;
  for (const auto& o : obs) distance += (o.landmark - Eigen::Vector2d(r.pose.x, r.pose.y)).norm();
  distance /= static_cast<double>(obs.size());
  CHECK(rep.protection_level == Approx(5.0 * std::sqrt(es.eigenvalues().maxCoeff())).epsilon(1e-12));
  CHECK(rep.alert_limit == Approx(0.01 * distance).epsilon(1e-12));
  CHECK(rep.within_alert_limit == (rep.protection_level <= rep.alert_limit));
  CHECK(rep.within_alert_limit);
  // A limit tighter than the bound fails it; a zero fraction switches it off.
  iopt.alert_fraction = 0.5 * rep.protection_level / distance;
  CHECK_FALSE(IntegrityCheck(r, obs, iopt).within_alert_limit);
  iopt.alert_fraction = 0.0;
  const IntegrityReport off = IntegrityCheck(r, obs, iopt);
  CHECK(off.within_alert_limit);
  CHECK(off.protection_level == 0.0);
  iopt.alert_fraction = -1.0;
  CHECK_THROWS_WITH(IntegrityCheck(r, obs, iopt), Catch::Contains("alert_fraction"));
}

TEST_CASE("Mahalanobis distance of a pose, heading wrapped", "[mahalanobis]") {
  const Eigen::Matrix3d cov = Eigen::Vector3d(4.0, 9.0, 0.01).asDiagonal();
  // (1 / 2)^2 + (3 / 3)^2 + (0.05 / 0.1)^2 = 1.5, across the +-pi seam.
  const double d2 = PoseMahalanobis2({11, 23, -M_PI + 0.02}, {10, 20, M_PI - 0.03}, cov);
  CHECK(d2 == Approx(1.5).epsilon(1e-12));
  // Correlated: against an explicit inverse.
  Eigen::Matrix3d c;
  c << 4, 1, 0.1, 1, 9, -0.2, 0.1, -0.2, 0.5;
  const Eigen::Vector3d e(1, -2, 0.3);
  CHECK(PoseMahalanobis2({1, -2, 0.3}, {0, 0, 0}, c) == Approx(e.dot(c.inverse() * e)).epsilon(1e-12));
  // Gating: 3 dof at 0.999.
  CHECK(d2 < ChiSquareQuantile(0.999, 3));
  CHECK(std::isinf(PoseMahalanobis2({1, 0, 0}, {0, 0, 0}, Eigen::Matrix3d::Zero())));
}

}  // namespace
}  // namespace pano
