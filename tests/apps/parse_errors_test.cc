// Command-line parse errors of the four programs: one line "tool: --flag:
// problem", the text typed quoted back, no CLI11 "Run with --help" line, no
// 300-digit range bound; an unknown subcommand named with the known ones.
#include <catch2/catch.hpp>

#include <string>

#include "run_command.h"

namespace pano {
namespace {

// The command exits 1 with exactly `line` (and a newline) on stderr.
void ExpectLine(const std::string& args, const std::string& line) {
  const test::CommandRun r = test::RunProgram(args);
  INFO(args);
  CHECK(r.code == 1);
  CHECK(r.out == line + "\n");
}

const std::string kLoc = "panoloc in.mp4 --calib c.yaml --map m.yaml ";
const std::string kRefine = "panomap refine in.mp4 --calib c.yaml --map m.yaml --poses p.csv -o o.yaml ";

TEST_CASE("list options: the count and form expected, and what was given", "[parse_errors]") {
  ExpectLine(kLoc + "--init 1,2", "panoloc: --init: expected 3 numbers x,y,theta, got 2");
  ExpectLine(kLoc + "--init 1,2,3,4", "panoloc: --init: expected 3 numbers x,y,theta, got 4");
  ExpectLine(kLoc + "--init a,b,c", "panoloc: --init: expected 3 numbers x,y,theta, got 'a,b,c'");
  ExpectLine("panocalib project --calib c.yaml --point 1,2", "panocalib: --point: expected 3 numbers x,y,z, got 2");
  ExpectLine("panocalib tilt --calib c.yaml --map m.yaml in.mp4 -o o.yaml --init 1",
             "panocalib: --init: expected 3 numbers x,y,theta, got 1");
  ExpectLine("panosim still --preset paper-real -o s.png --pose 1,2",
             "panosim: --pose: expected 3 numbers x,y,theta, got 2");
  ExpectLine("panomap check in.mp4 --calib c.yaml --map m.yaml --pose 1,2",
             "panomap: --pose: expected 3 numbers x,y,theta, got 2");
  ExpectLine("panomap build in.mp4 --calib c.yaml --map m.yaml -o o.yaml --start a,b,c",
             "panomap: --start: expected 3 numbers x,y,theta, got 'a,b,c'");
}

TEST_CASE("a list option before a positional argument takes one token", "[parse_errors]") {
  // The input after the list option stays the input: the run goes on to
  // the next problem, not to '--init: expected 3 numbers, got 4'.
  ExpectLine("panoloc --init 1,2,3 in.mp4 --calib c.yaml --map m.yaml",
             "panoloc: -o (output) or --out-dir (out_dir): give -o OUT.csv (one input) or --out-dir DIR");
  ExpectLine("panomap build --start 1,2,3 in.mp4 --calib c.yaml --map m.yaml -o o.yaml",
             "panomap: c.yaml: cannot open: No such file or directory");
}

TEST_CASE("values that do not convert, missing values, unknown options", "[parse_errors]") {
  ExpectLine(kLoc + "--fps abc", "panoloc: --fps: expected a number, got 'abc'");
  ExpectLine(kLoc + "--threads 99999999999999999999", "panoloc: --threads: 99999999999999999999 is out of range");
  ExpectLine(kLoc + "--scale", "panoloc: --scale: expected a number, got none");
  ExpectLine(kLoc + "--bogus", "panoloc: --bogus: unknown option (see panoloc --help)");
  ExpectLine(kRefine + "--bogus", "panomap: --bogus: unknown option (see panomap refine --help)");
  ExpectLine("panomap check --map m.yaml --calib c.yaml in.mp4 stray1 stray2",
             "panomap: unexpected arguments 'stray1 stray2' (see panomap check --help)");
  ExpectLine("panomap check --calib c.yaml in.mp4", "panomap: --map: required");
}

TEST_CASE("range errors: readable bounds and the value typed", "[parse_errors]") {
  ExpectLine(kRefine + "--edge-gap -1e300", "panomap: --edge-gap: expected 0 or more, got -1e300");
  ExpectLine(kRefine + "--map-sigma 0", "panomap: --map-sigma: expected a positive number, got 0");
  ExpectLine(kRefine + "--reject-sigmas 1e300", "panomap: --reject-sigmas: expected a value from 2.5 to 100, got 1e300");
  ExpectLine(kLoc + "--alert-fraction 2", "panoloc: --alert-fraction: expected a value from 0 to 1, got 2");
  ExpectLine(kLoc + "--max-speed 0", "panoloc: --max-speed: expected a positive number, got 0");
}

TEST_CASE("an unknown option is named before a required one that is missing", "[parse_errors]") {
  ExpectLine("panoloc --bogus", "panoloc: --bogus: unknown option (see panoloc --help)");
  ExpectLine("panocalib --bogus", "panocalib: --bogus: unknown option (see panocalib --help)");
  ExpectLine("panocalib lut --bogus x --calib c.yaml", "panocalib: --bogus: unknown option (see panocalib lut --help)");
  ExpectLine("panosim targets --otput=x", "panosim: --otput: unknown option (see panosim targets --help)");
}

TEST_CASE("NaN and infinities are refused under the flag's name", "[parse_errors]") {
  // CLI11's range checks let NaN through.
  ExpectLine(kLoc + "--survey-sigma nan", "panoloc: --survey-sigma: expected a finite number, got 'nan'");
  ExpectLine(kLoc + "--alert-fraction nan", "panoloc: --alert-fraction: expected a finite number, got 'nan'");
  ExpectLine(kLoc + "--init 40,35,inf", "panoloc: --init: expected a finite number, got 'inf'");
  ExpectLine("panocalib unwarp in.png --calib c.yaml -o u.png --elevation nan,10",
             "panocalib: --elevation: expected a finite number, got 'nan'");
  ExpectLine("panomap check in.mp4 --map m.yaml --calib c.yaml --bias-floor nan",
             "panomap: --bias-floor: expected a finite number, got 'nan'");
  ExpectLine("panosim still --preset paper-real -o s.png --noise 1e999",
             "panosim: --noise: expected a finite number, got '1e999'");
}

TEST_CASE("a subcommand missing or unknown is named with the known ones", "[parse_errors]") {
  ExpectLine("panomap frob", "panomap: unknown subcommand 'frob' (one of: check, refine, build)");
  ExpectLine("panomap", "panomap: a subcommand is required (one of: check, refine, build)");
  ExpectLine("panocalib calibate t.yaml -o c.yaml",
             "panocalib: unknown subcommand 'calibate' (one of: project, backproject, lut, calibrate, evaluate, "
             "tilt, export, unwarp)");
  ExpectLine("panosim render", "panosim: unknown subcommand 'render' (one of: still, sequence, targets, presets)");
}

TEST_CASE("help and version still print as before and exit 0", "[parse_errors]") {
  test::CommandRun r = test::RunProgram("panoloc --version");
  CHECK(r.code == 0);
  CHECK(r.out.rfind("panoloc ", 0) == 0);
  r = test::RunProgram("panomap refine --help");
  CHECK(r.code == 0);
  CHECK(r.out.find("--edge-gap") != std::string::npos);
}

}  // namespace
}  // namespace pano
