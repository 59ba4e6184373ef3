// Pose CSV (spec section 5): PoseRow as text, written by panoloc row by row,
// also the format of ground truth.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include "pose/pose_row.h"

namespace pano {

// Reads a pose CSV; checks the header, the column count, the numbers and the
// statuses, and names the file and line in errors.
std::vector<PoseRow> ReadPoseCsv(const std::string& path);

// Writes rows as they come and flushes each one, so that a crash loses
// nothing already computed. `extra_columns` are appended to the header.
class PoseCsvWriter {
 public:
  PoseCsvWriter(const std::string& path, const std::vector<std::string>& extra_columns = {});
  ~PoseCsvWriter();
  PoseCsvWriter(const PoseCsvWriter&) = delete;
  PoseCsvWriter& operator=(const PoseCsvWriter&) = delete;
  void Write(const PoseRow& row);
  void Close();
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
  size_t n_extra_ = 0;
};

std::string FormatPoseRow(const PoseRow& row);
extern const char* const kPoseCsvHeader;

}  // namespace pano
