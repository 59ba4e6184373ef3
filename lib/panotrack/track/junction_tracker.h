// Line-junction tracking with the Panoramic Hough Transform (paper section
// 4.2). For a predicted landmark:
//  - vertical edge (a radial line): linear samples in the tangential direction
//    at radii along the predicted segment; the step points' azimuths give the
//    edge's azimuth as a truncated median (the mode of the contiguous ones);
//  - horizontal edge (a PH curve): linear samples in the radial direction at
//    azimuths along the predicted segment; the step points vote in the PH
//    transform's tracking mode, whose peak updates (R_main, theta_main);
//  - end points at the junction by bisection between the last sample that
//    found a step and the first that did not; the landmark is declared when
//    both edges are found and meet within a threshold.
#pragma once

#include <memory>

#include "panotrack/hough/ph_table.h"
#include "panotrack/hough/tracking.h"
#include "panotrack/sensor/sensor.h"
#include "panotrack/track/tracker.h"

namespace pano {

struct JunctionOptions {
  double sample_spacing_px = 1.5;   // between linear samples along an edge
  double corner_gap_px = 3.0;       // no samples this close to the junction
  int max_samples = 10;             // per vertical edge, spread along it
  int max_horizontal_samples = 8;   // per horizontal edge (it validates the junction)
  double sample_step_px = 0.5;      // along a linear sample
  double min_step = 12.0;           // grey levels across an edge (over 2 px)
  double truncation_px = 0.8;       // truncated median half-width
  int min_vertical_points = 5;
  int min_horizontal_points = 5;
  double min_ph_score = 0.5;        // PH peak's inlier weight fraction
  double junction_tolerance_px = 3.0;
  int bisection_steps = 5;
  void Check() const;
};

class JunctionTracker : public LandmarkTracker {
 public:
  JunctionTracker(const Sensor& sensor, std::shared_ptr<PhTableCache> ph_tables,
                  const JunctionOptions& options);
  void BeginFrame(const cv::Mat& grey) override { grey_ = grey; }
  LandmarkMeasurement Measure(const PredictedLandmark& p, double search_px) const override;
  // The vertical edge only (its azimuth is the landmark's).
  LandmarkMeasurement MeasureAzimuth(const PredictedLandmark& p, double search_px) const override;
  bool MeasuresAzimuthCheaply() const override { return true; }

 private:
  struct VerticalEdge;                         // the steps of Measure and what they find
  struct HorizontalEdge;                       // (junction_tracker.cc)
  static constexpr double kProbeHalfPx = 2.5;  // half-length of the end points' probing samples
  // Each edge is searched for a step of its polarity (going into the face,
  // +1 or -1, as PredictedLandmark's).
  bool FindVerticalEdge(const PredictedLandmark& p, double half, int polarity, VerticalEdge* edge,
                        LandmarkMeasurement* m) const;
  bool FindHorizontalEdge(const PredictedLandmark& p, double half, const PhTable& ph, int polarity,
                          HorizontalEdge* edge, LandmarkMeasurement* m) const;
  static TrackingWindow HorizontalWindow(const PredictedLandmark& p, double half);
  // Whether each edge ends within `tolerance` of the junction at radius
  // `r_junction` (`meets`); false when it runs past it.
  bool VerticalEnd(const VerticalEdge& v, double r_junction, double tolerance, bool* meets,
                   LandmarkMeasurement* m) const;
  bool HorizontalEnd(const PhTable& ph, const HorizontalEdge& h, double theta_v, double r_junction,
                     double tolerance, bool needed, bool* meets, LandmarkMeasurement* m) const;
  bool LocateJunction(const PhTable& ph, const VerticalEdge& v, const HorizontalEdge& h,
                      LandmarkMeasurement* m) const;

  Sensor sensor_;
  std::shared_ptr<PhTableCache> ph_tables_;
  JunctionOptions opt_;
  int step_baseline_ = 2;  // the step detector's baseline in samples (from opt_)
  cv::Mat grey_;
};

}  // namespace pano
