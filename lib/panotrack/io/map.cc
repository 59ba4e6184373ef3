#include "panotrack/io/map.h"

#include <cmath>
#include <limits>

#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"
#include "panotrack/io/yaml_util.h"

namespace pano {

namespace {

double Shade(const YamlReader& r, const YAML::Node& n, const std::string& key, const std::string& path,
             double fallback) {
  const double s = r.Double(n, key, path, fallback);
  if (s < 0.0 || s > 1.0) r.Fail(path, "expected a reflectance between 0 and 1");
  return s;
}

// A landmark's shade: optional; without the key it is unknown (NaN), and the
// tracker learns its edges' polarities from the images.
// A survey sigma: optional (NaN without the key), >= 0.
double SurveySigma(const YamlReader& r, const YAML::Node& n, const std::string& path) {
  if (!r.Has(n, "survey_sigma")) return std::numeric_limits<double>::quiet_NaN();
  const double s = r.Double(n, "survey_sigma", path);
  if (!(s >= 0.0) || !std::isfinite(s)) r.Fail(path, "expected a standard deviation >= 0 (map units)");
  return s;
}

double LandmarkShade(const YamlReader& r, const YAML::Node& n, const std::string& path) {
  if (!r.Has(n, "shade")) return std::numeric_limits<double>::quiet_NaN();
  return Shade(r, n, "shade", path, 0.0);
}

std::vector<MapRectangle> ReadRectangles(const YamlReader& r, const YAML::Node& root,
                                         const std::string& key) {
  std::vector<MapRectangle> out;
  if (!r.Has(root, key)) return out;
  const YAML::Node list = r.List(root, key, key, "a list of rectangles");
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string path = key + "[" + std::to_string(i) + "]";
    const YAML::Node n = list[i];
    if (!n.IsMap()) r.Fail(path, "expected a mapping with id, from, to, z, got " + DescribeNode(n));
    MapRectangle rect;
    rect.id = r.String(n, "id", path + ".id", key.substr(0, 4) + std::to_string(i));
    const auto from = r.Vector<2>(n, "from", path + ".from");
    const auto to = r.Vector<2>(n, "to", path + ".to");
    const auto z = r.Vector<2>(n, "z", path + ".z");
    rect.from = {from[0], from[1]};
    rect.to = {to[0], to[1]};
    rect.z0 = z[0];
    rect.z1 = z[1];
    // Distractors are only rendered: they keep a default shade.
    rect.shade = key == "distractors" ? Shade(r, n, "shade", path + ".shade", rect.shade)
                                      : LandmarkShade(r, n, path + ".shade");
    if (key != "distractors") rect.survey_sigma = SurveySigma(r, n, path + ".survey_sigma");
    out.push_back(rect);
  }
  return out;
}

std::vector<MapBox> ReadBoxes(const YamlReader& r, const YAML::Node& root) {
  std::vector<MapBox> out;
  if (!r.Has(root, "boxes")) return out;
  const YAML::Node list = r.List(root, "boxes", "boxes", "a list of boxes");
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string p = "boxes[" + std::to_string(i) + "]";
    const YAML::Node n = list[i];
    if (!n.IsMap()) r.Fail(p, "expected a mapping with id, min, max, got " + DescribeNode(n));
    MapBox b;
    b.id = r.String(n, "id", p + ".id", "box" + std::to_string(i));
    const auto mn = r.Vector<3>(n, "min", p + ".min");
    const auto mx = r.Vector<3>(n, "max", p + ".max");
    b.min = {mn[0], mn[1], mn[2]};
    b.max = {mx[0], mx[1], mx[2]};
    b.shade = LandmarkShade(r, n, p + ".shade");
    b.survey_sigma = SurveySigma(r, n, p + ".survey_sigma");
    out.push_back(b);
  }
  return out;
}

