#include "panotrack/io/trajectory.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "panotrack/core/error.h"
#include "panotrack/io/pose_csv.h"

namespace pano {

std::vector<Pose2> ReadTrajectory(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot read the trajectory file");
  std::string header;
  if (!std::getline(in, header)) throw Error(path + ": empty trajectory file (expected a header)");
  if (!header.empty() && header.back() == '\r') header.pop_back();
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
    std::string line;
    int ln = 1;
    while (std::getline(in, line)) {
      ++ln;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      if (line.find_first_not_of(" \t") == std::string::npos) continue;
      std::stringstream ss(line);
      std::string f[3];
      Pose2 p;
      double* dst[3] = {&p.x, &p.y, &p.theta};
      for (int k = 0; k < 3; ++k) {
        if (!std::getline(ss, f[k], ','))
          throw Error(path + ": line " + std::to_string(ln) + ": expected 3 numbers x,y,theta");
        char* end = nullptr;
        *dst[k] = std::strtod(f[k].c_str(), &end);
        if (end == f[k].c_str() || *end != '\0' || !std::isfinite(*dst[k]))
          throw Error(path + ": line " + std::to_string(ln) + ": '" + f[k] + "' is not a number");
      }
      std::string rest;
      if (std::getline(ss, rest, ',')) throw Error(path + ": line " + std::to_string(ln) + ": expected 3 columns x,y,theta");
      out.push_back(p);
    }
  }
  if (out.empty()) throw Error(path + ": no poses in the trajectory file");
  return out;
}

std::vector<std::array<double, 6>> ReadBoardPoseRows(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot read the board poses file");
  std::string line;
  if (!std::getline(in, line)) throw Error(path + ": empty file (expected the header rx,ry,rz,tx,ty,tz)");
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (line != "rx,ry,rz,tx,ty,tz") throw Error(path + ": line 1: expected the header 'rx,ry,rz,tx,ty,tz'");
  std::vector<std::array<double, 6>> out;
  int ln = 1;
  while (std::getline(in, line)) {
    ++ln;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) continue;
    std::stringstream ss(line);
    std::string f;
    double v[6];
    int k = 0;
    while (std::getline(ss, f, ',')) {
      if (k >= 6) throw Error(path + ": line " + std::to_string(ln) + ": expected 6 numbers rx,ry,rz,tx,ty,tz");
      char* end = nullptr;
      v[k] = std::strtod(f.c_str(), &end);
      if (end == f.c_str() || *end != '\0' || !std::isfinite(v[k]))
        throw Error(path + ": line " + std::to_string(ln) + ": '" + f + "' is not a number");
      ++k;
    }
    if (k != 6) throw Error(path + ": line " + std::to_string(ln) + ": expected 6 numbers rx,ry,rz,tx,ty,tz");
    out.push_back({v[0], v[1], v[2], v[3], v[4], v[5]});
  }
  if (out.empty()) throw Error(path + ": no board poses");
  return out;
}

}  // namespace pano
