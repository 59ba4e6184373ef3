// panoloc's trajectory plot.
#pragma once

#include <string>
#include <vector>

#include "panotrack/pose/pose_row.h"
#include "panotrack/scene/map.h"

namespace pano {

// The map from above with the estimated trajectory (blue) and the ground
// truth (green, may be empty), written atomically as PNG.
void WritePlot(const std::string& path, const Map& map, const std::vector<PoseRow>& estimate,
               const std::vector<PoseRow>& truth);

}  // namespace pano
