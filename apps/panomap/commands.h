// Subcommands of panomap. Each registers itself on the CLI11 app and runs one
// tested library function (lib/panotrack/mapping); main() catches pano::Error.
#pragma once

#include <CLI/CLI.hpp>

#include "subcommand_main.h"

namespace pano::app {

// check: the map against video of the room (lib/panotrack/mapping/check.h).
void AddCheckCommand(CLI::App& app);
// refine: bundle-adjust the map's rectangles against tracked video (lib/panotrack/mapping/refine.h).
void AddRefineCommand(CLI::App& app);
// build: grow a map with rectangles triangulated from video (lib/panotrack/mapping/build.h).
void AddBuildCommand(CLI::App& app);

}  // namespace pano::app
