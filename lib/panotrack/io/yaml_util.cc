#include "panotrack/io/yaml_util.h"

#include <yaml-cpp/eventhandler.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <sstream>

#include "panotrack/core/atomic_file.h"

namespace pano {

namespace {

std::string LinePrefix(const YAML::Mark& mark) {
  return mark.is_null() ? std::string() : "line " + std::to_string(mark.line + 1) + ": ";
}

// A first pass over the parser's events, before yaml-cpp builds any node:
// counts the nodes against kMaxYamlNodes, and checks that every mapping key
// is a scalar that appears once (yaml-cpp would silently keep the first).
class StructureCheck : public YAML::EventHandler {
 public:
  explicit StructureCheck(const std::string& path) : path_(path) {}

  void OnDocumentStart(const YAML::Mark& mark) override {
    if (++documents_ > 1) Fail(mark, "more than one YAML document ('---') in the file");
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& mark, YAML::anchor_t) override { Node(mark, nullptr); }
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override { Node(mark, nullptr); }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                const std::string& value) override {
    Node(mark, &value);
  }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {
    Node(mark, nullptr);
    open_.push_back({false, true, {}});
  }
  void OnSequenceEnd() override { open_.pop_back(); }
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {
    Node(mark, nullptr);
    open_.push_back({true, true, {}});
  }
  void OnMapEnd() override { open_.pop_back(); }

 private:
  struct Collection {
    bool is_map;
    bool next_is_key;
    std::set<std::string> keys;
  };

  [[noreturn]] void Fail(const YAML::Mark& mark, const std::string& problem) const {
    throw Error(path_ + ": " + LinePrefix(mark) + problem);
  }

  // Every node: `scalar` is its text, null for anything else.
  void Node(const YAML::Mark& mark, const std::string* scalar) {
    if (++nodes_ > kMaxYamlNodes)
      Fail(mark, "more than " + std::to_string(kMaxYamlNodes) + " YAML nodes (the limit for one file)");
    if (open_.empty() || !open_.back().is_map) return;
    Collection& map = open_.back();
    map.next_is_key = !map.next_is_key;
    if (map.next_is_key) return;  // this node was a value
    if (!scalar) Fail(mark, "a mapping key must be a plain string, not a list, mapping, alias or null");
    if (!map.keys.insert(*scalar).second) Fail(mark, "duplicate key '" + *scalar + "'");
  }

  std::string path_;
  std::vector<Collection> open_;
  size_t nodes_ = 0;
  int documents_ = 0;
};

bool IsAsciiLetter(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); }
bool IsAsciiDigit(char c) { return c >= '0' && c <= '9'; }

}  // namespace

std::string YamlProblem(const YAML::Exception& e) {
  return (e.mark.is_null() ? std::string("malformed YAML: ") : "malformed YAML at " + LinePrefix(e.mark)) +
         e.msg;
}

YAML::Node YamlReader::LoadFile(const std::string& path) {
  const std::string text = ReadFile(path, kMaxYamlBytes);
  if (text.find('\0') != std::string::npos)
    throw Error(path + ": not a YAML text file (it contains NUL bytes)");
  try {
    std::istringstream in(text);
    YAML::Parser parser(in);
    StructureCheck check(path);
    while (parser.HandleNextDocument(check)) {
    }
    YAML::Node n = YAML::Load(text);
    if (!n.IsMap()) throw Error(path + ": malformed YAML: expected a mapping of keys at the top level");
    return n;
  } catch (const YAML::Exception& e) {
    throw Error(path + ": " + YamlProblem(e));
  }
}

void YamlReader::Fail(const std::string& key, const std::string& problem) const {
  throw Error(file_ + ": " + key + ": " + problem);
}

std::string DescribeNode(const YAML::Node& node) {
  if (node.IsScalar()) return "'" + node.Scalar() + "'";
  if (node.IsSequence()) return "a list";
  if (node.IsMap()) return "a mapping";
  return "nothing";
}

