#include "panotrack/hough/ph_table.h"

#include <algorithm>
#include <limits>
#include <sstream>

#include "panotrack/core/error.h"
#include "panotrack/core/parallel.h"

namespace pano {

namespace {
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr int kSliceSub = 8;  // E^-1 slice nodes per PH table R step

std::string Num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}
}  // namespace

void PhTableOptions::Check(const std::string& what) const {
  if (!(r_step > 0.0) || !std::isfinite(r_step))
    throw Error(what + ": r_step: expected a positive radius step in pixels, got " + Num(r_step));
  if (!(dtheta_step > 0.0) || !std::isfinite(dtheta_step))
    throw Error(what + ": dtheta_step: expected a positive angle step, got " + Num(dtheta_step));
  if (!(dtheta_max > 0.0) || !(dtheta_max < M_PI / 2))
    throw Error(what + ": dtheta_max: expected 0 < dtheta_max < pi/2, got " + Num(dtheta_max));
  if (num_threads < 0) throw Error(what + ": num_threads: expected 0 (all cores) or more");
}

bool ExactPh(const Sensor& sensor, double height, double r_i, double dtheta, double* r_main) {
  const double c = std::cos(dtheta);
  if (!(c > 0.0)) return false;
  double D;
  if (!sensor.inverse_image_radius(r_i, height, &D)) return false;
  return sensor.image_radius(D * c, height, r_main);
}

bool ExactCurveRadius(const Sensor& sensor, double height, double r_main, double dtheta,
                      double* r_i) {
  const double c = std::cos(dtheta);
  if (!(c > 0.0)) return false;
  double D;
  if (!sensor.inverse_image_radius(r_main, height, &D)) return false;
  return sensor.image_radius(D / c, height, r_i);
}

PhTable PhTable::Build(const RadiusTable& table, double height, const PhTableOptions& options) {
  const std::string what = "Panoramic Hough table";
  if (table.empty()) throw Error(what + ": the E(D,Z) lookup table is empty");
  options.Check(what);
  if (!std::isfinite(height) || height < table.ranges().z_min || height > table.ranges().z_max)
    throw Error(what + ": height " + Num(height) + " outside the E(D,Z) table's range [" +
                Num(table.ranges().z_min) + ", " + Num(table.ranges().z_max) + "]");
  PhTable t;
  t.height_ = height;
  t.options_ = options;
  t.r_max_ = table.sensor().limb_radius();
  t.n_r_ = static_cast<int>(std::ceil(t.r_max_ / options.r_step)) + 1;
  t.n_dt_ = static_cast<int>(std::ceil(options.dtheta_max / options.dtheta_step)) + 1;
  t.last_dt_node_ = t.n_dt_ - 1;
  if (static_cast<double>(t.n_r_) * t.n_dt_ > 5e7)
    throw Error(what + ": more than 5e7 nodes; use larger r_step / dtheta_step");
  t.inv_r_step_ = 1.0 / options.r_step;
  t.inv_dt_step_ = 1.0 / options.dtheta_step;
  const int nr = t.n_r_, nd = t.n_dt_;
  const Sensor& sensor = table.sensor();
  const double Z = height;
  // 1-D slices of E and E^-1 at Z (Eqn 4): from the E(D,Z) table's bilinear
  // lookups, or from the exact model.
  // The slices reach 4 d_max so that E^-1 of points beyond the table's range
  // still serves PH where D cos(dtheta) falls back inside it.
  const double d_lo = table.ranges().d_min, d_hi = 4.0 * table.ranges().d_max;
  const int n_slice = 8192;
  t.slice_log_d0_ = std::log(d_lo);
  const double log_step = (std::log(d_hi) - t.slice_log_d0_) / (n_slice - 1);
  t.slice_inv_log_step_ = 1.0 / log_step;
  t.slice_r_.assign(n_slice, std::numeric_limits<double>::quiet_NaN());
  const int n_slice_d = (nr - 1) * kSliceSub + 1;
  t.slice_inv_r_step_ = kSliceSub / options.r_step;
  t.slice_d_.assign(n_slice_d, std::numeric_limits<double>::quiet_NaN());
  // The loops' bodies only evaluate the model (nothing throws).
  const int threads = ThreadCount(options.num_threads);
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int k = 0; k < n_slice; ++k) {
    const double D = std::exp(t.slice_log_d0_ + k * log_step);
    double R;
    if (options.exact ? sensor.image_radius(D, Z, &R) : table.radius(D, Z, &R)) t.slice_r_[k] = R;
  }
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int i = 0; i < n_slice_d; ++i) {
    const double R = std::min(i * options.r_step / kSliceSub, t.r_max_);
    double D;
    if ((options.exact ? sensor.inverse_image_radius(R, Z, &D) : table.distance(R, Z, &D)) &&
        D >= d_lo && D <= d_hi)
      t.slice_d_[i] = D;
  }
  // PH (Eqn 5) on the (R_i, dtheta) grid, rows contiguous in dtheta.
  t.forward_.assign(static_cast<size_t>(nr) * nd, kNaN);
  std::vector<double> cosines(nd);
  for (int j = 0; j < nd; ++j) cosines[j] = std::cos(std::min(j * options.dtheta_step, options.dtheta_max));
