#include "panotrack/track/survey_error.h"

#include <algorithm>

#include "panotrack/core/error.h"

namespace pano {

namespace {
// Pairs needed before they cap the image noise.
constexpr double kMinPairs = 5.0;
// An estimate not yet confident is told from this many bearings (about a
// frame's).
constexpr double kMinEarlyBearings = 5.0;
// ... and reported where it exceeds this many times the exact map's doubt.
constexpr double kEarlyDoubt = 2.0;
}  // namespace

void SurveyErrorOptions::Check() const {
  if (!(unstated_fraction >= 0.0) || !(max_fraction >= unstated_fraction) || !std::isfinite(max_fraction))
    throw Error("survey error: unstated_fraction: expected >= 0, max_fraction: expected >= unstated_fraction");
  if (!(min_bearings >= 0.0)) throw Error("survey error: min_bearings: expected >= 0");
  if (!(exact_doubt_fraction >= 0.0) || !std::isfinite(exact_doubt_fraction))
    throw Error("survey error: exact_doubt_fraction: expected >= 0");
  if (!(forgetting > 0.0 && forgetting <= 1.0)) throw Error("survey error: forgetting: expected in (0, 1]");
  if (!(estimate_margin >= 1.0) || !std::isfinite(estimate_margin))
    throw Error("survey error: estimate_margin: expected >= 1");
}

SurveyErrorEstimate::SurveyErrorEstimate(const SurveyErrorOptions& options, double typical_distance)
    : opt_(options), typical_distance_(typical_distance) {
  opt_.Check();
  if (!(typical_distance_ > 0.0) || !std::isfinite(typical_distance_))
    throw Error("survey error: typical landmark distance: expected a positive length");
}

void SurveyErrorEstimate::Reset() {
  n_ = su_ = suu_ = sy_ = suy_ = 0.0;
  n_pairs_ = s_pairs_ = 0.0;
  survey_ = image_variance_ = provisional_ = 0.0;
}

double SurveyErrorEstimate::Sigma(double stated) const {
  const double base = std::isnan(stated) ? opt_.unstated_fraction * typical_distance_ : stated;
  if (!opt_.check) return base;
  if (!confident()) return std::max(base, provisional_);
  if (std::isnan(stated)) return survey_;
  // An exact map (a rendered room, a CAD model) stays exact unless the
  // residuals clearly say otherwise: below that the image's noise and the
  // fit's leave a small survey term in any estimate.
  if (stated == 0.0) return survey_ > opt_.exact_doubt_fraction * typical_distance_ ? survey_ : 0.0;
  return std::max(stated, survey_);
}

double SurveyErrorEstimate::ReportedSigma(double stated) const {
  const double used = Sigma(stated);
  if (!opt_.check || !(std::isnan(stated) || stated == 0.0)) return used;
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
  // A frame or two of residuals is a rough estimate, but an error beyond a
  // careful tape survey's is clear from the first frames. (Below it, the
  // residuals of a few frames with people, blur or exposure changes in
  // them look like a few millimetres of survey error on an exact map.)
  const bool clear = n_ >= kMinEarlyBearings && survey_ > opt_.unstated_fraction * typical_distance_;
  return clear ? survey_ : 0.0;
}

void SurveyErrorEstimate::Update(const std::vector<double>& residuals, const std::vector<double>& distances,
                                 const std::vector<double>& pairs, int fitted) {
  const size_t n = std::min(residuals.size(), distances.size());
  if (static_cast<int>(n) <= fitted) return;
  // Residuals of a least-squares fit are smaller than the errors by about
  // (n - fitted) / n in variance.
  const double inflate = static_cast<double>(n) / static_cast<double>(static_cast<int>(n) - fitted);
  const double keep = opt_.forgetting;
  n_ *= keep;
  su_ *= keep;
  suu_ *= keep;
  sy_ *= keep;
  suy_ *= keep;
  n_pairs_ *= keep;
  s_pairs_ *= keep;
  for (double q : pairs) {
    if (!std::isfinite(q)) continue;
    n_pairs_ += 1.0;
    s_pairs_ += 0.5 * q * q;
  }
  for (size_t i = 0; i < n; ++i) {
    if (!(distances[i] > 0.0) || !std::isfinite(residuals[i])) continue;
    const double u = 1.0 / (distances[i] * distances[i]);
    const double y = inflate * residuals[i] * residuals[i];
    n_ += 1.0;
    su_ += u;
    suu_ += u * u;
    sy_ += y;
    suy_ += u * y;
  }
  Fit();
}

void SurveyErrorEstimate::Fit() {
  if (!(n_ > 0.0)) return;
  const double mu = su_ / n_, my = sy_ / n_;
  const double var_u = suu_ / n_ - mu * mu, cov = suy_ / n_ - mu * my;
  double a = my, b = 0.0;
  // The distances must spread enough to tell the terms apart (relative
  // variance of u above 1 %); else the excess is the image noise's.
  if (var_u > 1e-2 * mu * mu) {
    b = std::max(0.0, cov / var_u);
    a = my - b * mu;
    if (a < 0.0) {  // all of it the survey's
      a = 0.0;
      b = my / mu;
    }
  }
  // The pairs' image noise, with a margin (four times its variance: a few
  // pairs vary), caps the image's share; the rest is the survey's.
  if (n_pairs_ >= kMinPairs && suu_ > 0.0) {
    const double image_bound = 4.0 * s_pairs_ / n_pairs_;
    if (a > image_bound) {
      a = image_bound;
      b = std::max(0.0, (suy_ - a * su_) / suu_);
    }
  }
  image_variance_ = a;
  survey_ = std::min(std::sqrt(b), opt_.max_fraction * typical_distance_);
}

}  // namespace pano
