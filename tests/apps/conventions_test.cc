// What the three programs share: "--version" as "tool X.Y.Z", the exit codes
// in every --help, the same names for the same options, and existing output
// files kept unless --force.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "panotrack/config.h"
#include "run_command.h"
#include "test_paths.h"

namespace pano {
namespace {

using Run = test::CommandRun;
Run Exec(const std::string& args) { return test::RunProgram(args); }

bool Contains(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

std::string ReadText(const std::string& path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

TEST_CASE("--version, --help with exit codes and the shared options, --force for existing outputs",
          "[conventions]") {
  for (const std::string tool : {"panoloc", "panocalib", "panosim", "panomap"}) {
    INFO(tool);
    Run r = Exec(tool + " --version");
    CHECK(r.code == 0);
    CHECK(r.out == tool + " " + PANO_VERSION + "\n");
    r = Exec(tool + " --help");
    CHECK(r.code == 0);
    CHECK(Contains(r.out, "Exit status: 0 success"));
    CHECK(Contains(r.out, "2 unexpected"));
  }
  Run r = Exec("panoloc --help");
  for (const char* option : {"-o,--output", "--force", "--summary-json", "-j,--jobs", "-q,--quiet", "-v,--verbose",
                             "130/143"})
    CHECK(Contains(r.out, option));
  CHECK(Contains(r.out, "junction"));  // defaults shown
  // Every subcommand: the exit codes, and the shared options where they apply.
  const std::vector<std::pair<std::string, std::vector<std::string>>> subcommands = {
      {"panocalib calibrate", {"-o,--output", "--force", "--summary-json", "-j,--jobs,--threads", "-q,--quiet",
                               "-v,--verbose"}},
      {"panocalib lut", {"-o,--output", "--force", "-q,--quiet"}},
      {"panocalib project", {"-q,--quiet"}},
      {"panosim still", {"-o,--output", "--force", "-j,--jobs", "-q,--quiet", "-v,--verbose"}},
      {"panosim sequence", {"-o,--output", "--force", "-j,--jobs", "-q,--quiet", "-v,--verbose"}},
      {"panosim targets", {"-o,--output", "--force", "-j,--jobs", "-q,--quiet", "-v,--verbose"}},
      {"panomap check", {"-o,--output", "--force", "-q,--quiet", "-v,--verbose"}},
      {"panomap refine", {"-o,--output", "--force", "-q,--quiet", "-v,--verbose"}},
      {"panomap build", {"-o,--output", "--force", "-q,--quiet", "-v,--verbose"}},
      {"panocalib tilt", {"-o,--output", "--force", "-q,--quiet"}}};
  for (const auto& [command, options] : subcommands) {
    INFO(command);
    r = Exec(command + " --help");
    CHECK(r.code == 0);
    CHECK(Contains(r.out, "Exit status: 0 success"));
    for (const std::string& option : options) CHECK(Contains(r.out, option));
  }
  // A bad option: exit 1.
  CHECK(Exec("panosim still --no-such-option").code == 1);
  CHECK(Exec("panocalib lut --no-such-option").code == 1);

  // Existing outputs: one line naming the file, exit 1, the file kept; --force replaces it.
  const std::string dir = test::ScratchDir("apps_conventions");
  const std::string calib = test::SourcePath("calib/paper-real.yaml");
  std::ofstream(dir + "/t.lut") << "keep\n";
  r = Exec("panocalib lut --calib " + calib + " --size 16 -o " + dir + "/t.lut");
  CHECK(r.code == 1);
  CHECK(r.out == "panocalib: " + dir + "/t.lut exists (use --force to replace it)\n");
  CHECK(ReadText(dir + "/t.lut") == "keep\n");
  r = Exec("panocalib lut --calib " + calib + " --size 16 -o " + dir + "/t.lut --force -q");
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK(r.out.empty());
  CHECK(ReadText(dir + "/t.lut") != "keep\n");

  std::ofstream(dir + "/still.png") << "keep\n";
  const std::string still = "panosim still --preset paper-synthetic --supersample 1 -j 2 -o " + dir + "/still.png";
  r = Exec(still);
  CHECK(r.code == 1);
  CHECK(r.out == "panosim: " + dir + "/still.png exists (use --force to replace it)\n");
  CHECK(ReadText(dir + "/still.png") == "keep\n");
  r = Exec(still + " --force -v");
  INFO(r.out);
  CHECK(r.code == 0);
  CHECK(Contains(r.out, "panosim: rendered in "));
  CHECK(std::filesystem::file_size(dir + "/still.png") > 1000);
}

}  // namespace
}  // namespace pano
