// Checked access to YAML nodes: every failure names the file, the key path
// and what was expected; and a writer that quotes every string that YAML
// could read as something else while numbers keep full precision.
#pragma once

#include <yaml-cpp/yaml.h>

#include <array>
#include <cstddef>
#include <initializer_list>
#include <string>
#include <vector>

#include "panotrack/core/error.h"

namespace pano {

// Limits on a YAML file the toolkit reads (a large map is well under 1 MiB
// and 100000 nodes): larger files, and endless streams given as a file, are
// refused before they fill the memory (yaml-cpp needs some 500 bytes a node).
constexpr size_t kMaxYamlBytes = size_t{64} << 20;
constexpr size_t kMaxYamlNodes = 1000000;

// A one-line description of a yaml-cpp error: its line (when known) and message.
std::string YamlProblem(const YAML::Exception& e);

// Runs `read`, a reader of `path`, turning any yaml-cpp exception that
// escapes it (a bad conversion, a subscript on a scalar) into pano::Error.
template <typename F>
auto GuardYaml(const std::string& path, F&& read) -> decltype(read()) {
  try {
    return read();
  } catch (const YAML::Exception& e) {
    throw Error(path + ": " + YamlProblem(e));
  }
}

class YamlReader {
 public:
  // Loads and parses `path`; throws pano::Error on an unreadable, oversized
  // or malformed file, on duplicate or non-scalar keys, and when the top
  // level is not a mapping.
  static YAML::Node LoadFile(const std::string& path);

  YamlReader(std::string file, YAML::Node root) : file_(std::move(file)), root_(root) {}
  const std::string& file() const { return file_; }
  const YAML::Node& root() const { return root_; }

  [[noreturn]] void Fail(const std::string& key, const std::string& problem) const;

  bool Has(const YAML::Node& node, const std::string& key) const;
  double Double(const YAML::Node& node, const std::string& key, const std::string& path) const;
  double Double(const YAML::Node& node, const std::string& key, const std::string& path,
                double fallback) const;
  // An integer within [lo, hi].
  int Int(const YAML::Node& node, const std::string& key, const std::string& path,
          int lo = -2147483647, int hi = 2147483647) const;
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
  // The value of `key` when it is a mapping (list: a sequence), else Fail
  // naming `path` and `what` was expected.
  YAML::Node Map(const YAML::Node& node, const std::string& key, const std::string& path,
                 const std::string& what) const;
  YAML::Node List(const YAML::Node& node, const std::string& key, const std::string& path,
                  const std::string& what) const;

 private:
  YAML::Node Get(const YAML::Node& node, const std::string& key, const std::string& path) const;
  std::string file_;
  YAML::Node root_;
};

// How a node reads in a message: 'text' for a scalar, else "a list" / "a mapping".
std::string DescribeNode(const YAML::Node& node);

// Formats a double for YAML with full round-trip precision: the shortest
// text that reads back exactly, always with a '.' ("1.0e+20"); .nan, .inf
// and -.inf for the others.
std::string YamlDouble(double v);

// Writes a YAML document through yaml-cpp's emitter: strings are quoted
// unless they are plain words that every YAML reader takes as strings,
// numbers are plain with YamlDouble's precision.
class YamlWriter {
 public:
  YamlWriter();
  // Comment lines ("# ..."), one per line of `text`; line breaks of any kind
  // inside a line become spaces so that nothing leaks out of the comment.
  YamlWriter& Comment(const std::string& text);
  YamlWriter& BeginMap();
  YamlWriter& EndMap();
  YamlWriter& BeginList();
  YamlWriter& EndList();
  YamlWriter& Key(const std::string& key);
  YamlWriter& String(const std::string& s);
  YamlWriter& Double(double v);
  YamlWriter& Int(long long v);
  YamlWriter& Unsigned(unsigned long long v);
  YamlWriter& Bool(bool b);
  // A flow list of numbers: [1.0, 2.5].
  YamlWriter& Numbers(std::initializer_list<double> values);
  // The document, ending in a newline; throws pano::Error if the emitter
  // reports a mistake (unbalanced maps, a key without a value).
  std::string Text() const;

 private:
  YAML::Emitter out_;
};

// True when `s` can be written unquoted and reads back as the same string
// in any YAML reader (not a number, bool, null or special character).
bool IsPlainYamlWord(const std::string& s);

}  // namespace pano
