// main() of the programs made of subcommands (panocalib, panomap): logging set
// up once after parsing, and one error policy (one line on stderr, exit 1 for
// bad input, 2 for an internal error).
#pragma once

#include <CLI/CLI.hpp>
#include <glog/logging.h>

#include <opencv2/core/utils/logger.hpp>

#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "cli_errors.h"
#include "panotrack/core/error.h"

namespace pano::app {

// The program's arguments (set by main), recorded in --summary-json files.
inline std::vector<std::string>& CommandLine() {
  static std::vector<std::string> args;
  return args;
}

// Whether the subcommand being run was given --verbose.
inline bool VerboseRequested(const CLI::App& app) {
  for (const CLI::App* sub : app.get_subcommands()) {
    const CLI::Option* verbose = sub->get_option_no_throw("--verbose");
    if (verbose && verbose->count() > 0) return true;
  }
  return false;
}

// The libraries' logs (Ceres through glog, OpenCV) on stderr, errors only
// unless --verbose. Set once, before any command runs (and any thread starts).
inline void SetUpLogging(const char* argv0, bool verbose) {
  FLAGS_logtostderr = true;
  FLAGS_minloglevel = verbose ? google::GLOG_INFO : google::GLOG_ERROR;
  google::InitGoogleLogging(argv0);
  cv::utils::logging::setLogLevel(verbose ? cv::utils::logging::LOG_LEVEL_WARNING
                                          : cv::utils::logging::LOG_LEVEL_ERROR);
}

// An exception's message on one line (OpenCV's span several).
inline std::string OneLine(const char* what) {
  std::string s = what;
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

// Parses and runs the chosen subcommand of `app` (named `tool` in messages).
inline int RunSubcommandApp(CLI::App& app, const char* tool, int argc, char** argv) {
  CommandLine().assign(argv, argv + argc);
  // Runs after the arguments are parsed and before the subcommand's callback.
  app.parse_complete_callback([&app, argv]() {
    RefuseNonFiniteNumbers(app);
    SetUpLogging(argv[0], VerboseRequested(app));
  });
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return ExitOnParseError(app, e, tool);
  } catch (const pano::Error& e) {
    std::fprintf(stderr, "%s: %s\n", tool, OneLine(e.what()).c_str());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: unexpected error: %s\n", tool, OneLine(e.what()).c_str());
    return 2;
  }
  return 0;
}

}  // namespace pano::app
