#include "panotrack/io/pose_csv.h"

#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "panotrack/core/error.h"
#include "panotrack/core/output_check.h"
#include "panotrack/io/csv_util.h"

namespace pano {

const char* const kPoseCsvHeader = "frame,time_s,x,y,theta_rad,status,n_landmarks,residual";

namespace {

int ParseInt(const std::string& s, const std::string& where, const char* column) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(s.c_str(), &end, 10);
  if (s.empty() || end != s.c_str() + s.size() || errno == ERANGE || v < 0 || v > 2147483647L)
    throw Error(where + ": column " + column + ": expected a non-negative integer, got '" + s + "'");
  return static_cast<int>(v);
}

}  // namespace

std::vector<PoseRow> ReadPoseCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot open the file");
  std::string line;
  if (!std::getline(in, line)) throw Error(path + ": empty file (expected the header '" +
                                           std::string(kPoseCsvHeader) + "')");
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (line.compare(0, std::strlen(kPoseCsvHeader), kPoseCsvHeader) != 0)
    throw Error(path + ": line 1: expected the header '" + std::string(kPoseCsvHeader) + "'");
  const size_t n_cols = SplitCsv(line).size();
  std::vector<PoseRow> rows;
  for (int lineno = 2; std::getline(in, line); ++lineno) {
    if (line.empty() || line == "\r") continue;
    const std::string where = path + ": line " + std::to_string(lineno);
    const std::vector<std::string> f = SplitCsv(line);
    if (f.size() != n_cols)
      throw Error(where + ": expected " + std::to_string(n_cols) + " columns, got " +
                  std::to_string(f.size()));
    PoseRow r;
    r.frame = ParseInt(f[0], where, "frame");
    r.time_s = ParseCsvDouble(f[1], where, "time_s");
    if (f[5] == "ok") r.status = PoseStatus::kOk;
    else if (f[5] == "lost") r.status = PoseStatus::kLost;
    else if (f[5] == "init") r.status = PoseStatus::kInit;
    else throw Error(where + ": column status: expected ok, lost or init, got '" + f[5] + "'");
    if (r.status == PoseStatus::kLost) {
      if (!f[2].empty() || !f[3].empty() || !f[4].empty())
        throw Error(where + ": a 'lost' row must leave x, y and theta_rad empty");
    } else {
      r.pose.x = ParseCsvDouble(f[2], where, "x");
      r.pose.y = ParseCsvDouble(f[3], where, "y");
      r.pose.theta = ParseCsvDouble(f[4], where, "theta_rad");
    }
    r.n_landmarks = ParseInt(f[6], where, "n_landmarks");
    r.residual = f[7].empty() ? 0.0 : ParseCsvDouble(f[7], where, "residual");
    for (size_t k = 8; k < f.size(); ++k)
      r.extra.push_back(f[k].empty() ? std::nan("") : ParseCsvDouble(f[k], where, ("column " + std::to_string(k + 1)).c_str()));
    if (!rows.empty() && r.frame <= rows.back().frame)
      throw Error(where + ": frame numbers must increase (" + f[0] + " after " +
                  std::to_string(rows.back().frame) + ")");
    rows.push_back(std::move(r));
  }
  return rows;
}

namespace {

// Appends printf's "%.<precision>f" (fixed) or "%.<precision>g" (general)
// of v. std::to_chars with a precision is defined as that conversion, at a
// fraction of printf's cost (a row per frame).
void AppendNumber(std::string* s, double v, std::chars_format format, int precision) {
  char buf[400];  // the longest fixed double, 309 digits, and the fraction
  const std::to_chars_result r = std::to_chars(buf, buf + sizeof buf, v, format, precision);
  if (r.ec == std::errc()) {
    s->append(buf, r.ptr);
    return;
  }
  std::snprintf(buf, sizeof buf, format == std::chars_format::fixed ? "%.*f" : "%.*g", precision, v);
  *s += buf;
}

void AppendInt(std::string* s, int v) {
  char buf[16];
  s->append(buf, std::to_chars(buf, buf + sizeof buf, v).ptr);
}

}  // namespace

std::string FormatPoseRow(const PoseRow& r) {
  std::string s;
  s.reserve(96 + 16 * r.extra.size());
  AppendInt(&s, r.frame);
  s += ',';
  AppendNumber(&s, r.time_s, std::chars_format::fixed, 6);
  if (r.status == PoseStatus::kLost) {
    s += ",,,,";
    s += PoseStatusName(r.status);
    s += ',';
    AppendInt(&s, r.n_landmarks);
    s += ',';
  } else {
    for (const double v : {r.pose.x, r.pose.y}) {
      s += ',';
      AppendNumber(&s, v, std::chars_format::fixed, 4);
    }
    s += ',';
    AppendNumber(&s, WrapAngle(r.pose.theta), std::chars_format::fixed, 6);
    s += ',';
    s += PoseStatusName(r.status);
    s += ',';
    AppendInt(&s, r.n_landmarks);
    s += ',';
    AppendNumber(&s, r.residual, std::chars_format::fixed, 4);
  }
  for (double e : r.extra) {
    s += ',';
    if (std::isfinite(e)) AppendNumber(&s, e, std::chars_format::general, 6);
  }
  return s;
}

const char* const kPartialSuffix = ".partial";

bool PoseCsvWriter::WritesDirectly(const std::string& path) { return WritesInPlace(path); }

StagedLineWriter::StagedLineWriter(const std::string& path, PoseCsvStaging staging) : path_(path) {
  if (path == "-") {
    is_stdout_ = true;
    file_ = stdout;
    written_path_ = "standard output";
    return;
  }
  const bool staged = staging == PoseCsvStaging::kPartial && !PoseCsvWriter::WritesDirectly(path);
  written_path_ = staged ? path + kPartialSuffix : path;
  file_ = std::fopen(written_path_.c_str(), "w");
  if (!file_) throw Error(written_path_ + ": cannot write: " + std::strerror(errno));
}

StagedLineWriter::~StagedLineWriter() {
  if (file_ && !is_stdout_) std::fclose(file_);
}

void StagedLineWriter::WriteLine(const std::string& line) {
  if (!file_) throw Error(path_ + ": write after close");
  if (std::fwrite(line.data(), 1, line.size(), file_) != line.size() || std::fputc('\n', file_) == EOF ||
      std::fflush(file_) != 0)
    throw Error(written_path_ + ": write failed: " + std::strerror(errno));
}

void StagedLineWriter::Close() {
  if (!file_) return;
  std::FILE* f = file_;
  file_ = nullptr;
  if (is_stdout_) {
    if (std::fflush(f) != 0) throw Error("standard output: write failed: " + std::string(std::strerror(errno)));
    return;
  }
  if (std::fclose(f) != 0) throw Error(written_path_ + ": close failed: " + std::strerror(errno));
  if (written_path_ != path_ && std::rename(written_path_.c_str(), path_.c_str()) != 0)
    throw Error(path_ + ": cannot move " + written_path_ + " into place: " + std::strerror(errno));
}

PoseCsvWriter::PoseCsvWriter(const std::string& path, const std::vector<std::string>& extra,
                             PoseCsvStaging staging)
    : out_(path, staging), n_extra_(extra.size()) {
  std::string header = kPoseCsvHeader;
  for (const std::string& c : extra) header += "," + c;
  out_.WriteLine(header);
}

void PoseCsvWriter::Write(const PoseRow& row) {
  PoseRow r = row;
  r.extra.resize(n_extra_, std::nan(""));
  out_.WriteLine(FormatPoseRow(r));
}

}  // namespace pano
