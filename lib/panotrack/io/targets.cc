#include "panotrack/io/targets.h"

#include "panotrack/core/atomic_file.h"
#include "panotrack/core/error.h"
#include "panotrack/io/yaml_util.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>

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
  if (t.board.type != "chessboard" && t.board.type != "charuco")
    r.Fail("board.type", "unknown board type '" + t.board.type + "' (expected chessboard or charuco)");
  t.board.cols = r.Int(b, "cols", "board.cols");
  t.board.rows = r.Int(b, "rows", "board.rows");
  t.board.square = r.Double(b, "square", "board.square");
  if (t.board.IsCharuco()) {
    if (!r.Has(b, "marker")) r.Fail("board.marker", "missing (a ChArUco board's marker side, below square)");
    t.board.marker = r.Double(b, "marker", "board.marker");
    t.board.dictionary = r.String(b, "dictionary", "board.dictionary", "DICT_4X4_50");
  }
  if (t.board.cols < 2 || t.board.rows < 2)
    r.Fail("board", "expected at least 2 x 2 inner corners");
  if (t.board.cols > kMaxBoardCorners || t.board.rows > kMaxBoardCorners)
    r.Fail("board", "expected at most " + std::to_string(kMaxBoardCorners) +
                        " inner corners along a side, got " + std::to_string(t.board.cols) + " x " +
                        std::to_string(t.board.rows));
  if (!(t.board.square > 0.0)) r.Fail("board.square", "expected a positive square size");
  const std::string problem = TargetBoardProblem(t.board);
  if (!problem.empty()) r.Fail("board", problem);
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
    // The calibration's per-image results are keyed by file name.
    for (size_t k = 0; k < t.images.size(); ++k)
      if (t.images[k].file == im.file)
        r.Fail(p + ".file", "'" + im.file + "' is listed already as images[" + std::to_string(k) + "]");
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
  if (t.board.IsCharuco()) {
    w.Key("marker").Double(t.board.marker);
    w.Key("dictionary").String(t.board.dictionary);
  }
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

TargetBoard ParseBoardSpec(const std::string& spec, double square, double marker, const std::string& dictionary) {
  TargetBoard b;
  std::string size = spec;
  const std::string prefix = "charuco:";
  if (size.rfind(prefix, 0) == 0) {
    b.type = "charuco";
    size = size.substr(prefix.size());
    b.marker = marker;
    b.dictionary = dictionary;
  }
  const size_t x = size.find_first_of("xX");
  auto number = [&](const std::string& text, int* out) {
    if (text.empty() || text.size() > 6) return false;
    for (char c : text)
      if (!std::isdigit(static_cast<unsigned char>(c))) return false;
    *out = std::stoi(text);
    return true;
  };
  if (x == std::string::npos || !number(size.substr(0, x), &b.cols) || !number(size.substr(x + 1), &b.rows))
    throw Error("--board: expected COLSxROWS inner corners (e.g. 7x11) or charuco:COLSxROWS, got '" + spec + "'");
  b.square = square;
  if (b.IsCharuco() && !(b.marker > 0.0))
    throw Error("--marker: a ChArUco board (--board " + spec + ") needs the side of its markers");
  CheckTargetBoard(b, "--board");
  return b;
}

bool NaturalLess(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  auto digit = [](char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; };
  while (i < a.size() && j < b.size()) {
    if (digit(a[i]) && digit(b[j])) {
      // Compare the digit runs as numbers: leading zeros off, then length, then digits.
      size_t i1 = i, j1 = j;
      while (i1 < a.size() && digit(a[i1])) ++i1;
      while (j1 < b.size() && digit(b[j1])) ++j1;
      size_t i0 = i, j0 = j;
      while (i0 + 1 < i1 && a[i0] == '0') ++i0;
      while (j0 + 1 < j1 && b[j0] == '0') ++j0;
      if (i1 - i0 != j1 - j0) return i1 - i0 < j1 - j0;
      const int c = a.compare(i0, i1 - i0, b, j0, j1 - j0);
      if (c != 0) return c < 0;
      i = i1;
      j = j1;
    } else {
      if (a[i] != b[j]) return static_cast<unsigned char>(a[i]) < static_cast<unsigned char>(b[j]);
      ++i;
      ++j;
    }
  }
  if ((i < a.size()) != (j < b.size())) return i >= a.size();  // the prefix first
  return a < b;
}

namespace {

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool IsImageFile(const std::filesystem::path& p) {
  static const char* const kExtensions[] = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".pgm", ".ppm", ".webp"};
  const std::string ext = Lower(p.extension().string());
  for (const char* e : kExtensions)
    if (ext == e) return true;
  return false;
}

}  // namespace

TargetInputKind ClassifyTargetInput(const std::string& path) {
  namespace fs = std::filesystem;
  const std::string ext = Lower(fs::path(path).extension().string());
  if (ext == ".yaml" || ext == ".yml") return TargetInputKind::kTargetFile;
  std::error_code ec;
  if (fs::is_directory(path, ec)) return TargetInputKind::kImageFolder;
  if (!fs::exists(path, ec))
    throw Error(path + ": no such target file (.yaml/.yml), image folder or video");
  return TargetInputKind::kVideo;
}

TargetSet TargetsFromFolder(const std::string& dir, const TargetBoard& board, const std::string& units) {
  namespace fs = std::filesystem;
  CheckTargetBoard(board, "--board");
  std::vector<std::string> names;
  std::error_code ec;
  fs::directory_iterator it(dir, ec);
  if (ec) throw Error(dir + ": cannot list the folder (" + ec.message() + ")");
  for (const fs::directory_entry& e : it) {
    std::error_code ec2;
    if (e.is_regular_file(ec2) && IsImageFile(e.path())) names.push_back(e.path().filename().string());
  }
  if (names.empty())
    throw Error(dir + ": no images in the folder (expected .png, .jpg, .jpeg, .bmp, .tif, .tiff, .pgm, .ppm or .webp files)");
  std::sort(names.begin(), names.end(), NaturalLess);
  TargetSet t;
  t.units = units;
  t.board = board;
  for (const std::string& n : names) {
    TargetImage im;
    im.file = n;
    im.resolved = JoinPath(dir, n);
    t.images.push_back(im);
  }
  return t;
}

int DefaultFrameStep(int frame_count) { return std::max(1, (frame_count + 29) / 30); }

TargetSet TargetsFromVideoFrames(const std::string& video, int frame_count, int every, const TargetBoard& board,
                                 const std::string& units) {
  CheckTargetBoard(board, "--board");
  if (every < 0) throw Error("--every: expected a positive frame step (0: about 30 frames), got " + std::to_string(every));
  if (frame_count < 1) throw Error(video + ": no frames in the video (or not a video OpenCV can read)");
  const int step = every > 0 ? every : DefaultFrameStep(frame_count);
  const std::string name = std::filesystem::path(video).filename().string();
  TargetSet t;
  t.units = units;
  t.board = board;
  for (int f = 0; f < frame_count; f += step) {
    TargetImage im;
    im.file = name + "#" + std::to_string(f);
    im.resolved = video;
    im.frame = f;
    t.images.push_back(im);
  }
  return t;
}

}  // namespace pano
