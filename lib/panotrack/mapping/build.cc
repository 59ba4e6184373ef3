// panomap build: vertical edges per frame, their floor positions over the
// run, heights, and rectangles (see build.h).
#include "panotrack/mapping/build.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <opencv2/imgproc.hpp>
#include <set>

#include "panotrack/core/angles.h"
#include "panotrack/core/error.h"
#include "panotrack/lut/radius_table.h"
#include "panotrack/scene/scene.h"

namespace pano {

namespace {

constexpr double kDeg = M_PI / 180;

double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  const size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(m), v.end());
  return v[m];
}

// Robust spread of a sample (MAD scaled to sigma).
double RobustSigma(const std::vector<double>& v) {
  const double med = Median(v);
  std::vector<double> dev;
  for (double x : v) dev.push_back(std::abs(x - med));
  return 1.4826 * Median(dev);
}

// Image polar radius of a world point seen from `pose` (false: not imaged).
bool PolarOf(const Sensor& sensor, const Pose2& pose, double sensor_height, const Eigen::Vector3d& world,
             double* radius, double* azimuth, Eigen::Vector2d* pixel = nullptr) {
  Eigen::Vector2d px;
  if (!sensor.project(sensor_from_world(pose, sensor_height, world), &px)) return false;
  sensor.to_polar(px.x(), px.y(), radius, azimuth);
  if (pixel) *pixel = px;
  return true;
}

// Bilinear grey level; false outside the image.
bool GreyAt(const cv::Mat& grey, const Eigen::Vector2d& p, double* value) {
  const double x = p.x(), y = p.y();
  if (!(x >= 0 && y >= 0 && x < grey.cols - 1 && y < grey.rows - 1)) return false;
  const int u = static_cast<int>(x), v = static_cast<int>(y);
  const double fx = x - u, fy = y - v;
  const uchar* r0 = grey.ptr<uchar>(v);
  const uchar* r1 = grey.ptr<uchar>(v + 1);
  *value = (1 - fy) * ((1 - fx) * r0[u] + fx * r0[u + 1]) + fy * ((1 - fx) * r1[u] + fx * r1[u + 1]);
  return true;
}

}  // namespace

const char* edge_verdict_name(EdgeVerdict v) {
  switch (v) {
    case EdgeVerdict::kAccepted:
      return "accepted";
    case EdgeVerdict::kTooFewViews:
      return "too few views";
    case EdgeVerdict::kLowParallax:
      return "low parallax";
    case EdgeVerdict::kPoorlyConditioned:
      return "poorly conditioned";
    case EdgeVerdict::kNoHeight:
      return "no height";
    case EdgeVerdict::kRoomCorner:
      return "room corner";
  }
  return "?";
}

void MapBuildOptions::Check() const {
  prediction.Check();
  auto positive = [](double v, const char* name) {
    if (!(v > 0) || !std::isfinite(v)) throw Error(std::string(name) + ": expected a positive number");
  };
  positive(azimuth_bin_deg, "azimuth_bin_deg");
  positive(min_gradient, "min_gradient");
  positive(seed_exclusion_deg, "seed_exclusion_deg");
  positive(cell_fraction, "cell_fraction");
  positive(ray_tolerance_deg, "ray_tolerance_deg");
  positive(max_std_fraction, "max_std_fraction");
  positive(height_tolerance_fraction, "height_tolerance_fraction");
  positive(min_width_fraction, "min_width_fraction");
  positive(min_step, "min_step");
  if (!(min_parallax_deg >= 0)) throw Error("--min-parallax (min_parallax_deg): expected 0 or more");
  if (min_edge_px < 3) throw Error("min_edge_px: expected at least 3");
  if (nms_bins < 1) throw Error("nms_bins: expected at least 1");
  if (min_views < 3) throw Error("--min-views (min_views): expected at least 3");
  if (!(max_width_fraction > min_width_fraction)) throw Error("max_width_fraction: expected above min_width_fraction");
  if (!(min_horizontal_score > 0 && min_horizontal_score <= 1))
    throw Error("--min-score (min_horizontal_score): expected a fraction in (0, 1]");
  if (min_horizontal_frames < 1) throw Error("min_horizontal_frames: expected at least 1");
  if (max_stored_frames < 1) throw Error("max_stored_frames: expected at least 1");
  if (id_prefix.empty()) throw Error("--id-prefix (id_prefix): expected a non-empty prefix");
}

