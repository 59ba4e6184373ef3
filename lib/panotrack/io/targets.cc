#include "panotrack/io/targets.h"

#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"
#include "panotrack/io/yaml_util.h"

namespace pano {

bool TargetSet::AllPosesKnown() const {
  if (images.empty()) return false;
  for (const TargetImage& i : images)
    if (!i.has_pose) return false;
  return true;
}

namespace {

TargetSet ParseTargets(const std::string& path, const YAML::Node& n) {
  YamlReader r(path, n);
  TargetSet t;
  t.units = r.String(n, "units", "units", "cm");
  if (!r.Has(n, "board")) r.Fail("board", "missing (expected a mapping with type, cols, rows, square)");
  const YAML::Node b = r.Map(n, "board", "board", "a mapping with type, cols, rows, square");
  t.board.type = r.String(b, "type", "board.type", "chessboard");
  if (t.board.type != "chessboard")
    r.Fail("board.type", "unknown board type '" + t.board.type + "' (expected chessboard)");
  t.board.cols = r.Int(b, "cols", "board.cols");
  t.board.rows = r.Int(b, "rows", "board.rows");
  t.board.square = r.Double(b, "square", "board.square");
  if (t.board.cols < 2 || t.board.rows < 2)
    r.Fail("board", "expected at least 2 x 2 inner corners");
  if (t.board.cols > kMaxBoardCorners || t.board.rows > kMaxBoardCorners)
    r.Fail("board", "expected at most " + std::to_string(kMaxBoardCorners) +
                        " inner corners along a side, got " + std::to_string(t.board.cols) + " x " +
                        std::to_string(t.board.rows));
  if (!(t.board.square > 0.0)) r.Fail("board.square", "expected a positive square size");
  if (!r.Has(n, "images")) r.Fail("images", "missing or empty (expected a list of {file, rvec?, tvec?})");
  const YAML::Node list = r.List(n, "images", "images", "a list of {file, rvec?, tvec?}");
  if (list.size() == 0) r.Fail("images", "missing or empty (expected a list of {file, rvec?, tvec?})");
  const std::string dir = DirName(path);
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string p = "images[" + std::to_string(i) + "]";
    const YAML::Node im_node = list[i];
    if (!im_node.IsMap())
      r.Fail(p, "expected a mapping with file, rvec?, tvec?, got " + DescribeNode(im_node));
    TargetImage im;
    im.file = r.String(im_node, "file", p + ".file");
    im.resolved = JoinPath(dir, im.file);
    const bool has_r = r.Has(im_node, "rvec"), has_t = r.Has(im_node, "tvec");
    if (has_r != has_t) r.Fail(p, "give both rvec and tvec, or neither");
    if (has_r) {
      im.has_pose = true;
      im.rvec = r.Vector<3>(im_node, "rvec", p + ".rvec");
      im.tvec = r.Vector<3>(im_node, "tvec", p + ".tvec");
    }
    t.images.push_back(im);
  }
  return t;
}

}  // namespace

TargetSet ReadTargets(const std::string& path) {
  const YAML::Node root = YamlReader::LoadFile(path);
  return GuardYaml(path, [&] { return ParseTargets(path, root); });
}

std::string TargetsToYaml(const TargetSet& t, bool with_poses) {
  YamlWriter w;
  w.BeginMap();
  w.Key("units").String(t.units);
  w.Key("board").BeginMap();
  w.Key("type").String(t.board.type);
  w.Key("cols").Int(t.board.cols);
  w.Key("rows").Int(t.board.rows);
  w.Key("square").Double(t.board.square);
  w.EndMap();
  w.Key("images").BeginList();
  for (const TargetImage& im : t.images) {
    w.BeginMap();
    w.Key("file").String(im.file);
    if (with_poses && im.has_pose) {
      w.Key("rvec").Numbers({im.rvec[0], im.rvec[1], im.rvec[2]});
      w.Key("tvec").Numbers({im.tvec[0], im.tvec[1], im.tvec[2]});
    }
    w.EndMap();
  }
  w.EndList();
  w.EndMap();
  return w.Text();
}

void WriteTargets(const std::string& path, const TargetSet& t, bool with_poses) {
  WriteFileAtomic(path, TargetsToYaml(t, with_poses));
}

}  // namespace pano
