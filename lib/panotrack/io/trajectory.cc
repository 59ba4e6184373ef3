#include "panotrack/io/trajectory.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "panotrack/core/error.h"
#include "panotrack/io/pose_csv.h"

namespace pano {

namespace {

// The first line (a trailing '\r' dropped); `empty` is the message when
// there is none.
std::string HeaderLine(std::istream& in, const std::string& path, const std::string& empty) {
  std::string line;
  if (!std::getline(in, line)) throw Error(path + ": " + empty);
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return line;
}

// use(line, line number) for each line after the header with something on
// it, a trailing '\r' dropped.
template <typename Use>
void ForEachDataLine(std::istream& in, Use use) {
  std::string line;
  int ln = 1;
  while (std::getline(in, line)) {
    ++ln;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) continue;
    use(line, ln);
  }
}

// A field as a finite number, or pano::Error "<path>: line <ln>: '<field>'
// is not a number".
double FieldNumber(const std::string& field, const std::string& path, int ln) {
  char* end = nullptr;
  const double v = std::strtod(field.c_str(), &end);
  if (end == field.c_str() || *end != '\0' || !std::isfinite(v))
    throw Error(path + ": line " + std::to_string(ln) + ": '" + field + "' is not a number");
  return v;
}

}  // namespace

std::vector<Pose2> ReadTrajectory(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot read the trajectory file");
  const std::string header = HeaderLine(in, path, "empty trajectory file (expected a header)");
  std::vector<Pose2> out;
  if (header.rfind("frame,", 0) == 0) {
    in.close();
    const std::vector<PoseRow> rows = ReadPoseCsv(path);
    for (size_t i = 0; i < rows.size(); ++i) {
      if (rows[i].status == PoseStatus::kLost)
        throw Error(path + ": line " + std::to_string(i + 2) + ": status 'lost' has no pose");
      out.push_back(rows[i].pose);
    }
  } else {
    if (header != "x,y,theta" && header != "x,y,theta_rad")
      throw Error(path + ": line 1: expected the header 'x,y,theta' (radians) or a pose CSV (docs/panoloc.md)");
    ForEachDataLine(in, [&](const std::string& line, int ln) {
      std::stringstream ss(line);
      std::string f;
      Pose2 p;
      double* dst[3] = {&p.x, &p.y, &p.theta};
      for (double* d : dst) {
        if (!std::getline(ss, f, ','))
          throw Error(path + ": line " + std::to_string(ln) + ": expected 3 numbers x,y,theta");
        *d = FieldNumber(f, path, ln);
      }
      if (std::getline(ss, f, ',')) throw Error(path + ": line " + std::to_string(ln) + ": expected 3 columns x,y,theta");
      out.push_back(p);
    });
  }
  if (out.empty()) throw Error(path + ": no poses in the trajectory file");
  return out;
}

std::vector<std::array<double, 6>> ReadBoardPoseRows(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot read the board poses file");
  if (HeaderLine(in, path, "empty file (expected the header rx,ry,rz,tx,ty,tz)") != "rx,ry,rz,tx,ty,tz")
    throw Error(path + ": line 1: expected the header 'rx,ry,rz,tx,ty,tz'");
  std::vector<std::array<double, 6>> out;
  ForEachDataLine(in, [&](const std::string& line, int ln) {
    const std::string wrong = path + ": line " + std::to_string(ln) + ": expected 6 numbers rx,ry,rz,tx,ty,tz";
    std::stringstream ss(line);
    std::string f;
    std::array<double, 6> v;
    int k = 0;
    while (std::getline(ss, f, ',')) {
      if (k >= 6) throw Error(wrong);
      v[static_cast<size_t>(k++)] = FieldNumber(f, path, ln);
    }
    if (k != 6) throw Error(wrong);
    out.push_back(v);
  });
  if (out.empty()) throw Error(path + ": no board poses");
  return out;
}

}  // namespace pano
