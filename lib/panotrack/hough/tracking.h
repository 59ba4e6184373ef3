// Tracking mode of the Panoramic Hough Transform (paper section 4.2): the step
// edges found along a predicted horizontal edge vote, through the PH mapping
// of Eqns 7-8, into a small (R_main, theta_main) accumulator around the
// prediction; the peak, refined to sub-bin precision, is the tracked line.
//
// Allocation-light: the accumulator lives in a thread_local buffer that grows
// to the largest window seen, so calling this every frame for every
// predicted edge (20-200 points each) allocates nothing in the steady state.
#pragma once

#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include "panotrack/hough/ph_table.h"

namespace pano {

// One detected step edge: image polar coordinates (Sensor::to_polar: radius
// with the aspect removed, image azimuth in radians) and a non-negative
// confidence ("variable according to the confidence of the point").
struct TrackingVote {
  double radius = 0.0;
  double azimuth = 0.0;
  double weight = 1.0;
};

struct TrackingWindow {
  // Predicted line parameters (Eqn 4: R_main = E(D_main, Z); theta_main the
  // image azimuth of the line's closest point to the axis).
  double r_main = 0.0;
  double theta_main = 0.0;
  // The accumulator covers r_main +- r_halfwidth and theta_main +-
  // theta_halfwidth (< pi/2) in bins of r_bin px and theta_bin rad, centred on
  // the prediction: 2 ceil(halfwidth / bin) + 1 bins per axis.
  double r_halfwidth = 6.0;
  double theta_halfwidth = 4.0 * M_PI / 180;
  double r_bin = 0.5;
  double theta_bin = 0.5 * M_PI / 180;
  // The paper's bounded range: (R_main, theta_main) is only plotted where
  // theta_min < theta_i + dtheta < theta_max (theta_i + dtheta = theta_main,
  // Eqn 8), taken counter-clockwise from theta_min to theta_max. Infinite
  // (the default): no bound beyond the window.
  double theta_min = -std::numeric_limits<double>::infinity();
  double theta_max = std::numeric_limits<double>::infinity();
  // Points vote only for |dtheta| < max_abs_dtheta (the table's range caps it).
  double max_abs_dtheta = 85.0 * M_PI / 180;
  // Smooth the accumulator with the 3x3 kernel [1 2 1]^T [1 2 1] / 16 before
  // the peak search (spreads the vote of a noisy point).
  bool smooth = true;
  // Refine the accumulator's peak by robust Gauss-Newton on the points'
  // residuals e = PH(R_i, theta_main - theta_i) - R_main (Tukey biweight,
  // scale refine_scale_bins * r_bin, at most refine_iterations steps). The
  // accumulator alone resolves theta_main poorly where the points lie near
  // the line's foot (there dPH/d(dtheta) is near zero: a plateau along
  // theta); the fit recovers it. 0 iterations: accumulator peak only.
  int refine_iterations = 20;
  double refine_scale_bins = 3.0;
  // A point is an inlier of the result when PH(R_i, theta_main - theta_i) is
  // within inlier_r_bins * r_bin of R_main.
  double inlier_r_bins = 1.0;
  // found requires score >= min_score.
  double min_score = 0.0;
};

struct TrackingResult {
  bool found = false;
  double r_main = 0.0;      // refined peak (px)
  double theta_main = 0.0;  // refined peak (rad, wrapped to (-pi, pi])
  // Inlier weight fraction: sum of the weights of the inlier points over the
  // weight of all points that voted (0..1).
  double score = 0.0;
  double peak = 0.0;        // accumulator value at the peak (weight units)
  int n_votes = 0;          // points that cast at least one vote
  int n_inliers = 0;
  bool at_border = false;   // peak on the window's edge: the line may lie outside it
  // Standard deviations of r_main (px) and theta_main (rad) from the robust
  // fit's normal equations and residual scatter (0 for exact points;
  // infinite where the points do not determine theta_main, e.g. a line close
  // to the horizon whose projection is nearly a circle). NaN without the fit.
  double r_sigma = std::numeric_limits<double>::quiet_NaN();
  double theta_sigma = std::numeric_limits<double>::quiet_NaN();
};

// Votes the points into the window's accumulator through PH (Eqns 7-8):
// for each theta_main bin centre c in the window (and in theta_min..theta_max),
// dtheta = c - theta_i, R_main = PH(R_i, dtheta), split linearly between the
// two nearest R bins. The peak is the accumulator's maximum, refined by a
// quadratic fitted to its 3x3 neighbourhood (separate parabolas per axis when
// that fit is not a maximum), then by the robust fit described at
// refine_iterations (each step projected onto the window). Throws pano::Error (one line) for a bad window
// (non-finite values, non-positive bins, theta_halfwidth >= pi/2, more than
// 1e6 bins) or a point with a non-finite coordinate or weight or a negative
// weight. found is false with no votes.
TrackingResult TrackHorizontalLine(const PhTable& table, const TrackingWindow& window,
                                   const TrackingVote* points, size_t n_points);
inline TrackingResult TrackHorizontalLine(const PhTable& table, const TrackingWindow& window,
                                          const std::vector<TrackingVote>& points) {
  return TrackHorizontalLine(table, window, points.data(), points.size());
}

}  // namespace pano
