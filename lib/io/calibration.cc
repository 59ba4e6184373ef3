#include "io/calibration.h"

#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "io/yaml_util.h"

namespace pano {

Calibration ReadCalibration(const std::string& path) {
  YamlReader r(path, YamlReader::LoadFile(path));
  const YAML::Node& n = r.root();
  Calibration c;
  const std::string model = r.String(n, "model", "model");
  Sensor& s = c.sensor;
  if (model == "sphere") {
    s.model = MirrorModel::kSphere;
  } else if (model == "conic") {
    s.model = MirrorModel::kConic;
  } else {
    r.Fail("model", "unknown model '" + model + "' (expected sphere or conic)");
  }
  c.units = r.String(n, "units", "units", "cm");
  s.image_width = r.Int(n, "image_width", "image_width");
  s.image_height = r.Int(n, "image_height", "image_height");
  SensorParams<double>& p = s.params;
  p.focal_px = r.Double(n, "focal_px", "focal_px");
  p.cx = r.Double(n, "cx", "cx");
  p.cy = r.Double(n, "cy", "cy");
  p.aspect = r.Double(n, "aspect", "aspect", 1.0);
  p.azimuth_offset = r.Double(n, "azimuth_offset", "azimuth_offset", 0.0);
  p.k1 = r.Double(n, "k1", "k1", 0.0);
  p.k2 = r.Double(n, "k2", "k2", 0.0);
  p.rim_radius = r.Double(n, "rim_radius", "rim_radius", 0.0);
  if (s.model == MirrorModel::kSphere) {
    const double radius = r.Double(n, "mirror_radius", "mirror_radius");
    const double distance = r.Double(n, "mirror_distance", "mirror_distance");
    if (!(radius > 0.0)) r.Fail("mirror_radius", "expected a positive radius");
    if (!(distance > radius))
      r.Fail("mirror_distance", "expected mirror_distance > mirror_radius (got " +
                                    YamlDouble(distance) + " <= " + YamlDouble(radius) + ")");
    set_sphere_mirror(&p, radius, distance);
  } else {
    p.curvature_radius = r.Double(n, "curvature_radius", "curvature_radius");
    p.conic_constant = r.Double(n, "conic_constant", "conic_constant");
    p.vertex_distance = r.Double(n, "vertex_distance", "vertex_distance");
  }
  s.Check(path);
  if (r.Has(n, "lut")) {
    c.lut = r.String(n, "lut", "lut");
    c.lut_resolved = JoinPath(DirName(path), c.lut);
  }
  static const char* kKnown[] = {"model", "units", "image_width", "image_height", "focal_px", "cx",
                                 "cy", "aspect", "azimuth_offset", "k1", "k2", "rim_radius",
                                 "mirror_radius", "mirror_distance", "curvature_radius",
                                 "conic_constant", "vertex_distance", "lut"};
  for (const auto& kv : n) {
    const std::string key = kv.first.as<std::string>();
    bool known = false;
    for (const char* k : kKnown) known = known || key == k;
    double d;
    if (!known && kv.second.IsScalar() && YAML::convert<double>::decode(kv.second, d))
      c.extras[key] = d;
  }
  return c;
}

std::string CalibrationToYaml(const Calibration& c) {
  const Sensor& s = c.sensor;
  const SensorParams<double>& p = s.params;
  std::ostringstream o;
  if (!c.comment.empty()) {
    std::istringstream lines(c.comment);
    for (std::string line; std::getline(lines, line);) o << "# " << line << "\n";
  }
  o << "model: " << mirror_model_name(s.model) << "\n";
  o << "units: " << c.units << "\n";
  o << "image_width: " << s.image_width << "\n";
  o << "image_height: " << s.image_height << "\n";
  o << "focal_px: " << YamlDouble(p.focal_px) << "\n";
  o << "cx: " << YamlDouble(p.cx) << "\n";
  o << "cy: " << YamlDouble(p.cy) << "\n";
  o << "aspect: " << YamlDouble(p.aspect) << "\n";
  if (s.model == MirrorModel::kSphere) {
    o << "mirror_radius: " << YamlDouble(s.mirror_radius()) << "\n";
    o << "mirror_distance: " << YamlDouble(s.mirror_distance()) << "\n";
  } else {
    o << "curvature_radius: " << YamlDouble(p.curvature_radius) << "\n";
    o << "conic_constant: " << YamlDouble(p.conic_constant) << "\n";
    o << "vertex_distance: " << YamlDouble(p.vertex_distance) << "\n";
  }
  o << "azimuth_offset: " << YamlDouble(p.azimuth_offset) << "\n";
  if (p.k1 != 0.0 || p.k2 != 0.0) {
    o << "k1: " << YamlDouble(p.k1) << "\n";
    o << "k2: " << YamlDouble(p.k2) << "\n";
  }
  if (p.rim_radius > 0.0) o << "rim_radius: " << YamlDouble(p.rim_radius) << "\n";
  if (!c.lut.empty()) o << "lut: " << c.lut << "\n";
  for (const auto& kv : c.extras) o << kv.first << ": " << YamlDouble(kv.second) << "\n";
  return o.str();
}

void WriteCalibration(const std::string& path, const Calibration& c) {
  c.sensor.Check(path);
  WriteFileAtomic(path, CalibrationToYaml(c));
}

}  // namespace pano
