// Map file (docs/maps.md): reads and writes scene/map.h's Map.
#pragma once

#include <string>

#include "panotrack/scene/map.h"

namespace pano {

// Reads and checks a map; throws pano::Error naming the file, key and problem.
Map ReadMap(const std::string& path);
// Writes it atomically; `with_distractors` false leaves the distractors out.
void WriteMap(const std::string& path, const Map& map, bool with_distractors = false);
std::string MapToYaml(const Map& map, bool with_distractors = false);

}  // namespace pano
