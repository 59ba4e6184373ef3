// Checked access to YAML nodes: every failure names the file, the key path
// and what was expected.
#pragma once

#include <yaml-cpp/yaml.h>

#include <array>
#include <string>
#include <vector>

namespace pano {

class YamlReader {
 public:
  // Loads and parses `path`; throws pano::Error on unreadable or malformed YAML.
  static YAML::Node LoadFile(const std::string& path);

  YamlReader(std::string file, YAML::Node root) : file_(std::move(file)), root_(root) {}
  const std::string& file() const { return file_; }
  const YAML::Node& root() const { return root_; }

  [[noreturn]] void Fail(const std::string& key, const std::string& problem) const;

  bool Has(const YAML::Node& node, const std::string& key) const;
  double Double(const YAML::Node& node, const std::string& key, const std::string& path) const;
  double Double(const YAML::Node& node, const std::string& key, const std::string& path,
                double fallback) const;
  int Int(const YAML::Node& node, const std::string& key, const std::string& path) const;
  std::string String(const YAML::Node& node, const std::string& key,
                     const std::string& path) const;
  std::string String(const YAML::Node& node, const std::string& key, const std::string& path,
                     const std::string& fallback) const;
  // A sequence of exactly N numbers.
  template <size_t N>
  std::array<double, N> Vector(const YAML::Node& node, const std::string& key,
                               const std::string& path) const {
    std::vector<double> v = VectorN(node, key, path, N);
    std::array<double, N> out{};
    for (size_t i = 0; i < N; ++i) out[i] = v[i];
    return out;
  }
  std::vector<double> VectorN(const YAML::Node& node, const std::string& key,
                              const std::string& path, size_t n) const;

 private:
  YAML::Node Get(const YAML::Node& node, const std::string& key, const std::string& path) const;
  std::string file_;
  YAML::Node root_;
};

// Formats a double for YAML with full round-trip precision.
std::string YamlDouble(double v);

}  // namespace pano
