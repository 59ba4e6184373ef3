// Pose CSV (spec section 5): written by panoloc row by row, also the format
// of ground truth.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include "sensor/sensor.h"

namespace pano {

enum class PoseStatus { kOk, kLost, kInit };
const char* pose_status_name(PoseStatus s);

struct PoseRow {
  int frame = 0;
  double time_s = 0.0;
  PoseStatus status = PoseStatus::kOk;
  Pose2 pose;  // meaningless when status is kLost
  int n_landmarks = 0;
  double residual = 0.0;
  std::vector<std::string> extra;  // trailing columns, as text
};

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
