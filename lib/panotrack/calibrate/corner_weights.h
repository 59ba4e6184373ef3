// How precisely each detected chessboard corner is located, from the
// detected grid alone: the weights of the calibration fit (step 3 of
// calibrate.h). Free of Ceres and glog, so tests can include it beside Catch.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "panotrack/calibrate/calibrate.h"

namespace pano {

// Square roots L (upper triangular) of the corners' information matrices
// L^T L, one per corner of the view (in its order; a partial view's
// corners take their neighbours from the corners it has); the fit's residual for a corner is
// L * (projected - observed).
//
// A corner is the crossing of the board's two lines through it; with n1, n2
// the unit normals of their images, its position has information N^T N
// (N = [n1 n2]^T), poor along the bisector of an acute crossing. Near a
// mirror's limb the board is also squeezed to a few pixels per square, and
// measured on rendered boards through the true model the error left after
// that crossing geometry grows as 1 / s, s the grid's smaller singular value
// (pixels per square): 0.03 px at s > 10, 0.06 px at 6-10, 0.09 at 4-6, 0.15
// at 3-4, 0.18 at 2-3 (docs/calibration.md). So the information is
// g^2 N^T N with g = min(1, s / full_px). Where the squares are full-size
// (s >= full_px) the corner counts as one plain pixel measurement (identity);
// between 0.8 full_px and full_px the two blend. full_px <= 0: every corner
// gets the identity. (The crossing angle enters both N^T N and s; that is
// what the measurements show, not a double count by mistake.)
std::vector<Eigen::Matrix2d> CornerWeights(const BoardView& view, const TargetBoard& board, double full_px);

}  // namespace pano
