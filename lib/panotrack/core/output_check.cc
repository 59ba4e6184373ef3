#include "panotrack/core/output_check.h"

#include <sys/stat.h>

#include <map>
#include <tuple>

namespace pano {

namespace fs = std::filesystem;

namespace {

bool IsCompared(const std::string& path) { return !path.empty() && !WritesInPlace(path); }

bool IsUrl(const std::string& path) { return path.find("://") != std::string::npos; }

// What tells one file from another: its device and inode where it exists
// (whatever the spelling, link or hard link), else its absolute path with
// links and dots resolved as far as they exist.
struct FileKey {
  bool exists = false;
  dev_t device = 0;
  ino_t inode = 0;
  std::string path;
  auto Tie() const { return std::tie(exists, device, inode, path); }
  bool operator<(const FileKey& o) const { return Tie() < o.Tie(); }
  bool operator==(const FileKey& o) const { return Tie() == o.Tie(); }
};

FileKey KeyOf(const std::string& path) {
  FileKey k;
  struct stat st;
  if (::stat(path.c_str(), &st) == 0) {
    k.exists = true;
    k.device = st.st_dev;
    k.inode = st.st_ino;
    return k;
  }
  std::error_code ec;
  fs::path resolved = fs::weakly_canonical(path, ec);
  if (ec) resolved = fs::absolute(path, ec).lexically_normal();
  k.path = resolved.string();
  return k;
}

std::string InputNamed(const std::string& path, const std::string& from) {
  return "the input " + path + (from.empty() ? "" : " (" + from + ")");
}

}  // namespace

bool WritesInPlace(const std::string& path) {
  if (path == "-" || path.rfind("/dev/", 0) == 0 || path.rfind("/proc/", 0) == 0) return true;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  return !ec && fs::exists(st) && !fs::is_regular_file(st);
}

bool SameFile(const std::string& a, const std::string& b) { return KeyOf(a) == KeyOf(b); }

void CheckOutputsDistinct(const NamedPaths& reads, const NamedPaths& writes) {
  // Keyed once each: a folder input may bring thousands of frames.
  std::map<FileKey, size_t> read_at, written_at;
  for (size_t r = 0; r < reads.size(); ++r)
    if (IsCompared(reads[r].second) && !IsUrl(reads[r].second)) read_at.emplace(KeyOf(reads[r].second), r);
  for (size_t w = 0; w < writes.size(); ++w) {
    const auto& [option, path] = writes[w];
    if (!IsCompared(path)) continue;
    const FileKey key = KeyOf(path);
    if (const auto r = read_at.find(key); r != read_at.end())
      throw Error(option + " " + path + ": the same file as " +
                  InputNamed(reads[r->second].second, reads[r->second].first) + "; refusing to overwrite it");
    if (const auto v = written_at.find(key); v != written_at.end())
      throw Error(option + " " + path + ": the same file as " + writes[v->second].first + " " +
                  writes[v->second].second);
    written_at.emplace(key, w);
  }
}

void CheckFolderOutputHoldsNoInput(const NamedPaths& reads, const std::string& option, const std::string& dir) {
  if (dir.empty()) return;
  const FileKey folder = KeyOf(dir);
  if (!folder.exists) return;  // a folder yet to be made holds nothing
  for (const auto& [from, read] : reads) {
    // Folders and special files too: the folder's removal takes them along.
    if (read.empty() || read == "-" || IsUrl(read) || read.rfind("/dev/", 0) == 0 || read.rfind("/proc/", 0) == 0)
      continue;
    std::error_code ec;
    // The input and each folder above it, links resolved: the input may be
    // reached through a link into the folder, or the folder through a link.
    for (fs::path p = fs::weakly_canonical(read, ec); !ec && !p.empty(); p = p.parent_path()) {
      if (KeyOf(p.string()) == folder)
        throw Error(option + " " + dir + ": replacing this folder would delete " + InputNamed(read, from) +
                    "; refusing");
      if (p == p.parent_path()) break;
    }
  }
}

void CreateOutputFolder(const std::string& dir, const std::string& option) {
  std::error_code ec;
  // A file at the folder's place (or at a parent's) would otherwise surface
  // as std::filesystem's "Not a directory" with no option named.
  for (fs::path p = dir; !p.empty(); p = p.parent_path()) {
    if (fs::exists(p, ec) && !fs::is_directory(p, ec))
      throw Error(option + ": " + p.string() + " is a file, not a folder" +
                  (p == fs::path(dir) ? "" : " (in the path " + dir + ")"));
    if (p == p.parent_path()) break;
  }
  fs::create_directories(dir, ec);
  if (ec) throw Error(option + ": cannot create the folder " + dir + ": " + ec.message());
}

void CheckPlannedOutputs(const NamedPaths& reads, const NamedPaths& writes, bool overwrite) {
  CheckOutputsDistinct(reads, writes);
  std::vector<std::string> paths;
  for (const auto& named : writes) paths.push_back(named.second);
  RefuseToReplace(paths, overwrite);
}

}  // namespace pano
