#include <catch2/catch.hpp>

#include "panotrack/core/command_line.h"

namespace pano {
namespace {

TEST_CASE("plain arguments stay as they are, others are single-quoted", "[command_line]") {
  CHECK(ShellQuote("calib/paper-real.yaml") == "calib/paper-real.yaml");
  CHECK(ShellQuote("--init=1,2,0.5") == "--init=1,2,0.5");
  CHECK(ShellQuote("") == "''");
  CHECK(ShellQuote("my board.png") == "'my board.png'");
  CHECK(ShellQuote("it's") == "'it'\\''s'");
  CHECK(ShellQuote("$HOME") == "'$HOME'");
  CHECK(ShellCommandLine({"panocalib", "calibrate", "a b.yaml", "-o", "c.yaml"}) ==
        "panocalib calibrate 'a b.yaml' -o c.yaml");
}

}  // namespace
}  // namespace pano