std::vector<VerticalEdgeDetection> DetectVerticalEdges(const cv::Mat& grey, const Sensor& sensor,
                                                       const MapBuildOptions& options) {
  if (grey.empty() || grey.type() != CV_8UC1) throw Error("vertical edges: expected an 8-bit grey frame");
  const double limb = sensor.limb_radius();
  const int r0 = static_cast<int>(std::ceil(options.prediction.min_radius_fraction * limb));
  const int r1 = static_cast<int>(std::floor(limb - options.prediction.max_radius_margin - 1));
  const double bin = options.azimuth_bin_deg * kDeg;
  const int n_az = static_cast<int>(std::lround(2 * M_PI / bin));
  const int rows = r1 - r0 + 1;
  if (rows < options.min_edge_px || n_az < 8) return {};
  // Polar resampling: row j is radius r0 + j, column k azimuth (k + 0.5) bin.
  cv::Mat map_x(rows, n_az, CV_32F), map_y(rows, n_az, CV_32F);
  for (int j = 0; j < rows; ++j)
    for (int k = 0; k < n_az; ++k) {
      const Eigen::Vector2d p = sensor.from_polar(r0 + j, (k + 0.5) * 2 * M_PI / n_az);
      map_x.at<float>(j, k) = static_cast<float>(p.x());
      map_y.at<float>(j, k) = static_cast<float>(p.y());
    }
  cv::Mat blurred, polar;
  cv::blur(grey, blurred, cv::Size(3, 3));
  cv::remap(blurred, polar, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  polar.convertTo(polar, CV_32F);
  // Signed marks: +1 / -1 where the tangential step (towards increasing
  // azimuth, per px) exceeds min_gradient and dominates the radial one.
  cv::Mat marks(rows, n_az, CV_8S, cv::Scalar(0)), tangential(rows, n_az, CV_32F, cv::Scalar(0));
  std::vector<float> count_pos(static_cast<size_t>(n_az), 0.f), count_neg(static_cast<size_t>(n_az), 0.f);
  for (int j = 1; j + 1 < rows; ++j) {
    const double r = r0 + j;
    const int step = std::max(1, static_cast<int>(std::lround(1.0 / (r * 2 * M_PI / n_az))));
    const double span_px = 2.0 * step * r * 2 * M_PI / n_az;
    const float* row = polar.ptr<float>(j);
    const float* up = polar.ptr<float>(j + 1);
    const float* down = polar.ptr<float>(j - 1);
    signed char* m = marks.ptr<signed char>(j);
    for (int k = 0; k < n_az; ++k) {
      const double dt = (row[(k + step) % n_az] - row[(k - step + n_az) % n_az]) / span_px;
      const double dr = 0.5 * (up[k] - down[k]);
      tangential.at<float>(j, k) = static_cast<float>(dt);
      if (std::abs(dt) < options.min_gradient || std::abs(dt) < 1.5 * std::abs(dr)) continue;
      m[k] = dt > 0 ? 1 : -1;
      (dt > 0 ? count_pos : count_neg)[static_cast<size_t>(k)] += 1.f;
    }
  }
  std::vector<VerticalEdgeDetection> out;
  for (int sign : {1, -1}) {
    const std::vector<float>& raw = sign > 0 ? count_pos : count_neg;
    std::vector<float> c(raw.size());
    for (int k = 0; k < n_az; ++k)
      c[static_cast<size_t>(k)] = 0.25f * raw[static_cast<size_t>((k + n_az - 1) % n_az)] +
                                  0.5f * raw[static_cast<size_t>(k)] + 0.25f * raw[static_cast<size_t>((k + 1) % n_az)];
    for (int k = 0; k < n_az; ++k) {
      const float v = c[static_cast<size_t>(k)];
      if (v < options.min_edge_px) continue;
      bool peak = true;
      for (int d = -options.nms_bins; d <= options.nms_bins && peak; ++d) {
        if (d == 0) continue;
        const float w = c[static_cast<size_t>((k + d + n_az) % n_az)];
        if (w > v || (w == v && d < 0)) peak = false;
      }
      if (!peak) continue;
      const float a = c[static_cast<size_t>((k + n_az - 1) % n_az)], b = c[static_cast<size_t>((k + 1) % n_az)];
      const double denom = a - 2 * v + b;
      const double offset = denom < 0 ? std::clamp(0.5 * (a - b) / denom, -0.5, 0.5) : 0.0;
      // Radial extent: the longest run of this sign's marks in the peak's
      // column or its neighbours, gaps up to 3 px bridged.
      int best_lo = -1, best_hi = -1, run_lo = -1, last = -100;
      for (int j = 0; j < rows; ++j) {
        const signed char* m = marks.ptr<signed char>(j);
        bool on = false;
        for (int d = -1; d <= 1; ++d) on = on || m[(k + d + n_az) % n_az] == sign;
        if (!on) continue;
        if (j - last > 4) run_lo = j;
        last = j;
        if (best_lo < 0 || j - run_lo > best_hi - best_lo) {
          best_lo = run_lo;
          best_hi = j;
        }
      }
      if (best_hi - best_lo + 1 < options.min_edge_px) continue;
      // The azimuth: per row of the run, the sub-bin maximum of the signed
      // tangential step near the peak; the median over the rows (the count
      // peak's own position when too few rows give one).
      std::vector<double> at;
      for (int j = best_lo; j <= best_hi; ++j) {
        const float* t = tangential.ptr<float>(j);
        int kb = 0;
        double vb = 0;
        for (int d = -options.nms_bins; d <= options.nms_bins; ++d) {
          const double here = sign * t[(k + d + n_az) % n_az];
          if (here > vb) {
            vb = here;
            kb = d;
          }
        }
        if (vb < options.min_gradient || std::abs(kb) == options.nms_bins) continue;
        const double va = sign * t[(k + kb - 1 + n_az) % n_az], vc = sign * t[(k + kb + 1 + n_az) % n_az];
        const double den = va - 2 * vb + vc;
        at.push_back(kb + (den < 0 ? std::clamp(0.5 * (va - vc) / den, -0.5, 0.5) : 0.0));
      }
      const double refined = at.size() >= 5 ? Median(at) : offset;
      VerticalEdgeDetection e;
      e.azimuth = wrap_angle((k + 0.5 + refined) * 2 * M_PI / n_az);
      e.polarity = sign;
      e.r_lo = r0 + best_lo;
      e.r_hi = r0 + best_hi;
      e.support = static_cast<int>(std::lround(raw[static_cast<size_t>(k)]));
      out.push_back(e);
    }
  }
  std::sort(out.begin(), out.end(),
            [](const VerticalEdgeDetection& a, const VerticalEdgeDetection& b) { return a.azimuth < b.azimuth; });
  return out;
}

MapBuilder::MapBuilder(const Calibration& calib, const Map& seed, const MapBuildOptions& options)
    : calib_(calib),
      seed_(seed),
      opt_(options),
      landmarks_(LandmarksFromMap(seed)),
      scene_(Scene::FromMap(seed, false)),
      table_(RadiusTable::Build(calib.sensor, RangesForMap(seed, calib.sensor))) {
  opt_.Check();
  Eigen::Vector2d lo, hi;
  double top = 0;
  seed_.Extent(&lo, &hi, &top);
  scale_ = std::max((hi - lo).maxCoeff(), 1e-9);
}

void MapBuilder::AddFrame(const cv::Mat& grey, const Pose2& pose) {
  const Sensor& sensor = calib_.sensor;
  if (grey.type() != CV_8UC1 || grey.cols != sensor.image_width || grey.rows != sensor.image_height)
    throw Error("map build: expected 8-bit grey frames of the calibration's size");
  Frame f;
  f.pose = pose;
  const std::vector<PredictedLandmark> predicted =
      PredictLandmarks(landmarks_, seed_, scene_, sensor, table_, pose, opt_.prediction);
  if (!predicted.empty()) ++frames_with_seed_;
  const std::vector<VerticalEdgeDetection> all = DetectVerticalEdges(grey, sensor, opt_);
  detections_ += static_cast<int>(all.size());
  for (const VerticalEdgeDetection& d : all) {
    bool explained = false;
    for (const PredictedLandmark& p : predicted)
      if (std::abs(wrap_angle(d.azimuth - p.azimuth)) < opt_.seed_exclusion_deg * kDeg) explained = true;
    if (!explained) f.edges.push_back(d);
  }
  unexplained_ += static_cast<int>(f.edges.size());
  stored_.push_back({static_cast<int>(frames_list_.size()), grey.clone()});
  frames_list_.push_back(std::move(f));
  // Keep every other stored frame once there are too many (evenly spread).
  if (static_cast<int>(stored_.size()) > 2 * opt_.max_stored_frames) {
    std::vector<std::pair<int, cv::Mat>> kept;
    for (size_t i = 0; i < stored_.size(); i += 2) kept.push_back(std::move(stored_[i]));
    stored_ = std::move(kept);
  }
  ++frames_;
}

namespace {

struct Ray {
  Eigen::Vector2d origin;
  double world_angle;
};

// The normal equations of the bearings of `rays` at `x`, each weighted by
// Huber's loss (huber 0: plain least squares); returns the sum of squared
// residuals.
double BearingNormalEquations(const std::vector<Ray>& rays, const Eigen::Vector2d& x, double huber,
                              Eigen::Matrix2d* H, Eigen::Vector2d* g) {
  H->setZero();
  g->setZero();
  double ss = 0;
  for (const Ray& r : rays) {
    const Eigen::Vector2d d = x - r.origin;
    const double d2 = d.squaredNorm();
    const double res = wrap_angle(r.world_angle - std::atan2(d.y(), d.x()));
    const Eigen::Vector2d J(d.y() / d2, -d.x() / d2);
    const double w = huber <= 0 || std::abs(res) <= huber ? 1.0 : huber / std::abs(res);
    *H += w * J * J.transpose();
    *g += w * J * res;
    ss += res * res;
  }
  return ss;
}

// Least squares on the bearings of `rays` (Huber), from `x`. Returns the
// RMS residual (radians); `cov` the position covariance.
double SolveEdge(const std::vector<Ray>& rays, Eigen::Vector2d* x, Eigen::Matrix2d* cov) {
  const double huber = 0.1 * kDeg;
  Eigen::Matrix2d H;
  Eigen::Vector2d g;
  for (int it = 0; it < 15; ++it) {
    BearingNormalEquations(rays, *x, huber, &H, &g);
    const Eigen::Vector2d step = -H.ldlt().solve(g);
    if (!step.allFinite()) break;
    *x += step;
    if (step.norm() < 1e-9) break;
  }
  const double ss = BearingNormalEquations(rays, *x, 0.0, &H, &g);
  const int n = static_cast<int>(rays.size());
  const double rms = std::sqrt(ss / std::max(n, 1));
  const double sigma = std::max(rms * std::sqrt(n / std::max(1.0, n - 2.0)), 0.05 * kDeg);
  *cov = sigma * sigma * H.inverse();
  return rms;
}

}  // namespace

MapBuildResult MapBuilder::Build() const {
  const Sensor& sensor = calib_.sensor;
  MapBuildResult res;
  res.map = seed_;
  res.frames = frames_;
  res.frames_with_pose = static_cast<int>(frames_list_.size());
  res.frames_with_seed = frames_with_seed_;
  res.detections = detections_;
  res.unexplained = unexplained_;
  if (frames_list_.empty()) return res;
  const double h = seed_.sensor_height;

  // Floor grid over the map's extent (and the trajectory), 5 % margin.
  Eigen::Vector2d lo, hi;
  double top = 0;
  seed_.Extent(&lo, &hi, &top);
  for (const Frame& f : frames_list_) {
    lo = lo.cwiseMin(Eigen::Vector2d(f.pose.x, f.pose.y));
    hi = hi.cwiseMax(Eigen::Vector2d(f.pose.x, f.pose.y));
  }
  lo -= Eigen::Vector2d::Constant(0.05 * scale_);
  hi += Eigen::Vector2d::Constant(0.05 * scale_);
  const double cell = opt_.cell_fraction * scale_;
  const int gw = static_cast<int>(std::ceil((hi.x() - lo.x()) / cell)),
            gh = static_cast<int>(std::ceil((hi.y() - lo.y()) / cell));
  auto to_grid = [&](const Eigen::Vector2d& p) {
    return cv::Point2d((p.x() - lo.x()) / cell, (p.y() - lo.y()) / cell);
  };
  std::vector<std::vector<Ray>> rays(frames_list_.size());
  cv::Mat acc(gh, gw, CV_32F, cv::Scalar(0)), mask(gh, gw, CV_8U);
  const int shift = 4;  // cv::line sub-pixel bits
  for (size_t fi = 0; fi < frames_list_.size(); ++fi) {
    const Frame& f = frames_list_[fi];
    mask.setTo(0);
    const Eigen::Vector2d o(f.pose.x, f.pose.y);
    for (const VerticalEdgeDetection& d : f.edges) {
      const double a = wrap_angle(f.pose.theta + sensor.bearing_of_azimuth(d.azimuth));
      rays[fi].push_back({o, a});
      const cv::Point2d p0 = to_grid(o), p1 = to_grid(o + 3 * scale_ * Eigen::Vector2d(std::cos(a), std::sin(a)));
      cv::line(mask, cv::Point(int(p0.x * (1 << shift)), int(p0.y * (1 << shift))),
               cv::Point(int(p1.x * (1 << shift)), int(p1.y * (1 << shift))), cv::Scalar(1), 1, cv::LINE_8, shift);
    }
    cv::accumulate(mask, acc);
  }
  cv::Mat smooth, dilated;
  cv::GaussianBlur(acc, smooth, cv::Size(5, 5), 1.0);
  cv::dilate(smooth, dilated, cv::Mat::ones(5, 5, CV_8U));
  struct Peak {
    float votes;
    Eigen::Vector2d position;
  };
  std::vector<Peak> peaks;
  for (int y = 0; y < gh; ++y)
    for (int x = 0; x < gw; ++x) {
      const float v = smooth.at<float>(y, x);
      if (v >= 0.4f * opt_.min_views && v >= dilated.at<float>(y, x))
        peaks.push_back({v, lo + cell * Eigen::Vector2d(x + 0.5, y + 0.5)});
    }
  std::sort(peaks.begin(), peaks.end(), [](const Peak& a, const Peak& b) { return a.votes > b.votes; });
  if (peaks.size() > 400) peaks.resize(400);

  // Each peak claims, per frame, the nearest unclaimed ray in bearing.
  std::vector<std::vector<char>> used(frames_list_.size());
  for (size_t fi = 0; fi < rays.size(); ++fi) used[fi].assign(rays[fi].size(), 0);
  const double min_range = 0.03 * scale_;
  auto associate = [&](const Eigen::Vector2d& x, double tol, std::vector<std::pair<int, int>>* ids) {
    std::vector<Ray> out;
    ids->clear();
    for (size_t fi = 0; fi < rays.size(); ++fi) {
      const Eigen::Vector2d o(frames_list_[fi].pose.x, frames_list_[fi].pose.y);
      const Eigen::Vector2d d = x - o;
      if (d.norm() < min_range) continue;
      const double a = std::atan2(d.y(), d.x());
      int best = -1;
      double best_err = tol;
      for (size_t k = 0; k < rays[fi].size(); ++k) {
        if (used[fi][k]) continue;
        const double e = std::abs(wrap_angle(rays[fi][k].world_angle - a));
        if (e < best_err) {
          best_err = e;
          best = static_cast<int>(k);
        }
      }
      if (best >= 0) {
        out.push_back(rays[fi][static_cast<size_t>(best)]);
        ids->push_back({static_cast<int>(fi), best});
      }
    }
    return out;
  };
  const double tol = opt_.ray_tolerance_deg * kDeg;
  for (const Peak& pk : peaks) {
    Eigen::Vector2d x = pk.position;
    std::vector<std::pair<int, int>> ids;
    std::vector<Ray> r = associate(x, tol, &ids);
    if (r.size() < 3) continue;
    Eigen::Matrix2d cov;
    double rms = SolveEdge(r, &x, &cov);
    r = associate(x, std::min(tol, std::max(0.25 * kDeg, 3 * rms)), &ids);
    if (r.size() < 3) continue;
    rms = SolveEdge(r, &x, &cov);
    if (!x.allFinite()) continue;
    BuiltEdge e;
    e.position = x;
    e.views = static_cast<int>(r.size());
    e.rms_bearing_deg = rms / kDeg;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
    e.std_major = std::sqrt(std::max(0.0, eig.eigenvalues().maxCoeff()));
    // Parallax: the spread of the rays' directions at the edge.
    double amin = 1e9, amax = -1e9;
    const double a0 = r.front().world_angle;
    for (const Ray& ray : r) {
      const double a = wrap_angle(ray.world_angle - a0);
      amin = std::min(amin, a);
      amax = std::max(amax, a);
    }
    e.parallax_deg = (amax - amin) / kDeg;
    e.rays = ids;
    for (const auto& id : ids) used[static_cast<size_t>(id.first)][static_cast<size_t>(id.second)] = 1;
    // Heights from the radial extent in each frame.
    std::vector<double> z_lo, z_hi;
    const double z_top = std::max(top, seed_.room.present ? seed_.room.height : 0.0) * 1.5 + h;
    for (const auto& id : ids) {
      const Frame& f = frames_list_[static_cast<size_t>(id.first)];
      const VerticalEdgeDetection& d = f.edges[static_cast<size_t>(id.second)];
      // Radius along the edge's vertical line, by height.
      const int n = 160;
      std::vector<double> zs, rs;
      for (int i = 0; i <= n; ++i) {
        const double z = z_top * i / n - 0.1 * z_top;
        double rr, az;
        if (PolarOf(sensor, f.pose, h, Eigen::Vector3d(x.x(), x.y(), z), &rr, &az)) {
          zs.push_back(z);
          rs.push_back(rr);
        }
      }
      auto height_at = [&](double radius, double* z) {
        for (size_t i = 1; i < rs.size(); ++i)
          if ((rs[i - 1] - radius) * (rs[i] - radius) <= 0 && rs[i] != rs[i - 1]) {
            *z = zs[i - 1] + (zs[i] - zs[i - 1]) * (radius - rs[i - 1]) / (rs[i] - rs[i - 1]);
            return true;
          }
        return false;
      };
      const double limb = sensor.limb_radius();
      const double r_in = opt_.prediction.min_radius_fraction * limb + 1.5;
      const double r_out = limb - opt_.prediction.max_radius_margin - 2.5;
      // An extent that reaches the annulus' border says nothing about that
      // end; each end that does not gives one height.
      for (double radius : {d.r_lo, d.r_hi}) {
        if (radius <= r_in || radius >= r_out) continue;
        double z;
        if (!height_at(radius, &z)) continue;
        // The other end's height tells which end this is.
        const double other = radius == d.r_lo ? d.r_hi : d.r_lo;
        double z_other;
        bool is_low;
        if (height_at(other, &z_other))
          is_low = z < z_other;
        else
          is_low = (rs.back() > rs.front()) == (radius < other);
        (is_low ? z_lo : z_hi).push_back(z);
      }
    }
    if (z_lo.size() >= 3 && z_hi.size() >= 3) {
      e.z0 = std::max(0.0, Median(z_lo));
      e.z1 = Median(z_hi);
      e.z0_std = RobustSigma(z_lo) / std::sqrt(double(z_lo.size()));
      e.z1_std = RobustSigma(z_hi) / std::sqrt(double(z_hi.size()));
    }
    bool room_corner = false;
    if (seed_.room.present)
      for (double cx : {seed_.room.min.x(), seed_.room.max.x()})
        for (double cy : {seed_.room.min.y(), seed_.room.max.y()})
          if ((x - Eigen::Vector2d(cx, cy)).norm() < 0.03 * scale_) room_corner = true;
    if (e.views < opt_.min_views)
      e.verdict = EdgeVerdict::kTooFewViews;
    else if (e.parallax_deg < opt_.min_parallax_deg)
      e.verdict = EdgeVerdict::kLowParallax;
    else if (e.std_major > opt_.max_std_fraction * scale_)
      e.verdict = EdgeVerdict::kPoorlyConditioned;
    else if (room_corner)
      e.verdict = EdgeVerdict::kRoomCorner;
    else if (z_lo.size() < 3 || z_hi.size() < 3 || !(e.z1 > e.z0))
      e.verdict = EdgeVerdict::kNoHeight;
    res.edges.push_back(e);
  }

  // Horizontal edges between two accepted edges at height z: the fraction
  // of samples showing a step of the majority sign, the mean step, and the
  // frames they were seen in.
  const double limb = sensor.limb_radius();
  const double r_in = opt_.prediction.min_radius_fraction * limb, r_out = limb - opt_.prediction.max_radius_margin;
  auto horizontal = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b, double z, double* mean_step, int* frames) {
    double score = 0, step_sum = 0;
    int nf = 0;
    const int samples = 16;
    for (const auto& sf : stored_) {
      const Pose2& pose = frames_list_[static_cast<size_t>(sf.first)].pose;
      int valid = 0, pos = 0, neg = 0;
      double sum = 0;
      for (int i = 0; i < samples; ++i) {
        const double t = 0.15 + 0.7 * i / (samples - 1);
        const Eigen::Vector2d p = a + t * (b - a), q = a + (t + 0.01) * (b - a);
        double rp, ap, rq, aq;
        Eigen::Vector2d pp, pq;
        if (!PolarOf(sensor, pose, h, Eigen::Vector3d(p.x(), p.y(), z), &rp, &ap, &pp) ||
            !PolarOf(sensor, pose, h, Eigen::Vector3d(q.x(), q.y(), z), &rq, &aq, &pq))
          continue;
        if (rp < r_in || rp > r_out) continue;
        Eigen::Vector2d tangent = pq - pp;
        if (tangent.norm() < 1e-9) continue;
        tangent.normalize();
        Eigen::Vector2d normal(-tangent.y(), tangent.x());
        // Orient the normal outwards (increasing radius) for a stable sign.
        double rn, an;
        sensor.to_polar(pp.x() + normal.x(), pp.y() + normal.y(), &rn, &an);
        if (rn < rp) normal = -normal;
        double g1, g2;
        if (!GreyAt(sf.second, pp + 1.0 * normal, &g1) || !GreyAt(sf.second, pp - 1.0 * normal, &g2)) continue;
        const double diff = g1 - g2;
        ++valid;
        sum += diff;
        if (diff > opt_.min_step) ++pos;
        if (diff < -opt_.min_step) ++neg;
      }
      if (valid < samples * 6 / 10) continue;
      ++nf;
      score += double(std::max(pos, neg)) / valid;
      step_sum += std::abs(sum / valid);
    }
    *frames = nf;
    *mean_step = nf ? step_sum / nf : 0.0;
    return nf ? score / nf : 0.0;
  };

  // Pairs with matching heights, strongest horizontal evidence first. One
  // of the two heights may disagree (an edge partly hidden in most frames
  // reads short): that height is then searched over both edges' values.
  const double htol = opt_.height_tolerance_fraction * scale_;
  struct Pair {
    int a, b;
    double z0, z1, top, bottom;
    int frames;
    bool both_heights_agree;
  };
  std::vector<Pair> pairs;
  for (size_t i = 0; i < res.edges.size(); ++i)
    for (size_t j = i + 1; j < res.edges.size(); ++j) {
      const BuiltEdge &ea = res.edges[i], &eb = res.edges[j];
      if (ea.verdict != EdgeVerdict::kAccepted || eb.verdict != EdgeVerdict::kAccepted) continue;
      const double w = (ea.position - eb.position).norm();
      if (w < opt_.min_width_fraction * scale_ || w > opt_.max_width_fraction * scale_) continue;
      const bool z0_agree = std::abs(ea.z0 - eb.z0) <= htol, z1_agree = std::abs(ea.z1 - eb.z1) <= htol;
      if (!z0_agree && !z1_agree) continue;
      ++res.pairs_considered;
      Pair p{static_cast<int>(i), static_cast<int>(j), 0.5 * (ea.z0 + eb.z0), 0.5 * (ea.z1 + eb.z1), 0, 0, 0,
             z0_agree && z1_agree};
      const double spread[2] = {z0_agree ? htol : 0.5 * std::abs(ea.z0 - eb.z0) + htol,
                                z1_agree ? htol : 0.5 * std::abs(ea.z1 - eb.z1) + htol};
      // Refine each height to the strongest horizontal edge near it.
      // (the maximum of the mean step over a scan, to a fraction of a step
      // by a parabola through its neighbours).
      for (int end = 0; end < 2; ++end) {
        double* z = end == 0 ? &p.z0 : &p.z1;
        const double range = spread[end];
        const int half = static_cast<int>(std::ceil(24 * range / htol));
        std::vector<double> steps(2 * half + 1, -1.0);
        int best = -1;
        for (int k = -half; k <= half; ++k) {
          const double zz = *z + range * k / half;
          if (zz < 0) continue;
          double step;
          int nf;
          horizontal(ea.position, eb.position, zz, &step, &nf);
          if (nf < opt_.min_horizontal_frames) continue;
          steps[static_cast<size_t>(k + half)] = step;
          if (best < 0 || step > steps[static_cast<size_t>(best)]) best = k + half;
        }
        if (best < 0) continue;
        double offset = 0;
        if (best > 0 && best < 2 * half && steps[static_cast<size_t>(best - 1)] >= 0 &&
            steps[static_cast<size_t>(best + 1)] >= 0) {
          const double a = steps[static_cast<size_t>(best - 1)], b = steps[static_cast<size_t>(best)],
                       c = steps[static_cast<size_t>(best + 1)];
          const double den = a - 2 * b + c;
          if (den < 0) offset = std::clamp(0.5 * (a - c) / den, -0.5, 0.5);
        }
        *z += range * (best - half + offset) / half;
      }
      if (p.z0 < 0.5 * htol) p.z0 = 0.0;  // standing on the floor
      double step;
      int nf0, nf1;
      p.bottom = horizontal(ea.position, eb.position, p.z0, &step, &nf0);
      p.top = horizontal(ea.position, eb.position, p.z1, &step, &nf1);
      p.frames = std::min(nf0, nf1);
      if (p.frames < opt_.min_horizontal_frames || p.top < opt_.min_horizontal_score ||
          p.bottom < opt_.min_horizontal_score || !(p.z1 > p.z0)) {
        ++res.pairs_rejected;
        continue;
      }
      pairs.push_back(p);
    }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& x, const Pair& y) {
    if (x.both_heights_agree != y.both_heights_agree) return x.both_heights_agree;
    return std::min(x.top, x.bottom) > std::min(y.top, y.bottom);
  });
  std::set<std::string> ids;
  for (const MapRectangle& r : seed_.rectangles) ids.insert(r.id);
  for (const MapBox& b : seed_.boxes) ids.insert(b.id);
  int next = 1;
  for (const Pair& p : pairs) {
    BuiltEdge &ea = res.edges[static_cast<size_t>(p.a)], &eb = res.edges[static_cast<size_t>(p.b)];
    if (ea.rectangle >= 0 || eb.rectangle >= 0) continue;
    BuiltRectangle br;
    while (ids.count(opt_.id_prefix + std::to_string(next))) ++next;
    br.rectangle.id = opt_.id_prefix + std::to_string(next++);
    ids.insert(br.rectangle.id);
    br.rectangle.from = ea.position;
    br.rectangle.to = eb.position;
    br.rectangle.z0 = p.z0;
    br.rectangle.z1 = p.z1;
    br.rectangle.shade = std::nan("");
    br.edge_from = p.a;
    br.edge_to = p.b;
    br.top_score = p.top;
    br.bottom_score = p.bottom;
    br.frames = p.frames;
    ea.rectangle = eb.rectangle = static_cast<int>(res.rectangles.size());
    res.rectangles.push_back(br);
    res.map.rectangles.push_back(br.rectangle);
  }
  return res;
}

