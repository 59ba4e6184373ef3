#include "panotrack/core/output_check.h"

namespace pano {

namespace fs = std::filesystem;

namespace {

bool IsCompared(const std::string& path) { return !path.empty() && !WritesInPlace(path); }

}  // namespace

bool WritesInPlace(const std::string& path) {
  if (path == "-" || path.rfind("/dev/", 0) == 0 || path.rfind("/proc/", 0) == 0) return true;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  return !ec && fs::exists(st) && !fs::is_regular_file(st);
}

bool SameFile(const std::string& a, const std::string& b) {
  std::error_code ec_a, ec_b;
  if (fs::exists(a, ec_a) && fs::exists(b, ec_b)) {
    std::error_code ec;
    return fs::equivalent(a, b, ec);
  }
  std::error_code ec;
  const fs::path ca = fs::weakly_canonical(a, ec);
  if (ec) return fs::absolute(a).lexically_normal() == fs::absolute(b).lexically_normal();
  const fs::path cb = fs::weakly_canonical(b, ec);
  return !ec && ca == cb;
}

void CheckOutputsDistinct(const NamedPaths& reads, const NamedPaths& writes) {
  for (size_t w = 0; w < writes.size(); ++w) {
    const auto& [option, path] = writes[w];
    if (!IsCompared(path)) continue;
    for (const auto& [read_option, read] : reads)
      if (IsCompared(read) && read.find("://") == std::string::npos && SameFile(path, read))
        throw Error(option + " " + path + ": the same file as the input " + read +
                    (read_option.empty() ? "" : " (" + read_option + ")") + "; refusing to overwrite it");
    for (size_t v = 0; v < w; ++v)
      if (IsCompared(writes[v].second) && SameFile(path, writes[v].second))
        throw Error(option + " " + path + ": the same file as " + writes[v].first + " " + writes[v].second);
  }
}

void CheckPlannedOutputs(const NamedPaths& reads, const NamedPaths& writes, bool overwrite) {
  CheckOutputsDistinct(reads, writes);
  std::vector<std::string> paths;
  for (const auto& named : writes) paths.push_back(named.second);
  RefuseToReplace(paths, overwrite);
}

}  // namespace pano