#pragma omp parallel for schedule(static) num_threads(threads)
  for (int i = 0; i < nr; ++i) {
    const double D = t.slice_d_[static_cast<size_t>(i) * kSliceSub];
    if (std::isnan(D)) continue;
    float* fwd = &t.forward_[static_cast<size_t>(i) * nd];
    for (int j = 0; j < nd; ++j) {
      double out;
      if (t.SliceRadius(D * cosines[j], &out)) fwd[j] = static_cast<float>(out);
    }
  }
  return t;
}

bool PhTable::SliceRadius(double D, double* R) const {
  if (!(D > 0.0)) return false;
  const double f = (std::log(D) - slice_log_d0_) * slice_inv_log_step_;
  const int n = static_cast<int>(slice_r_.size());
  if (!(f >= 0.0) || f > n - 1) return false;
  const int i = std::min(static_cast<int>(f), n - 2);
  const double t = f - i;
  const double v = (1.0 - t) * slice_r_[i] + t * slice_r_[i + 1];
  if (std::isnan(v)) return false;
  *R = v;
  return true;
}

bool PhTable::SliceDistance(double R, double* D) const {
  const double f = R * slice_inv_r_step_;
  const int n = static_cast<int>(slice_d_.size());
  if (!(f >= 0.0) || f > n - 1) return false;
  const int i = std::min(static_cast<int>(f), n - 2);
  const double t = f - i;
  const double v = (1.0 - t) * slice_d_[i] + t * slice_d_[i + 1];
  if (std::isnan(v)) return false;
  *D = v;
  return true;
}

bool PhTable::Curve(double r_main, double dtheta, double* r_i) const {
  const double c = std::cos(dtheta);
  if (!(std::abs(dtheta) <= options_.dtheta_max) || !(c > 0.0)) return false;
  double D;
  if (!SliceDistance(r_main, &D)) return false;
  return SliceRadius(D / c, r_i);  // Eqn 6
}

double CurveRadius(const PhTable& table, double r_main, double dtheta) {
  double r;
  if (!table.Curve(r_main, dtheta, &r)) return std::numeric_limits<double>::quiet_NaN();
  return r;
}

PhTableCache::PhTableCache(std::shared_ptr<const RadiusTable> table, PhTableOptions options)
    : table_(std::move(table)), options_(options) {
  if (!table_ || table_->empty()) throw Error("Panoramic Hough table cache: empty E(D,Z) table");
  options_.Check("Panoramic Hough table cache");
}

std::shared_ptr<const PhTable> PhTableCache::Get(double height) {
  std::lock_guard<std::mutex> lock(mu_);
  auto it = tables_.find(height);
  if (it != tables_.end()) return it->second;
  auto t = std::make_shared<const PhTable>(PhTable::Build(*table_, height, options_));
  tables_.emplace(height, t);
  return t;
}

size_t PhTableCache::size() const {
  std::lock_guard<std::mutex> lock(mu_);
  return tables_.size();
}

}  // namespace pano