std::string FormatMapBuildReport(const MapBuildResult& r) {
  std::string out;
  char line[512];
  std::map<EdgeVerdict, int> by_verdict;
  int paired = 0;
  for (const BuiltEdge& e : r.edges) {
    ++by_verdict[e.verdict];
    if (e.rectangle >= 0) ++paired;
  }
  std::snprintf(line, sizeof line,
                "frames: %d, with a pose: %d, with seed landmarks in view: %d\n"
                "vertical edges detected: %d, not explained by the seed: %d\n",
                r.frames, r.frames_with_pose, r.frames_with_seed, r.detections, r.unexplained);
  out += line;
  std::snprintf(line, sizeof line, "candidate edges: %zu, accepted: %d", r.edges.size(),
                by_verdict[EdgeVerdict::kAccepted]);
  out += line;
  for (const auto& kv : by_verdict)
    if (kv.first != EdgeVerdict::kAccepted) {
      std::snprintf(line, sizeof line, ", %s: %d", edge_verdict_name(kv.first), kv.second);
      out += line;
    }
  std::snprintf(line, sizeof line,
                "\npairs with matching heights: %d, rejected (horizontal edges not seen): %d\n"
                "new rectangles: %zu (from %d accepted edges; %d accepted edges left unpaired)\n",
                r.pairs_considered, r.pairs_rejected, r.rectangles.size(), paired,
                by_verdict[EdgeVerdict::kAccepted] - paired);
  out += line;
  out += "\nedge           x         y   std  views parallax  rms_deg     z0     z1  verdict\n";
  for (size_t i = 0; i < r.edges.size(); ++i) {
    const BuiltEdge& e = r.edges[i];
    std::string verdict = edge_verdict_name(e.verdict);
    if (e.rectangle >= 0) verdict += " -> " + r.rectangles[static_cast<size_t>(e.rectangle)].rectangle.id;
    std::snprintf(line, sizeof line, "e%-4zu %9.2f %9.2f %5.2f %6d %8.1f %8.3f %6.1f %6.1f  %s\n", i, e.position.x(),
                  e.position.y(), e.std_major, e.views, e.parallax_deg, e.rms_bearing_deg, e.z0, e.z1, verdict.c_str());
    out += line;
  }
  if (!r.rectangles.empty()) {
    out += "\nrectangle      from (x, y)          to (x, y)        z0     z1   xy std   z std  top  bottom\n";
    for (const BuiltRectangle& b : r.rectangles) {
      const BuiltEdge &ea = r.edges[static_cast<size_t>(b.edge_from)], &eb = r.edges[static_cast<size_t>(b.edge_to)];
      std::snprintf(line, sizeof line, "%-8s (%7.2f, %7.2f) (%7.2f, %7.2f) %6.1f %6.1f %8.2f %7.2f %4.2f %6.2f\n",
                    b.rectangle.id.c_str(), b.rectangle.from.x(), b.rectangle.from.y(), b.rectangle.to.x(),
                    b.rectangle.to.y(), b.rectangle.z0, b.rectangle.z1, std::max(ea.std_major, eb.std_major),
                    std::max({ea.z0_std, eb.z0_std, ea.z1_std, eb.z1_std}), b.top_score, b.bottom_score);
      out += line;
    }
  }
  return out;
}

}  // namespace pano
