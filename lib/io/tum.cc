#include "io/tum.h"

#include <cerrno>
#include <cmath>
#include <cstring>

#include "core/angles.h"
#include "core/atomic_file.h"
#include "core/error.h"

namespace pano {

void TumConversion::Check() const {
  if (!(metres_per_unit > 0) || !std::isfinite(metres_per_unit))
    throw Error("metres_per_unit: expected a positive number");
  if (!std::isfinite(z_metres)) throw Error("z_metres: expected a finite number");
}

TumConversion TumConversionForMap(const Map& map, double metres_per_unit) {
  TumConversion c;
  c.metres_per_unit = metres_per_unit > 0 ? metres_per_unit : 1.0 / map.UnitsPerMetre();
  c.z_metres = map.sensor_height * c.metres_per_unit;
  return c;
}

std::string FormatTumLine(const PoseRow& row, const TumConversion& c) {
  if (row.status != PoseStatus::kOk)
    throw Error("TUM line of frame " + std::to_string(row.frame) + ": only ok rows have a pose to write, not " +
                pose_status_name(row.status));
  // The yaw about z as a quaternion: half the angle, qw >= 0 for theta in (-pi, pi].
  const double half = 0.5 * wrap_angle(row.pose.theta);
  char buf[256];
  std::snprintf(buf, sizeof buf, "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f", row.time_s,
                row.pose.x * c.metres_per_unit, row.pose.y * c.metres_per_unit, c.z_metres, 0.0, 0.0,
                std::sin(half), std::cos(half));
  return buf;
}

TumWriter::TumWriter(const std::string& path, const TumConversion& conversion, PoseCsvStaging staging)
    : path_(path), conversion_(conversion) {
  try {
    conversion_.Check();
  } catch (const Error& e) {
    throw Error(path + ": " + e.what());
  }
  const bool staged = staging == PoseCsvStaging::kPartial && !PoseCsvWriter::WritesDirectly(path);
  written_path_ = staged ? path + kPartialSuffix : path;
  file_ = std::fopen(written_path_.c_str(), "w");
  if (!file_) throw Error(written_path_ + ": cannot write: " + std::strerror(errno));
}

TumWriter::~TumWriter() {
  if (file_) std::fclose(file_);
}

bool TumWriter::Write(const PoseRow& row) {
  if (!file_) throw Error(path_ + ": write after close");
  if (row.status != PoseStatus::kOk) return false;
  const std::string line = FormatTumLine(row, conversion_);
  if (std::fprintf(file_, "%s\n", line.c_str()) < 0 || std::fflush(file_) != 0)
    throw Error(written_path_ + ": write failed: " + std::strerror(errno));
  return true;
}

void TumWriter::Close() {
  if (!file_) return;
  std::FILE* f = file_;
  file_ = nullptr;
  if (std::fclose(f) != 0) throw Error(written_path_ + ": close failed: " + std::strerror(errno));
  if (written_path_ != path_ && std::rename(written_path_.c_str(), path_.c_str()) != 0)
    throw Error(path_ + ": cannot move " + written_path_ + " into place: " + std::strerror(errno));
}

void WriteTumTrajectory(const std::string& path, const std::vector<PoseRow>& rows,
                        const TumConversion& conversion) {
  conversion.Check();
  std::string text;
  for (const PoseRow& r : rows)
    if (r.status == PoseStatus::kOk) text += FormatTumLine(r, conversion) + "\n";
  WriteFileAtomic(path, text);
}

}  // namespace pano
