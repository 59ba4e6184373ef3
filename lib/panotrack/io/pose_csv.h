// Pose CSV (docs/panoloc.md): PoseRow as text, written by panoloc row by row,
// also the format of ground truth.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include "panotrack/pose/pose_row.h"

namespace pano {

// Reads a pose CSV; checks the header, the column count, the numbers and the
// statuses, and names the file and line in errors.
std::vector<PoseRow> ReadPoseCsv(const std::string& path);

// Where a pose CSV's rows go while it is written.
enum class PoseCsvStaging {
  kDirect,  // into the file itself
  // Into `<path>.partial`, which Close() renames to `<path>`. A writer
  // destroyed without Close() (a failure, a killed process) leaves
  // `<path>.partial`: the name says the rows stop early, and an older
  // `<path>` is left as it was. Special files are written directly anyway.
  kPartial,
};

// Text lines written as they come, each flushed, so that a crash loses
// nothing already computed; with kPartial into `<path>.partial`, renamed to
// `<path>` by Close(). "-" writes to standard output. Special files (devices
// such as /dev/null, FIFOs, anything under /dev/ or /proc/) are always
// written directly. Errors name the file.
class StagedLineWriter {
 public:
  StagedLineWriter(const std::string& path, PoseCsvStaging staging);
  ~StagedLineWriter();
  StagedLineWriter(const StagedLineWriter&) = delete;
  StagedLineWriter& operator=(const StagedLineWriter&) = delete;
  void WriteLine(const std::string& line);
  // Flushes and closes; a staged file is renamed into place.
  void Close();
  bool is_open() const { return file_ != nullptr; }
  const std::string& path() const { return path_; }
  // Where the lines are written until Close(): `<path>.partial` when staged.
  const std::string& written_path() const { return written_path_; }

 private:
  std::string path_;
  std::string written_path_;
  std::FILE* file_ = nullptr;
  bool is_stdout_ = false;
};

// Writes pose rows as they come (StagedLineWriter). `extra_columns` are
// appended to the header.
class PoseCsvWriter {
 public:
  PoseCsvWriter(const std::string& path, const std::vector<std::string>& extra_columns = {},
                PoseCsvStaging staging = PoseCsvStaging::kDirect);
  void Write(const PoseRow& row);
  // Flushes and closes; a staged file is renamed into place.
  void Close() { out_.Close(); }
  const std::string& path() const { return out_.path(); }
  // Where the rows are written until Close(): `<path>.partial` when staged.
  const std::string& written_path() const { return out_.written_path(); }

  // True for "-" and special files, which are written directly.
  static bool WritesDirectly(const std::string& path);

 private:
  StagedLineWriter out_;
  size_t n_extra_ = 0;
};

// Suffix of a pose CSV while it is written.
extern const char* const kPartialSuffix;

std::string FormatPoseRow(const PoseRow& row);
extern const char* const kPoseCsvHeader;

}  // namespace pano
