// TUM trajectory files (the TUM RGB-D benchmark's format, which evo and most
// SLAM evaluation tools read): one line per pose, "t x y z qx qy qz qw",
// space separated, positions in metres, the orientation a unit quaternion.
// panoloc's planar pose becomes x, y scaled to metres, a constant z (the
// sensor's height) and the yaw theta about z.
#pragma once

#include <string>
#include <vector>

#include "panotrack/io/pose_csv.h"
#include "panotrack/pose/pose_row.h"
#include "panotrack/scene/map.h"

namespace pano {

// How map units and the sensor's height become TUM's metres.
struct TumConversion {
  double metres_per_unit = 1.0;  // x, y are multiplied by this
  double z_metres = 0.0;         // every line's z
  // Throws pano::Error naming the field when a value is not finite or the
  // scale not positive.
  void Check() const;
};

// The map's units to metres (`metres_per_unit` > 0 overrides them; 0: from
// Map::UnitsPerMetre), z the map's sensor height in metres.
TumConversion TumConversionForMap(const Map& map, double metres_per_unit = 0.0);

// One line (no newline) for an ok row: t with 6 decimals like the pose CSV,
// metres and quaternion with 9 (a nanometre: evo's statistics match the
// pose CSV's full-precision ones to far better than 1e-6). Throws
// pano::Error for rows that are not ok.
std::string FormatTumLine(const PoseRow& row, const TumConversion& conversion);

// Writes the ok rows as they come (lost and init rows have no pose to
// report and are skipped) and flushes each line, like PoseCsvWriter, whose
// staging it shares: with kPartial the lines go to `<path>.partial`, renamed
// to `<path>` by Close(), so that a run that fails or is killed never leaves
// a file passed off as whole. Errors name the file.
class TumWriter {
 public:
  TumWriter(const std::string& path, const TumConversion& conversion,
            PoseCsvStaging staging = PoseCsvStaging::kDirect);
  // Writes the row when it is ok; returns whether it did.
  bool Write(const PoseRow& row);
  // Flushes and closes; a staged file is renamed into place.
  void Close() { out_.Close(); }
  const std::string& path() const { return out_.path(); }
  const std::string& written_path() const { return out_.written_path(); }

 private:
  TumConversion conversion_;  // checked before the file is opened
  StagedLineWriter out_;
};

// The ok rows of `rows` as a TUM file, written atomically (core/atomic_file.h:
// a failure leaves no file, and an older one as it was).
void WriteTumTrajectory(const std::string& path, const std::vector<PoseRow>& rows,
                        const TumConversion& conversion);

}  // namespace pano
