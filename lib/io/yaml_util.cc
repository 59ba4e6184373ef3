#include "io/yaml_util.h"

#include <cmath>
#include <cstdio>
#include <fstream>

#include "core/error.h"

namespace pano {

YAML::Node YamlReader::LoadFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot open the file");
  try {
    YAML::Node n = YAML::Load(in);
    if (!n.IsMap()) throw Error(path + ": malformed YAML: expected a mapping of keys at the top level");
    return n;
  } catch (const YAML::Exception& e) {
    throw Error(path + ": malformed YAML at line " + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
}

void YamlReader::Fail(const std::string& key, const std::string& problem) const {
  throw Error(file_ + ": " + key + ": " + problem);
}

bool YamlReader::Has(const YAML::Node& node, const std::string& key) const {
  return node.IsMap() && node[key] && !node[key].IsNull();
}

YAML::Node YamlReader::Get(const YAML::Node& node, const std::string& key,
                           const std::string& path) const {
  if (!node.IsMap() || !node[key] || node[key].IsNull()) Fail(path, "missing (required key)");
  return node[key];
}

double YamlReader::Double(const YAML::Node& node, const std::string& key,
                          const std::string& path) const {
  YAML::Node v = Get(node, key, path);
  double d;
  if (!v.IsScalar() || !YAML::convert<double>::decode(v, d))
    Fail(path, "expected a number, got '" + (v.IsScalar() ? v.Scalar() : std::string("a structure")) + "'");
  if (!std::isfinite(d)) Fail(path, "expected a finite number, got '" + v.Scalar() + "'");
  return d;
}

double YamlReader::Double(const YAML::Node& node, const std::string& key, const std::string& path,
                          double fallback) const {
  return Has(node, key) ? Double(node, key, path) : fallback;
}

int YamlReader::Int(const YAML::Node& node, const std::string& key, const std::string& path) const {
  YAML::Node v = Get(node, key, path);
  long long i;
  if (!v.IsScalar() || !YAML::convert<long long>::decode(v, i))
    Fail(path, "expected an integer, got '" + (v.IsScalar() ? v.Scalar() : std::string("a structure")) + "'");
  if (i < -2147483647LL || i > 2147483647LL) Fail(path, "integer out of range");
  return static_cast<int>(i);
}

std::string YamlReader::String(const YAML::Node& node, const std::string& key,
                               const std::string& path) const {
  YAML::Node v = Get(node, key, path);
  if (!v.IsScalar()) Fail(path, "expected a string");
  return v.Scalar();
}

std::string YamlReader::String(const YAML::Node& node, const std::string& key,
                               const std::string& path, const std::string& fallback) const {
  return Has(node, key) ? String(node, key, path) : fallback;
}

std::vector<double> YamlReader::VectorN(const YAML::Node& node, const std::string& key,
                                        const std::string& path, size_t n) const {
  YAML::Node v = Get(node, key, path);
  if (!v.IsSequence() || v.size() != n)
    Fail(path, "expected a list of " + std::to_string(n) + " numbers");
  std::vector<double> out(n);
  for (size_t i = 0; i < n; ++i) {
    double d;
    if (!v[i].IsScalar() || !YAML::convert<double>::decode(v[i], d) || !std::isfinite(d))
      Fail(path + "[" + std::to_string(i) + "]", "expected a finite number");
    out[i] = d;
  }
  return out;
}

std::string YamlDouble(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  // Prefer the shortest representation that reads back exactly.
  for (int prec = 6; prec < 17; ++prec) {
    char shorter[64];
    std::snprintf(shorter, sizeof shorter, "%.*g", prec, v);
    if (std::strtod(shorter, nullptr) == v) {
      std::string s = shorter;
      if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
      return s;
    }
  }
  std::string s = buf;
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

}  // namespace pano
