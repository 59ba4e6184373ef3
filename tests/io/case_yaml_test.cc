// panosim's case.yaml goes through the same YAML writer: a preset name or
// description with YAML's special characters reads back as written.
#include <catch2/catch.hpp>

#include <yaml-cpp/yaml.h>

#include "panotrack/render/presets.h"
#include "panotrack/render/writers.h"

namespace pano {
namespace {

TEST_CASE("case.yaml quotes names and descriptions, numbers stay plain", "[case_yaml]") {
  SequenceCase c;
  c.name = "custom: #1";
  c.description = "a \"quoted\" run - with: colons # and hashes\nover two lines";
  c.map.units = "yes";
  c.poses = {{100.5, -0.0, 0.785398}, {101.0, 0.0, 0.8}};
  c.fps = 12.5;
  c.options.seed = 18446744073709551615ULL;
  c.kidnap_frames = {1};
  const std::string text = CaseYaml(c, "mp4v");
  INFO(text);
  CHECK(text.rfind("# panosim test case", 0) == 0);
  const YAML::Node n = YAML::Load(text);
  CHECK(n["preset"].as<std::string>() == c.name);
  CHECK(n["description"].as<std::string>() == c.description);
  CHECK(n["units"].as<std::string>() == "yes");
  CHECK(n["frames"].as<int>() == 2);
  CHECK(n["fps"].as<double>() == 12.5);
  CHECK(n["fps"].Tag() == "?");
  CHECK(n["seed"].as<uint64_t>() == c.options.seed);
  CHECK(n["initial_pose"]["x"].as<double>() == 100.5);
  CHECK(n["initial_pose"]["theta"].as<double>() == 0.785398);
  CHECK(n["kidnap_frame"].as<int>() == 1);
  CHECK(n["video_codec"].as<std::string>() == "mp4v");
  CHECK(n["render"]["blur_3x3"].as<bool>() == c.options.blur);
  CHECK(n["render"]["supersample"].as<int>() == c.options.supersample);
}

}  // namespace
}  // namespace pano
