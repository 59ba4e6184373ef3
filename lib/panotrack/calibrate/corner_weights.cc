#include "panotrack/calibrate/corner_weights.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace pano {

std::vector<Eigen::Matrix2d> CornerWeights(const BoardView& view, const TargetBoard& board, double full_px) {
  const int cols = board.cols, rows = board.rows;
  std::vector<Eigen::Matrix2d> out(view.corners.size(), Eigen::Matrix2d::Identity());
  if (!(full_px > 0.0) || static_cast<int>(view.corners.size()) != cols * rows) return out;
  auto at = [&](int i, int j) { return view.corners[static_cast<size_t>(j * cols + i)]; };
  // Image of one square step along the board's x (or y) at corner (i, j):
  // central difference, one-sided at the board's edge.
  auto step = [&](int i, int j, bool along_x) {
    const int n = along_x ? cols : rows, c = along_x ? i : j;
    const int lo = std::max(c - 1, 0), hi = std::min(c + 1, n - 1);
    const Eigen::Vector2d d = along_x ? at(hi, j) - at(lo, j) : at(i, hi) - at(i, lo);
    return Eigen::Vector2d(d / (hi - lo));
  };
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < cols; ++i) {
      const Eigen::Vector2d dx = step(i, j, true), dy = step(i, j, false);
      if (!dx.allFinite() || !dy.allFinite() || !(dx.norm() > 0.0) || !(dy.norm() > 0.0)) continue;
      const Eigen::Vector2d n1 = Eigen::Vector2d(-dx.y(), dx.x()).normalized();
      const Eigen::Vector2d n2 = Eigen::Vector2d(-dy.y(), dy.x()).normalized();
      Eigen::Matrix2d grid;
      grid << dx, dy;
      const double squeeze = Eigen::JacobiSVD<Eigen::Matrix2d>(grid).singularValues()(1);
      const double g = std::min(1.0, squeeze / full_px);
      const double b = std::min(1.0, (1.0 - g) / 0.2);
      // The floor keeps parallel lines (a degenerate grid) positive definite.
      const Eigen::Matrix2d crossing = n1 * n1.transpose() + n2 * n2.transpose() + 1e-3 * Eigen::Matrix2d::Identity();
      const Eigen::Matrix2d info = g * g * (b * crossing + (1.0 - b) * Eigen::Matrix2d::Identity());
      const Eigen::LLT<Eigen::Matrix2d> llt(info);
      // Should the factorisation fail, the corner gets the smallest weight.
      out[static_cast<size_t>(j * cols + i)] =
          llt.info() == Eigen::Success ? Eigen::Matrix2d(llt.matrixU())
                                       : Eigen::Matrix2d(std::sqrt(1e-3) * g * Eigen::Matrix2d::Identity());
    }
  return out;
}

}  // namespace pano
