// Output files that never appear half-written: data goes to a temporary file
// beside the target, which is renamed into place only by Commit(). A writer
// destroyed without Commit() (an error, an exception) removes the temporary.
#pragma once

#include <cstdio>
#include <string>

namespace pano {

class AtomicFile {
 public:
  explicit AtomicFile(const std::string& path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  // Path of the temporary file, for libraries that write by name (OpenCV).
  const std::string& temp_path() const { return temp_path_; }
  const std::string& path() const { return path_; }
  // Stream on the temporary file (opened on first use).
  std::FILE* stream();
  void Write(const void* data, size_t size);
  void Write(const std::string& text) { Write(text.data(), text.size()); }
  // Flushes, closes and renames into place. Throws pano::Error on failure.
  void Commit();

 private:
  std::string path_;
  std::string temp_path_;
  std::FILE* file_ = nullptr;
  bool committed_ = false;
};

// Writes `text` to `path` atomically.
void WriteFileAtomic(const std::string& path, const std::string& text);
// Reads a whole file; throws pano::Error naming it when it cannot be read.
std::string ReadFile(const std::string& path);
// Directory part of a path ("." when none), and a path joined to a base dir
// unless it is absolute.
std::string DirName(const std::string& path);
std::string JoinPath(const std::string& dir, const std::string& path);

}  // namespace pano
