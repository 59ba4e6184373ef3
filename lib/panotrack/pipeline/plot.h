// panoloc's trajectory plot and, with ground truth, its error-over-time plot.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "panotrack/plot/figure.h"
#include "panotrack/pose/pose_row.h"
#include "panotrack/scene/map.h"

namespace pano {

// The map from above: axes in the map's units, a scale bar, the walls and
// boxes with their ids, the estimated path (broken at lost frames) with
// heading arrows, start and end markers and the lost frames (crosses at the
// ground truth's pose, or at the last pose known without it). With ground
// truth, its path is drawn under the estimate and the estimate is coloured by
// its position error (colour bar). `transform` maps map coordinates to the
// image's pixels (for tests).
struct TrajectoryFigure {
  cv::Mat image;  // BGR
  PlotTransform transform;
};
TrajectoryFigure DrawTrajectoryPlot(const Map& map, const std::vector<PoseRow>& estimate,
                                    const std::vector<PoseRow>& truth);

// Position error (x and y, map units) and heading error (degrees) against
// time for the frames the truth has, each with the band of +/- 3 standard
// deviations the estimate reported (std_x, std_y, std_theta: the first three
// extra columns), lost frames shaded.
cv::Mat DrawErrorPlot(const std::vector<PoseRow>& estimate, const std::vector<PoseRow>& truth,
                      const std::string& units);

// "<dir>/<stem>_error.png" beside `plot_path`.
std::string ErrorPlotPath(const std::string& plot_path);

// Writes DrawTrajectoryPlot to `path` and, when `truth` is not empty,
// DrawErrorPlot to ErrorPlotPath(path), each atomically as PNG.
void WritePlot(const std::string& path, const Map& map, const std::vector<PoseRow>& estimate,
               const std::vector<PoseRow>& truth);

}  // namespace pano
