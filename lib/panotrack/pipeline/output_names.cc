#include "panotrack/pipeline/output_names.h"

#include <cctype>
#include <filesystem>
#include <map>

#include "panotrack/core/error.h"
#include "panotrack/io/pose_csv.h"

namespace pano {

namespace fs = std::filesystem;

namespace {

// The length of the UTF-8 sequence at `s[i]` that encodes a printable
// character beyond ASCII (U+00A0 and up); 0 for anything else (ASCII, a
// stray or overlong byte, a surrogate, C1 controls).
size_t NonAsciiCharLength(const std::string& s, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char lead = byte(i);
  const size_t n = lead >= 0xF0 && lead <= 0xF4 ? 4 : lead >= 0xE0 ? 3 : lead >= 0xC2 ? 2 : 0;
  if (n == 0 || lead > 0xF4 || i + n > s.size()) return 0;
  unsigned long code = lead & (0x7F >> n);
  for (size_t k = 1; k < n; ++k) {
    if ((byte(i + k) & 0xC0) != 0x80) return 0;
    code = (code << 6) | (byte(i + k) & 0x3F);
  }
  const unsigned long least[] = {0, 0, 0xA0, 0x800, 0x10000};  // shorter forms are overlong
  if (code < least[n] || code > 0x10FFFF || (code >= 0xD800 && code <= 0xDFFF)) return 0;
  return n;
}

// A part of an input's path as a part of a file name: letters, digits, '-',
// '_', '.' and every non-ASCII character (UTF-8) kept, so that names in any
// script stay apart; other ASCII characters become '_'; a byte that is not
// UTF-8 (a Latin-1 name) becomes '_' and its two hex digits (caf\xe9 ->
// caf_E9), which keeps such names apart too.
std::string Sanitized(const std::string& part) {
  std::string out;
  for (size_t i = 0; i < part.size();) {
    const unsigned char c = static_cast<unsigned char>(part[i]);
    if (const size_t n = NonAsciiCharLength(part, i)) {
      out.append(part, i, n);
      i += n;
      continue;
    }
    if (c >= 0x80) {
      static const char kHex[] = "0123456789ABCDEF";
      out += {'_', kHex[c >> 4], kHex[c & 15]};
    } else {
      out += std::isalnum(c) || c == '-' || c == '_' || c == '.' ? static_cast<char>(c) : '_';
    }
    ++i;
  }
  return out;
}

// The parts an input's output name is made of, the file name first, then its
// folders from the nearest up; and how many of them the name starts with.
std::vector<std::string> NameParts(const std::string& input, size_t* base) {
  *base = 1;
  if (input == "-") return {"stdin"};
  const size_t scheme = input.find("://");
  const fs::path p = scheme != std::string::npos ? fs::path(input.substr(scheme + 3))
                                                 : fs::absolute(input).lexically_normal();
  std::vector<std::string> parts;
  for (const fs::path& part : p.relative_path()) {
    const std::string s = part.string();
    if (!s.empty() && s != ".") parts.insert(parts.begin(), s);
  }
  if (parts.empty()) return {Sanitized(input)};
  const std::string stem = fs::path(parts.front()).stem().string();
  if (!stem.empty() && !fs::is_directory(p)) parts.front() = stem;
  const size_t percent = parts.front().find('%');
  if (percent != std::string::npos) {  // a printf pattern: its fixed prefix, after its folder
    std::string prefix = parts.front().substr(0, percent);
    while (!prefix.empty() && (prefix.back() == '_' || prefix.back() == '-' || prefix.back() == '.')) prefix.pop_back();
    if (prefix.empty()) parts.erase(parts.begin());
    else parts.front() = prefix;
    if (parts.empty()) return {"frames"};
    *base = prefix.empty() ? 1 : 2;
  }
  if (stem == "video") *base = 2;
  for (std::string& s : parts) s = Sanitized(s);
  return parts;
}

std::string JoinParts(const std::vector<std::string>& parts, size_t depth) {
  std::string name;
  for (size_t k = std::min(depth, parts.size()); k-- > 0;) name += (name.empty() ? "" : "_") + parts[k];
  return name;
}

}  // namespace

std::vector<std::string> OutputPathsInDir(const std::vector<std::string>& inputs, const std::string& out_dir) {
  const size_t n = inputs.size();
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j)
      if (inputs[i] == inputs[j] || (inputs[i] != "-" && SameFile(inputs[i], inputs[j])))
        throw Error(inputs[j] + ": given twice as an input");
  std::vector<std::vector<std::string>> parts(n);
  std::vector<size_t> depth(n);
  for (size_t i = 0; i < n; ++i) {
    parts[i] = NameParts(inputs[i], &depth[i]);
    depth[i] = std::min(depth[i], parts[i].size());
    for (size_t j = 0; j < i; ++j)
      if (parts[j] == parts[i])
        throw Error("--out-dir: " + inputs[j] + " and " + inputs[i] + " would both write " +
                    JoinParts(parts[i], depth[i]) + ".csv; rename one of them or run them separately");
  }
  // Names that coincide take one more folder each, until they all differ.
  for (;;) {
    std::map<std::string, std::vector<size_t>> by_name;
    for (size_t i = 0; i < n; ++i) by_name[JoinParts(parts[i], depth[i])].push_back(i);
    bool clash = false;
    for (const auto& [name, members] : by_name) {
      if (members.size() < 2) continue;
      clash = true;
      bool grew = false;
      for (size_t i : members)
        if (depth[i] < parts[i].size()) ++depth[i], grew = true;
      if (!grew)
        throw Error("--out-dir: " + inputs[members[0]] + " and " + inputs[members[1]] + " would both write " +
                    name + ".csv; rename one of them or run them separately");
    }
    if (!clash) break;
  }
  std::vector<std::string> out;
  for (size_t i = 0; i < n; ++i) out.push_back((fs::path(out_dir) / (JoinParts(parts[i], depth[i]) + ".csv")).string());
  return out;
}



}  // namespace pano
