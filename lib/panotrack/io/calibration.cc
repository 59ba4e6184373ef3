#include "panotrack/io/calibration.h"

#include <array>
#include <cmath>
#include <set>

#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"
#include "panotrack/io/yaml_util.h"

namespace pano {

namespace {

const char* const kKnownKeys[] = {"model", "units", "image_width", "image_height", "focal_px", "cx",
                                  "cy", "aspect", "azimuth_offset", "k1", "k2", "rim_radius",
                                  "mirror_radius", "mirror_distance", "curvature_radius",
                                  "conic_constant", "vertex_distance", "asphere_a4", "asphere_a6", "xi", "lut",
                                  "mirror_offset", "camera_tilt", "sensor_tilt", "p1", "p2", "k3", "skew",
                                  "images", "images_not_found", "images_used", "images_total",
                                  "software", "command_line"};

bool IsKnownKey(const std::string& key) {
  for (const char* k : kKnownKeys)
    if (key == k) return true;
  return false;
}

// panocalib's record of the images: per-image results keyed by file name,
// the images without a board, and the software and command line.
void ReadImageResults(const YamlReader& r, const YAML::Node& n, Calibration* c) {
  if (r.Has(n, "images")) {
    const YAML::Node images = n["images"];
    if (!images.IsMap()) r.Fail("images", "expected a mapping from file name to that image's results");
    for (const auto& kv : images) {
      CalibrationImage im;
      im.file = kv.first.Scalar();
      const std::string at = "images." + im.file;
      im.method = r.String(kv.second, "method", at + ".method", "raw");
      im.corners = r.Int(kv.second, "corners", at + ".corners", 0);
      im.rms_px = r.Double(kv.second, "rms_px", at + ".rms_px");
      const std::array<double, 3> rv = r.Vector<3>(kv.second, "rvec", at + ".rvec");
      const std::array<double, 3> tv = r.Vector<3>(kv.second, "tvec", at + ".tvec");
      im.rvec = Eigen::Vector3d(rv[0], rv[1], rv[2]);
      im.tvec = Eigen::Vector3d(tv[0], tv[1], tv[2]);
      c->images.push_back(im);
    }
  }
  if (r.Has(n, "images_not_found")) {
    const YAML::Node missing = n["images_not_found"];
    if (!missing.IsSequence()) r.Fail("images_not_found", "expected a list of file names");
    for (const auto& f : missing) c->images_not_found.push_back(f.Scalar());
  }
  if (r.Has(n, "images_total")) {
    // Earlier versions wrote the count as a real number ("14.0").
    const double total = r.Double(n, "images_total", "images_total");
    if (!(total >= 0 && total <= 1e9 && total == std::floor(total)))
      r.Fail("images_total", "expected a count of images, got " + YamlDouble(total));
    c->images_total = static_cast<int>(total);
  }
  if (r.Has(n, "software")) c->software = r.String(n, "software", "software");
  if (r.Has(n, "command_line")) c->command_line = r.String(n, "command_line", "command_line");
}

void WriteImageResults(const Calibration& c, YamlWriter* w) {
  if (!c.images.empty()) {
    w->Key("images_used").Int(static_cast<long long>(c.images.size()));
    if (c.images_total > 0) w->Key("images_total").Int(c.images_total);
    w->Key("images").BeginMap();
    for (const CalibrationImage& im : c.images) {
      w->Key(im.file).BeginMap();
      w->Key("method").String(im.method);
      w->Key("corners").Int(im.corners);
      w->Key("rms_px").Double(im.rms_px);
      w->Key("rvec").Numbers({im.rvec.x(), im.rvec.y(), im.rvec.z()});
      w->Key("tvec").Numbers({im.tvec.x(), im.tvec.y(), im.tvec.z()});
      w->EndMap();
    }
    w->EndMap();
  }
  if (!c.images_not_found.empty()) {
    w->Key("images_not_found").BeginList();
    for (const std::string& f : c.images_not_found) w->String(f);
    w->EndList();
  }
  if (!c.software.empty()) w->Key("software").String(c.software);
  if (!c.command_line.empty()) w->Key("command_line").String(c.command_line);
}

Calibration ParseCalibration(const std::string& path, const YAML::Node& n) {
  YamlReader r(path, n);
  Calibration c;
  const std::string model = r.String(n, "model", "model");
  Sensor& s = c.sensor;
  if (model == "sphere") {
    s.model = MirrorModel::kSphere;
  } else if (model == "conic") {
    s.model = MirrorModel::kConic;
  } else if (model == "asphere") {
    s.model = MirrorModel::kAsphere;
  } else if (model == "unified") {
    s.model = MirrorModel::kUnified;
  } else {
    r.Fail("model", "unknown model '" + model + "' (expected sphere, conic, asphere or unified)");
  }
  c.units = r.String(n, "units", "units", "cm");
  s.image_width = r.Int(n, "image_width", "image_width", 1, kMaxImageSide);
  s.image_height = r.Int(n, "image_height", "image_height", 1, kMaxImageSide);
  if (static_cast<long long>(s.image_width) * s.image_height > kMaxImagePixels)
    r.Fail("image_width/image_height",
           "image of " + std::to_string(s.image_width) + " x " + std::to_string(s.image_height) +
               " pixels: more than the limit of " + std::to_string(kMaxImagePixels) + " pixels");
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
    SetSphereMirror(&p, radius, distance);
  } else if (s.model == MirrorModel::kUnified) {
    for (const char* key : {"curvature_radius", "conic_constant", "vertex_distance", "mirror_radius", "mirror_distance"})
      if (r.Has(n, key)) r.Fail(key, "not a parameter of the unified model (it has xi instead)");
    p.unified = true;
    p.xi = r.Double(n, "xi", "xi");
  } else {
    p.curvature_radius = r.Double(n, "curvature_radius", "curvature_radius");
    p.conic_constant = r.Double(n, "conic_constant", "conic_constant");
    p.vertex_distance = r.Double(n, "vertex_distance", "vertex_distance");
  }
  // The even-asphere terms: optional (absent: zero), and only for model asphere.
  for (const char* key : {"asphere_a4", "asphere_a6"})
    if (s.model != MirrorModel::kAsphere && r.Has(n, key)) r.Fail(key, "only with model asphere");
  if (s.model == MirrorModel::kAsphere) {
    p.asphere_a4 = r.Double(n, "asphere_a4", "asphere_a4", 0.0);
    p.asphere_a6 = r.Double(n, "asphere_a6", "asphere_a6", 0.0);
  }
  // Faults of a real rig (all optional; absent: an aligned rig).
  RigFaults<double>& f = s.faults;
  auto pair = [&](const char* key, double* out) {
    if (!r.Has(n, key)) return;
    const std::array<double, 2> v = r.Vector<2>(n, key, key);
    out[0] = v[0];
    out[1] = v[1];
  };
  pair("mirror_offset", f.mirror_offset);
  pair("camera_tilt", f.camera_tilt);
  pair("sensor_tilt", f.sensor_tilt);
  f.p1 = r.Double(n, "p1", "p1", 0.0);
  f.p2 = r.Double(n, "p2", "p2", 0.0);
  f.k3 = r.Double(n, "k3", "k3", 0.0);
  f.skew = r.Double(n, "skew", "skew", 0.0);
  s.Check(path);
  if (r.Has(n, "lut")) {
    c.lut = r.String(n, "lut", "lut");
    c.lut_resolved = JoinPath(DirName(path), c.lut);
  }
  ReadImageResults(r, n, &c);
  // Keys of later versions and panocalib's statistics: numbers are kept, the rest ignored.
  for (const auto& kv : n) {
    const std::string key = kv.first.Scalar();
    double d;
    if (!IsKnownKey(key) && kv.second.IsScalar() && YAML::convert<double>::decode(kv.second, d))
      c.extras[key] = d;
  }
  return c;
}

// The mirror_distance written for a sphere: the double nearest
// vertex_distance + radius that reads back (mirror_distance - mirror_radius)
// as the same vertex_distance, so that a calibration round-trips exactly.
double SphereDistanceToWrite(const SensorParams<double>& p) {
  const double radius = p.curvature_radius, vertex = p.vertex_distance;
  const double sum = vertex + radius;
  if (sum - radius == vertex) return sum;
  double up = sum, down = sum;
  for (int step = 0; step < 4; ++step) {
    up = std::nextafter(up, HUGE_VAL);
    down = std::nextafter(down, -HUGE_VAL);
    if (up - radius == vertex) return up;
    if (down - radius == vertex) return down;
  }
  return sum;
}

void CheckExtras(const Calibration& c, const std::string& what) {
  for (const auto& kv : c.extras)
    if (IsKnownKey(kv.first))
      throw Error(what + ": extra key '" + kv.first + "' would repeat a calibration key");
  std::set<std::string> files;
  for (const CalibrationImage& im : c.images)
    if (!files.insert(im.file).second)
      throw Error(what + ": image '" + im.file + "' is listed twice (the per-image results are keyed by file name)");
}

}  // namespace

