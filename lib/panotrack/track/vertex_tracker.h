// Vertex tracking (paper section 3): corners located by a variance-normalised
// correlation with an ideal corner template in the quasi-cylindrical view.
//
//  - The quasi-cylindrical view: the useful annulus of the image warped by
//    bilinear interpolation into a long rectangle, x = azimuth, y = radius
//    (1 px per row, increasing downwards). Its width is the circumference of
//    the horizon circle, 2 pi rad_h, so one column is one pixel at the horizon
//    radius. The view is padded by `pad` columns at both ends (the azimuths
//    wrapped round) so that no template or search window ever wraps. The warp
//    maps (bilinear taps) are computed once per sensor. Per landmark only the
//    search window (plus the template's reach) is warped, inside Measure, so
//    that the warp runs in the localiser's parallel loop over landmarks and
//    costs nothing where no landmark is; Warp() makes the whole view (for
//    tests, figures and debugging; rows in parallel).
//  - For a predicted landmark: the corner's position in the view and its type,
//    one of 8 (face towards -x/+x, -y/+y, lighter/darker than its
//    surroundings), from the map's prediction (inside signs and polarities).
//    Where the two edges' polarities disagree (the surroundings across the
//    vertical and the horizontal edge differ in shade) the template has three
//    levels instead of two.
//  - The template is piecewise constant on its four quadrants, so its Pearson
//    correlation with every placement over the search window (r_range x
//    theta_range from the expected image motion) takes O(1) per placement from
//    the window's integral images. The best response, refined to sub-pixel precision by
//    a parabola in x and y, gives the corner's radius; a best response below
//    `min_score` means not found, and so does one that another response a
//    template's size away comes within `min_peak_margin` of.
//  - The azimuth: the correlation peak is broad along x (flat over the ramp
//    of an edge blurred by the camera's turn), so the vertical edge beside
//    the corner is located by the step detector of the line-junction tracker
//    (track/edge_profile.h) in the face's rows, within the expected ramp.
// Measure() only reads the per-frame data (the frame, padded), so landmarks
// are tracked in parallel.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "panotrack/sensor/sensor.h"
#include "panotrack/track/tracker.h"

namespace pano {

struct VertexOptions {
  int max_half_px = 8;         // template quadrant size, at most (warped px)
  int min_half_px = 4;         // ... and at least
  double face_fraction = 0.7;  // quadrant size from the predicted edge lengths
  double min_score = 0.7;      // weakest accepted correlation (an edge alone scores ~0.58)
  // The best response must beat any other a template's size away by this
  // much; otherwise two corner-like features compete and the corner is not
  // declared (0: the paper's rule, the best response wins). It costs nothing
  // on the paper presets and rejects some false fixes after a kidnap.
  double min_peak_margin = 0.1;
  double min_search_px = 2.0;  // smallest search half-width (px)
  int max_search_warped_px = 48;     // largest search half-width in the view's columns
  double inner_radius_fraction = 0.15;  // of the limb: the view's first row
  void Check() const;
};

// A corner type: where the landmark's face lies from the corner in the view
// and the shade steps into it across its two edges (+1 brighter inside).
struct CornerType {
  int x_sign = 1;       // face towards +x (increasing azimuth) or -x
  int y_sign = 1;       // face towards +y (increasing radius) or -y
  int v_polarity = 1;   // step into the face across the vertical edge
  int h_polarity = 1;   // ... across the horizontal edge
};

// Best correlation peak of a corner search in the view.
struct CornerPeak {
  bool found = false;
  double x = 0.0, y = 0.0;  // the corner in view coordinates (pixel centres are integers)
  double score = -1.0;
  double second = -1.0;  // best score a template's size or more from the peak (-1: none)
};

class QuasiCylindricalView {
 public:
  // `pad`: columns repeated at each end.
  QuasiCylindricalView(const Sensor& sensor, double inner_radius, double outer_radius, int pad);
  double horizon_radius() const { return rad_h_; }
  int width() const { return width_; }   // 2 pi rad_h, rounded, without the padding
  int pad() const { return pad_; }
  int cols() const { return width_ + 2 * pad_; }
  int rows() const { return rows_; }
  double inner_radius() const { return r0_; }
  // View coordinates of image polar coordinates and back. x lies in
  // [pad, pad + width); ToView wraps the azimuth.
  double x_of_azimuth(double azimuth) const;
  double azimuth_of_x(double x) const;
  double y_of_radius(double radius) const { return radius - r0_; }
  double radius_of_y(double y) const { return r0_ + y; }
  // The warp maps: image u, v sampled by every view pixel (CV_32FC1; they
  // could be handed to cv::remap). Warp() interpolates exactly at these
  // points (cv::remap quantises them to 1/32 px).
  const cv::Mat& map_u() const { return map_u_; }
  const cv::Mat& map_v() const { return map_v_; }
  // Warps a grey frame (CV_8UC1 of the sensor's size) into a CV_32FC1 view by
  // bilinear interpolation, rows in parallel (OpenMP). Outside the image: 0.
  // Rows on `num_threads` threads (0: OpenMP's default).
  void Warp(const cv::Mat& grey, cv::Mat* view, int num_threads = 0) const;
  // The frame with one pixel of zeros round it, as WarpRegion reads it.
  void PadFrame(const cv::Mat& grey, cv::Mat* padded) const;
  // View pixels [x0, x0 + w) x [y0, y0 + h) (inside the view) of a padded
  // frame into a CV_32FC1 image, serially (callers run in parallel).
  void WarpRegion(const cv::Mat& padded, int x0, int y0, int w, int h, cv::Mat* out) const;

 private:
  struct Tap {  // bilinear taps into the frame padded by one pixel of zeros
    int offset;  // of the top-left tap; -1: outside the frame
    float wx, wy;
  };
  static void WarpRow(const uint8_t* src, int stride, const Tap* taps, int n, float* out);
  double rad_h_ = 0.0, r0_ = 0.0;
  int width_ = 0, rows_ = 0, pad_ = 0;
  int image_width_ = 0, image_height_ = 0;
  cv::Mat map_u_, map_v_;  // CV_32FC1
  std::vector<Tap> taps_;  // rows() x cols()
};

// Horizon radius: the image radius of a point at the pinhole's height far away.
double HorizonRadius(const Sensor& sensor);

// Pearson correlation of the ideal corner of `type` (quadrants half_x x half_y
// px) with every placement whose corner lies within (cx +- sx, cy +- sy) in a
// view given by its integral images (cv::integral, CV_64F sums and squares).
CornerPeak FindCorner(const cv::Mat& sum, const cv::Mat& sqsum, const CornerType& type, int half_x,
                      int half_y, double cx, double cy, double sx, double sy);

class VertexTracker : public LandmarkTracker {
 public:
  VertexTracker(const Sensor& sensor, const VertexOptions& options);
  void BeginFrame(const cv::Mat& grey) override;
  LandmarkMeasurement Measure(const PredictedLandmark& p, double search_px) const override;

  const QuasiCylindricalView& view() const { return view_; }
  static CornerType TypeOf(const PredictedLandmark& p);
  // The corner types to try: TypeOf's, with each edge of unknown polarity
  // (0) taken with either sign.
  static std::vector<CornerType> TypesOf(const PredictedLandmark& p);

 private:
  Sensor sensor_;
  VertexOptions opt_;
  QuasiCylindricalView view_;
  cv::Mat padded_;  // the frame, padded for the view's taps
};

}  // namespace pano
