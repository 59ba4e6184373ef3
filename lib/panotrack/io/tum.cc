#include "panotrack/io/tum.h"

#include <cmath>

#include "panotrack/core/angles.h"
#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"

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
                PoseStatusName(row.status));
  // The yaw about z as a quaternion: half the angle, qw >= 0 for theta in (-pi, pi].
  const double half = 0.5 * WrapAngle(row.pose.theta);
  char buf[256];
  std::snprintf(buf, sizeof buf, "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f", row.time_s,
                row.pose.x * c.metres_per_unit, row.pose.y * c.metres_per_unit, c.z_metres, 0.0, 0.0,
                std::sin(half), std::cos(half));
  return buf;
}

namespace {

TumConversion Checked(const std::string& path, const TumConversion& conversion) {
  try {
    conversion.Check();
  } catch (const Error& e) {
    throw Error(path + ": " + e.what());
  }
  return conversion;
}

}  // namespace

TumWriter::TumWriter(const std::string& path, const TumConversion& conversion, PoseCsvStaging staging)
    : conversion_(Checked(path, conversion)), out_(path, staging) {}

bool TumWriter::Write(const PoseRow& row) {
  if (!out_.is_open()) throw Error(out_.path() + ": write after close");
  if (row.status != PoseStatus::kOk) return false;
  out_.WriteLine(FormatTumLine(row, conversion_));
  return true;
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