bool YamlReader::Has(const YAML::Node& node, const std::string& key) const {
  return node.IsMap() && node[key] && !node[key].IsNull();
}

YAML::Node YamlReader::Get(const YAML::Node& node, const std::string& key,
                           const std::string& path) const {
  if (!Has(node, key)) Fail(path, "missing (required key)");
  return node[key];
}

double YamlReader::Double(const YAML::Node& node, const std::string& key,
                          const std::string& path) const {
  YAML::Node v = Get(node, key, path);
  double d;
  if (!v.IsScalar() || !YAML::convert<double>::decode(v, d))
    Fail(path, "expected a number, got " + DescribeNode(v));
  if (!std::isfinite(d)) Fail(path, "expected a finite number, got '" + v.Scalar() + "'");
  return d;
}

double YamlReader::Double(const YAML::Node& node, const std::string& key, const std::string& path,
                          double fallback) const {
  return Has(node, key) ? Double(node, key, path) : fallback;
}

int YamlReader::Int(const YAML::Node& node, const std::string& key, const std::string& path,
                    int lo, int hi) const {
  YAML::Node v = Get(node, key, path);
  long long i;
  if (!v.IsScalar() || !YAML::convert<long long>::decode(v, i))
    Fail(path, "expected an integer, got " + DescribeNode(v));
  if (i < lo || i > hi)
    Fail(path, "expected an integer from " + std::to_string(lo) + " to " + std::to_string(hi) + ", got " +
                   std::to_string(i));
  return static_cast<int>(i);
}

std::string YamlReader::String(const YAML::Node& node, const std::string& key,
                               const std::string& path) const {
  YAML::Node v = Get(node, key, path);
  if (!v.IsScalar()) Fail(path, "expected a string, got " + DescribeNode(v));
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
    Fail(path, "expected a list of " + std::to_string(n) + " numbers, got " +
                   (v.IsSequence() ? "a list of " + std::to_string(v.size()) : DescribeNode(v)));
  std::vector<double> out(n);
  for (size_t i = 0; i < n; ++i) {
    double d;
    if (!v[i].IsScalar() || !YAML::convert<double>::decode(v[i], d) || !std::isfinite(d))
      Fail(path + "[" + std::to_string(i) + "]", "expected a finite number, got " + DescribeNode(v[i]));
    out[i] = d;
  }
  return out;
}

YAML::Node YamlReader::Map(const YAML::Node& node, const std::string& key, const std::string& path,
                           const std::string& what) const {
  YAML::Node v = Get(node, key, path);
  if (!v.IsMap()) Fail(path, "expected " + what + ", got " + DescribeNode(v));
  return v;
}

YAML::Node YamlReader::List(const YAML::Node& node, const std::string& key, const std::string& path,
                            const std::string& what) const {
  YAML::Node v = Get(node, key, path);
  if (!v.IsSequence()) Fail(path, "expected " + what + ", got " + DescribeNode(v));
  return v;
}

