#include "core/atomic_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace pano {

AtomicFile::AtomicFile(const std::string& path)
    : path_(path), temp_path_(path + ".tmp." + std::to_string(::getpid())) {
  // Keep the extension last so that libraries choosing a codec by name work.
  const size_t slash = path.find_last_of('/');
  const size_t dot = path.find_last_of('.');
  if (dot != std::string::npos && (slash == std::string::npos || dot > slash + 1)) {
    temp_path_ = path.substr(0, dot) + ".tmp" + std::to_string(::getpid()) + path.substr(dot);
  }
}

AtomicFile::~AtomicFile() {
  if (file_) std::fclose(file_);
  if (!committed_) std::remove(temp_path_.c_str());
}

std::FILE* AtomicFile::stream() {
  if (!file_) {
    file_ = std::fopen(temp_path_.c_str(), "wb");
    if (!file_)
      throw Error(path_ + ": cannot write: " + std::string(std::strerror(errno)));
  }
  return file_;
}

void AtomicFile::Write(const void* data, size_t size) {
  if (size == 0) {
    stream();
    return;
  }
  if (std::fwrite(data, 1, size, stream()) != size)
    throw Error(path_ + ": write failed: " + std::string(std::strerror(errno)));
}

void AtomicFile::Commit() {
  if (file_) {
    const bool ok = std::fflush(file_) == 0 && ::fsync(::fileno(file_)) == 0;
    const bool closed = std::fclose(file_) == 0;
    file_ = nullptr;
    if (!ok || !closed) throw Error(path_ + ": write failed: " + std::strerror(errno));
  }
  if (std::rename(temp_path_.c_str(), path_.c_str()) != 0)
    throw Error(path_ + ": cannot move the finished file into place: " + std::strerror(errno));
  committed_ = true;
}

void WriteFileAtomic(const std::string& path, const std::string& text) {
  AtomicFile f(path);
  f.Write(text);
  f.Commit();
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open: " + std::strerror(errno));
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw Error(path + ": read failed");
  return ss.str();
}

std::string DirName(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

std::string JoinPath(const std::string& dir, const std::string& path) {
  if (path.empty() || path[0] == '/' || dir.empty() || dir == ".") return path;
  return dir + "/" + path;
}

}  // namespace pano
