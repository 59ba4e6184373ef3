#include "panotrack/track/relocalize.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <opencv2/imgproc.hpp>

#include "panotrack/core/cpu_features.h"
#include "panotrack/core/error.h"
#include "panotrack/core/parallel.h"

#ifdef PANO_HAVE_X86_TARGETS
#include <immintrin.h>
#endif

namespace pano {

void RelocalizeOptions::Check() const {
  if (grid_step < 0 || wall_margin < 0 || heading_bins < 36 || hypotheses < 1 || !(support_cap >= 0 && support_cap <= 1))
    throw Error("relocalisation: grid_step, wall_margin >= 0, heading_bins >= 36, hypotheses >= 1, support_cap 0..1");
}

namespace {

// The histogram bin of an image azimuth in (-pi, pi].
int AzimuthBin(double azimuth, int bins) {
  const int b = static_cast<int>(std::floor((azimuth + M_PI) / (2 * M_PI) * bins));
  return (b % bins + bins) % bins;
}

// The distinct vertical edges seen from a position (a rectangle's two
// corners share one), as azimuth bins at heading 0.
std::vector<int> EdgeBinsAt(const Eigen::Vector2d& position, int bins, const Sensor& sensor,
                            const RadiusTable& table, const Map& map, const Scene& scene,
                            const std::vector<Landmark>& landmarks, const PredictionOptions& prediction) {
  auto bin_of = [bins](const PredictedLandmark& p) { return AzimuthBin(p.azimuth, bins); };
  // A landmark on an edge already seen (its rectangle's other corner) adds
  // nothing: it is left out before the ray casts that would check it.
  auto on_new_edge = [&](const PredictedLandmark& candidate, const std::vector<PredictedLandmark>& predicted) {
    const int b = bin_of(candidate);
    return std::none_of(predicted.begin(), predicted.end(),
                        [&](const PredictedLandmark& p) { return bin_of(p) == b; });
  };
  std::vector<int> edge_bins;
  for (const PredictedLandmark& p : PredictLandmarks(landmarks, map, scene, sensor, table,
                                                     Pose2{position.x(), position.y(), 0.0}, prediction, on_new_edge))
    edge_bins.push_back(bin_of(p));
  return edge_bins;
}

}  // namespace

HeadingSearch::HeadingSearch(const std::vector<float>& hist)
    : bins_(static_cast<int>(hist.size())), reversed2_(2 * hist.size()) {
  if (bins_ < 1) throw Error("heading search: expected a histogram of >= 1 bins");
  for (int j = 0; j < 2 * bins_; ++j)
    reversed2_[static_cast<size_t>(j)] = hist[static_cast<size_t>((2 * bins_ - j) % bins_)];
}

namespace {

// out[t] = sum over k of runs[offsets[k] + t], t < n, summed in double in
// the order of k (every path below gives the same bits).
void SumRuns(const float* runs, const std::vector<int>& offsets, int n, double* out) {
  std::fill(out, out + n, 0.0);
  for (int offset : offsets) {
    const float* run = runs + offset;
    for (int t = 0; t < n; ++t) out[t] += run[t];
  }
}

// The first t of the largest score sum[t] - penalty when above 0, with
// that score in *best; -1 (*best 0) when none is above 0.
int FirstBest(const double* sum, int n, double penalty, double* best) {
  *best = 0.0;
  int best_t = -1;
  for (int t = 0; t < n; ++t) {
    const double score = sum[t] - penalty;
    if (score > *best) {
      *best = score;
      best_t = t;
    }
  }
  return best_t;
}

#ifdef PANO_HAVE_X86_TARGETS
// The same, four scores at a time: their maximum, then the first score
// that equals it (the one the scalar scan keeps).
__attribute__((target("avx2"))) int FirstBestAvx2(const double* sum, int n, double penalty, double* best) {
  const __m256d vpenalty = _mm256_set1_pd(penalty);
  __m256d vmax = _mm256_setzero_pd();
  int t = 0;
  for (; t + 4 <= n; t += 4) vmax = _mm256_max_pd(vmax, _mm256_sub_pd(_mm256_loadu_pd(sum + t), vpenalty));
  double lanes[4];
  _mm256_storeu_pd(lanes, vmax);
  double top = std::max(std::max(lanes[0], lanes[1]), std::max(lanes[2], lanes[3]));
  for (; t < n; ++t) top = std::max(top, sum[t] - penalty);
  *best = 0.0;
  if (!(top > 0.0)) return -1;
  *best = top;
  const __m256d vtop = _mm256_set1_pd(top);
  for (t = 0; t + 4 <= n; t += 4) {
    const __m256d score = _mm256_sub_pd(_mm256_loadu_pd(sum + t), vpenalty);
    const int mask = _mm256_movemask_pd(_mm256_cmp_pd(score, vtop, _CMP_EQ_OQ));
    if (mask) return t + __builtin_ctz(static_cast<unsigned>(mask));
  }
  for (; t < n; ++t)
    if (sum[t] - penalty == top) return t;
  return -1;  // not reached: top is one of the scores
}

// SumRuns, 32 headings at a time held in registers across the runs.
__attribute__((target("avx2"))) void SumRunsAvx2(const float* runs, const std::vector<int>& offsets, int n,
                                                 double* out) {
  constexpr int kLanes = 4, kRegisters = 8, kChunk = kLanes * kRegisters;
  int t0 = 0;
  for (; t0 + kChunk <= n; t0 += kChunk) {
    __m256d acc[kRegisters];
    for (__m256d& a : acc) a = _mm256_setzero_pd();
    for (int offset : offsets) {
      const float* run = runs + offset + t0;
      for (int r = 0; r < kRegisters; ++r)
        acc[r] = _mm256_add_pd(acc[r], _mm256_cvtps_pd(_mm_loadu_ps(run + kLanes * r)));
    }
    for (int r = 0; r < kRegisters; ++r) _mm256_storeu_pd(out + t0 + kLanes * r, acc[r]);
  }
  std::fill(out + t0, out + n, 0.0);
  for (int offset : offsets)
    for (int t = t0; t < n; ++t) out[t] += runs[offset + t];
}
#endif

}  // namespace

int HeadingSearch::Best(const std::vector<int>& edge_bins, double* best_score) const {
  // Every heading at once: edge bin b adds hist[b - t] to heading t, a
  // contiguous run of the reversed histogram. Summed in double in the
  // edges' order, as one heading at a time would: the same scores.
  thread_local std::vector<int> offsets;
  thread_local std::vector<double> sum;
  offsets.clear();
  for (int b : edge_bins) offsets.push_back(bins_ - b);
  sum.resize(static_cast<size_t>(bins_));
  const double penalty = 0.15 * edge_bins.size();
#ifdef PANO_HAVE_X86_TARGETS
  if (HaveAvx2()) {
    SumRunsAvx2(reversed2_.data(), offsets, bins_, sum.data());
    return FirstBestAvx2(sum.data(), bins_, penalty, best_score);
  }
#endif
  SumRuns(reversed2_.data(), offsets, bins_, sum.data());
  return FirstBest(sum.data(), bins_, penalty, best_score);
}

namespace {

// The best heading at one position.
PoseHypothesis BestHeadingAt(const Eigen::Vector2d& position, const std::vector<int>& edge_bins,
                             const HeadingSearch& search, int bins) {
  PoseHypothesis best{Pose2{position.x(), position.y(), 0.0}, 0.0};
  if (edge_bins.size() < 3) return best;
  const int t = search.Best(edge_bins, &best.score);
  if (t >= 0) best.pose.theta = WrapAngle((t + 0.5) * 2 * M_PI / bins);
  return best;
}

}  // namespace

RelocalizationIndex::RelocalizationIndex(const Sensor& sensor, const RadiusTable& table, const Map& map,
                                         const Scene& scene, const std::vector<Landmark>& landmarks,
                                         const PredictionOptions& prediction, const RelocalizeOptions& options,
                                         int num_threads)
    : opt_(options), cols_(sensor.image_width), rows_(sensor.image_height), aspect_(sensor.params.aspect) {
  opt_.Check();
  const int bins = opt_.heading_bins;
  const double limb = sensor.limb_radius();
  for (int v = 1; v < rows_ - 1; ++v)
    for (int u = 1; u < cols_ - 1; ++u) {
      double r, az;
      sensor.to_polar(u, v, &r, &az);
      if (r < 0.3 * limb || r > 0.97 * limb) continue;
      pixels_.push_back({v * cols_ + u, v, AzimuthBin(az, bins), static_cast<float>(std::cos(az)),
                         static_cast<float>(std::sin(az))});
    }
  Eigen::Vector2d lo, hi;
  double top;
  map.Extent(&lo, &hi, &top);
  step_ = opt_.grid_step > 0 ? opt_.grid_step : std::max(hi.x() - lo.x(), hi.y() - lo.y()) / 40.0;
  const double margin = opt_.wall_margin > 0 ? opt_.wall_margin : step_;
  for (double x = lo.x() + margin; x <= hi.x() - margin; x += step_)
    for (double y = lo.y() + margin; y <= hi.y() - margin; y += step_)
      if (map.IsFree(x, y) && map.IsFree(x + margin, y) && map.IsFree(x - margin, y) &&
          map.IsFree(x, y + margin) && map.IsFree(x, y - margin))
        positions_.emplace_back(x, y);
  edge_bins_.resize(positions_.size());
  // Built when a run first searches, beside the decoder: threads of its own.
  ParallelForOnOwnThreads(
      static_cast<int>(positions_.size()),
      [&](int i) { edge_bins_[i] = EdgeBinsAt(positions_[i], bins, sensor, table, map, scene, landmarks, prediction); },
      num_threads, 4);
}

std::vector<float> RelocalizationIndex::RadialEdgeHistogram(const cv::Mat& grey) const {
  if (grey.type() != CV_8UC1 || grey.cols != cols_ || grey.rows != rows_)
    throw Error("relocalisation: expected an 8-bit grey image of the sensor's size");
  const int bins = opt_.heading_bins;
  const uint8_t* img = grey.ptr<uint8_t>(0);
  const int w = static_cast<int>(grey.step[0]);  // bytes from one row to the next
  const int row_padding = w - cols_;              // 0 for a continuous frame
  std::vector<double> h(bins, 0.0);
  for (const Pixel& p : pixels_) {
    // 3x3 Sobel, as cv::Sobel computes it inside the image.
    const uint8_t* c = img + p.offset + p.row * row_padding;
    const float gx = static_cast<float>((c[-w + 1] + 2 * c[1] + c[w + 1]) - (c[-w - 1] + 2 * c[-1] + c[w - 1]));
    const float gy = static_cast<float>((c[w - 1] + 2 * c[w] + c[w + 1]) - (c[-w - 1] + 2 * c[-w] + c[-w + 1]));
    const double g_tan = -p.sin_az * gx + p.cos_az * gy / aspect_;
    const double g_rad = p.cos_az * gx + p.sin_az * gy / aspect_;
    if (std::abs(g_tan) < 2.0 * std::abs(g_rad) || std::abs(g_tan) < 8.0) continue;
    h[p.bin] += std::abs(g_tan);
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

std::vector<PoseHypothesis> RelocalizationIndex::Hypotheses(const cv::Mat& grey, int num_threads, int count) const {
  if (count <= 0) count = opt_.hypotheses;
  std::vector<float> hist = RadialEdgeHistogram(grey);
  if (opt_.support_cap > 0)
    for (float& h : hist) h = static_cast<float>(std::min<double>(h, opt_.support_cap) / opt_.support_cap);
  const int bins = static_cast<int>(hist.size());
  const HeadingSearch search(hist);
  std::vector<PoseHypothesis> scored(positions_.size());
  ParallelForOnOwnThreads(
      static_cast<int>(positions_.size()),
      [&](int i) { scored[i] = BestHeadingAt(positions_[i], edge_bins_[i], search, bins); }, num_threads, 16);
  std::stable_sort(scored.begin(), scored.end(),
                   [](const PoseHypothesis& a, const PoseHypothesis& b) { return a.score > b.score; });
  // Distinct hypotheses: at least two grid steps or 20 degrees apart.
  std::vector<PoseHypothesis> out;
  for (const PoseHypothesis& h : scored) {
    if (h.score <= 0) break;
    bool distinct = true;
    for (const PoseHypothesis& o : out)
      if (std::hypot(h.pose.x - o.pose.x, h.pose.y - o.pose.y) < 2 * step_ &&
          std::abs(WrapAngle(h.pose.theta - o.pose.theta)) < 20 * M_PI / 180)
        distinct = false;
    if (distinct) out.push_back(h);
    if (static_cast<int>(out.size()) >= count) break;
  }
  return out;
}

std::shared_ptr<const RelocalizationIndex> SharedRelocalizationIndex::Get(
    const std::function<std::unique_ptr<const RelocalizationIndex>()>& build) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!index_) index_ = build();
  return index_;
}

}  // namespace pano
