// panomap: make and check the landmark map of a room.
#include <CLI/CLI.hpp>

#include <string>

#include "cli_help.h"
#include "commands.h"
#include "panotrack/config.h"
#include "subcommand_main.h"

int main(int argc, char** argv) {
  CLI::App app{
      "panomap: check a room's landmark map against video, refine it, and grow it from video.\n"
      "Subcommands: see 'panomap SUBCOMMAND --help'. Existing output files are kept unless\n"
      "--force is given; the input map is never overwritten.",
      "panomap"};
  const std::string exit_codes =
      "Exit status: 0 success; 1 bad options or files, an existing output without --force, or\n"
      "the work failed; 2 unexpected internal error.";
  app.footer(exit_codes);
  app.require_subcommand(1);
  app.set_version_flag("--version", "panomap " PANO_VERSION, "Print the version and exit");
  app.set_help_flag("-h,--help", "Print this help and exit");
  // Subcommands made from here on show every option's default.
  app.option_defaults()->always_capture_default();
  pano::app::AddCheckCommand(app);
  pano::app::AddRefineCommand(app);
  pano::app::AddBuildCommand(app);
  pano::app::SplitDescriptions(app, exit_codes);
  return pano::app::RunSubcommandApp(app, "panomap", argc, argv);
}
