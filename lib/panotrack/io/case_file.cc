#include "panotrack/io/case_file.h"

#include "panotrack/io/yaml_util.h"

namespace pano {

std::optional<Pose2> ReadCaseInitialPose(const std::string& path) {
  const YAML::Node root = YamlReader::LoadFile(path);
  return GuardYaml(path, [&]() -> std::optional<Pose2> {
    const YamlReader r(path, root);
    if (!r.Has(root, "initial_pose")) return std::nullopt;
    const YAML::Node ip = r.Map(root, "initial_pose", "initial_pose", "a mapping with x, y, theta");
    return Pose2{r.Double(ip, "x", "initial_pose.x"), r.Double(ip, "y", "initial_pose.y"),
                 r.Double(ip, "theta", "initial_pose.theta")};
  });
}

}  // namespace pano
