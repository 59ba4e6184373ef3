// Visual compass: the robot's rotation between two frames from the images
// alone. A turn of the robot by d shifts every image azimuth by -d (a mirror
// of revolution keeps azimuths), so the azimuthal intensity signature of the
// annulus shifts rigidly; circular cross-correlation of two signatures finds
// d. Translation distorts the signature only locally. The localiser uses it
// to predict the heading, so that fast turns stay inside the trackers'
// search windows (the paper's prototype had to keep rotations slow).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "panotrack/sensor/sensor.h"

namespace pano {

class AzimuthCompass {
 public:
  // Bins of the signature over 2 pi; the annulus between the two fractions
  // of the limb radius is used.
  AzimuthCompass(const Sensor& sensor, int bins = 720, double inner_fraction = 0.3,
                 double outer_fraction = 0.97);
  // Zero-mean, unit-norm signature of a grey frame of the sensor's size: per
  // azimuth bin the mean intensity over eight rings of the annulus,
  // high-passed.
  std::vector<float> Signature(const cv::Mat& grey) const;
  // Rotation of the robot from the frame of `previous` to that of `current`
  // (radians, counter-clockwise positive), searched within +-max_rotation;
  // `score` receives the normalised correlation at the peak (-1..1).
  double Rotation(const std::vector<float>& previous, const std::vector<float>& current,
                  double max_rotation, double* score) const;
  int bins() const { return bins_; }

 private:
  int bins_;
  std::vector<int> pixel_offset_;  // pixel index (row * width + col) per sample, bin by bin
  std::vector<int> pixel_row_;     // its row (frames may have padded rows)
  std::vector<int> pixel_bin_;     // its azimuth bin (while building)
  std::vector<int> bin_begin_;     // bin b's samples: [bin_begin_[b], bin_begin_[b + 1])
  int width_ = 0, height_ = 0;
};

}  // namespace pano
