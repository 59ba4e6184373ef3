// The case.yaml that panosim writes beside a rendered sequence: panoloc takes
// its initial_pose when no --init is given.
#pragma once

#include <optional>
#include <string>

#include "panotrack/pose/pose2.h"
#include "panotrack/sensor/sensor.h"

namespace pano {

// initial_pose {x, y, theta} of a case file, or nullopt when it has none.
// Throws pano::Error naming the file for unreadable or malformed YAML.
std::optional<Pose2> ReadCaseInitialPose(const std::string& path);

}  // namespace pano
