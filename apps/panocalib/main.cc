// panocalib: calibrate a catadioptric sensor and check calibrations.
#include <CLI/CLI.hpp>

#include <string>
#include <vector>

#include "cli_help.h"
#include "commands.h"
#include "panotrack/config.h"
#include "subcommand_main.h"

int main(int argc, char** argv) {
  CLI::App app{
      "panocalib: fit a catadioptric sensor (camera + mirror) and check calibrations.\n"
      "Subcommands: see 'panocalib SUBCOMMAND --help'. Existing output files are kept unless\n"
      "--force is given.",
      "panocalib"};
  const std::string exit_codes =
      "Exit status: 0 success; 1 bad options or files, an existing output without --force, or\n"
      "the calibration failed; 2 unexpected internal error.";
  app.footer(exit_codes);
  app.require_subcommand(1);
  app.set_version_flag("--version", "panocalib " PANO_VERSION, "Print the version and exit");
  app.set_help_flag("-h,--help", "Print this help and exit");
  // Subcommands made from here on show every option's default.
  app.option_defaults()->always_capture_default();
  pano::app::AddProjectCommands(app);
  pano::app::AddLutCommand(app);
  pano::app::AddCalibrateCommand(app);
  pano::app::AddEvaluateCommand(app);
  pano::app::AddTiltCommand(app);
  pano::app::AddExportCommand(app);
  pano::app::AddUnwarpCommand(app);
  pano::app::SplitDescriptions(app, exit_codes);
  return pano::app::RunSubcommandApp(app, "panocalib", argc, argv);
}
