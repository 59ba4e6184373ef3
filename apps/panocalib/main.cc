// panocalib: calibrate a catadioptric sensor and check calibrations.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>

#include "commands.h"
#include "core/error.h"
#include "pano/config.h"

int main(int argc, char** argv) {
  CLI::App app{
      "panocalib " PANO_VERSION
      ": fit a catadioptric sensor (camera + mirror) and check calibrations.\n"
      "Subcommands: see 'panocalib SUBCOMMAND --help'."};
  app.require_subcommand(1);
  app.set_version_flag("--version", PANO_VERSION);
  pano::app::AddProjectCommands(app);
  pano::app::AddLutCommand(app);
  pano::app::AddCalibrateCommand(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const pano::Error& e) {
    std::fprintf(stderr, "panocalib: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "panocalib: unexpected error: %s\n", e.what());
    return 2;
  }
  return 0;
}
