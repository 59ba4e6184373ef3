#include "panotrack/scene/map.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <set>

#include "panotrack/core/error.h"

namespace pano {

bool Map::IsFree(double x, double y) const {
  if (room.present &&
      (x <= room.min.x() || y <= room.min.y() || x >= room.max.x() || y >= room.max.y()))
    return false;
  for (const MapBox& b : boxes)
    if (x > b.min.x() && x < b.max.x() && y > b.min.y() && y < b.max.y() &&
        b.min.z() <= sensor_height && b.max.z() >= 0.0)
      return false;
  return true;
}

void Map::Extent(Eigen::Vector2d* lo, Eigen::Vector2d* hi, double* top) const {
  *lo = Eigen::Vector2d(1e300, 1e300);
  *hi = Eigen::Vector2d(-1e300, -1e300);
  *top = 0.0;
  auto add = [&](const Eigen::Vector2d& p, double z) {
    *lo = lo->cwiseMin(p);
    *hi = hi->cwiseMax(p);
    *top = std::max(*top, z);
  };
  if (room.present) add(room.min, room.height), add(room.max, room.height);
  for (const MapRectangle& r : rectangles) add(r.from, r.z1), add(r.to, r.z1);
  for (const MapRectangle& r : distractors) add(r.from, r.z1), add(r.to, r.z1);
  for (const MapBox& b : boxes) add(b.min.head<2>(), b.max.z()), add(b.max.head<2>(), b.max.z());
}

namespace {

// Every coordinate within a sane room. A mistyped exponent (1e300) would
// otherwise pass the checks of order and surface later as a distance range
// or a table that names no rectangle, or overflow to infinity.
void CheckCoordinatesInRoom(const Map& m, const std::string& what) {
  constexpr double kMaxCoordinate = 1e6;  // map units: a kilometre in mm
  auto check = [&](std::initializer_list<double> values, const std::string& key, const std::string& id) {
    for (double v : values) {
      if (std::abs(v) < kMaxCoordinate) continue;
      char got[32];
      std::snprintf(got, sizeof(got), "%g", v);
      throw Error(what + ": " + key + (id.empty() ? "" : " ('" + id + "')") +
                  ": expected coordinates within +-1e6 map units, got " + got);
    }
  };
  check({m.sensor_height}, "sensor_height", "");
  if (m.room.present) {
    check({m.room.min.x(), m.room.min.y()}, "room.min", "");
    check({m.room.max.x(), m.room.max.y()}, "room.max", "");
    check({m.room.height}, "room.height", "");
  }
  auto check_rects = [&](const std::vector<MapRectangle>& rects, const std::string& key) {
    for (size_t i = 0; i < rects.size(); ++i) {
      const MapRectangle& r = rects[i];
      const std::string path = key + "[" + std::to_string(i) + "]";
      check({r.from.x(), r.from.y()}, path + ".from", r.id);
      check({r.to.x(), r.to.y()}, path + ".to", r.id);
      check({r.z0, r.z1}, path + ".z", r.id);
    }
  };
  check_rects(m.rectangles, "rectangles");
  check_rects(m.distractors, "distractors");
  for (size_t i = 0; i < m.boxes.size(); ++i) {
    const MapBox& b = m.boxes[i];
    const std::string path = "boxes[" + std::to_string(i) + "]";
    check({b.min.x(), b.min.y(), b.min.z()}, path + ".min", b.id);
    check({b.max.x(), b.max.y(), b.max.z()}, path + ".max", b.id);
  }
}

}  // namespace

void CheckMap(const Map& m, const std::string& what) {
  CheckCoordinatesInRoom(m, what);
  auto fail = [&](const std::string& key, const std::string& problem) {
    throw Error(what + ": " + key + ": " + problem);
  };
  if (!(m.sensor_height > 0.0)) fail("sensor_height", "expected a positive height of the pinhole");
  auto check_sigma = [&](double sigma, const std::string& key) {
    if (!std::isnan(sigma) && !(sigma >= 0.0 && std::isfinite(sigma)))
      fail(key, "expected a standard deviation >= 0 (map units)");
  };
  check_sigma(m.survey_sigma, "survey_sigma");
  for (size_t i = 0; i < m.rectangles.size(); ++i)
    check_sigma(m.rectangles[i].survey_sigma, "rectangles[" + std::to_string(i) + "].survey_sigma");
  for (size_t i = 0; i < m.boxes.size(); ++i)
    check_sigma(m.boxes[i].survey_sigma, "boxes[" + std::to_string(i) + "].survey_sigma");
  if (m.room.present) {
    if (!(m.room.max.x() > m.room.min.x()) || !(m.room.max.y() > m.room.min.y()))
      fail("room", "expected max > min on both axes");
    if (!(m.room.height > m.sensor_height))
      fail("room.height", "expected a ceiling above the sensor (sensor_height " +
                              std::to_string(m.sensor_height) + ")");
  }
  std::set<std::string> ids;
  auto check_rects = [&](const std::vector<MapRectangle>& rects, const std::string& key) {
    for (size_t i = 0; i < rects.size(); ++i) {
      const MapRectangle& r = rects[i];
      const std::string path = key + "[" + std::to_string(i) + "]";
      if ((r.to - r.from).norm() <= 0.0) fail(path, "'from' and 'to' are the same point");
      if (!(r.z1 > r.z0)) fail(path + ".z", "expected [bottom, top] with top > bottom");
      if (!ids.insert(r.id).second) fail(path + ".id", "duplicate id '" + r.id + "'");
    }
  };
  check_rects(m.rectangles, "rectangles");
  check_rects(m.distractors, "distractors");
  for (size_t i = 0; i < m.boxes.size(); ++i) {
    const MapBox& b = m.boxes[i];
    const std::string path = "boxes[" + std::to_string(i) + "]";
    if (!(b.max.array() > b.min.array()).all()) fail(path, "expected max > min on every axis");
    if (!ids.insert(b.id).second) fail(path + ".id", "duplicate id '" + b.id + "'");
  }
}

double Map::RectangleSurveySigma(size_t k) const {
  const double own = rectangles[k].survey_sigma;
  return std::isnan(own) ? survey_sigma : own;
}

double Map::BoxSurveySigma(size_t k) const {
  const double own = boxes[k].survey_sigma;
  return std::isnan(own) ? survey_sigma : own;
}

bool Map::SurveySigmaStated() const {
  if (!std::isnan(survey_sigma)) return true;
  for (const MapRectangle& r : rectangles)
    if (!std::isnan(r.survey_sigma)) return true;
  for (const MapBox& b : boxes)
    if (!std::isnan(b.survey_sigma)) return true;
  return false;
}

double Map::UnitsPerMetre() const {
  const std::string& u = units;
  if (u == "m" || u == "metre" || u == "metres" || u == "meter" || u == "meters") return 1.0;
  if (u == "cm") return 100.0;
  if (u == "mm") return 1000.0;
  if (u == "in" || u == "inch" || u == "inches") return 39.37;
  if (u == "ft" || u == "feet") return 3.281;
  Eigen::Vector2d lo, hi;
  double top;
  Extent(&lo, &hi, &top);
  return std::max(1e-6, (hi - lo).maxCoeff() / 5.0);
}

}  // namespace pano
