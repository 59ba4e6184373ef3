#include "io/targets.h"

#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "io/yaml_util.h"

namespace pano {

bool TargetSet::AllPosesKnown() const {
  if (images.empty()) return false;
  for (const TargetImage& i : images)
    if (!i.has_pose) return false;
  return true;
}

TargetSet ReadTargets(const std::string& path) {
  YamlReader r(path, YamlReader::LoadFile(path));
  const YAML::Node& n = r.root();
  TargetSet t;
  t.units = r.String(n, "units", "units", "cm");
  if (!r.Has(n, "board") || !n["board"].IsMap())
    r.Fail("board", "missing (expected a mapping with type, cols, rows, square)");
  const YAML::Node b = n["board"];
  t.board.type = r.String(b, "type", "board.type", "chessboard");
  if (t.board.type != "chessboard")
    r.Fail("board.type", "unknown board type '" + t.board.type + "' (expected chessboard)");
  t.board.cols = r.Int(b, "cols", "board.cols");
  t.board.rows = r.Int(b, "rows", "board.rows");
  t.board.square = r.Double(b, "square", "board.square");
  if (t.board.cols < 2 || t.board.rows < 2)
    r.Fail("board", "expected at least 2 x 2 inner corners");
  if (!(t.board.square > 0.0)) r.Fail("board.square", "expected a positive square size");
  if (!r.Has(n, "images") || !n["images"].IsSequence() || n["images"].size() == 0)
    r.Fail("images", "missing or empty (expected a list of {file, rvec?, tvec?})");
  const YAML::Node list = n["images"];
  const std::string dir = DirName(path);
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string p = "images[" + std::to_string(i) + "]";
    if (!list[i].IsMap()) r.Fail(p, "expected a mapping with file, rvec?, tvec?");
    TargetImage im;
    im.file = r.String(list[i], "file", p + ".file");
    im.resolved = JoinPath(dir, im.file);
    const bool has_r = r.Has(list[i], "rvec"), has_t = r.Has(list[i], "tvec");
    if (has_r != has_t) r.Fail(p, "give both rvec and tvec, or neither");
    if (has_r) {
      im.has_pose = true;
      im.rvec = r.Vector<3>(list[i], "rvec", p + ".rvec");
      im.tvec = r.Vector<3>(list[i], "tvec", p + ".tvec");
    }
    t.images.push_back(im);
  }
  return t;
}

void WriteTargets(const std::string& path, const TargetSet& t, bool with_poses) {
  std::ostringstream o;
  o << "units: " << t.units << "\nboard:\n  type: " << t.board.type << "\n  cols: " << t.board.cols
    << "\n  rows: " << t.board.rows << "\n  square: " << YamlDouble(t.board.square) << "\nimages:\n";
  auto v3 = [](const std::array<double, 3>& v) {
    return "[" + YamlDouble(v[0]) + ", " + YamlDouble(v[1]) + ", " + YamlDouble(v[2]) + "]";
  };
  for (const TargetImage& im : t.images) {
    o << "  - file: " << im.file << "\n";
    if (with_poses && im.has_pose)
      o << "    rvec: " << v3(im.rvec) << "\n    tvec: " << v3(im.tvec) << "\n";
  }
  WriteFileAtomic(path, o.str());
}

}  // namespace pano
