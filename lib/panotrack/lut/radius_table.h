// The E(D, Z) lookup table: image radius of a point at horizontal distance D
// and height Z (sensor frame), tabulated on a grid in log distance and
// elevation angle so that the bilinear interpolation error is even across the
// table, plus the inverse D = E^-1(R, Z) on a grid in (R, Z) that the
// Panoramic Hough Transform needs (paper Eqns 4-8). The inverse's radius
// axis is spaced evenly in sqrt(1 - R / R_limb).
#pragma once

#include <string>
#include <vector>

#include "panotrack/sensor/sensor.h"

namespace pano {

struct Map;

// Version of the lookup table file format (RadiusTable::Save / Load).
constexpr unsigned kRadiusTableFormatVersion = 1;

struct LutRanges {
  double d_min = 0.0;  // horizontal distance range
  double d_max = 0.0;
  double z_min = 0.0;  // height range relative to the pinhole
  double z_max = 0.0;
  void Check(const std::string& what) const;
};

// Ranges that cover every point of the map seen from anywhere in its room,
// from the floor (or the lowest corner, when one lies below it) to the
// ceiling (or the highest corner).
LutRanges RangesForMap(const Map& map, const Sensor& sensor);
// Ranges for a sensor alone (used by panocalib when no map is given):
// distances from 1 to 400 mirror distances, heights within +-D_max/2.
LutRanges DefaultRanges(const Sensor& sensor);

struct LutSize {
  int n_distance = 1024;   // forward table: log D nodes
  int n_elevation = 1024;  // forward table: elevation nodes
  int n_radius = 1024;     // inverse table: image radius nodes
  int n_height = 1024;     // inverse table: height nodes
  void Check(const std::string& what) const;
};

class RadiusTable {
 public:
  RadiusTable() = default;
  // Tabulates the exact model, rows on `num_threads` threads (0: every
  // core, ThreadCount); the table is the same for every count.
  static RadiusTable Build(const Sensor& sensor, const LutRanges& ranges,
                           const LutSize& size = LutSize(), int num_threads = 0);
  // Loads a table; rejects a corrupt, truncated or foreign file, and (when
  // `expected` is given) one built for other sensor parameters.
  static RadiusTable Load(const std::string& path, const Sensor* expected = nullptr);
  // Writes atomically (temporary file renamed into place).
  void Save(const std::string& path) const;

  bool empty() const { return forward_.empty(); }
  const Sensor& sensor() const { return sensor_; }
  const LutRanges& ranges() const { return ranges_; }
  const LutSize& size() const { return size_; }
  // True when the table covers `r` and was built for `sensor`.
  bool Covers(const LutRanges& r) const;
  bool Matches(const Sensor& sensor) const;

  // E(D, Z), bilinear. False outside the table or where the point is not visible.
  bool radius(double distance, double height, double* radius) const;
  // E^-1(R, Z), bilinear. False outside the table or where no point of that
  // height appears at that radius.
  bool distance(double radius, double height, double* distance) const;

  // Grid geometry (exposed for tests: points between the nodes).
  double log_d_min() const { return log_d_min_; }
  double log_d_step() const { return log_d_step_; }
  double elev_min() const { return elev_min_; }
  double elev_step() const { return elev_step_; }

 private:
  void SetGeometry();
  Sensor sensor_;
  LutRanges ranges_;
  LutSize size_;
  double log_d_min_ = 0, log_d_step_ = 0, elev_min_ = 0, elev_step_ = 0;
  double r_max_ = 0, z_step_ = 0;
  std::vector<float> forward_;  // [elevation][distance], NaN: not visible
  std::vector<float> inverse_;  // [height][radius] of 1/D (<= 0: behind), NaN: no mirror
};

}  // namespace pano
