#include "io/map.h"

#include <algorithm>
#include <set>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "io/yaml_util.h"

namespace pano {

namespace {

double Shade(const YamlReader& r, const YAML::Node& n, const std::string& path, double fallback) {
  const double s = r.Double(n, "shade", path + ".shade", fallback);
  if (s < 0.0 || s > 1.0) r.Fail(path + ".shade", "expected a reflectance between 0 and 1");
  return s;
}

std::vector<MapRectangle> ReadRectangles(const YamlReader& r, const YAML::Node& root,
                                         const std::string& key) {
  std::vector<MapRectangle> out;
  if (!r.Has(root, key)) return out;
  const YAML::Node list = root[key];
  if (!list.IsSequence()) r.Fail(key, "expected a list of rectangles");
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string path = key + "[" + std::to_string(i) + "]";
    const YAML::Node n = list[i];
    if (!n.IsMap()) r.Fail(path, "expected a mapping with id, from, to, z");
    MapRectangle rect;
    rect.id = r.String(n, "id", path + ".id", key.substr(0, 4) + std::to_string(i));
    const auto from = r.Vector<2>(n, "from", path + ".from");
    const auto to = r.Vector<2>(n, "to", path + ".to");
    const auto z = r.Vector<2>(n, "z", path + ".z");
    rect.from = {from[0], from[1]};
    rect.to = {to[0], to[1]};
    rect.z0 = z[0];
    rect.z1 = z[1];
    rect.shade = Shade(r, n, path, rect.shade);
    out.push_back(rect);
  }
  return out;
}

}  // namespace

Map ReadMap(const std::string& path) {
  YamlReader r(path, YamlReader::LoadFile(path));
  const YAML::Node& n = r.root();
  Map m;
  m.units = r.String(n, "units", "units", "cm");
  m.sensor_height = r.Double(n, "sensor_height", "sensor_height");
  if (r.Has(n, "room")) {
    const YAML::Node room = n["room"];
    if (!room.IsMap()) r.Fail("room", "expected a mapping with min, max, height");
    m.room.present = true;
    const auto mn = r.Vector<2>(room, "min", "room.min");
    const auto mx = r.Vector<2>(room, "max", "room.max");
    m.room.min = {mn[0], mn[1]};
    m.room.max = {mx[0], mx[1]};
    m.room.height = r.Double(room, "height", "room.height");
    auto shade = [&](const char* key, double fallback) {
      const double s = r.Double(room, key, std::string("room.") + key, fallback);
      if (s < 0.0 || s > 1.0) r.Fail(std::string("room.") + key, "expected a reflectance between 0 and 1");
      return s;
    };
    m.room.wall_shade = shade("wall_shade", m.room.wall_shade);
    m.room.floor_shade = shade("floor_shade", m.room.floor_shade);
    m.room.ceiling_shade = shade("ceiling_shade", m.room.ceiling_shade);
  }
  m.rectangles = ReadRectangles(r, n, "rectangles");
  m.distractors = ReadRectangles(r, n, "distractors");
  if (r.Has(n, "boxes")) {
    const YAML::Node list = n["boxes"];
    if (!list.IsSequence()) r.Fail("boxes", "expected a list of boxes");
    for (size_t i = 0; i < list.size(); ++i) {
      const std::string p = "boxes[" + std::to_string(i) + "]";
      if (!list[i].IsMap()) r.Fail(p, "expected a mapping with id, min, max");
      MapBox b;
      b.id = r.String(list[i], "id", p + ".id", "box" + std::to_string(i));
      const auto mn = r.Vector<3>(list[i], "min", p + ".min");
      const auto mx = r.Vector<3>(list[i], "max", p + ".max");
      b.min = {mn[0], mn[1], mn[2]};
      b.max = {mx[0], mx[1], mx[2]};
      b.shade = Shade(r, list[i], p, b.shade);
      m.boxes.push_back(b);
    }
  }
  if (m.rectangles.empty() && m.boxes.empty())
    r.Fail("rectangles", "the map has no rectangles and no boxes: nothing to use as a landmark");
  CheckMap(m, path);
  return m;
}

std::string MapToYaml(const Map& m, bool with_distractors) {
  std::ostringstream o;
  auto v2 = [](const Eigen::Vector2d& v) {
    return "[" + YamlDouble(v.x()) + ", " + YamlDouble(v.y()) + "]";
  };
  auto v3 = [](const Eigen::Vector3d& v) {
    return "[" + YamlDouble(v.x()) + ", " + YamlDouble(v.y()) + ", " + YamlDouble(v.z()) + "]";
  };
  o << "units: " << m.units << "\n";
  o << "sensor_height: " << YamlDouble(m.sensor_height) << "\n";
  if (m.room.present) {
    o << "room:\n  min: " << v2(m.room.min) << "\n  max: " << v2(m.room.max)
      << "\n  height: " << YamlDouble(m.room.height)
      << "\n  wall_shade: " << YamlDouble(m.room.wall_shade)
      << "\n  floor_shade: " << YamlDouble(m.room.floor_shade)
      << "\n  ceiling_shade: " << YamlDouble(m.room.ceiling_shade) << "\n";
  }
  auto rects = [&](const char* key, const std::vector<MapRectangle>& list) {
    if (list.empty()) return;
    o << key << ":\n";
    for (const MapRectangle& r : list)
      o << "  - id: " << r.id << "\n    from: " << v2(r.from) << "\n    to: " << v2(r.to)
        << "\n    z: [" << YamlDouble(r.z0) << ", " << YamlDouble(r.z1) << "]\n    shade: "
        << YamlDouble(r.shade) << "\n";
  };
  rects("rectangles", m.rectangles);
  if (!m.boxes.empty()) {
    o << "boxes:\n";
    for (const MapBox& b : m.boxes)
      o << "  - id: " << b.id << "\n    min: " << v3(b.min) << "\n    max: " << v3(b.max)
        << "\n    shade: " << YamlDouble(b.shade) << "\n";
  }
  if (with_distractors) rects("distractors", m.distractors);
  return o.str();
}

void WriteMap(const std::string& path, const Map& m, bool with_distractors) {
  CheckMap(m, path);
  WriteFileAtomic(path, MapToYaml(m, with_distractors));
}

}  // namespace pano
