#include "panotrack/track/compass.h"

#include <algorithm>
#include <cmath>

#include "panotrack/core/error.h"

namespace pano {

AzimuthCompass::AzimuthCompass(const Sensor& s, int bins, double inner, double outer)
    : bins_(bins), width_(s.image_width), height_(s.image_height) {
  if (bins < 36 || !(inner >= 0.0) || !(outer > inner) || outer > 1.0)
    throw Error("compass: expected at least 36 bins and 0 <= inner < outer <= 1");
  // Eight rings across the annulus, one nearest-pixel sample per bin and
  // ring: cheap, and enough to correlate (every ring sees every landmark).
  const double limb = s.limb_radius();
  const int rings = 8;
  for (int k = 0; k < rings; ++k) {
    const double r = (inner + (outer - inner) * (k + 0.5) / rings) * limb;
    for (int b = 0; b < bins; ++b) {
      const double az = -M_PI + (b + 0.5) * 2 * M_PI / bins;
      const Eigen::Vector2d px = s.from_polar(r, az);
      const int u = static_cast<int>(std::lround(px.x())), v = static_cast<int>(std::lround(px.y()));
      if (u < 0 || v < 0 || u >= width_ || v >= height_) continue;
      pixel_offset_.push_back(v * width_ + u);
      pixel_row_.push_back(v);
      pixel_bin_.push_back(b);
    }
  }
}

std::vector<float> AzimuthCompass::Signature(const cv::Mat& grey) const {
  if (grey.type() != CV_8UC1 || grey.cols != width_ || grey.rows != height_)
    throw Error("compass: expected an 8-bit grey frame of the calibration's size");
  std::vector<double> sum(bins_, 0.0);
  std::vector<int> count(bins_, 0);
  const uchar* data = grey.ptr<uchar>(0);
  const int row_padding = static_cast<int>(grey.step[0]) - width_;  // 0 for a continuous frame
  for (size_t i = 0; i < pixel_offset_.size(); ++i) {
    sum[pixel_bin_[i]] += data[pixel_offset_[i] + pixel_row_[i] * row_padding];
    ++count[pixel_bin_[i]];
  }
  std::vector<float> mean(bins_);
  for (int b = 0; b < bins_; ++b) mean[b] = count[b] ? static_cast<float>(sum[b] / count[b]) : 0.0f;
  // High-pass: minus a moving average over 1/12 of the circle, so that
  // slow illumination changes do not pull the correlation.
  const int h = bins_ / 24;
  std::vector<float> sig(bins_);
  double acc = 0;
  for (int k = -h; k <= h; ++k) acc += mean[(k + bins_) % bins_];
  for (int b = 0; b < bins_; ++b) {
    sig[b] = mean[b] - static_cast<float>(acc / (2 * h + 1));
    acc += mean[(b + h + 1) % bins_] - mean[(b - h + bins_) % bins_];
  }
  double norm = 0;
  for (float v : sig) norm += v * v;
  norm = std::sqrt(norm);
  if (norm > 0)
    for (float& v : sig) v = static_cast<float>(v / norm);
  return sig;
}

double AzimuthCompass::Rotation(const std::vector<float>& prev, const std::vector<float>& cur,
                                double max_rotation, double* score) const {
  if (static_cast<int>(prev.size()) != bins_ || static_cast<int>(cur.size()) != bins_)
    throw Error("compass: signatures of the wrong size");
  const int max_shift = std::min(bins_ / 2 - 1, static_cast<int>(std::ceil(max_rotation / (2 * M_PI) * bins_)));
  // current(a) = previous(a + d): correlate cur[i] with prev[i + s]. Coarse
  // to fine: every 4th shift first (the high-passed signatures are smooth
  // over a few bins), then every shift around the best.
  // prev twice over, so that prev[(i + s) mod bins] = prev2[i + s + bins]
  // without a division in the inner loop (which then vectorises).
  std::vector<float> prev2(3 * bins_);
  for (int k = 0; k < 3; ++k) std::copy(prev.begin(), prev.end(), prev2.begin() + k * bins_);
  auto corr_at = [&](int s) {
    const float* p2 = prev2.data() + bins_ + s;
    float c = 0;
    for (int i = 0; i < bins_; ++i) c += cur[i] * p2[i];
    return static_cast<double>(c);
  };
  int coarse = 0;
  double coarse_best = -1e300;
  for (int s = -max_shift; s <= max_shift; s += 4) {
    const double c = corr_at(s);
    if (c > coarse_best) coarse_best = c, coarse = s;
  }
  const int lo = std::max(-max_shift, coarse - 4), hi = std::min(max_shift, coarse + 4);
  std::vector<double> corr(2 * max_shift + 1, -1e300);
  int best = lo + max_shift;
  for (int s = lo; s <= hi; ++s) {
    corr[s + max_shift] = corr_at(s);
    if (corr[s + max_shift] > corr[best]) best = s + max_shift;
  }
  double shift = best - max_shift;
  if (best > 0 && best < 2 * max_shift && corr[best - 1] > -1e299 && corr[best + 1] > -1e299) {
    const double a = corr[best - 1], b = corr[best], c = corr[best + 1];
    const double den = a - 2 * b + c;
    if (den < 0) shift += 0.5 * (a - c) / den;
  }
  *score = corr[best];
  return shift * 2 * M_PI / bins_;
}

}  // namespace pano