std::string YamlDouble(double v) {
  if (std::isnan(v)) return ".nan";
  if (std::isinf(v)) return v > 0 ? ".inf" : "-.inf";
  char buf[64];
  // The shortest representation that reads back exactly (17 digits always
  // do); from 6 digits up, so that 100 reads "100.0", not "1e+02".
  for (int prec = 6; prec <= 17; ++prec) {
    std::snprintf(buf, sizeof buf, "%.*g", prec, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  // A '.' always: YAML 1.1 readers (PyYAML) take "1e+20" for a string.
  std::string s = buf;
  if (s.find('.') == std::string::npos) {
    const size_t e = s.find_first_of("eE");
    s.insert(e == std::string::npos ? s.size() : e, ".0");
  }
  return s;
}

bool IsPlainYamlWord(const std::string& s) {
  if (s.empty() || !(IsAsciiLetter(s[0]) || s[0] == '_' || s[0] == '/')) return false;
  for (char c : s)
    if (!(IsAsciiLetter(c) || IsAsciiDigit(c) || c == '_' || c == '-' || c == '.' || c == '/')) return false;
  // Words that YAML 1.1 readers take for booleans or null.
  std::string lower;
  for (char c : s) lower += static_cast<char>(c >= 'A' && c <= 'Z' ? c - 'A' + 'a' : c);
  for (const char* w : {"y", "n", "yes", "no", "true", "false", "on", "off", "null"})
    if (lower == w) return false;
  return true;
}

YamlWriter::YamlWriter() {
  out_.SetIndent(2);
  out_.SetMapFormat(YAML::Block);
  out_.SetSeqFormat(YAML::Block);
}

YamlWriter& YamlWriter::Comment(const std::string& text) {
  std::istringstream lines(text);
  bool first = true;
  for (std::string line; std::getline(lines, line); first = false) {
    if (!first) out_ << YAML::Newline;  // else the emitter puts the next comment on the same line
    std::string clean;
    for (size_t i = 0; i < line.size(); ++i) {
      const unsigned char c = static_cast<unsigned char>(line[i]);
      // \r, and NEL (U+0085), LS and PS (U+2028, U+2029) that YAML 1.1 reads as line breaks.
      const bool nel = c == 0xC2 && i + 1 < line.size() && static_cast<unsigned char>(line[i + 1]) == 0x85;
      const bool ls_ps = c == 0xE2 && i + 2 < line.size() &&
                         static_cast<unsigned char>(line[i + 1]) == 0x80 &&
                         (static_cast<unsigned char>(line[i + 2]) == 0xA8 ||
                          static_cast<unsigned char>(line[i + 2]) == 0xA9);
      if (nel || ls_ps) {
        clean += ' ';
        i += nel ? 1 : 2;
      } else {
        clean += (c < 0x20 && c != '\t') || c == 0x7F ? ' ' : line[i];
      }
    }
    out_ << YAML::Comment(clean);
  }
  return *this;
}

YamlWriter& YamlWriter::BeginMap() {
  out_ << YAML::BeginMap;
  return *this;
}
YamlWriter& YamlWriter::EndMap() {
  out_ << YAML::EndMap;
  return *this;
}
YamlWriter& YamlWriter::BeginList() {
  out_ << YAML::BeginSeq;
  return *this;
}
YamlWriter& YamlWriter::EndList() {
  out_ << YAML::EndSeq;
  return *this;
}
YamlWriter& YamlWriter::Key(const std::string& key) {
  out_ << YAML::Key;
  String(key);
  out_ << YAML::Value;
  return *this;
}
YamlWriter& YamlWriter::String(const std::string& s) {
  if (IsPlainYamlWord(s)) {
    out_ << s;
  } else {
    out_ << YAML::DoubleQuoted << s;
  }
  return *this;
}
YamlWriter& YamlWriter::Double(double v) {
  out_ << YamlDouble(v);
  return *this;
}
YamlWriter& YamlWriter::Int(long long v) {
  out_ << v;
  return *this;
}
YamlWriter& YamlWriter::Unsigned(unsigned long long v) {
  out_ << v;
  return *this;
}
YamlWriter& YamlWriter::Bool(bool b) {
  out_ << YAML::TrueFalseBool << YAML::LowerCase << b;
  return *this;
}
YamlWriter& YamlWriter::Numbers(std::initializer_list<double> values) {
  out_ << YAML::Flow << YAML::BeginSeq;
  for (double v : values) out_ << YamlDouble(v);
  out_ << YAML::EndSeq;
  return *this;
}

std::string YamlWriter::Text() const {
  if (!out_.good()) throw Error("YAML writer: " + out_.GetLastError());
  return std::string(out_.c_str()) + "\n";
}

}  // namespace pano
