// Output files that never appear half-written: data goes to a temporary file
// beside the target, which is renamed into place only by Commit(). A writer
// destroyed without Commit() (an error, an exception) removes the temporary.
// Targets that are not regular files (devices such as /dev/null, FIFOs,
// sockets) are written in place: renaming over them would replace them. A
// symbolic link stays a link: the file it points to is replaced.
//
// Input files are read with a bound, so that a folder, a device or an endless
// stream (/dev/zero, a FIFO) given as a file fails with a message instead of
// filling the memory.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

namespace pano {

class AtomicFile {
 public:
  explicit AtomicFile(const std::string& path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  // Path to write, for libraries that write by name (OpenCV): a temporary
  // file, or the target itself when it is written in place.
  const std::string& temp_path() const { return temp_path_; }
  const std::string& path() const { return path_; }
  // True when the target is a device, FIFO or socket, written directly.
  bool in_place() const { return in_place_; }
  // Stream on the temporary file (opened on first use).
  std::FILE* stream();
  void Write(const void* data, size_t size);
  void Write(const std::string& text) { Write(text.data(), text.size()); }
  // Flushes, closes and renames into place. Throws pano::Error on failure.
  void Commit();

 private:
  std::string path_;
  std::string target_;  // the file replaced: path_, or where a symbolic link leads
  std::string temp_path_;
  bool in_place_ = false;
  std::FILE* file_ = nullptr;
  bool committed_ = false;
};

// Writes `text` to `path` atomically.
void WriteFileAtomic(const std::string& path, const std::string& text);
// WriteFileAtomic, or standard output when `path` is "-" (flushed; a failure
// throws pano::Error naming `what`, the option that asked for it).
void WriteFileOrStdout(const std::string& path, const std::string& text, const std::string& what);

// A file opened for reading: a folder is refused with a message naming it,
// and reads stop where the caller says, whatever the file is.
class InputFile {
 public:
  explicit InputFile(const std::string& path);
  ~InputFile();
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;

  const std::string& path() const { return path_; }
  // Size of a regular file in bytes; -1 for a device, FIFO or socket.
  int64_t size() const { return size_; }
  // Reads up to `n` bytes; fewer only at the end of the file.
  size_t Read(void* data, size_t n);

 private:
  std::string path_;
  int fd_ = -1;
  int64_t size_ = -1;
};

constexpr size_t kMaxReadFileBytes = size_t{64} << 20;
// Reads a whole file of at most `max_bytes` bytes; throws pano::Error naming
// it when it cannot be read, is a folder or is larger (an endless stream).
std::string ReadFile(const std::string& path, size_t max_bytes = kMaxReadFileBytes);
// Directory part of a path ("." when none), and a path joined to a base dir
// unless it is absolute.
std::string DirName(const std::string& path);
std::string JoinPath(const std::string& dir, const std::string& path);

}  // namespace pano
