#include "panotrack/mapping/refine.h"

#include <ceres/ceres.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <sstream>

#include "panotrack/core/angles.h"
#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"
#include "panotrack/core/parallel.h"
#include "panotrack/lut/radius_table.h"
#include "panotrack/scene/scene.h"
#include "panotrack/sensor/catadioptric.h"
#include "panotrack/video/frame_source.h"

namespace pano {

const std::array<const char*, kRectangleParams> kRectangleParamNames = {"from_x", "from_y", "to_x",
                                                                       "to_y",   "z0",     "z1"};

void RefineOptions::Check() const {
  if (!(map_sigma > 0.0) || !std::isfinite(map_sigma)) throw Error("map_sigma: expected a positive number");
  if (passes < 1 || passes > 10) throw Error("passes: expected 1..10");
  if (!(search_px > 0.0) || !(refine_search_px > 0.0)) throw Error("search_px: expected positive widths");
  if (min_corners_per_frame < 2) throw Error("min_corners_per_frame: expected at least 2");
  if (!(loss_sigmas > 0.0)) throw Error("loss_sigmas: expected a positive number");
  if (!(initial_azimuth_sigma > 0.0) || !(initial_radius_sigma > 0.0))
    throw Error("initial sigmas: expected positive numbers");
  if (max_iterations < 1) throw Error("max_iterations: expected at least 1");
  tracking.Check();
}

std::array<double, kRectangleParams> RectangleParams(const MapRectangle& r) {
  return {r.from.x(), r.from.y(), r.to.x(), r.to.y(), r.z0, r.z1};
}

void SetRectangleParams(const std::array<double, kRectangleParams>& p, MapRectangle* r) {
  r->from = {p[0], p[1]};
  r->to = {p[2], p[3]};
  r->z0 = p[4];
  r->z1 = p[5];
}

namespace {

// Landmarks of rectangle k are 4k..4k+3 in LandmarksFromMap's order:
// from-bottom, from-top, to-bottom, to-top.
int CornerEnd(int landmark) { return (landmark % 4) / 2; }    // 0 from, 1 to
int CornerLevel(int landmark) { return landmark % 2; }        // 0 z0, 1 z1

// The measurement a corner at world `X` gives from `pose` with the pinhole
// `h` above the floor: the image azimuth (radius false) or the image radius.
template <typename T>
bool PredictMeasurement(const SensorParams<double>& sensor, const T* pose, const T* X, const T& h,
                        bool radius, T* out) {
  using std::atan2;
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T dx = X[0] - pose[0], dy = X[1] - pose[1];
  const T c = cos(pose[2]), s = sin(pose[2]);
  const T xs = c * dx + s * dy, ys = -s * dx + c * dy;
  if (!radius) {
    *out = atan2(ys, xs) + T(sensor.azimuth_offset);
    return true;
  }
  const T D = sqrt(xs * xs + ys * ys);
  return image_radius(sensor.cast<T>(), D, T(X[2] - h), out);
}

template <typename T>
T Residual(const T& predicted, double measured, bool radius, double sigma) {
  T d = predicted - T(measured);
  if (!radius) d -= T(2.0 * M_PI * std::round(scalar_value(d) / (2.0 * M_PI)));
  return d / T(sigma);
}

// A corner of a rectangle being adjusted.
struct RectangleCornerCost {
  SensorParams<double> sensor;
  int end = 0, level = 0;
  bool radius = false;
  double measured = 0.0, sigma = 1.0;
  template <typename T>
  bool operator()(const T* pose, const T* rect, const T* height, T* residual) const {
    const T X[3] = {rect[2 * end], rect[2 * end + 1], rect[4 + level]};
    T predicted;
    if (!PredictMeasurement(sensor, pose, X, height[0], radius, &predicted)) return false;
    residual[0] = Residual(predicted, measured, radius, sigma);
    return true;
  }
};

// A box corner: fixed in the map, it still ties the poses and the height.
struct FixedCornerCost {
  SensorParams<double> sensor;
  Eigen::Vector3d corner;
  bool radius = false;
  double measured = 0.0, sigma = 1.0;
  template <typename T>
  bool operator()(const T* pose, const T* height, T* residual) const {
    const T X[3] = {T(corner.x()), T(corner.y()), T(corner.z())};
    T predicted;
    if (!PredictMeasurement(sensor, pose, X, height[0], radius, &predicted)) return false;
    residual[0] = Residual(predicted, measured, radius, sigma);
    return true;
  }
};

// The survey: each rectangle parameter at its surveyed value, sigma map_sigma.
struct PriorCost {
  std::array<double, kRectangleParams> surveyed;
  double sigma = 1.0;
  template <typename T>
  bool operator()(const T* rect, T* residual) const {
    for (int i = 0; i < kRectangleParams; ++i) residual[i] = (rect[i] - T(surveyed[i])) / T(sigma);
    return true;
  }
};

// 1.4826 x the median absolute value: the noise sigma of residuals with outliers.
double RobustSigma(std::vector<double> v, double fallback) {
  if (v.size() < 8) return fallback;
  for (double& x : v) x = std::abs(x);
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  const double s = 1.4826 * v[v.size() / 2];
  return s > 0.0 ? s : fallback;
}

struct Unknowns {
  std::vector<std::array<double, kRectangleParams>> rects;
  std::vector<std::array<double, 3>> poses;
  double height = 0.0;
};

// Raw (unscaled) residuals of every observation at `u`: azimuth and radius.
void RawResiduals(const SensorParams<double>& sensor, const std::vector<Landmark>& landmarks, const Unknowns& u,
                  const std::vector<CornerObservation>& obs, std::vector<double>* az, std::vector<double>* rad) {
  az->clear();
  rad->clear();
  const int n_rect_landmarks = static_cast<int>(u.rects.size()) * 4;
  for (const CornerObservation& o : obs) {
    double X[3];
    if (o.landmark < n_rect_landmarks) {
      const auto& r = u.rects[static_cast<size_t>(o.landmark / 4)];
      X[0] = r[2 * CornerEnd(o.landmark)];
      X[1] = r[2 * CornerEnd(o.landmark) + 1];
      X[2] = r[4 + CornerLevel(o.landmark)];
    } else {
      const Eigen::Vector3d& c = landmarks[static_cast<size_t>(o.landmark)].corner;
      X[0] = c.x();
      X[1] = c.y();
      X[2] = c.z();
    }
    const double* pose = u.poses[static_cast<size_t>(o.frame)].data();
    double a, r;
    PredictMeasurement(sensor, pose, X, u.height, false, &a);
    az->push_back(wrap_angle(a - o.azimuth));
    if (PredictMeasurement(sensor, pose, X, u.height, true, &r)) rad->push_back(r - o.radius);
  }
}

double Rms(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return v.empty() ? 0.0 : std::sqrt(s / static_cast<double>(v.size()));
}

}  // namespace

RefineResult SolveMapRefinement(const Calibration& calib, const Map& surveyed, const std::vector<Pose2>& poses,
                                const std::vector<CornerObservation>& observations, const RefineOptions& opt) {
  opt.Check();
  if (observations.empty()) throw Error("no corner observations to refine the map from");
  const std::vector<Landmark> landmarks = LandmarksFromMap(surveyed);
  const SensorParams<double>& sensor = calib.sensor.params;
  const int n_rect = static_cast<int>(surveyed.rectangles.size());
  for (const CornerObservation& o : observations)
    if (o.frame < 0 || o.frame >= static_cast<int>(poses.size()) || o.landmark < 0 ||
        o.landmark >= static_cast<int>(landmarks.size()))
      throw Error("corner observation of frame " + std::to_string(o.frame) + ", landmark " +
                  std::to_string(o.landmark) + ": out of range");

  Unknowns u;
  for (const MapRectangle& r : surveyed.rectangles) u.rects.push_back(RectangleParams(r));
  for (const Pose2& p : poses) u.poses.push_back({p.x, p.y, p.theta});
  u.height = surveyed.sensor_height;

  RefineResult res;
  std::vector<double> az, rad;
  RawResiduals(sensor, landmarks, u, observations, &az, &rad);
  res.rms_azimuth_before = Rms(az);
  double sigma_az = opt.initial_azimuth_sigma, sigma_r = opt.initial_radius_sigma;

  std::vector<int> frame_count(poses.size(), 0);
  for (const CornerObservation& o : observations) ++frame_count[static_cast<size_t>(o.frame)];
  int first_frame = -1;
  for (size_t f = 0; f < frame_count.size() && first_frame < 0; ++f)
    if (frame_count[f] > 0) first_frame = static_cast<int>(f);

  std::unique_ptr<ceres::Problem> problem;
  // Two solves: the second with the noise sigmas measured on the first's
  // residuals, so that the priors and the measurements are weighed right.
  for (int round = 0; round < 2; ++round) {
    ceres::Problem::Options po;
    problem = std::make_unique<ceres::Problem>(po);
    for (const CornerObservation& o : observations) {
      double* pose = u.poses[static_cast<size_t>(o.frame)].data();
      for (bool radius : {false, true}) {
        const double sigma = radius ? sigma_r : sigma_az;
        const double measured = radius ? o.radius : o.azimuth;
        ceres::LossFunction* loss = new ceres::HuberLoss(opt.loss_sigmas);
        if (o.landmark < 4 * n_rect) {
          auto* f = new RectangleCornerCost{sensor, CornerEnd(o.landmark), CornerLevel(o.landmark), radius,
                                            measured, sigma};
          problem->AddResidualBlock(
              new ceres::AutoDiffCostFunction<RectangleCornerCost, 1, 3, kRectangleParams, 1>(f), loss, pose,
              u.rects[static_cast<size_t>(o.landmark / 4)].data(), &u.height);
        } else {
          auto* f = new FixedCornerCost{sensor, landmarks[static_cast<size_t>(o.landmark)].corner, radius,
                                        measured, sigma};
          problem->AddResidualBlock(new ceres::AutoDiffCostFunction<FixedCornerCost, 1, 3, 1>(f), loss, pose,
                                    &u.height);
        }
      }
    }
    for (int k = 0; k < n_rect; ++k) {
      auto* prior = new PriorCost{RectangleParams(surveyed.rectangles[static_cast<size_t>(k)]), opt.map_sigma};
      problem->AddResidualBlock(new ceres::AutoDiffCostFunction<PriorCost, kRectangleParams, kRectangleParams>(prior),
                                nullptr, u.rects[static_cast<size_t>(k)].data());
    }
    if (opt.hold_floor_contacts)
      for (int k = 0; k < n_rect; ++k)
        if (surveyed.rectangles[static_cast<size_t>(k)].z0 == 0.0)
          problem->SetManifold(u.rects[static_cast<size_t>(k)].data(),
                               new ceres::SubsetManifold(kRectangleParams, {4}));
    if (!opt.free_height) problem->SetParameterBlockConstant(&u.height);
    if (opt.fix_first_pose && first_frame >= 0)
      problem->SetParameterBlockConstant(u.poses[static_cast<size_t>(first_frame)].data());
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::SPARSE_SCHUR;
    so.max_num_iterations = opt.max_iterations;
    so.num_threads = ThreadCount(opt.num_threads);
    so.function_tolerance = 1e-10;
    so.parameter_tolerance = 1e-10;
    so.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(so, problem.get(), &summary);
    if (!summary.IsSolutionUsable()) throw Error("map refinement failed: " + summary.message);
    RawResiduals(sensor, landmarks, u, observations, &az, &rad);
    sigma_az = RobustSigma(az, sigma_az);
    sigma_r = RobustSigma(rad, sigma_r);
  }
  res.azimuth_sigma = sigma_az;
  res.radius_sigma = sigma_r;
  res.rms_azimuth_after = Rms(az);
  res.measurements = static_cast<int>(observations.size());

  // Standard deviations of the rectangles (and the height) from the last solve.
  std::vector<std::array<double, kRectangleParams>> stds(static_cast<size_t>(n_rect));
  for (auto& s : stds) s.fill(std::nan(""));
  {
    ceres::Covariance::Options co;
    co.algorithm_type = ceres::SPARSE_QR;
    co.num_threads = ThreadCount(opt.num_threads);
    ceres::Covariance cov(co);
    std::vector<std::pair<const double*, const double*>> blocks;
    for (auto& r : u.rects) blocks.push_back({r.data(), r.data()});
    if (opt.free_height) blocks.push_back({&u.height, &u.height});
    if (cov.Compute(blocks, problem.get())) {
      res.covariance_ok = true;
      for (int k = 0; k < n_rect; ++k) {
        double c[kRectangleParams * kRectangleParams];
        cov.GetCovarianceBlock(u.rects[static_cast<size_t>(k)].data(), u.rects[static_cast<size_t>(k)].data(), c);
        for (int i = 0; i < kRectangleParams; ++i)
          stds[static_cast<size_t>(k)][static_cast<size_t>(i)] = std::sqrt(std::max(0.0, c[i * kRectangleParams + i]));
      }
      if (opt.free_height) {
        double c;
        cov.GetCovarianceBlock(&u.height, &u.height, &c);
        res.sensor_height_std = std::sqrt(std::max(0.0, c));
      }
    }
  }

  res.map = surveyed;
  res.map.sensor_height = u.height;
  std::vector<int> per_rect(static_cast<size_t>(n_rect), 0);
  for (const CornerObservation& o : observations)
    if (o.landmark < 4 * n_rect) ++per_rect[static_cast<size_t>(o.landmark / 4)];
  for (int k = 0; k < n_rect; ++k) {
    const size_t kk = static_cast<size_t>(k);
    MapRectangle& r = res.map.rectangles[kk];
    SetRectangleParams(u.rects[kk], &r);
    LandmarkCorrection lc;
    lc.id = r.id;
    lc.observations = per_rect[kk];
    lc.surveyed = RectangleParams(surveyed.rectangles[kk]);
    lc.refined = u.rects[kk];
    lc.std = stds[kk];
    for (int i = 0; i < kRectangleParams; ++i)
      if (std::abs(lc.refined[static_cast<size_t>(i)] - lc.surveyed[static_cast<size_t>(i)]) > 3.0 * opt.map_sigma)
        lc.flagged = true;
    for (int c = 0; c < 4; ++c) {
      const int e = CornerEnd(c), l = CornerLevel(c);
      const double dx = lc.refined[static_cast<size_t>(2 * e)] - lc.surveyed[static_cast<size_t>(2 * e)];
      const double dy = lc.refined[static_cast<size_t>(2 * e + 1)] - lc.surveyed[static_cast<size_t>(2 * e + 1)];
      const double dz = lc.refined[static_cast<size_t>(4 + l)] - lc.surveyed[static_cast<size_t>(4 + l)];
      lc.max_corner_shift = std::max(lc.max_corner_shift, std::sqrt(dx * dx + dy * dy + dz * dz));
    }
    res.landmarks.push_back(lc);
  }
  for (const auto& p : u.poses) res.poses.push_back({p[0], p[1], wrap_angle(p[2])});
  for (int c : frame_count) res.frames_used += c > 0;
  return res;
}

namespace {

// The frames of a video and the rows of its pose CSV must match one for one.
void CheckFrameCount(const RefineVideo& v, int frames) {
  if (static_cast<int>(v.poses.size()) != frames)
    throw Error(v.poses_path + ": " + std::to_string(v.poses.size()) + " pose rows for the " +
                std::to_string(frames) + " frames of " + v.video + " (expected one row per frame)");
}

}  // namespace

RefineResult RefineMap(const Calibration& calib, const Map& surveyed, const std::vector<RefineVideo>& videos,
                       const RefineOptions& opt) {
  opt.Check();
  if (videos.empty()) throw Error("no video to refine the map from");
  if (surveyed.rectangles.empty()) throw Error("the map has no rectangles to refine");
  for (const RefineVideo& v : videos) {
    const int n = FrameSource::FrameCount(v.video);
    if (n >= 0) CheckFrameCount(v, n);
    for (size_t i = 0; i < v.poses.size(); ++i)
      if (v.poses[i].frame != static_cast<int>(i))
        throw Error(v.poses_path + ": row " + std::to_string(i + 1) + " is frame " +
                    std::to_string(v.poses[i].frame) + " (expected one row per frame, in order)");
  }
  // The pose of each (video, frame) the adjustment has solved.
  std::vector<std::vector<std::optional<Pose2>>> solved(videos.size());
  for (size_t v = 0; v < videos.size(); ++v) solved[v].resize(videos[v].poses.size());
  Map current = surveyed;
  RefineResult res;
  for (int pass = 0; pass < opt.passes; ++pass) {
    const std::vector<Landmark> landmarks = LandmarksFromMap(current);
    // The walls moved out by 3 survey sigmas for the predictions: a poster
    // surveyed a little behind its wall is still looked for.
    Map predicting = current;
    if (predicting.room.present) {
      predicting.room.min.array() -= 3.0 * opt.map_sigma;
      predicting.room.max.array() += 3.0 * opt.map_sigma;
    }
    const Scene scene = Scene::FromMap(predicting, false);
    auto table = std::make_shared<RadiusTable>(RadiusTable::Build(calib.sensor, RangesForMap(predicting, calib.sensor)));
    auto ph_tables = MakeTrackingPhTables(table, opt.num_threads);
    std::unique_ptr<LandmarkTracker> tracker =
        MakeTracker(TrackingMethod::kJunction, calib.sensor, table, opt.tracking, ph_tables);
    const double search = pass == 0 ? opt.search_px : opt.refine_search_px;
    const int threads = ThreadCount(opt.num_threads);

    std::vector<Pose2> poses;
    std::vector<std::pair<size_t, size_t>> frame_of;  // adjustment frame -> (video, frame)
    std::vector<CornerObservation> obs;
    for (size_t v = 0; v < videos.size(); ++v) {
      const RefineVideo& rv = videos[v];
      FrameSource source(rv.video);
      cv::Mat grey;
      int i = 0;
      std::optional<Pose2> previous;
      for (; source.Read(&grey); ++i) {
        if (i >= static_cast<int>(rv.poses.size())) continue;  // counted, reported below
        const PoseRow& row = rv.poses[static_cast<size_t>(i)];
        if (row.status != PoseStatus::kOk) {
          previous.reset();
          continue;
        }
        const Pose2 pose = solved[v][static_cast<size_t>(i)].value_or(row.pose);
        std::vector<PredictedLandmark> predicted =
            PredictLandmarks(landmarks, predicting, scene, calib.sensor, *table, pose, opt.tracking.prediction);
        const Pose2 before = previous.value_or(
            Pose2{pose.x, pose.y, pose.theta - opt.tracking.unknown_turn_per_frame});
        SetImageMotion(predicting, calib.sensor, *table, before, opt.tracking.exposure_fraction, &predicted);
        previous = pose;
        if (predicted.empty()) continue;
        tracker->BeginFrame(grey);
        std::vector<LandmarkMeasurement> meas(predicted.size());
        ParallelFor(
            static_cast<int>(predicted.size()),
            [&](int k) { meas[static_cast<size_t>(k)] = tracker->Measure(predicted[static_cast<size_t>(k)], search); },
            predicted.size() > 4, threads);
        std::vector<CornerObservation> found;
        for (size_t k = 0; k < predicted.size(); ++k)
          if (meas[k].found)
            found.push_back({static_cast<int>(poses.size()), predicted[k].index, meas[k].azimuth, meas[k].radius});
        if (static_cast<int>(found.size()) < opt.min_corners_per_frame) continue;
        obs.insert(obs.end(), found.begin(), found.end());
        poses.push_back(pose);
        frame_of.push_back({v, static_cast<size_t>(i)});
      }
      CheckFrameCount(rv, i);
    }
    if (obs.empty()) {
      std::string names;
      for (const RefineVideo& v : videos) names += (names.empty() ? "" : ", ") + v.video;
      throw Error("no landmark of the map was found in " + std::string(videos.size() > 1 ? "any of " : "") + names +
                  " (the map, the calibration or the poses do not fit the video)");
    }
    res = SolveMapRefinement(calib, surveyed, poses, obs, opt);
    for (size_t f = 0; f < frame_of.size(); ++f) solved[frame_of[f].first][frame_of[f].second] = res.poses[f];
    current = res.map;
  }
  return res;
}

std::string RefineReportTable(const RefineResult& r, const Map& surveyed, double map_sigma) {
  std::ostringstream out;
  char line[512];
  std::snprintf(line, sizeof line, "%-14s %5s  %-42s %8s  %s\n", "landmark", "obs",
                "correction +- std (from x,y  to x,y  z0 z1)", "max move", "flag");
  out << line;
  for (const LandmarkCorrection& l : r.landmarks) {
    std::string cells;
    for (int i = 0; i < kRectangleParams; ++i) {
      char cell[48];
      const size_t ii = static_cast<size_t>(i);
      std::snprintf(cell, sizeof cell, "%s%+.2f(%.2f)", i ? " " : "", l.refined[ii] - l.surveyed[ii], l.std[ii]);
      cells += cell;
    }
    std::snprintf(line, sizeof line, "%-14s %5d  %-42s %8.2f  %s\n", l.id.c_str(), l.observations, cells.c_str(),
                  l.max_corner_shift, l.flagged ? "BEYOND 3 SIGMA" : "");
    out << line;
  }
  int flagged = 0;
  for (const LandmarkCorrection& l : r.landmarks) flagged += l.flagged;
  std::snprintf(line, sizeof line,
                "%d frames, %d corner observations; noise %.3f deg azimuth, %.2f px radius; %d of %zu "
                "landmarks beyond 3 sigma (%.3g %s) of the survey\n",
                r.frames_used, r.measurements, r.azimuth_sigma * 180.0 / M_PI, r.radius_sigma, flagged,
                r.landmarks.size(), 3.0 * map_sigma, surveyed.units.c_str());
  out << line;
  if (r.sensor_height_std > 0.0) {
    std::snprintf(line, sizeof line, "sensor height %.3f +- %.3f %s (surveyed %.3f)\n", r.map.sensor_height,
                  r.sensor_height_std, surveyed.units.c_str(), surveyed.sensor_height);
    out << line;
  }
  if (!r.covariance_ok) out << "note: the covariance could not be computed (std shown as nan)\n";
  return out.str();
}

void WriteRefineReportCsv(const std::string& path, const RefineResult& r) {
  std::ostringstream out;
  out << "landmark,parameter,observations,surveyed,refined,correction,std,flagged\n";
  char line[256];
  for (const LandmarkCorrection& l : r.landmarks)
    for (int i = 0; i < kRectangleParams; ++i) {
      const size_t ii = static_cast<size_t>(i);
      std::snprintf(line, sizeof line, "%s,%s,%d,%.6f,%.6f,%.6f,%.6f,%d\n", l.id.c_str(), kRectangleParamNames[ii],
                    l.observations, l.surveyed[ii], l.refined[ii], l.refined[ii] - l.surveyed[ii], l.std[ii],
                    l.flagged ? 1 : 0);
      out << line;
    }
  WriteFileAtomic(path, out.str());
}

namespace {

// Corners (x, y, z - sensor height) of the rectangles of `a` and of the same
// rectangles of `b`.
void MatchedCorners(const Map& a, const Map& b, std::vector<Eigen::Vector3d>* pa, std::vector<Eigen::Vector3d>* pb) {
  if (a.rectangles.size() != b.rectangles.size()) throw Error("CornerRms: the maps have different rectangles");
  for (const MapRectangle& ra : a.rectangles) {
    auto it = std::find_if(b.rectangles.begin(), b.rectangles.end(),
                           [&](const MapRectangle& rb) { return rb.id == ra.id; });
    if (it == b.rectangles.end()) throw Error("CornerRms: rectangle '" + ra.id + "' is in one map only");
    for (int c = 0; c < 4; ++c) {
      const int e = CornerEnd(c), l = CornerLevel(c);
      const Eigen::Vector2d& xa = e ? ra.to : ra.from;
      const Eigen::Vector2d& xb = e ? it->to : it->from;
      pa->push_back({xa.x(), xa.y(), (l ? ra.z1 : ra.z0) - a.sensor_height});
      pb->push_back({xb.x(), xb.y(), (l ? it->z1 : it->z0) - b.sensor_height});
    }
  }
}

}  // namespace

double CornerRms(const Map& a, const Map& b) {
  std::vector<Eigen::Vector3d> pa, pb;
  MatchedCorners(a, b, &pa, &pb);
  double sum = 0.0;
  const Eigen::Vector3d dh(0.0, 0.0, a.sensor_height - b.sensor_height);
  for (size_t i = 0; i < pa.size(); ++i) sum += (pa[i] - pb[i] + dh).squaredNorm();
  return pa.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(pa.size()));
}

double CornerRmsAfterGauge(const Map& estimate, const Map& truth) {
  std::vector<Eigen::Vector3d> pa, pb;
  MatchedCorners(estimate, truth, &pa, &pb);
  if (pa.empty()) return 0.0;
  // x' = a x - b y + tx, y' = b x + a y + ty, z' = a z: linear in (a, b, tx, ty)
  // for the small turns a survey leaves.
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3 * static_cast<long>(pa.size()), 4);
  Eigen::VectorXd y(3 * static_cast<long>(pa.size()));
  for (size_t i = 0; i < pa.size(); ++i) {
    const long r = 3 * static_cast<long>(i);
    A.row(r) << pa[i].x(), -pa[i].y(), 1, 0;
    A.row(r + 1) << pa[i].y(), pa[i].x(), 0, 1;
    A.row(r + 2) << pa[i].z(), 0, 0, 0;
    y.segment<3>(r) = pb[i];
  }
  const Eigen::VectorXd g = A.colPivHouseholderQr().solve(y);
  return std::sqrt((A * g - y).squaredNorm() / static_cast<double>(pa.size()));
}

}  // namespace pano
