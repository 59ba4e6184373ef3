#include "panotrack/pipeline/output_names.h"

#include <cctype>
#include <filesystem>
#include <map>

#include "panotrack/core/error.h"
#include "panotrack/io/pose_csv.h"

namespace pano {

namespace fs = std::filesystem;

namespace {

std::string Sanitized(const std::string& part) {
  std::string out = part;
  for (char& c : out)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-' && c != '_' && c != '.') c = '_';
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
