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
  if (!sensor.project(SensorFromWorld(pose, sensor_height, world), &px)) return false;
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

const char* EdgeVerdictName(EdgeVerdict v) {
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
      e.azimuth = WrapAngle((k + 0.5 + refined) * 2 * M_PI / n_az);
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
      if (std::abs(WrapAngle(d.azimuth - p.azimuth)) < opt_.seed_exclusion_deg * kDeg) explained = true;
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
    const double res = WrapAngle(r.world_angle - std::atan2(d.y(), d.x()));
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

// What Build works on: the frames' poses, the vertical edges no seed
// landmark explains, and the grey frames kept for the horizontal edges.
struct BuildInputs {
  const Sensor& sensor;
  const Map& seed;
  const MapBuildOptions& opt;
  double scale;  // the map's size
  std::vector<Pose2> poses;
  std::vector<const std::vector<VerticalEdgeDetection>*> edges;
  const std::vector<std::pair<int, cv::Mat>>& stored;  // (index into poses, grey)
};

// The floor grid the rays vote in: the map's extent and the trajectory's,
// 5 % of the map's size around.
struct FloorGrid {
  Eigen::Vector2d lo{0, 0};
  double cell = 1.0;
  int gw = 0, gh = 0;
  cv::Point2d ToGrid(const Eigen::Vector2d& p) const { return cv::Point2d((p.x() - lo.x()) / cell, (p.y() - lo.y()) / cell); }
};

FloorGrid GridOf(const BuildInputs& in, double* top) {
  Eigen::Vector2d lo, hi;
  in.seed.Extent(&lo, &hi, top);
  for (const Pose2& p : in.poses) {
    lo = lo.cwiseMin(Eigen::Vector2d(p.x, p.y));
    hi = hi.cwiseMax(Eigen::Vector2d(p.x, p.y));
  }
  lo -= Eigen::Vector2d::Constant(0.05 * in.scale);
  hi += Eigen::Vector2d::Constant(0.05 * in.scale);
  FloorGrid g;
  g.lo = lo;
  g.cell = in.opt.cell_fraction * in.scale;
  g.gw = static_cast<int>(std::ceil((hi.x() - lo.x()) / g.cell));
  g.gh = static_cast<int>(std::ceil((hi.y() - lo.y()) / g.cell));
  return g;
}

// Each frame's rays (one per unexplained vertical edge), drawn into the
// grid; returns the votes, each cell counting a frame once.
cv::Mat RayVotes(const BuildInputs& in, const FloorGrid& g, std::vector<std::vector<Ray>>* rays) {
  rays->assign(in.poses.size(), {});
  cv::Mat acc(g.gh, g.gw, CV_32F, cv::Scalar(0)), mask(g.gh, g.gw, CV_8U);
  const int shift = 4;  // cv::line sub-pixel bits
  for (size_t fi = 0; fi < in.poses.size(); ++fi) {
    const Pose2& pose = in.poses[fi];
    mask.setTo(0);
    const Eigen::Vector2d o(pose.x, pose.y);
    for (const VerticalEdgeDetection& d : *in.edges[fi]) {
      const double a = WrapAngle(pose.theta + in.sensor.bearing_of_azimuth(d.azimuth));
      (*rays)[fi].push_back({o, a});
      const cv::Point2d p0 = g.ToGrid(o), p1 = g.ToGrid(o + 3 * in.scale * Eigen::Vector2d(std::cos(a), std::sin(a)));
      cv::line(mask, cv::Point(int(p0.x * (1 << shift)), int(p0.y * (1 << shift))),
               cv::Point(int(p1.x * (1 << shift)), int(p1.y * (1 << shift))), cv::Scalar(1), 1, cv::LINE_8, shift);
    }
    cv::accumulate(mask, acc);
  }
  return acc;
}

// The candidate edges: local maxima of the smoothed votes with at least 40 %
// of min_views, strongest first, 400 at most.
std::vector<Eigen::Vector2d> VotePeaks(const cv::Mat& acc, const FloorGrid& g, int min_views) {
  cv::Mat smooth, dilated;
  cv::GaussianBlur(acc, smooth, cv::Size(5, 5), 1.0);
  cv::dilate(smooth, dilated, cv::Mat::ones(5, 5, CV_8U));
  struct Peak {
    float votes;
    Eigen::Vector2d position;
  };
  std::vector<Peak> peaks;
  for (int y = 0; y < g.gh; ++y)
    for (int x = 0; x < g.gw; ++x) {
      const float v = smooth.at<float>(y, x);
      if (v >= 0.4f * min_views && v >= dilated.at<float>(y, x))
        peaks.push_back({v, g.lo + g.cell * Eigen::Vector2d(x + 0.5, y + 0.5)});
    }
  std::sort(peaks.begin(), peaks.end(), [](const Peak& a, const Peak& b) { return a.votes > b.votes; });
  if (peaks.size() > 400) peaks.resize(400);
  std::vector<Eigen::Vector2d> out;
  for (const Peak& p : peaks) out.push_back(p.position);
  return out;
}

// The rays not yet claimed by an edge: per frame, the one nearest in
// bearing to a point (within a tolerance) until an edge claims it.
class RayClaims {
 public:
  RayClaims(const std::vector<std::vector<Ray>>& rays, const std::vector<Pose2>& poses, double min_range)
      : rays_(rays), poses_(poses), min_range_(min_range) {
    used_.resize(rays.size());
    for (size_t fi = 0; fi < rays.size(); ++fi) used_[fi].assign(rays[fi].size(), 0);
  }
  std::vector<Ray> Associate(const Eigen::Vector2d& x, double tol, std::vector<std::pair<int, int>>* ids) const {
    std::vector<Ray> out;
    ids->clear();
    for (size_t fi = 0; fi < rays_.size(); ++fi) {
      const Eigen::Vector2d d = x - Eigen::Vector2d(poses_[fi].x, poses_[fi].y);
      if (d.norm() < min_range_) continue;
      const double a = std::atan2(d.y(), d.x());
      int best = -1;
      double best_err = tol;
      for (size_t k = 0; k < rays_[fi].size(); ++k) {
        if (used_[fi][k]) continue;
        const double e = std::abs(WrapAngle(rays_[fi][k].world_angle - a));
        if (e < best_err) {
          best_err = e;
          best = static_cast<int>(k);
        }
      }
      if (best >= 0) {
        out.push_back(rays_[fi][static_cast<size_t>(best)]);
        ids->push_back({static_cast<int>(fi), best});
      }
    }
    return out;
  }
  void Claim(const std::vector<std::pair<int, int>>& ids) {
    for (const auto& id : ids) used_[static_cast<size_t>(id.first)][static_cast<size_t>(id.second)] = 1;
  }

 private:
  const std::vector<std::vector<Ray>>& rays_;
  const std::vector<Pose2>& poses_;
  double min_range_;
  std::vector<std::vector<char>> used_;
};

// The spread of the rays' directions at the edge (degrees).
double ParallaxDeg(const std::vector<Ray>& r) {
  double amin = 1e9, amax = -1e9;
  const double a0 = r.front().world_angle;
  for (const Ray& ray : r) {
    const double a = WrapAngle(ray.world_angle - a0);
    amin = std::min(amin, a);
    amax = std::max(amax, a);
  }
  return (amax - amin) / kDeg;
}

// The heights of the edge at `x` from its radial extent in each frame that
// saw it (`ids`): each end of an extent inside the annulus gives one height,
// low or high by the other end.
void EdgeHeights(const BuildInputs& in, const Eigen::Vector2d& x, const std::vector<std::pair<int, int>>& ids,
                 double z_top, std::vector<double>* z_lo, std::vector<double>* z_hi) {
  const double h = in.seed.sensor_height;
  for (const auto& id : ids) {
    const Pose2& pose = in.poses[static_cast<size_t>(id.first)];
    const VerticalEdgeDetection& d = (*in.edges[static_cast<size_t>(id.first)])[static_cast<size_t>(id.second)];
    // Radius along the edge's vertical line, by height.
    const int n = 160;
    std::vector<double> zs, rs;
    for (int i = 0; i <= n; ++i) {
      const double z = z_top * i / n - 0.1 * z_top;
      double rr, az;
      if (PolarOf(in.sensor, pose, h, Eigen::Vector3d(x.x(), x.y(), z), &rr, &az)) {
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
    const double limb = in.sensor.limb_radius();
    const double r_in = in.opt.prediction.min_radius_fraction * limb + 1.5;
    const double r_out = limb - in.opt.prediction.max_radius_margin - 2.5;
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
      (is_low ? z_lo : z_hi)->push_back(z);
    }
  }
}

EdgeVerdict VerdictOf(const BuildInputs& in, const BuiltEdge& e, size_t n_low, size_t n_high) {
  bool room_corner = false;
  const MapRoom& room = in.seed.room;
  if (room.present)
    for (double cx : {room.min.x(), room.max.x()})
      for (double cy : {room.min.y(), room.max.y()})
        if ((e.position - Eigen::Vector2d(cx, cy)).norm() < 0.03 * in.scale) room_corner = true;
  if (e.views < in.opt.min_views) return EdgeVerdict::kTooFewViews;
  if (e.parallax_deg < in.opt.min_parallax_deg) return EdgeVerdict::kLowParallax;
  if (e.std_major > in.opt.max_std_fraction * in.scale) return EdgeVerdict::kPoorlyConditioned;
  if (room_corner) return EdgeVerdict::kRoomCorner;
  if (n_low < 3 || n_high < 3 || !(e.z1 > e.z0)) return EdgeVerdict::kNoHeight;
  return EdgeVerdict::kAccepted;
}

// The edge a candidate makes: its position from the bearings of the rays it
// claims (twice: the second time within 3 RMS), then its views, parallax,
// heights and verdict. False when fewer than 3 rays agree.
bool EdgeAt(const BuildInputs& in, Eigen::Vector2d x, double tol, double top, RayClaims* claims, BuiltEdge* e) {
  std::vector<std::pair<int, int>> ids;
  std::vector<Ray> r = claims->Associate(x, tol, &ids);
  if (r.size() < 3) return false;
  Eigen::Matrix2d cov;
  double rms = SolveEdge(r, &x, &cov);
  r = claims->Associate(x, std::min(tol, std::max(0.25 * kDeg, 3 * rms)), &ids);
  if (r.size() < 3) return false;
  rms = SolveEdge(r, &x, &cov);
  if (!x.allFinite()) return false;
  e->position = x;
  e->views = static_cast<int>(r.size());
  e->rms_bearing_deg = rms / kDeg;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
  e->std_major = std::sqrt(std::max(0.0, eig.eigenvalues().maxCoeff()));
  e->parallax_deg = ParallaxDeg(r);
  e->rays = ids;
  claims->Claim(ids);
  std::vector<double> z_lo, z_hi;
  const double z_top = std::max(top, in.seed.room.present ? in.seed.room.height : 0.0) * 1.5 + in.seed.sensor_height;
  EdgeHeights(in, x, ids, z_top, &z_lo, &z_hi);
  if (z_lo.size() >= 3 && z_hi.size() >= 3) {
    e->z0 = std::max(0.0, Median(z_lo));
    e->z1 = Median(z_hi);
    e->z0_std = RobustSigma(z_lo) / std::sqrt(double(z_lo.size()));
    e->z1_std = RobustSigma(z_hi) / std::sqrt(double(z_hi.size()));
  }
  e->verdict = VerdictOf(in, *e, z_lo.size(), z_hi.size());
  return true;
}

// Vertical edges where the frames' rays cross: each vote peak claims, per
// frame, the nearest unclaimed ray in bearing.
void FindEdges(const BuildInputs& in, MapBuildResult* res) {
  double top = 0;
  const FloorGrid grid = GridOf(in, &top);
  std::vector<std::vector<Ray>> rays;
  const cv::Mat acc = RayVotes(in, grid, &rays);
  RayClaims claims(rays, in.poses, 0.03 * in.scale);
  const double tol = in.opt.ray_tolerance_deg * kDeg;
  for (const Eigen::Vector2d& peak : VotePeaks(acc, grid, in.opt.min_views)) {
    BuiltEdge e;
    if (EdgeAt(in, peak, tol, top, &claims, &e)) res->edges.push_back(e);
  }
}

// The horizontal edge between a and b at height z: the fraction of samples
// showing a step of the majority sign (mean over the frames kept), the mean
// step and the frames it was seen in.
double HorizontalEvidence(const BuildInputs& in, const Eigen::Vector2d& a, const Eigen::Vector2d& b, double z,
                          double* mean_step, int* frames) {
  const double h = in.seed.sensor_height;
  const double limb = in.sensor.limb_radius();
  const double r_in = in.opt.prediction.min_radius_fraction * limb, r_out = limb - in.opt.prediction.max_radius_margin;
  double score = 0, step_sum = 0;
  int nf = 0;
  const int samples = 16;
  for (const auto& sf : in.stored) {
    const Pose2& pose = in.poses[static_cast<size_t>(sf.first)];
    int valid = 0, pos = 0, neg = 0;
    double sum = 0;
    for (int i = 0; i < samples; ++i) {
      const double t = 0.15 + 0.7 * i / (samples - 1);
      const Eigen::Vector2d p = a + t * (b - a), q = a + (t + 0.01) * (b - a);
      double rp, ap, rq, aq;
      Eigen::Vector2d pp, pq;
      if (!PolarOf(in.sensor, pose, h, Eigen::Vector3d(p.x(), p.y(), z), &rp, &ap, &pp) ||
          !PolarOf(in.sensor, pose, h, Eigen::Vector3d(q.x(), q.y(), z), &rq, &aq, &pq))
        continue;
      if (rp < r_in || rp > r_out) continue;
      Eigen::Vector2d tangent = pq - pp;
      if (tangent.norm() < 1e-9) continue;
      tangent.normalize();
      Eigen::Vector2d normal(-tangent.y(), tangent.x());
      // Orient the normal outwards (increasing radius) for a stable sign.
      double rn, an;
      in.sensor.to_polar(pp.x() + normal.x(), pp.y() + normal.y(), &rn, &an);
      if (rn < rp) normal = -normal;
      double g1, g2;
      if (!GreyAt(sf.second, pp + 1.0 * normal, &g1) || !GreyAt(sf.second, pp - 1.0 * normal, &g2)) continue;
      const double diff = g1 - g2;
      ++valid;
      sum += diff;
      if (diff > in.opt.min_step) ++pos;
      if (diff < -in.opt.min_step) ++neg;
    }
    if (valid < samples * 6 / 10) continue;
    ++nf;
    score += double(std::max(pos, neg)) / valid;
    step_sum += std::abs(sum / valid);
  }
  *frames = nf;
  *mean_step = nf ? step_sum / nf : 0.0;
  return nf ? score / nf : 0.0;
}

// A height moved to the strongest horizontal edge within +-range of it: the
// maximum of the mean step over a scan, to a fraction of a step by a
// parabola through its neighbours. Unchanged where no height shows one.
void RefineHeightToEdge(const BuildInputs& in, const Eigen::Vector2d& a, const Eigen::Vector2d& b, double range,
                        double htol, double* z) {
  const int half = static_cast<int>(std::ceil(24 * range / htol));
  std::vector<double> steps(2 * half + 1, -1.0);
  int best = -1;
  for (int k = -half; k <= half; ++k) {
    const double zz = *z + range * k / half;
    if (zz < 0) continue;
    double step;
    int nf;
    HorizontalEvidence(in, a, b, zz, &step, &nf);
    if (nf < in.opt.min_horizontal_frames) continue;
    steps[static_cast<size_t>(k + half)] = step;
    if (best < 0 || step > steps[static_cast<size_t>(best)]) best = k + half;
  }
  if (best < 0) return;
  double offset = 0;
  if (best > 0 && best < 2 * half && steps[static_cast<size_t>(best - 1)] >= 0 &&
      steps[static_cast<size_t>(best + 1)] >= 0) {
    const double sa = steps[static_cast<size_t>(best - 1)], sb = steps[static_cast<size_t>(best)],
                 sc = steps[static_cast<size_t>(best + 1)];
    const double den = sa - 2 * sb + sc;
    if (den < 0) offset = std::clamp(0.5 * (sa - sc) / den, -0.5, 0.5);
  }
  *z += range * (best - half + offset) / half;
}

// Two accepted edges and the horizontal edges between them.
struct EdgePair {
  int a, b;
  double z0, z1, top, bottom;
  int frames;
  bool both_heights_agree;
};

// The pair of edges i and j when their widths and heights match and both
// horizontal edges show (counted in res->pairs_considered and
// pairs_rejected). One of the two heights may disagree (an edge partly
// hidden in most frames reads short): that height is then searched over
// both edges' values.
bool PairOf(const BuildInputs& in, size_t i, size_t j, MapBuildResult* res, EdgePair* out) {
  const BuiltEdge &ea = res->edges[i], &eb = res->edges[j];
  if (ea.verdict != EdgeVerdict::kAccepted || eb.verdict != EdgeVerdict::kAccepted) return false;
  const double w = (ea.position - eb.position).norm();
  if (w < in.opt.min_width_fraction * in.scale || w > in.opt.max_width_fraction * in.scale) return false;
  const double htol = in.opt.height_tolerance_fraction * in.scale;
  const bool z0_agree = std::abs(ea.z0 - eb.z0) <= htol, z1_agree = std::abs(ea.z1 - eb.z1) <= htol;
  if (!z0_agree && !z1_agree) return false;
  ++res->pairs_considered;
  EdgePair p{static_cast<int>(i), static_cast<int>(j), 0.5 * (ea.z0 + eb.z0), 0.5 * (ea.z1 + eb.z1), 0, 0, 0,
             z0_agree && z1_agree};
  RefineHeightToEdge(in, ea.position, eb.position, z0_agree ? htol : 0.5 * std::abs(ea.z0 - eb.z0) + htol, htol,
                     &p.z0);
  RefineHeightToEdge(in, ea.position, eb.position, z1_agree ? htol : 0.5 * std::abs(ea.z1 - eb.z1) + htol, htol,
                     &p.z1);
  if (p.z0 < 0.5 * htol) p.z0 = 0.0;  // standing on the floor
  double step;
  int nf0, nf1;
  p.bottom = HorizontalEvidence(in, ea.position, eb.position, p.z0, &step, &nf0);
  p.top = HorizontalEvidence(in, ea.position, eb.position, p.z1, &step, &nf1);
  p.frames = std::min(nf0, nf1);
  if (p.frames < in.opt.min_horizontal_frames || p.top < in.opt.min_horizontal_score ||
      p.bottom < in.opt.min_horizontal_score || !(p.z1 > p.z0)) {
    ++res->pairs_rejected;
    return false;
  }
  *out = p;
  return true;
}

// Rectangles from the pairs, strongest horizontal evidence first (both
// heights agreeing before one), each edge in one rectangle at most, named
// with the next free id.
void FindRectangles(const BuildInputs& in, MapBuildResult* res) {
  std::vector<EdgePair> pairs;
  for (size_t i = 0; i < res->edges.size(); ++i)
    for (size_t j = i + 1; j < res->edges.size(); ++j) {
      EdgePair p;
      if (PairOf(in, i, j, res, &p)) pairs.push_back(p);
    }
  std::sort(pairs.begin(), pairs.end(), [](const EdgePair& x, const EdgePair& y) {
    if (x.both_heights_agree != y.both_heights_agree) return x.both_heights_agree;
    return std::min(x.top, x.bottom) > std::min(y.top, y.bottom);
  });
  std::set<std::string> ids;
  for (const MapRectangle& r : in.seed.rectangles) ids.insert(r.id);
  for (const MapBox& b : in.seed.boxes) ids.insert(b.id);
  int next = 1;
  for (const EdgePair& p : pairs) {
    BuiltEdge &ea = res->edges[static_cast<size_t>(p.a)], &eb = res->edges[static_cast<size_t>(p.b)];
    if (ea.rectangle >= 0 || eb.rectangle >= 0) continue;
    BuiltRectangle br;
    while (ids.count(in.opt.id_prefix + std::to_string(next))) ++next;
    br.rectangle.id = in.opt.id_prefix + std::to_string(next++);
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
    ea.rectangle = eb.rectangle = static_cast<int>(res->rectangles.size());
    res->rectangles.push_back(br);
    res->map.rectangles.push_back(br.rectangle);
  }
}

}  // namespace

MapBuildResult MapBuilder::Build() const {
  MapBuildResult res;
  res.map = seed_;
  res.frames = frames_;
  res.frames_with_pose = static_cast<int>(frames_list_.size());
  res.frames_with_seed = frames_with_seed_;
  res.detections = detections_;
  res.unexplained = unexplained_;
  if (frames_list_.empty()) return res;
  BuildInputs in{calib_.sensor, seed_, opt_, scale_, {}, {}, stored_};
  for (const Frame& f : frames_list_) {
    in.poses.push_back(f.pose);
    in.edges.push_back(&f.edges);
  }
  FindEdges(in, &res);
  FindRectangles(in, &res);
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
      std::snprintf(line, sizeof line, ", %s: %d", EdgeVerdictName(kv.first), kv.second);
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
    std::string verdict = EdgeVerdictName(e.verdict);
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
