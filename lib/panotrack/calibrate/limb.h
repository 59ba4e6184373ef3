// The mirror's limb as a measurement: a sphere seen from the pinhole has a
// sharp silhouette, the image of the cone of rays that graze it. Its place
// in the image depends on the principal point and on the sphere's centre in
// the camera's frame differently from the corners' (a pure shift of the
// principal point moves the limb as much as the mirror's picture; a centre
// off the axis moves the limb by (1 + tan^2 of the cone's half angle) times
// as much), so it separates the two where the boards alone trade them; its
// radius ties the focal length to the mirror's angular size.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <vector>

#include "panotrack/sensor/sensor.h"

namespace ceres {
class Problem;
}

namespace pano {

struct LimbObservation {
  // Points on the limb, one per azimuth sampled (pixels): per azimuth the
  // median over the images of the edge's crossing of its mid grey.
  std::vector<Eigen::Vector2d> points;
  double point_sigma_px = 0.0;  // scatter of one point (robust, from the images' spread)
  int images_used = 0;          // images that showed the limb somewhere
  // Scale of each residual in the fit (the corners' sigma over the points').
  double weight = 1.0;
  bool Empty() const { return points.empty(); }
};

struct LimbOptions {
  int azimuths = 360;            // points sampled around the limb
  double search_px = 8.0;        // the edge searched this far either side of the prediction
  double min_contrast = 20.0;    // grey levels between the mirror's side and the outside
  double min_image_fraction = 0.5;  // an azimuth needs a clean edge in this fraction of the images
  double min_point_fraction = 0.5;  // the limb needs this fraction of its azimuths measured
  double min_sigma_px = 0.02;    // floor of a point's sigma (the model's own limits)
};

// The limb predicted by `sensor` at cone angle psi (radians about the
// sphere's centre direction); false when it is not a sphere or the point is
// not in front of the camera.
bool LimbPixel(const Sensor& sensor, double psi, Eigen::Vector2d* pixel);

// Measures the limb in the images near where `sensor` predicts it (the
// sphere only; an empty observation otherwise, or when the limb is not
// clean in enough of the images, e.g. hidden by a mount or outside the
// image). num_threads: images measured at once (0: OpenMP's default).
LimbObservation MeasureLimb(const std::vector<cv::Mat>& images, const Sensor& sensor,
                            const LimbOptions& options = {}, int num_threads = 0);

// Adds one residual per limb point to a fit: the angle between the point's
// camera ray and the sphere's centre direction minus the limb's half angle,
// in pixels (times observation.weight). sensor_block and fault_block are the
// fit's calib_internal blocks; the fault block is added constant when the
// problem does not have it.
void AddLimbResiduals(ceres::Problem* problem, const LimbObservation& observation, double* sensor_block,
                      double* fault_block);

// Each limb point's signed distance outside the limb of `sensor` (pixels,
// unweighted; NaN where it cannot be evaluated), and their RMS.
std::vector<double> LimbResidualsPx(const LimbObservation& observation, const Sensor& sensor);
double LimbRmsPx(const LimbObservation& observation, const Sensor& sensor);

}  // namespace pano
