#include "panotrack/track/compass.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Core>

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
  // Grouped by bin (rings in order within each): a frame's bin sums are
  // then runs of consecutive samples.
  std::vector<int> order(pixel_bin_.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return pixel_bin_[a] < pixel_bin_[b]; });
  std::vector<int> offset(order.size()), row(order.size());
  bin_begin_.assign(static_cast<size_t>(bins_) + 1, 0);
  for (size_t i = 0; i < order.size(); ++i) {
    offset[i] = pixel_offset_[order[i]];
    row[i] = pixel_row_[order[i]];
    ++bin_begin_[static_cast<size_t>(pixel_bin_[order[i]]) + 1];
  }
  for (int b = 0; b < bins_; ++b) bin_begin_[b + 1] += bin_begin_[b];
  pixel_offset_ = std::move(offset);
  pixel_row_ = std::move(row);
  pixel_bin_.clear();
}

std::vector<float> AzimuthCompass::Signature(const cv::Mat& grey) const {
  if (grey.type() != CV_8UC1 || grey.cols != width_ || grey.rows != height_)
    throw Error("compass: expected an 8-bit grey frame of the calibration's size");
  std::vector<float> mean(bins_);
  const uchar* data = grey.ptr<uchar>(0);
  const int row_padding = static_cast<int>(grey.step[0]) - width_;  // 0 for a continuous frame
  for (int b = 0; b < bins_; ++b) {
    // Integer sums of at most eight pixels: exact, as a double sum would be.
    int sum = 0;
    const int begin = bin_begin_[b], end = bin_begin_[b + 1];
    if (row_padding == 0)
      for (int i = begin; i < end; ++i) sum += data[pixel_offset_[i]];
    else
      for (int i = begin; i < end; ++i) sum += data[pixel_offset_[i] + pixel_row_[i] * row_padding];
    mean[b] = end > begin ? static_cast<float>(static_cast<double>(sum) / (end - begin)) : 0.0f;
  }
  // High-pass: minus a moving average over 1/12 of the circle, so that
  // slow illumination changes do not pull the correlation.
  const int h = bins_ / 24;
  std::vector<float> sig(bins_);
  double acc = 0;
  for (int k = -h; k <= h; ++k) acc += mean[(k + bins_) % bins_];
  int ahead = h + 1, behind = bins_ - h;  // (b + h + 1) and (b - h) modulo bins_
  if (ahead >= bins_) ahead -= bins_;
  if (behind >= bins_) behind -= bins_;
  for (int b = 0; b < bins_; ++b) {
    sig[b] = mean[b] - static_cast<float>(acc / (2 * h + 1));
    acc += mean[ahead] - mean[behind];
    if (++ahead == bins_) ahead = 0;
    if (++behind == bins_) behind = 0;
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
  // Eigen's dot product sums in vector lanes (a strict left-to-right float
  // sum does not vectorise): a few times fewer instructions, and the
  // correlations differ only in their last bits.
  const Eigen::Map<const Eigen::VectorXf> cur_vec(cur.data(), bins_);
  auto corr_at = [&](int s) {
    return static_cast<double>(cur_vec.dot(Eigen::Map<const Eigen::VectorXf>(prev2.data() + bins_ + s, bins_)));
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
