// ChArUco boards (TargetBoard of type charuco): the printable image and the
// detection of the board's inner corners, each with its board point id, in a
// grey image. OpenCV's aruco module stays behind this header.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

#include "panotrack/io/targets.h"

namespace pano {

// The board as printed: `pixels_per_square` pixels per square and a white
// margin of `margin_px` (8-bit grey). The board point (x, y, 0) of the board
// frame (origin at the first inner corner) lies at
// (margin_px + (x / square + 1) * pixels_per_square, same for y) in the
// image's continuous coordinates (pixel k spans [k, k + 1); subtract 0.5 for
// OpenCV's pixel-centre coordinates);
// the square at the origin's top left is black, like the chessboard's.
// Throws pano::Error for a board that is not a ChArUco board.
cv::Mat DrawCharucoBoard(const TargetBoard& board, int pixels_per_square, int margin_px = 0);

struct CharucoDetection {
  std::vector<Eigen::Vector2d> corners;  // pixels
  std::vector<int> ids;                  // board point index j * cols + i of each corner
  int markers = 0;                       // ArUco markers found
};

// Markers (cv::aruco::detectMarkers, tuned for small markers) and the inner
// corners between them (interpolateCornersCharuco: a local homography from
// the neighbouring markers, then cornerSubPix), with no camera model. A
// mirror reflects the board (its codes read backwards), so the image is
// searched flipped left to right and as it is; the orientation with more
// corners wins. An OpenCV error is rethrown as pano::Error.
CharucoDetection DetectCharuco(const cv::Mat& grey, const TargetBoard& board);

}  // namespace pano
