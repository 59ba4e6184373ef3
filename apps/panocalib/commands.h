// Subcommands of panocalib. Each registers itself on the CLI11 app and runs
// one tested library function; main() catches pano::Error and prints it.
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include "panotrack/pipeline/target_input.h"
#include "subcommand_main.h"

namespace pano::app {

// project / backproject: check a calibration by hand.
void AddProjectCommands(CLI::App& app);
// lut: build the E(D,Z) lookup table of a calibration.
void AddLutCommand(CLI::App& app);
// calibrate: fit the sensor to chessboard images (lib/panotrack/calibrate).
void AddCalibrateCommand(CLI::App& app);
// evaluate: a fixed calibration's reprojection error on other images.
void AddEvaluateCommand(CLI::App& app);
// unwarp: a panorama or perspective view of a raw image (lib/panotrack/unwarp).
void AddUnwarpCommand(CLI::App& app);
// tilt: the sensor's tilt from a video in a mapped room (pipeline/sensor_tilt.h).
void AddTiltCommand(CLI::App& app);
// export: the calibration in OpenCV's terms (camera matrix, cv::omnidir model).
void AddExportCommand(CLI::App& app);

// The board of a folder or video input (calibrate, evaluate) from --board,
// --square, --marker, --dictionary, --units and --every; none when --board
// was not given. `square_units` says what --square is measured in, for its
// error.
TargetInputBoard BoardInputOf(const std::string& board, double square, double marker, const std::string& dictionary,
                              const std::string& units, int every, const std::string& square_units);

}  // namespace pano::app
