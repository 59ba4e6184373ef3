#include "panotrack/track/survey_error.h"

#include <algorithm>
#include <limits>

#include "panotrack/core/cpu_features.h"
#include "panotrack/core/error.h"

#ifdef PANO_HAVE_X86_TARGETS
#include <immintrin.h>
#endif

namespace pano {

namespace {
// Pairs needed before they cap the image noise.
constexpr double kMinPairs = 5.0;
// An estimate not yet confident is told from this many bearings (about a
// frame's).
constexpr double kMinEarlyBearings = 5.0;
// ... and reported where it exceeds this many times the exact map's doubt.
constexpr double kEarlyDoubt = 2.0;
// ... and made provisional (Early) where it exceeds this many times a
// careful tape survey's error.
constexpr double kEarlyClear = 1.5;
// The largest share of a bearing's error the pose fit is taken to absorb.
constexpr double kMaxLeverage = 0.8;
// Reweighting steps of the fit.
constexpr int kFitIterations = 6;
// The median of a chi-square of one degree of freedom.
constexpr double kChiSquare1Median = 0.454936423119572;
// A pair difference beyond this many standard deviations of the pairs'
// core is a wrong junction's, not image noise.
constexpr double kPairOutlier = 3.0;
// The smallest variance a reweighting step divides by.
constexpr double kMinVariance = 1e-30;

using internal::NormalSums;

constexpr int kLanes = 4;  // WeightedNormalSums' order

NormalSums SumLanes(const double (&lanes)[5][kLanes]) {
  double total[5];
  for (int k = 0; k < 5; ++k) total[k] = (lanes[k][0] + lanes[k][1]) + (lanes[k][2] + lanes[k][3]);
  return {total[0], total[1], total[2], total[3], total[4]};
}

void AddSample(double u, double y, double weight, double a, double b, double (&lanes)[5][kLanes], int lane) {
  const double v = std::max(a + b * u, kMinVariance);
  const double w = weight / (v * v);
  const double wu = w * u;
  lanes[0][lane] += w;
  lanes[1][lane] += wu;
  lanes[2][lane] += wu * u;
  lanes[3][lane] += w * y;
  lanes[4][lane] += wu * y;
}

#ifdef PANO_HAVE_X86_TARGETS
// The same, four samples at a time (the same operations per lane, none
// fused: the same sums to the bit).
__attribute__((target("avx2"))) NormalSums SumsAvx2(const double* u, const double* y, const double* weight, size_t n,
                                                   double a, double b) {
  const __m256d va = _mm256_set1_pd(a), vb = _mm256_set1_pd(b), floor = _mm256_set1_pd(kMinVariance);
  __m256d acc[5];
  for (__m256d& x : acc) x = _mm256_setzero_pd();
  size_t i = 0;
  for (; i + kLanes <= n; i += kLanes) {
    const __m256d vu = _mm256_loadu_pd(u + i), vy = _mm256_loadu_pd(y + i);
    // max(floor, v): v where v is NaN, as std::max(v, floor).
    const __m256d v = _mm256_max_pd(floor, _mm256_add_pd(va, _mm256_mul_pd(vb, vu)));
    const __m256d w = _mm256_div_pd(_mm256_loadu_pd(weight + i), _mm256_mul_pd(v, v));
    const __m256d wu = _mm256_mul_pd(w, vu);
    acc[0] = _mm256_add_pd(acc[0], w);
    acc[1] = _mm256_add_pd(acc[1], wu);
    acc[2] = _mm256_add_pd(acc[2], _mm256_mul_pd(wu, vu));
    acc[3] = _mm256_add_pd(acc[3], _mm256_mul_pd(w, vy));
    acc[4] = _mm256_add_pd(acc[4], _mm256_mul_pd(wu, vy));
  }
  double lanes[5][kLanes];
  for (int k = 0; k < 5; ++k) _mm256_storeu_pd(lanes[k], acc[k]);
  for (; i < n; ++i) AddSample(u[i], y[i], weight[i], a, b, lanes, static_cast<int>(i % kLanes));
  return SumLanes(lanes);
}
#endif

}  // namespace

namespace internal {

NormalSums PortableNormalSums(const double* u, const double* y, const double* weight, size_t n, double a, double b) {
  double lanes[5][kLanes] = {};
  for (size_t i = 0; i < n; ++i) AddSample(u[i], y[i], weight[i], a, b, lanes, static_cast<int>(i % kLanes));
  return SumLanes(lanes);
}

NormalSums WeightedNormalSums(const double* u, const double* y, const double* weight, size_t n, double a, double b) {
#ifdef PANO_HAVE_X86_TARGETS
  if (HaveAvx2()) return SumsAvx2(u, y, weight, n, a, b);
#endif
  return PortableNormalSums(u, y, weight, n, a, b);
}

}  // namespace internal

void SurveyErrorOptions::Check() const {
  if (!(unstated_fraction >= 0.0) || !(max_fraction >= unstated_fraction) || !std::isfinite(max_fraction))
    throw Error("survey error: unstated_fraction: expected >= 0, max_fraction: expected >= unstated_fraction");
  if (!(min_bearings >= 0.0)) throw Error("survey error: min_bearings: expected >= 0");
  if (!(exact_doubt_fraction >= 0.0) || !std::isfinite(exact_doubt_fraction))
    throw Error("survey error: exact_doubt_fraction: expected >= 0");
  if (!(max_image_sigma > 0.0) || !std::isfinite(max_image_sigma))
    throw Error("survey error: max_image_sigma: expected a positive angle");
  if (!(forgetting > 0.0 && forgetting <= 1.0)) throw Error("survey error: forgetting: expected in (0, 1]");
  if (!(estimate_margin >= 1.0) || !std::isfinite(estimate_margin))
    throw Error("survey error: estimate_margin: expected >= 1");
  if (!(doubt_fraction >= 0.0) || !std::isfinite(doubt_fraction))
    throw Error("survey error: doubt_fraction: expected >= 0");
  if (!(stated_margin >= 1.0) || !std::isfinite(stated_margin))
    throw Error("survey error: stated_margin: expected >= 1");
}

SurveyErrorEstimate::SurveyErrorEstimate(const SurveyErrorOptions& options, double typical_distance)
    : opt_(options), typical_distance_(typical_distance) {
  opt_.Check();
  if (!(typical_distance_ > 0.0) || !std::isfinite(typical_distance_))
    throw Error("survey error: typical landmark distance: expected a positive length");
}

void SurveyErrorEstimate::Reset() {
  sample_u_.clear();
  sample_y_.clear();
  sample_weight_.clear();
  first_sample_ = 0;
  weight_scale_ = 1.0;
  stored_weight_ = 0.0;
  n_ = 0.0;
  pair_samples_.clear();
  survey_ = image_variance_ = provisional_ = 0.0;
}

double SurveyErrorEstimate::StatedSigma(double stated) const {
  return std::isnan(stated) ? opt_.unstated_fraction * typical_distance_ : stated;
}

double SurveyErrorEstimate::Sigma(double stated) const {
  const double base = StatedSigma(stated);
  if (!opt_.check) return base;
  if (!confident()) return std::max(base, provisional_);
  if (std::isnan(stated)) return survey_;
  // An exact map (a rendered room, a CAD model) stays exact unless the
  // residuals clearly say otherwise: below that the image's noise and the
  // fit's leave a small survey term in any estimate.
  // The survey's share must also stand out of the image noise's at the
  // typical distance: a few frames with someone in front of an edge leave
  // such a share in an unbiased fit.
  if (stated == 0.0) return survey_ > ExactDoubt() ? survey_ : 0.0;
  return std::max(stated, survey_);
}

double SurveyErrorEstimate::ExactDoubt() const {
  return std::max(opt_.exact_doubt_fraction, image_sigma()) * typical_distance_;
}

double SurveyErrorEstimate::ReportedSigma(double stated) const {
  const double used = Sigma(stated);
  if (!(std::isnan(stated) || stated == 0.0)) return opt_.stated_margin * used;
  if (!opt_.check) return used;
  // The estimate alone decides: a map that states nothing, or an exact
  // statement the residuals overrule; before it is confident, what the
  // first frames show where it is clearly more than an exact map's (the
  // tolerances wait for more, the covariances need not).
  const bool shown = confident() ? used > 0.0
                                 : n_ >= kMinEarlyBearings &&
                                       survey_ > kEarlyDoubt * opt_.exact_doubt_fraction * typical_distance_;
  return shown ? std::max(used, std::min(opt_.estimate_margin * survey_, opt_.max_fraction * typical_distance_))
               : used;
}

double SurveyErrorEstimate::Early() const {
  // A frame or two of residuals is a rough estimate, but an error well
  // beyond a careful tape survey's is clear from the first frames. (Below
  // it, the residuals of a few frames with people, blur or exposure changes
  // in them look like up to a tape survey's error on an exact map.)
  const bool clear = n_ >= kMinEarlyBearings && survey_ > kEarlyClear * opt_.unstated_fraction * typical_distance_;
  return clear ? survey_ : 0.0;
}

void SurveyErrorEstimate::Update(const std::vector<double>& residuals, const std::vector<double>& distances,
                                 const std::vector<double>& pairs, int fitted, const std::vector<double>& leverages) {
  const size_t n = std::min(residuals.size(), distances.size());
  if (static_cast<int>(n) <= fitted) return;
  // Residuals of a least-squares fit are smaller than the errors by about
  // (n - fitted) / n in variance.
  const double inflate = static_cast<double>(n) / static_cast<double>(static_cast<int>(n) - fitted);
  const double keep = opt_.forgetting;
  // Evidence forgotten below a hundredth no longer counts.
  constexpr double kForgotten = 1e-2;
  Forget(keep, kForgotten);
  for (PairSample& pair : pair_samples_) pair.weight *= keep;
  pair_samples_.erase(std::remove_if(pair_samples_.begin(), pair_samples_.end(),
                                     [](const PairSample& x) { return x.weight < kForgotten; }),
                      pair_samples_.end());
  // Kept in the order of y, which forgetting keeps (PairVariance's median).
  for (double q : pairs) {
    if (!std::isfinite(q)) continue;
    const PairSample pair{0.5 * q * q, 1.0};
    pair_samples_.insert(std::upper_bound(pair_samples_.begin(), pair_samples_.end(), pair,
                                          [](const PairSample& a, const PairSample& b) { return a.y < b.y; }),
                         pair);
  }
  for (size_t i = 0; i < n; ++i) {
    if (!(distances[i] > 0.0) || !std::isfinite(residuals[i])) continue;
    // A bearing the fit rests on almost alone tells little: its share is
    // capped at kMaxLeverage.
    const double kept = i < leverages.size() ? 1.0 - std::clamp(leverages[i], 0.0, kMaxLeverage) : 1.0 / inflate;
    sample_u_.push_back(1.0 / (distances[i] * distances[i]));
    sample_y_.push_back(residuals[i] * residuals[i] / kept);
    sample_weight_.push_back(1.0 / weight_scale_);
    stored_weight_ += sample_weight_.back();
  }
  n_ = stored_weight_ * weight_scale_;
  Fit();
}

void SurveyErrorEstimate::Forget(double keep, double forgotten) {
  weight_scale_ *= keep;
  // The oldest samples weigh least: the forgotten ones are the first.
  const size_t end = sample_weight_.size();
  while (first_sample_ < end && sample_weight_[first_sample_] * weight_scale_ < forgotten)
    stored_weight_ -= sample_weight_[first_sample_++];
  if (first_sample_ == end) stored_weight_ = 0.0;
  // Now and then: the forgotten samples' room back, and the stored weights
  // back to the weights themselves (far from overflow in the fit's sums).
  constexpr double kSmallestScale = 1e-20;
  if (2 * first_sample_ > end || weight_scale_ < kSmallestScale) {
    for (std::vector<double>* column : {&sample_u_, &sample_y_, &sample_weight_})
      column->erase(column->begin(), column->begin() + static_cast<std::ptrdiff_t>(first_sample_));
    first_sample_ = 0;
    stored_weight_ = 0.0;
    for (double& weight : sample_weight_) stored_weight_ += weight *= weight_scale_;
    weight_scale_ = 1.0;
  }
}

double SurveyErrorEstimate::PairWeight() const {
  double total = 0.0;
  for (const PairSample& pair : pair_samples_) total += pair.weight;
  return total;
}

bool SurveyErrorEstimate::WantsPairs() const { return PairWeight() < 2.0 * kMinPairs; }

double SurveyErrorEstimate::PairVariance() const {
  const double total = PairWeight();
  if (total < kMinPairs) return std::numeric_limits<double>::infinity();
  // The weighted median of the halved squared differences, over the median
  // of a chi-square of one degree of freedom: the variance of the pairs'
  // core. The mean square of the pairs within kPairOutlier of its standard
  // deviations: one pair with a wrong junction (a person in front of one
  // corner, a degree off) is no image noise, and lifted the mean square
  // enough to take a map's error for the images'; the median alone would
  // leave out blur's broad tails, which are.
  const std::vector<PairSample>& sorted = pair_samples_;  // in the order of y (Update)
  double below = 0.0, core = sorted.back().y;
  for (const PairSample& pair : sorted) {
    below += pair.weight;
    if (below >= 0.5 * total) {
      core = pair.y / kChiSquare1Median;
      break;
    }
  }
  const double limit = kPairOutlier * kPairOutlier * core;
  double weight = 0.0, sum = 0.0;
  for (const PairSample& pair : sorted) {
    if (pair.y > limit) break;
    weight += pair.weight;
    sum += pair.weight * pair.y;
  }
  return weight > 0.0 ? sum / weight : core;
}

void SurveyErrorEstimate::Fit() {
  if (first_sample_ == sample_u_.size()) return;
  // The pairs' image noise, with a margin (four times its variance: a few
  // pairs vary), caps the image's share, as does the noisiest tracker's;
  // the rest is the survey's.
  const double image_bound = std::min(opt_.max_image_sigma * opt_.max_image_sigma, 4.0 * PairVariance());
  // The stored weights, not the weights: a common factor changes no step.
  const size_t n = sample_u_.size() - first_sample_;
  const double *u = sample_u_.data() + first_sample_, *y = sample_y_.data() + first_sample_,
               *weight = sample_weight_.data() + first_sample_;
  // Start from all of it the survey's (the residuals' mean square in map
  // units), then reweigh by the variance fitted.
  double a = 0.0, b = 0.0, sw = 0.0;
  for (size_t i = 0; i < n; ++i) {
    b += weight[i] * y[i] / u[i];
    sw += weight[i];
  }
  b /= sw;
  for (int iteration = 0; iteration < kFitIterations; ++iteration) {
    // Weighted normal equations of y = a + b u, weights 1 / (a + b u)^2.
    const NormalSums sums = internal::WeightedNormalSums(u, y, weight, n, a, b);
    const double s1 = sums.s1, su = sums.su, suu = sums.suu, sy = sums.sy, suy = sums.suy;
    const double det = s1 * suu - su * su;
    // The distances must spread enough to tell the terms apart (relative
    // weighted variance of u above 1 %); else the excess is the image
    // noise's, up to its bound.
    double next_a = sy / s1, next_b = 0.0;  // all of it the image's
    if (det > 1e-2 * su * su) {
      const double slope = (s1 * suy - su * sy) / det;
      if (slope > 0.0) {
        next_b = slope;
        next_a = (sy - slope * su) / s1;
      }
    }
    // All of it the survey's; or as much as the image may hold, the rest
    // the survey's.
    if (next_a < 0.0 || next_a > image_bound) {
      next_a = std::clamp(next_a, 0.0, image_bound);
      next_b = std::max(0.0, (suy - next_a * su) / suu);
    }
    // A fixed point reached: the further steps would repeat it.
    const bool converged = next_a == a && next_b == b;
    a = next_a;
    b = next_b;
    if (converged) break;
  }
  image_variance_ = a;
  survey_ = std::min(std::sqrt(b), opt_.max_fraction * typical_distance_);
}

}  // namespace pano
