// Pose from bearings: exact for exact bearings, spread as predicted to first
// order for noisy ones, degenerate geometry detected, outliers rejected.
#include <catch2/catch.hpp>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

#include "panotrack/pose/robust_pose.h"
#include "panotrack/pose/triangulate.h"
#include "observe.h"
#include "test_rng.h"

namespace pano {
namespace {

using test::Observe;

// Corners of rectangles around a 200 x 200 room, about 70 units away.
const std::vector<Eigen::Vector2d> kLandmarks = {{0, 60},   {0, 95},   {40, 200}, {75, 200},
                                                 {200, 130}, {200, 90}, {150, 0},  {110, 0}};

// Exact bearings give the pose to rounding: bounds of 100 ulps at the scale
// of the room (positions, distances) and of a half turn (headings).
constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr double kPositionTol = 100 * kEps * 200;  // about 4.4e-12 map units
constexpr double kHeadingTol = 100 * kEps * M_PI;  // about 7e-14 rad

TEST_CASE("noise-free bearings give the exact pose", "[exact]") {
  for (const Pose2 truth : {Pose2{100, 100, 0.3}, Pose2{60, 130, -2.5}, Pose2{150, 40, 3.1}}) {
    const auto obs = Observe(truth, kLandmarks);
    // Start the heading 20 degrees off: Newton-Raphson on Eqn 2 converges.
    const TriangulationResult r = Triangulate(obs, {0, 0, truth.theta + 0.35});
    REQUIRE(r.ok);
    CHECK(std::abs(r.pose.x - truth.x) < kPositionTol);
    CHECK(std::abs(r.pose.y - truth.y) < kPositionTol);
    CHECK(std::abs(WrapAngle(r.pose.theta - truth.theta)) < kHeadingTol);
    CHECK(r.residual < kPositionTol);
    CHECK(r.inliers.size() == kLandmarks.size());
    // The paper's solve alone (Eqns 1-2) is exact too.
    TriangulationOptions paper;
    paper.refine = false;
    const TriangulationResult p = Triangulate(obs, {0, 0, truth.theta - 0.35}, paper);
    REQUIRE(p.ok);
    CHECK(std::abs(p.pose.x - truth.x) < kPositionTol);
    CHECK(std::abs(p.pose.y - truth.y) < kPositionTol);
    // Eqn 1 at the true heading.
    Eigen::Vector2d pos;
    double s;
    REQUIRE(PositionFromBearings(obs, truth.theta, &pos, &s));
    CHECK((pos - Eigen::Vector2d(truth.x, truth.y)).norm() < kPositionTol);
    CHECK(s < (100 * kEps * 100) * (100 * kEps * 100));  // a sum of squared distances
  }
}

TEST_CASE("noisy bearings: the error spread matches the first-order prediction", "[noise]") {
  PANO_SEEDED_RNG(42);
  const Pose2 truth{95, 110, 0.8};
  const double sigma = 0.1 * M_PI / 180;  // 0.1 degree per bearing
  std::normal_distribution<double> noise(0.0, sigma);
  const int trials = 2000;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d predicted = Eigen::Matrix3d::Zero();
  TriangulationOptions opt;
  opt.outlier_threshold = 10 * sigma;
  opt.huber = 10 * sigma;  // Gaussian noise: plain least squares
  for (int t = 0; t < trials; ++t) {
    auto obs = Observe(truth, kLandmarks);
    for (auto& o : obs) o.bearing += noise(rng);
    const TriangulationResult r = Triangulate(obs, truth, opt);
    REQUIRE(r.ok);
    const Eigen::Vector3d e(r.pose.x - truth.x, r.pose.y - truth.y,
                            WrapAngle(r.pose.theta - truth.theta));
    mean += e;
    scatter += e * e.transpose();
    predicted += r.covariance;
  }
  mean /= trials;
  scatter /= trials;
  predicted /= trials;
  INFO("empirical cov\n" << scatter << "\npredicted\n" << predicted);
  // Unbiased to first order: the mean error is within 4 standard errors.
  for (int k = 0; k < 3; ++k) CHECK(std::abs(mean[k]) < 4.0 * std::sqrt(scatter(k, k) / trials));
  // Variances agree within 15 % (the standard error of a variance estimate
  // from 2000 samples is about 3 %).
  for (int k = 0; k < 3; ++k) CHECK(scatter(k, k) == Approx(predicted(k, k)).epsilon(0.15));
  // The position's standard deviation for 0.1 degree bearings ~70 units away
  // is of order 70 * 0.1 deg = 0.12 units.
  const double std_xy = std::sqrt(scatter(0, 0) + scatter(1, 1));
  CHECK(std_xy > 0.03);
  CHECK(std_xy < 0.3);
  WARN("0.1 deg bearing noise: position std " << std_xy << " units (predicted "
                                               << std::sqrt(predicted(0, 0) + predicted(1, 1)) << ")");
}

TEST_CASE("leverages: a bearing's share of its own error that the fit absorbs", "[leverage]") {
  const Pose2 truth{95, 110, 0.8};
  std::vector<BearingObservation> obs = Observe(truth, kLandmarks);
  for (size_t i = 0; i < obs.size(); ++i) obs[i].weight = 1.0 + 0.25 * static_cast<double>(i % 3);
  TriangulationOptions exact;
  exact.huber = 1.0;  // no down-weighting: the plain weighted least squares
  const TriangulationResult fit = Triangulate(obs, truth, exact);
  REQUIRE(fit.ok);
  const std::vector<double> leverage = BearingLeverages(obs, fit);
  REQUIRE(leverage.size() == obs.size());
  // The hat matrix's trace is the number of parameters fitted.
  double sum = 0.0;
  for (double h : leverage) sum += h;
  CHECK(sum == Approx(3.0).epsilon(1e3 * kEps));
  // Against the solver: a bearing nudged by e leaves (1 - h) e in its own
  // residual (to first order; the nudge is small).
  const double nudge = 1e-6;
  for (size_t i = 0; i < obs.size(); ++i) {
    std::vector<BearingObservation> moved = obs;
    moved[i].bearing -= nudge;  // the residual is predicted minus measured
    const TriangulationResult refit = Triangulate(moved, truth, exact);
    REQUIRE(refit.ok);
    INFO("bearing " << i << " leverage " << leverage[i]);
    CHECK(refit.bearing_residuals[i] / nudge == Approx(1.0 - leverage[i]).margin(1e-4));
    CHECK(leverage[i] > 0.0);
    CHECK(leverage[i] < 1.0);
  }
}

// No Huber down-weighting, no bearing dropped: the plain weighted least squares.
TriangulationOptions PlainLeastSquares() {
  TriangulationOptions o;
  o.huber = 1.0;
  o.outlier_threshold = 1.0;
  return o;
}

// kLandmarks seen from `truth`, weighted 1, 1.5 and 2 in turn; the last
// landmark seen at two corners of one edge (one bearing, its weight shared).
std::vector<BearingObservation> WeightedWithAnEdge(const Pose2& truth) {
  std::vector<BearingObservation> obs = Observe(truth, kLandmarks);
  for (size_t i = 0; i < obs.size(); ++i) obs[i].weight = 1.0 + 0.5 * static_cast<double>(i % 3);
  BearingObservation twin = obs.back();
  obs.back().weight = twin.weight = 0.5;
  obs.back().group = twin.group = static_cast<int>(obs.size()) - 1;
  obs.push_back(twin);
  return obs;
}

TEST_CASE("standardized residuals: unit spread under the noise model, the pulling bearing stands out",
          "[leverage]") {
  PANO_SEEDED_RNG(7);
  const Pose2 truth{95, 110, 0.8};
  const double sigma = 0.1 * M_PI / 180;
  const TriangulationOptions exact = PlainLeastSquares();
  std::normal_distribution<double> unit(0.0, 1.0);
  // A bearing of weight w has noise sigma / sqrt(w).
  const std::vector<BearingObservation> base = WeightedWithAnEdge(truth);
  double sum2 = 0.0;
  int count = 0;
  const int trials = 1000;
  for (int t = 0; t < trials; ++t) {
    std::vector<BearingObservation> obs = base;
    const double shared = unit(rng);
    for (size_t i = 0; i + 2 < obs.size(); ++i) obs[i].bearing += sigma / std::sqrt(obs[i].weight) * unit(rng);
    for (size_t i = obs.size() - 2; i < obs.size(); ++i) obs[i].bearing += sigma * shared;
    const TriangulationResult fit = Triangulate(obs, truth, exact);
    REQUIRE(fit.ok);
    const std::vector<double> w = StandardizedResiduals(obs, fit, sigma);
    REQUIRE(w.size() == obs.size());
    CHECK(w[obs.size() - 1] == w[obs.size() - 2]);  // one bearing, one statistic
    for (size_t k = 0; k + 1 < w.size(); ++k) {
      REQUIRE(std::isfinite(w[k]));
      sum2 += w[k] * w[k];
      ++count;
    }
  }
  // Unit variance within 10 % (the standard error of 8000 squares, not all
  // independent, is about 2 %).
  CHECK(sum2 / count == Approx(1.0).epsilon(0.1));
  // A bearing off by 6 sigma: whatever it pulled, its statistic is the
  // largest, and beyond Baarda's 3.29.
  for (size_t bad = 0; bad + 2 < base.size(); ++bad) {
    std::vector<BearingObservation> obs = base;
    obs[bad].bearing += 6.0 * sigma / std::sqrt(obs[bad].weight);
    const TriangulationResult fit = Triangulate(obs, truth, exact);
    REQUIRE(fit.ok);
    const std::vector<double> w = StandardizedResiduals(obs, fit, sigma);
    size_t largest = 0;
    for (size_t k = 1; k < w.size(); ++k)
      if (std::abs(w[k]) > std::abs(w[largest])) largest = k;
    INFO("bad bearing " << bad << " statistic " << w[bad]);
    CHECK(largest == bad);
    CHECK(std::abs(w[bad]) > 3.29);
  }
}

TEST_CASE("solution separation: the largest shift of leaving one bearing out, as the solver finds it",
          "[separation]") {
  PANO_SEEDED_RNG(11);
  const Pose2 truth{95, 110, 0.8};
  const double sigma = 0.1 * M_PI / 180;
  const TriangulationOptions exact = PlainLeastSquares();
  std::normal_distribution<double> unit(0.0, 1.0);
  const std::vector<BearingObservation> base = WeightedWithAnEdge(truth);
  // Each group left out and the pose solved again from the full one.
  const auto solved_shift = [&](const std::vector<BearingObservation>& obs, const TriangulationResult& fit) {
    double largest = 0.0;
    for (int left_out : fit.inliers) {
      if (BearingGroup(obs, left_out) != left_out) continue;  // a group's first member stands for it
      std::vector<BearingObservation> rest;
      for (int i : fit.inliers)
        if (BearingGroup(obs, i) != left_out) rest.push_back(obs[static_cast<size_t>(i)]);
      const TriangulationResult refit = Triangulate(rest, fit.pose, exact);
      REQUIRE(refit.ok);
      largest = std::max(largest, std::hypot(refit.pose.x - fit.pose.x, refit.pose.y - fit.pose.y));
    }
    return largest;
  };
  for (int t = 0; t < 20; ++t) {
    std::vector<BearingObservation> obs = base;
    for (BearingObservation& o : obs) o.bearing += sigma / std::sqrt(o.weight) * unit(rng);
    const TriangulationResult fit = Triangulate(obs, truth, exact);
    REQUIRE(fit.ok);
    const double separation = SolutionSeparation(obs, fit);
    // One Gauss-Newton step from a pose that fits to noise is the solve.
    CHECK(separation == Approx(solved_shift(obs, fit)).epsilon(0.01));
    CHECK(separation > 0.0);
  }
  // Five bearings, one of them 1 degree off: the pose is pulled, and the
  // separation is at least that pull (leaving the wrong one out undoes it;
  // leaving a good one out may move the pose farther).
  std::vector<BearingObservation> five(base.begin(), base.begin() + 5);
  five[2].bearing += 1.0 * M_PI / 180;
  const TriangulationResult pulled = Triangulate(five, truth, exact);
  REQUIRE(pulled.ok);
  REQUIRE(pulled.inliers.size() == 5);
  const double pull = std::hypot(pulled.pose.x - truth.x, pulled.pose.y - truth.y);
  CHECK(pull > 0.5);
  CHECK(SolutionSeparation(five, pulled) > 0.95 * pull);
  CHECK(SolutionSeparation(five, pulled) == Approx(solved_shift(five, pulled)).epsilon(0.1));
  // Three distinct bearings: leaving one out leaves no pose.
  std::vector<BearingObservation> three(base.begin(), base.begin() + 3);
  const TriangulationResult exactly = Triangulate(three, truth, exact);
  REQUIRE(exactly.ok);
  CHECK(std::isinf(SolutionSeparation(three, exactly)));
}

TEST_CASE("degenerate geometry: landmarks on one line through the camera", "[degenerate]") {
  const Pose2 truth{100, 100, 0.0};
  // All on the line y = x through the camera, on both sides.
  const std::vector<Eigen::Vector2d> line = {{20, 20}, {50, 50}, {150, 150}, {180, 180}};
  const TriangulationResult r = Triangulate(Observe(truth, line), truth);
  CHECK_FALSE(r.ok);
  CHECK(r.failure.find("degenerate") != std::string::npos);
  TriangulationOptions paper;
  paper.refine = false;
  const TriangulationResult p = Triangulate(Observe(truth, line), truth, paper);
  CHECK_FALSE(p.ok);
  CHECK(p.failure.find("degenerate") != std::string::npos);
}

TEST_CASE("degenerate geometry: the test does not depend on the map's units", "[degenerate]") {
  // The same room and poses in metres, centimetres, millimetres and tenths
  // of a millimetre: the same verdicts (before the position rows were
  // normalised, landmarks a few hundred units away looked degenerate).
  const Pose2 truth{100, 100, 0.4};
  const std::vector<Eigen::Vector2d> line = {{20, 20}, {50, 50}, {150, 150}, {180, 180}};
  for (const double units : {0.01, 1.0, 10.0, 100.0}) {
    CAPTURE(units);
    std::vector<Eigen::Vector2d> room, on_line;
    for (const Eigen::Vector2d& l : kLandmarks) room.push_back(units * l);
    for (const Eigen::Vector2d& l : line) on_line.push_back(units * l);
    const Pose2 scaled{units * truth.x, units * truth.y, truth.theta};
    const TriangulationResult r = Triangulate(Observe(scaled, room), scaled);
    REQUIRE(r.ok);
    CHECK(std::abs(r.pose.x - scaled.x) < units * kPositionTol);
    CHECK(std::abs(r.pose.y - scaled.y) < units * kPositionTol);
    const TriangulationResult d = Triangulate(Observe(scaled, on_line), scaled);
    CHECK_FALSE(d.ok);
    CHECK(d.failure.find("degenerate") != std::string::npos);
  }
}

TEST_CASE("an outlying bearing is rejected", "[outliers]") {
  const Pose2 truth{80, 120, -1.0};
  auto obs = Observe(truth, kLandmarks);
  obs[3].bearing += 5.0 * M_PI / 180;  // a wrong junction
  const TriangulationResult r = Triangulate(obs, truth);
  REQUIRE(r.ok);
  CHECK(r.inliers.size() == kLandmarks.size() - 1);
  CHECK(std::find(r.inliers.begin(), r.inliers.end(), 3) == r.inliers.end());
  CHECK(std::hypot(r.pose.x - truth.x, r.pose.y - truth.y) < kPositionTol);
  CHECK(std::abs(r.bearing_residuals[3]) == Approx(5.0 * M_PI / 180).epsilon(500 * kEps));
}

TEST_CASE("too few or bad observations fail with a reason", "[bad_input]") {
  const Pose2 truth{100, 100, 0.0};
  auto obs = Observe(truth, {{0, 50}, {200, 50}});
  TriangulationResult r = Triangulate(obs, truth);
  CHECK_FALSE(r.ok);
  CHECK(r.failure.find("too few") != std::string::npos);
  obs = Observe(truth, kLandmarks);
  obs[0].bearing = std::nan("");
  r = Triangulate(obs, truth);
  CHECK_FALSE(r.ok);
  CHECK(r.failure.find("non-finite") != std::string::npos);
  TriangulationOptions bad;
  bad.min_landmarks = 1;
  CHECK_THROWS(Triangulate(Observe(truth, kLandmarks), truth, bad));
}

}  // namespace
}  // namespace pano
