#include "panotrack/scene/target_board.h"

#include <cmath>

#include "panotrack/core/error.h"

namespace pano {

namespace {

// OpenCV's cv::aruco::PREDEFINED_DICTIONARY_NAME, in its enum order, with
// each dictionary's marker count.
struct ArucoDictionary {
  const char* name;
  int markers;
};
constexpr ArucoDictionary kArucoDictionaries[] = {
    {"DICT_4X4_50", 50},          {"DICT_4X4_100", 100},       {"DICT_4X4_250", 250},
    {"DICT_4X4_1000", 1000},      {"DICT_5X5_50", 50},         {"DICT_5X5_100", 100},
    {"DICT_5X5_250", 250},        {"DICT_5X5_1000", 1000},     {"DICT_6X6_50", 50},
    {"DICT_6X6_100", 100},        {"DICT_6X6_250", 250},       {"DICT_6X6_1000", 1000},
    {"DICT_7X7_50", 50},          {"DICT_7X7_100", 100},       {"DICT_7X7_250", 250},
    {"DICT_7X7_1000", 1000},      {"DICT_ARUCO_ORIGINAL", 1024}, {"DICT_APRILTAG_16h5", 30},
    {"DICT_APRILTAG_25h9", 35},   {"DICT_APRILTAG_36h10", 2320}, {"DICT_APRILTAG_36h11", 587},
};
constexpr int kNumArucoDictionaries = sizeof(kArucoDictionaries) / sizeof(kArucoDictionaries[0]);

}  // namespace

int ArucoDictionaryId(const std::string& name) {
  for (int k = 0; k < kNumArucoDictionaries; ++k)
    if (name == kArucoDictionaries[k].name) return k;
  return -1;
}

int ArucoDictionarySize(int id) {
  return id >= 0 && id < kNumArucoDictionaries ? kArucoDictionaries[id].markers : 0;
}

int CharucoMarkerCount(const TargetBoard& board) { return (board.cols + 1) * (board.rows + 1) / 2; }

std::string TargetBoardProblem(const TargetBoard& b) {
  if (b.type != "chessboard" && b.type != "charuco")
    return std::string("unknown board type '" + b.type + "' (expected chessboard or charuco)");
  if (b.cols < 2 || b.rows < 2 || b.cols > kMaxBoardCorners || b.rows > kMaxBoardCorners)
    return std::string("expected 2.." + std::to_string(kMaxBoardCorners) + " inner corners along each side, got " +
                std::to_string(b.cols) + " x " + std::to_string(b.rows));
  if (!(b.square > 0.0) || !std::isfinite(b.square)) return std::string("expected a positive square size");
  if (!b.IsCharuco()) return "";
  if (!(b.marker > 0.0) || !(b.marker < b.square))
    return std::string("a ChArUco board's marker side must be positive and below the square size (" +
                std::to_string(b.square) + "), got " + std::to_string(b.marker));
  const int id = ArucoDictionaryId(b.dictionary);
  if (id < 0) {
    std::string names;
    for (const ArucoDictionary& d : kArucoDictionaries) names += (names.empty() ? "" : ", ") + std::string(d.name);
    return std::string("unknown ArUco dictionary '" + b.dictionary + "' (expected one of " + names + ")");
  }
  if (ArucoDictionarySize(id) < CharucoMarkerCount(b))
    return std::string("a " + std::to_string(b.cols) + " x " + std::to_string(b.rows) +
                " ChArUco board needs " + std::to_string(CharucoMarkerCount(b)) + " markers, " + b.dictionary +
                " has " + std::to_string(ArucoDictionarySize(id)));
  return "";
}

void CheckTargetBoard(const TargetBoard& board, const std::string& field) {
  const std::string problem = TargetBoardProblem(board);
  if (!problem.empty()) throw Error(field + ": " + problem);
}

}  // namespace pano