Map ParseMap(const std::string& path, const YAML::Node& n) {
  YamlReader r(path, n);
  Map m;
  m.units = r.String(n, "units", "units", "cm");
  m.sensor_height = r.Double(n, "sensor_height", "sensor_height");
  m.survey_sigma = SurveySigma(r, n, "survey_sigma");
  if (r.Has(n, "room")) {
    const YAML::Node room = r.Map(n, "room", "room", "a mapping with min, max, height");
    m.room.present = true;
    const auto mn = r.Vector<2>(room, "min", "room.min");
    const auto mx = r.Vector<2>(room, "max", "room.max");
    m.room.min = {mn[0], mn[1]};
    m.room.max = {mx[0], mx[1]};
    m.room.height = r.Double(room, "height", "room.height");
    m.room.wall_shade = Shade(r, room, "wall_shade", "room.wall_shade", m.room.wall_shade);
    m.room.floor_shade = Shade(r, room, "floor_shade", "room.floor_shade", m.room.floor_shade);
    m.room.ceiling_shade = Shade(r, room, "ceiling_shade", "room.ceiling_shade", m.room.ceiling_shade);
  }
  m.rectangles = ReadRectangles(r, n, "rectangles");
  m.distractors = ReadRectangles(r, n, "distractors");
  m.boxes = ReadBoxes(r, n);
  if (m.rectangles.empty() && m.boxes.empty())
    r.Fail("rectangles", "the map has no rectangles and no boxes: nothing to use as a landmark");
  CheckMap(m, path);
  return m;
}

void WriteRectangles(YamlWriter& w, const std::string& key, const std::vector<MapRectangle>& list) {
  if (list.empty()) return;
  w.Key(key).BeginList();
  for (const MapRectangle& r : list) {
    w.BeginMap();
    w.Key("id").String(r.id);
    w.Key("from").Numbers({r.from.x(), r.from.y()});
    w.Key("to").Numbers({r.to.x(), r.to.y()});
    w.Key("z").Numbers({r.z0, r.z1});
    if (r.shade_known()) w.Key("shade").Double(r.shade);
    if (!std::isnan(r.survey_sigma)) w.Key("survey_sigma").Double(r.survey_sigma);
    w.EndMap();
  }
  w.EndList();
}

}  // namespace

Map ReadMap(const std::string& path) {
  const YAML::Node root = YamlReader::LoadFile(path);
  return GuardYaml(path, [&] { return ParseMap(path, root); });
}

std::string MapToYaml(const Map& m, bool with_distractors) {
  YamlWriter w;
  w.BeginMap();
  w.Key("units").String(m.units);
  w.Key("sensor_height").Double(m.sensor_height);
  if (!std::isnan(m.survey_sigma)) w.Key("survey_sigma").Double(m.survey_sigma);
  if (m.room.present) {
    w.Key("room").BeginMap();
    w.Key("min").Numbers({m.room.min.x(), m.room.min.y()});
    w.Key("max").Numbers({m.room.max.x(), m.room.max.y()});
    w.Key("height").Double(m.room.height);
    w.Key("wall_shade").Double(m.room.wall_shade);
    w.Key("floor_shade").Double(m.room.floor_shade);
    w.Key("ceiling_shade").Double(m.room.ceiling_shade);
    w.EndMap();
  }
  WriteRectangles(w, "rectangles", m.rectangles);
  if (!m.boxes.empty()) {
    w.Key("boxes").BeginList();
    for (const MapBox& b : m.boxes) {
      w.BeginMap();
      w.Key("id").String(b.id);
      w.Key("min").Numbers({b.min.x(), b.min.y(), b.min.z()});
      w.Key("max").Numbers({b.max.x(), b.max.y(), b.max.z()});
      if (b.shade_known()) w.Key("shade").Double(b.shade);
      if (!std::isnan(b.survey_sigma)) w.Key("survey_sigma").Double(b.survey_sigma);
      w.EndMap();
    }
    w.EndList();
  }
  if (with_distractors) WriteRectangles(w, "distractors", m.distractors);
  w.EndMap();
  return w.Text();
}

void WriteMap(const std::string& path, const Map& m, bool with_distractors) {
  CheckMap(m, path);
  WriteFileAtomic(path, MapToYaml(m, with_distractors));
}

}  // namespace pano
