#include "track/relocalize.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "core/parallel.h"

namespace pano {

void RelocalizeOptions::Check() const {
  if (grid_step < 0 || wall_margin < 0 || heading_bins < 36 || hypotheses < 1)
    throw Error("relocalisation: grid_step, wall_margin >= 0, heading_bins >= 36, hypotheses >= 1");
}

std::vector<float> RadialEdgeHistogram(const cv::Mat& grey, const Sensor& s, int bins) {
  cv::Mat gx, gy;
  cv::Sobel(grey, gx, CV_32F, 1, 0, 3);
  cv::Sobel(grey, gy, CV_32F, 0, 1, 3);
  std::vector<double> h(bins, 0.0);
  const double limb = s.limb_radius();
  for (int v = 1; v < grey.rows - 1; ++v) {
    const float* px = gx.ptr<float>(v);
    const float* py = gy.ptr<float>(v);
    for (int u = 1; u < grey.cols - 1; ++u) {
      double r, az;
      s.to_polar(u, v, &r, &az);
      if (r < 0.3 * limb || r > 0.97 * limb) continue;
      const double c = std::cos(az), sn = std::sin(az);
      const double g_tan = -sn * px[u] + c * py[u] / s.params.aspect;
      const double g_rad = c * px[u] + sn * py[u] / s.params.aspect;
      if (std::abs(g_tan) < 2.0 * std::abs(g_rad) || std::abs(g_tan) < 8.0) continue;
      int b = static_cast<int>(std::floor((az + M_PI) / (2 * M_PI) * bins));
      h[(b % bins + bins) % bins] += std::abs(g_tan);
    }
  }
  // Smooth with a triangle of half-width 2 degrees (a candidate position a
  // grid step off shifts near bearings by that much) and normalise to a
  // maximum of 1.
  const int half = std::max(1, static_cast<int>(std::lround(2.0 / 360.0 * bins)));
  std::vector<float> out(bins);
  double mx = 0;
  for (int b = 0; b < bins; ++b) {
    double v = 0;
    for (int k = -half; k <= half; ++k) v += (half + 1 - std::abs(k)) * h[((b + k) % bins + bins) % bins];
    out[b] = static_cast<float>(v);
    mx = std::max(mx, v);
  }
  if (mx > 0)
    for (float& v : out) v = static_cast<float>(v / mx);
  return out;
}

namespace {

// The best heading at one grid position: the predicted vertical edges'
// support in the radial-edge histogram, less a little per predicted edge.
PoseHypothesis BestHeadingAt(const Eigen::Vector2d& position, const std::vector<float>& hist, int bins,
                             const Sensor& sensor, const RadiusTable& table, const Map& map,
                             const Scene& scene, const std::vector<Landmark>& landmarks,
                             const PredictionOptions& prediction) {
  const Pose2 at0{position.x(), position.y(), 0.0};
  const std::vector<PredictedLandmark> pred =
      PredictLandmarks(landmarks, map, scene, sensor, table, at0, prediction);
  // Distinct vertical edges (a rectangle's two corners share one).
  std::vector<int> edge_bins;
  for (const PredictedLandmark& p : pred) {
    int b = static_cast<int>(std::floor((p.azimuth + M_PI) / (2 * M_PI) * bins));
    b = (b % bins + bins) % bins;
    if (std::find(edge_bins.begin(), edge_bins.end(), b) == edge_bins.end()) edge_bins.push_back(b);
  }
  PoseHypothesis best{at0, 0.0};
  if (edge_bins.size() < 3) return best;
  // At heading theta the azimuths are those at 0 minus theta.
  for (int t = 0; t < bins; ++t) {
    double sum = 0;
    for (int b : edge_bins) sum += hist[(b - t + bins) % bins];
    // Support of the predicted edges, less a little for each predicted
    // edge: a pose that predicts edges where there are none is worse.
    const double score = sum - 0.15 * edge_bins.size();
    if (score > best.score) {
      best.score = score;
      best.pose.theta = wrap_angle((t + 0.5) * 2 * M_PI / bins);
    }
  }
  return best;
}

}  // namespace

std::vector<PoseHypothesis> RelocalizationHypotheses(const cv::Mat& grey, const Sensor& sensor,
                                                     const RadiusTable& table, const Map& map,
                                                     const Scene& scene,
                                                     const std::vector<Landmark>& landmarks,
                                                     const PredictionOptions& prediction,
                                                     const RelocalizeOptions& opt, int num_threads) {
  opt.Check();
  const int bins = opt.heading_bins;
  const std::vector<float> hist = RadialEdgeHistogram(grey, sensor, bins);
  Eigen::Vector2d lo, hi;
  double top;
  map.Extent(&lo, &hi, &top);
  const double step = opt.grid_step > 0 ? opt.grid_step : std::max(hi.x() - lo.x(), hi.y() - lo.y()) / 40.0;
  const double margin = opt.wall_margin > 0 ? opt.wall_margin : step;
  std::vector<Eigen::Vector2d> positions;
  for (double x = lo.x() + margin; x <= hi.x() - margin; x += step)
    for (double y = lo.y() + margin; y <= hi.y() - margin; y += step)
      if (map.IsFree(x, y) && map.IsFree(x + margin, y) && map.IsFree(x - margin, y) &&
          map.IsFree(x, y + margin) && map.IsFree(x, y - margin))
        positions.emplace_back(x, y);
  std::vector<PoseHypothesis> scored(positions.size());
  std::vector<std::exception_ptr> errors(positions.size());
#pragma omp parallel for schedule(dynamic, 4) num_threads(ThreadCount(num_threads))
  for (int i = 0; i < static_cast<int>(positions.size()); ++i) {
    try {
      scored[i] = BestHeadingAt(positions[i], hist, bins, sensor, table, map, scene, landmarks, prediction);
    } catch (...) {
      errors[static_cast<size_t>(i)] = std::current_exception();
    }
  }
  RethrowFirst(errors);
  std::sort(scored.begin(), scored.end(),
            [](const PoseHypothesis& a, const PoseHypothesis& b) { return a.score > b.score; });
  // Distinct hypotheses: at least two grid steps or 20 degrees apart.
  std::vector<PoseHypothesis> out;
  for (const PoseHypothesis& h : scored) {
    if (h.score <= 0) break;
    bool distinct = true;
    for (const PoseHypothesis& o : out)
      if (std::hypot(h.pose.x - o.pose.x, h.pose.y - o.pose.y) < 2 * step &&
          std::abs(wrap_angle(h.pose.theta - o.pose.theta)) < 20 * M_PI / 180)
        distinct = false;
    if (distinct) out.push_back(h);
    if (static_cast<int>(out.size()) >= opt.hypotheses) break;
  }
  return out;
}

}  // namespace pano
