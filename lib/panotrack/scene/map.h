// The a-priori model of the room and its landmarks (paper section 2; the map
// file (docs/maps.md) is read and written by io/map.h).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <string>
#include <vector>

namespace pano {

struct MapRoom {
  bool present = false;
  Eigen::Vector2d min{0, 0};
  Eigen::Vector2d max{0, 0};
  double height = 0.0;
  double wall_shade = 0.55;
  double floor_shade = 0.35;
  double ceiling_shade = 0.8;
};

// A vertical planar rectangle: bottom edge from `from` to `to`, heights z0..z1.
struct MapRectangle {
  std::string id;
  Eigen::Vector2d from{0, 0};
  Eigen::Vector2d to{0, 0};
  double z0 = 0.0;
  double z1 = 0.0;
  // Reflectance 0..1 of its face; NaN when the map does not give it
  // (unknown: the tracker learns the edges' polarities from the images).
  double shade = 0.1;
  bool shade_known() const { return !std::isnan(shade); }
  // Standard deviation of each measured coordinate of its corners (map
  // units); NaN: the map's survey_sigma.
  double survey_sigma = std::nan("");
};

// An axis-aligned box.
struct MapBox {
  std::string id;
  Eigen::Vector3d min{0, 0, 0};
  Eigen::Vector3d max{0, 0, 0};
  double shade = 0.9;  // NaN: unknown (as MapRectangle::shade)
  bool shade_known() const { return !std::isnan(shade); }
  double survey_sigma = std::nan("");  // as MapRectangle::survey_sigma
};

struct Map {
  std::string units = "cm";
  double sensor_height = 0.0;
  // How well the corners were measured: the standard deviation of each
  // coordinate (map units) of a corner, as a tape measure gives it
  // (docs/maps.md). 0: exact (a rendered room, a survey far better than
  // the images; the localiser still overrules it where the residuals
  // clearly show a survey error); NaN: not stated (the localiser estimates
  // it from the residuals it sees).
  double survey_sigma = std::nan("");
  MapRoom room;
  std::vector<MapRectangle> rectangles;
  std::vector<MapBox> boxes;
  // Optional: rendered by panosim but not landmarks (never written to the
  // map that panosim hands to panoloc).
  std::vector<MapRectangle> distractors;

  // True when (x, y) is inside the room (or there is no room) and not inside a box.
  bool IsFree(double x, double y) const;
  // Horizontal extent of the room, rectangles, distractors and boxes, and
  // the height of the highest of them.
  void Extent(Eigen::Vector2d* lo, Eigen::Vector2d* hi, double* top) const;
  // Map units per metre, from `units` (m, cm, mm, in, ft); for other units
  // the room is taken to be about 5 m across. Scales defaults given in
  // metres (the motion model's, the odometry's noise).
  double UnitsPerMetre() const;
  // The survey sigma of rectangle k, of box k: its own, else the map's
  // (NaN when neither is stated).
  double RectangleSurveySigma(size_t k) const;
  double BoxSurveySigma(size_t k) const;
  // Whether the map states how well it was measured (anywhere).
  bool SurveySigmaStated() const;
};

// Checks the geometry (positive sizes, unique ids, shades in 0..1 or unknown); `what`
// names the file in messages.
void CheckMap(const Map& map, const std::string& what);

}  // namespace pano
