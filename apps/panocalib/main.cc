// panocalib: calibrate a catadioptric sensor and check calibrations.
#include <CLI/CLI.hpp>
#include <glog/logging.h>

#include <opencv2/core/utils/logger.hpp>

#include <cstdio>
#include <exception>
#include <sstream>
#include <string>
#include <vector>

#include "commands.h"
#include "panotrack/core/error.h"
#include "cli_help.h"
#include "panotrack/config.h"

namespace {


// Whether the subcommand being run was given --verbose.
bool VerboseRequested(const CLI::App& app) {
  for (const CLI::App* sub : app.get_subcommands()) {
    const CLI::Option* verbose = sub->get_option_no_throw("--verbose");
    if (verbose && verbose->count() > 0) return true;
  }
  return false;
}

// The libraries' logs (Ceres through glog, OpenCV) on stderr, errors only
// unless --verbose. Set once, before any command runs (and any thread starts).
void SetUpLogging(const char* argv0, bool verbose) {
  FLAGS_logtostderr = true;
  FLAGS_minloglevel = verbose ? google::GLOG_INFO : google::GLOG_ERROR;
  google::InitGoogleLogging(argv0);
  cv::utils::logging::setLogLevel(verbose ? cv::utils::logging::LOG_LEVEL_WARNING
                                          : cv::utils::logging::LOG_LEVEL_ERROR);
}

// An exception's message on one line (OpenCV's span several).
std::string OneLine(const char* what) {
  std::string s = what;
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

}  // namespace

namespace pano::app {
std::vector<std::string>& CommandLine() {
  static std::vector<std::string> args;
  return args;
}
}  // namespace pano::app

int main(int argc, char** argv) {
  pano::app::CommandLine().assign(argv, argv + argc);
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
  pano::app::AddExportCommand(app);
  pano::app::AddUnwarpCommand(app);
  pano::app::SplitDescriptions(app, exit_codes);
  // Runs after the arguments are parsed and before the subcommand's callback.
  app.parse_complete_callback([&app, argv]() { SetUpLogging(argv[0], VerboseRequested(app)); });
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 1;  // --help, --version; bad options exit 1 like bad files
  } catch (const pano::Error& e) {
    std::fprintf(stderr, "panocalib: %s\n", OneLine(e.what()).c_str());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "panocalib: unexpected error: %s\n", OneLine(e.what()).c_str());
    return 2;
  }
  return 0;
}
