#include "panotrack/calibrate/corner_weights.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace pano {

std::vector<Eigen::Matrix2d> CornerWeights(const BoardView& view, const TargetBoard& board, double full_px) {
  const int cols = board.cols, rows = board.rows;
  std::vector<Eigen::Matrix2d> out(view.corners.size(), Eigen::Matrix2d::Identity());
  if (!(full_px > 0.0)) return out;
  if (!view.Partial() && static_cast<int>(view.corners.size()) != cols * rows) return out;
  // The corners on the board's grid (NaN where a partial view has none), and
  // where each grid point's corner sits in the view.
  const Eigen::Vector2d none(NAN, NAN);
  std::vector<Eigen::Vector2d> placed(static_cast<size_t>(cols) * rows, none);
  std::vector<int> slot(placed.size(), -1);
  for (size_t k = 0; k < view.corners.size(); ++k) {
    const int id = view.PointId(k);
    if (id < 0 || id >= cols * rows) return out;
    placed[static_cast<size_t>(id)] = view.corners[k];
    slot[static_cast<size_t>(id)] = static_cast<int>(k);
  }
  auto at = [&](int i, int j) { return placed[static_cast<size_t>(j * cols + i)]; };
  auto has = [&](int i, int j) { return slot[static_cast<size_t>(j * cols + i)] >= 0; };
  // Image of one square step along the board's x (or y) at corner (i, j):
  // central difference, one-sided at the board's edge or beside a missing
  // corner (NaN when both neighbours are missing).
  auto step = [&](int i, int j, bool along_x) {
    const int n = along_x ? cols : rows, c = along_x ? i : j;
    int lo = std::max(c - 1, 0), hi = std::min(c + 1, n - 1);
    if (!(along_x ? has(lo, j) : has(i, lo))) lo = c;
    if (!(along_x ? has(hi, j) : has(i, hi))) hi = c;
    if (hi == lo) return none;
    const Eigen::Vector2d d = along_x ? at(hi, j) - at(lo, j) : at(i, hi) - at(i, lo);
    return Eigen::Vector2d(d / (hi - lo));
  };
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < cols; ++i) {
      if (!has(i, j)) continue;
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
      out[static_cast<size_t>(slot[static_cast<size_t>(j * cols + i)])] =
          llt.info() == Eigen::Success ? Eigen::Matrix2d(llt.matrixU())
                                       : Eigen::Matrix2d(std::sqrt(1e-3) * g * Eigen::Matrix2d::Identity());
    }
  return out;
}

}  // namespace pano