Calibration ReadCalibration(const std::string& path) {
  const YAML::Node root = YamlReader::LoadFile(path);
  return GuardYaml(path, [&] { return ParseCalibration(path, root); });
}

std::string CalibrationToYaml(const Calibration& c) {
  CheckExtras(c, "calibration");
  const Sensor& s = c.sensor;
  const SensorParams<double>& p = s.params;
  YamlWriter w;
  if (!c.comment.empty()) w.Comment(c.comment);
  w.BeginMap();
  w.Key("model").String(MirrorModelName(s.model));
  w.Key("units").String(c.units);
  w.Key("image_width").Int(s.image_width);
  w.Key("image_height").Int(s.image_height);
  w.Key("focal_px").Double(p.focal_px);
  w.Key("cx").Double(p.cx);
  w.Key("cy").Double(p.cy);
  w.Key("aspect").Double(p.aspect);
  if (s.model == MirrorModel::kSphere) {
    w.Key("mirror_radius").Double(s.mirror_radius());
    w.Key("mirror_distance").Double(SphereDistanceToWrite(p));
  } else if (s.model == MirrorModel::kUnified) {
    w.Key("xi").Double(p.xi);
  } else {
    w.Key("curvature_radius").Double(p.curvature_radius);
    w.Key("conic_constant").Double(p.conic_constant);
    w.Key("vertex_distance").Double(p.vertex_distance);
    if (p.asphere_a4 != 0.0) w.Key("asphere_a4").Double(p.asphere_a4);
    if (p.asphere_a6 != 0.0) w.Key("asphere_a6").Double(p.asphere_a6);
  }
  w.Key("azimuth_offset").Double(p.azimuth_offset);
  if (p.k1 != 0.0 || p.k2 != 0.0) {
    w.Key("k1").Double(p.k1);
    w.Key("k2").Double(p.k2);
  }
  if (p.rim_radius > 0.0) w.Key("rim_radius").Double(p.rim_radius);
  // The faults of a real rig, only when present (an aligned rig's file is unchanged).
  const RigFaults<double>& f = s.faults;
  if (f.mirror_offset[0] != 0.0 || f.mirror_offset[1] != 0.0)
    w.Key("mirror_offset").Numbers({f.mirror_offset[0], f.mirror_offset[1]});
  if (f.camera_tilt[0] != 0.0 || f.camera_tilt[1] != 0.0)
    w.Key("camera_tilt").Numbers({f.camera_tilt[0], f.camera_tilt[1]});
  if (f.p1 != 0.0 || f.p2 != 0.0 || f.k3 != 0.0) {
    if (p.k1 == 0.0 && p.k2 == 0.0) {
      w.Key("k1").Double(p.k1);
      w.Key("k2").Double(p.k2);
    }
    w.Key("p1").Double(f.p1);
    w.Key("p2").Double(f.p2);
    w.Key("k3").Double(f.k3);
  }
  if (f.sensor_tilt[0] != 0.0 || f.sensor_tilt[1] != 0.0)
    w.Key("sensor_tilt").Numbers({f.sensor_tilt[0], f.sensor_tilt[1]});
  if (f.skew != 0.0) w.Key("skew").Double(f.skew);
  if (!c.lut.empty()) w.Key("lut").String(c.lut);
  for (const auto& kv : c.extras) w.Key(kv.first).Double(kv.second);
  WriteImageResults(c, &w);
  w.EndMap();
  return w.Text();
}

void WriteCalibration(const std::string& path, const Calibration& c) {
  c.sensor.Check(path);
  CheckExtras(c, path);
  WriteFileAtomic(path, CalibrationToYaml(c));
}

}  // namespace pano
