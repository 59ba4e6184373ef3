// The Panoramic Hough (PH) mapping of Fiala & Basu, section 4.1 (Eqns 4-8),
// tabulated per line height, as the paper did ("the PH-Transform calculation
// was done with lookup table").
//
// A horizontal 3-D line at height Z (sensor frame: relative to the pinhole)
// whose closest point to the mirror axis lies at horizontal distance D_main in
// image azimuth theta_main projects to a curve. Its point at angle dtheta from
// theta_main is at horizontal distance D_main / cos(dtheta) and appears at
//   image azimuth  theta_i = theta_main + dtheta          (Eqn 8; a mirror of
//                                                          revolution keeps it)
//   image radius   R_i = E(D_main / cos(dtheta), Z)       (Eqn 6: PH^-1)
// so, with R_main = E(D_main, Z) (Eqn 4),
//   R_main = PH(R_i, dtheta) = E(E^-1(R_i, Z) cos(dtheta), Z)      (Eqns 5, 7)
//   R_i = PH^-1(R_main, dtheta) = E(E^-1(R_main, Z) / cos(dtheta), Z) (Eqn 6)
// Both are exact for any mirror of revolution (non-single-viewpoint included)
// once Z is known, as it is in tracking (map height minus sensor height).
// Azimuths are image azimuths throughout (azimuth_offset shifts all equally).
// PH is even in dtheta; the table holds dtheta >= 0.
#pragma once

#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

#include "panotrack/lut/radius_table.h"

namespace pano {

struct PhTableOptions {
  double r_step = 0.25;                   // px between R nodes
  double dtheta_step = 0.25 * M_PI / 180;  // rad between dtheta nodes
  double dtheta_max = 89.0 * M_PI / 180;  // largest |dtheta| tabulated (< pi/2)
  // Tabulate the 1-D slices E(D, Z) and E^-1(R, Z) that PH is composed of
  // from the exact sensor model (pano::Sensor) instead of the E(D,Z) table's
  // bilinear lookups: about 20 ms more per height, no 2-D table error.
  bool exact = false;
  int num_threads = 0;  // threads of the build's loops; 0: OpenMP's default (all cores)
  void Check(const std::string& what) const;
};

// PH(R_i, dtheta) and PH^-1(R_main, dtheta) for one height Z, bilinear in
// (R, |dtheta|). Cheap to copy around by shared_ptr (see PhTableCache).
class PhTable {
 public:
  PhTable() = default;
  // Builds both tables for height Z from the E(D, Z) table (Eqns 5-8).
  // Throws pano::Error for an empty table, Z outside its height range, or
  // bad options.
  static PhTable Build(const RadiusTable& table, double height,
                       const PhTableOptions& options = PhTableOptions());

  bool empty() const { return forward_.empty(); }
  double height() const { return height_; }
  double r_max() const { return r_max_; }  // largest tabulated radius (the limb)
  double dtheta_max() const { return options_.dtheta_max; }
  const PhTableOptions& options() const { return options_; }

  // R_main = PH(R_i, dtheta) (Eqns 5, 7). False where undefined: no point of
  // height Z at R_i, |dtheta| beyond dtheta_max, or the line's foot outside
  // the E table.
  inline bool Main(double r_i, double dtheta, double* r_main) const {
    MainRow row;
    return RowAt(r_i, &row) && MainOnRow(row, dtheta, r_main);
  }
  // Main split in two for many dtheta at one R_i: the table rows around R_i
  // once (RowAt; false where R_i is off the table, so Main is false for any
  // dtheta), then MainOnRow per dtheta, bit-identical to Main.
  struct MainRow {
    const float* nodes = nullptr;  // row ix; row ix + 1 follows
    float tx = 0.0f;               // weight of row ix + 1
    float sx = 1.0f;               // 1 - tx: weight of row ix
  };
  inline bool RowAt(double r_i, MainRow* row) const {
    const double fx = r_i * inv_r_step_;
    if (!(fx >= 0.0) || fx > n_r_ - 1) return false;
    int ix = static_cast<int>(fx);
    if (ix > n_r_ - 2) ix = n_r_ - 2;
    row->nodes = &forward_[static_cast<size_t>(ix) * n_dt_];  // row ix: contiguous in dtheta
    row->tx = static_cast<float>(fx - ix);
    row->sx = 1.0f - row->tx;
    return true;
  }
  inline bool MainOnRow(const MainRow& row, double dtheta, double* r_main) const {
    const double fy = std::abs(dtheta) * inv_dt_step_;
    if (!(fy >= 0.0) || fy > last_dt_node_) return false;
    int iy = static_cast<int>(fy);
    if (iy > n_dt_ - 2) iy = n_dt_ - 2;
    const float ty = static_cast<float>(fy - iy), sy = 1.0f - ty;
    const float* a = row.nodes + iy;
    const float* b = a + n_dt_;
    const float v = row.sx * (sy * a[0] + ty * a[1]) + row.tx * (sy * b[0] + ty * b[1]);
    if (std::isnan(v)) return false;
    *r_main = v;
    return true;
  }
  // R_i = PH^-1(R_main, dtheta) (Eqn 6): the predicted curve's radius at
  // image azimuth theta_main + dtheta, composed exactly as
  // E(E^-1(R_main, Z) / cos dtheta, Z) from the table's 1-D slices of E and
  // E^-1 at this Z (no interpolation across dtheta).
  bool Curve(double r_main, double dtheta, double* r_i) const;
  // The 1-D slices at this Z: E(D, Z) and E^-1(R, Z) (Eqn 4), linear
  // interpolation on fine grids (log D, R).
  bool SliceRadius(double distance, double* radius) const;
  bool SliceDistance(double radius, double* distance) const;

 private:
  double height_ = 0.0;
  PhTableOptions options_;
  double r_max_ = 0.0;
  int n_r_ = 0, n_dt_ = 0;
  double last_dt_node_ = 0.0;  // n_dt_ - 1
  double inv_r_step_ = 0.0, inv_dt_step_ = 0.0;
  std::vector<float> forward_;  // PH:    [R_i node][dtheta node], NaN undefined
  // 1-D slices at Z: D at R nodes (step r_step / 8), R at log D nodes.
  std::vector<double> slice_d_;
  std::vector<double> slice_r_;
  double slice_log_d0_ = 0.0, slice_inv_log_step_ = 0.0, slice_inv_r_step_ = 0.0;
};

// Convenience for callers that hold a PhTable: PH^-1 (Eqn 6), NaN where
// undefined. The localiser draws / samples a predicted edge with it.
double CurveRadius(const PhTable& table, double r_main, double dtheta);

// The exact compositions through the sensor model (references for tests and
// for the table build): PH = E(E^-1(R_i, Z) cos dtheta, Z) and
// PH^-1 = E(E^-1(R_main, Z) / cos dtheta, Z).
bool ExactPh(const Sensor& sensor, double height, double r_i, double dtheta, double* r_main);
bool ExactCurveRadius(const Sensor& sensor, double height, double r_main, double dtheta,
                      double* r_i);

// Tables keyed by height (exact double key, as map heights are), built on
// first use; thread-safe. The localiser keeps one for its map's edge heights.
class PhTableCache {
 public:
  PhTableCache(std::shared_ptr<const RadiusTable> table, PhTableOptions options = PhTableOptions());
  std::shared_ptr<const PhTable> Get(double height);
  size_t size() const;

 private:
  std::shared_ptr<const RadiusTable> table_;
  PhTableOptions options_;
  mutable std::mutex mu_;
  std::map<double, std::shared_ptr<const PhTable>> tables_;
};

}  // namespace pano
