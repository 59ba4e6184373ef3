// A calibration board: the chessboard or ChArUco board panocalib finds in
// the images and panosim renders (its geometry, its ArUco dictionary).
#pragma once

#include <string>

namespace pano {

// Inner corners a board may have along each side; more are taken for a
// corrupt file rather than allocated.
constexpr int kMaxBoardCorners = 1000;

struct TargetBoard {
  std::string type = "chessboard";  // "chessboard" or "charuco"
  int cols = 0;  // inner corners along the board's x axis
  int rows = 0;  // inner corners along the board's y axis
  double square = 0.0;
  // ChArUco only: the markers' side (map units, below square) and OpenCV's
  // predefined ArUco dictionary (DICT_4X4_50...). The board has (cols + 1) x
  // (rows + 1) squares; its inner corner (i, j) is OpenCV's ChArUco corner
  // j * cols + i, and the board frame's origin is the first inner corner.
  double marker = 0.0;
  std::string dictionary;
  bool IsCharuco() const { return type == "charuco"; }
};

// OpenCV's predefined ArUco dictionaries: the enum value of a name (-1 when
// unknown) and the number of markers it holds.
int ArucoDictionaryId(const std::string& name);
int ArucoDictionarySize(int id);
// Markers a ChArUco board needs (one per white square).
int CharucoMarkerCount(const TargetBoard& board);
// What is wrong with the board: "" when nothing.
std::string TargetBoardProblem(const TargetBoard& board);
// Throws pano::Error naming `field` (the option or the YAML key) when the
// board is not a usable chessboard or ChArUco board.
void CheckTargetBoard(const TargetBoard& board, const std::string& field = "board");

}  // namespace pano
