#include "panotrack/core/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>

#include "panotrack/core/error.h"

namespace pano {

namespace {

std::string ErrnoText() { return std::strerror(errno); }

// Where `path` leads through symbolic links (the last one may dangle: the
// file it names is then created).
std::string FollowLinks(const std::string& path) {
  std::string p = path;
  for (int hops = 0; hops < 40; ++hops) {
    struct stat st;
    if (::lstat(p.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) return p;
    std::string link(4096, '\0');
    const ssize_t n = ::readlink(p.c_str(), &link[0], link.size());
    if (n < 0 || static_cast<size_t>(n) >= link.size())
      throw Error(path + ": cannot read the symbolic link '" + p + "'");
    link.resize(static_cast<size_t>(n));
    p = link[0] == '/' ? link : JoinPath(DirName(p), link);
  }
  throw Error(path + ": too many levels of symbolic links");
}

// A fresh name beside `target`, keeping the extension last so that libraries
// choosing a codec by name (OpenCV) still see it.
std::string TempPathBeside(const std::string& target) {
  static std::atomic<unsigned> counter{0};
  const std::string tag = ".tmp" + std::to_string(::getpid()) + "_" + std::to_string(counter++);
  const size_t slash = target.find_last_of('/');
  const size_t dot = target.find_last_of('.');
  if (dot != std::string::npos && (slash == std::string::npos || dot > slash + 1))
    return target.substr(0, dot) + tag + target.substr(dot);
  return target + tag;
}

std::string ByteCount(size_t n) {
  if (n % (size_t{1} << 20) == 0) return std::to_string(n >> 20) + " MiB";
  return std::to_string(n) + " bytes";
}

}  // namespace

AtomicFile::AtomicFile(const std::string& path) : path_(path), target_(FollowLinks(path)) {
  struct stat st;
  if (::stat(target_.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode)) throw Error(path + ": cannot write: it is a folder, not a file");
    in_place_ = !S_ISREG(st.st_mode);
  }
  temp_path_ = in_place_ ? path_ : TempPathBeside(target_);
}

AtomicFile::~AtomicFile() {
  if (file_) std::fclose(file_);
  if (!committed_ && !in_place_) std::remove(temp_path_.c_str());
}

std::FILE* AtomicFile::stream() {
  if (!file_) {
    file_ = std::fopen(temp_path_.c_str(), "wb");
    if (!file_) throw Error(path_ + ": cannot write: " + ErrnoText());
  }
  return file_;
}

void AtomicFile::Write(const void* data, size_t size) {
  if (size == 0) {
    stream();
    return;
  }
  if (std::fwrite(data, 1, size, stream()) != size)
    throw Error(path_ + ": write failed: " + ErrnoText());
}

void AtomicFile::Commit() {
  if (file_) {
    // Devices and FIFOs cannot be synced (EINVAL); there is nothing to sync.
    const bool ok = std::fflush(file_) == 0 && (in_place_ || ::fsync(::fileno(file_)) == 0);
    const int sync_errno = errno;
    const bool closed = std::fclose(file_) == 0;
    file_ = nullptr;
    if (!ok || !closed) {
      if (!ok) errno = sync_errno;
      throw Error(path_ + ": write failed: " + ErrnoText());
    }
  }
  if (!in_place_ && std::rename(temp_path_.c_str(), target_.c_str()) != 0)
    throw Error(path_ + ": cannot move the finished file into place: " + ErrnoText());
  committed_ = true;
}

void WriteFileAtomic(const std::string& path, const std::string& text) {
  AtomicFile f(path);
  f.Write(text);
  f.Commit();
}

InputFile::InputFile(const std::string& path) : path_(path) {
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) throw Error(path + ": cannot open: " + ErrnoText());
  struct stat st;
  if (::fstat(fd_, &st) != 0) {
    const std::string why = ErrnoText();
    ::close(fd_);
    throw Error(path + ": cannot open: " + why);
  }
  if (S_ISDIR(st.st_mode)) {
    ::close(fd_);
    throw Error(path + ": cannot read: it is a folder, not a file");
  }
  if (S_ISREG(st.st_mode)) size_ = static_cast<int64_t>(st.st_size);
}

InputFile::~InputFile() { ::close(fd_); }

size_t InputFile::Read(void* data, size_t n) {
  char* out = static_cast<char*>(data);
  size_t got = 0;
  while (got < n) {
    const ssize_t r = ::read(fd_, out + got, std::min(n - got, size_t{1} << 30));
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) throw Error(path_ + ": read failed: " + ErrnoText());
    if (r == 0) break;
    got += static_cast<size_t>(r);
  }
  return got;
}

std::string ReadFile(const std::string& path, size_t max_bytes) {
  InputFile in(path);
  const std::string limit = "the limit is " + ByteCount(max_bytes);
  if (in.size() > static_cast<int64_t>(max_bytes))
    throw Error(path + ": file too large (" + std::to_string(in.size()) + " bytes; " + limit + ")");
  std::string text;
  if (in.size() > 0) text.reserve(static_cast<size_t>(in.size()) + 1);
  // Read one byte past the limit (in chunks, however much a stream offers)
  // to tell a file of exactly max_bytes from a longer one.
  constexpr size_t kChunk = size_t{1} << 16;
  for (;;) {
    const size_t old = text.size();
    const size_t want = std::min(kChunk, max_bytes + 1 - old);
    text.resize(old + want);
    const size_t got = in.Read(&text[old], want);
    text.resize(old + got);
    if (text.size() > max_bytes)
      throw Error(path + ": more than " + ByteCount(max_bytes) +
                  " of data (the limit for this file; an endless stream?)");
    if (got < want) return text;
  }
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

void WriteFileOrStdout(const std::string& path, const std::string& text, const std::string& what) {
  if (path != "-") return WriteFileAtomic(path, text);
  if (std::fwrite(text.data(), 1, text.size(), stdout) != text.size() || std::fflush(stdout) != 0)
    throw Error(what + ": cannot write to standard output");
}

}  // namespace pano
