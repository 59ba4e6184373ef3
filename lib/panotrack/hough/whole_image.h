// Whole-image mode of the Panoramic Hough Transform (feature extraction, the
// paper's reference [10]; section 4.1, Eqns 7-8 over -pi/2 < dtheta < pi/2):
// every edge pixel (R_i, theta_i) votes into an (R_main x theta_main)
// accumulator for the dtheta range its gradient orientation allows; peaks
// with non-maximum suppression are the horizontal lines' projections in
// view. Vertical 3-D lines project to radial lines (section 4): a theta
// histogram of edge pixels whose gradient is tangential finds them.
//
// Unknown height. PH depends on the line's height Z (relative to the
// pinhole). For a single-viewpoint mirror it would depend on sign(Z) only;
// the sphere is close to that at room distances, so the transform votes in a
// small family of Z planes (options.heights), each edge pixel in every plane
// where E^-1(R_i, Z) exists: with one plane below and one above the pinhole
// each pixel votes in about one plane (points below the horizon radius see
// Z < 0, above it Z > 0). A line whose true height differs from its plane's
// nominal Z is found with the error documented in BENCHMARKS.md
// ("Panoramic Hough Transform": nominal-Z error) and measured by the test
// hough/nominal_z: for the paper's sensor under 0.4 px (half a bin) away from
// the sphere's effective viewpoint height (about Z = 11 units, where the
// curves of all distances crowd at the horizon radius and depend strongly on
// Z): give two planes just below and above that height as well, as the
// defaults do. distance_min/max bound each plane to its own band of radii.
// Tracking (tracking.h) uses the exact Z.
//
// Orientation gating. Through an edge pixel at (R_i, theta_i), the PH curve of
// parameter dtheta has the tangent dR/dtheta = -(dPH/d dtheta) / (dPH/dR)
// (R_main constant along the curve, Eqn 5), so its normal makes the angle
//   psi(R_i, dtheta) = atan((dPH/d dtheta) / (R_i dPH/dR))
// with the radial direction. The pixel's gradient makes the angle phi with
// the radial direction (in aspect-corrected coordinates, modulo 180 degrees:
// edge polarity is ignored). The pixel votes only for the dtheta where
// |psi - phi| <= orientation_tolerance (the contiguous range spanning them,
// within the range where PH is defined). A pixel on a radial (vertical) edge
// has phi near 90 degrees and casts no horizontal votes.
//
// Exactness and determinism. Votes are integers (one per pixel and
// theta_main bin). The PH table is fixed point (1/256 bin) and interpolated
// between R rows with 8-bit weights in integer arithmetic, dtheta quantised
// to theta_bin / sub_steps: the same records give bit-identical accumulators
// on the CPU (any thread count: per-thread integer accumulators summed) and
// on the GPU (integer atomicAdd), see whole_image_gpu.h.
//
// Speed (BENCHMARKS.md, "Panoramic Hough Transform"). The CPU path works on
// the sparse list of edge pixels (the mask scanned eight bytes at a time
// inside the annulus's outer circle), takes their azimuths from a per-pixel
// table and their gradient angle bins from comparisons of tangents (no
// arctangent), reads one cache line of orientation ranges per pixel (all
// planes together, prefetched), votes in (plane, theta_main) order so that
// the accumulator rows in use stay in cache, computes each run's R_main bins
// in a vectorisable loop (SIMD over theta, AVX2 where the processor has it),
// counts in 16 bits when no bin can exceed 2^15 - 1, and keeps of each plane
// only the R bins its table can reach (its band of distances is a narrow
// band of radii). The peak search skips the bins below min_votes and tests
// the nearest neighbours with SSE2 before the full neighbourhood. None of
// this changes a vote or a peak: the result is the plain raster-order
// vote's, bit for bit (tests hough/reference_vote, hough/gradient_bin).
#pragma once

#include <opencv2/core.hpp>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "panotrack/hough/gpu_vote.h"
#include "panotrack/hough/ph_table.h"

namespace pano {

// Edge detection: optional 3x3 box blur (the paper's pre-processing), Sobel
// 3x3 derivatives, Canny with the L2 gradient on them.
struct EdgeOptions {
  bool blur = true;
  double low_threshold = 25.0;
  double high_threshold = 50.0;
};

// An edge map with its gradient: mask CV_8U (non-zero = edge pixel), dx and
// dy CV_16S Sobel derivatives, all the same size.
struct EdgeMap {
  cv::Mat mask;
  cv::Mat dx;
  cv::Mat dy;
};

// From an 8-bit grey (or BGR, converted) image. Throws pano::Error for an
// empty image or another depth.
EdgeMap ComputeEdgeMap(const cv::Mat& image, const EdgeOptions& options = EdgeOptions());

struct WholeImageOptions {
  // Z planes (sensor frame, relative to the pinhole, map units); at least
  // one. The defaults suit the paper's sensor and room (pinhole 30 above the
  // floor, ceiling 120): well below, just below / above the effective
  // viewpoint (about 11), well above.
  std::vector<double> heights = {-30.0, 9.0, 13.0, 60.0};
  double r_bin = 1.0;                      // px
  double theta_bin = M_PI / 180;           // rad; rounded so that 2 pi / theta_bin is whole
  double dtheta_max = 85.0 * M_PI / 180;   // |dtheta| voted (< pi/2)
  int sub_steps = 4;                       // dtheta quantised to theta_bin / sub_steps
  double r_row_step = 0.5;                 // px between the integer table's R rows
  double orientation_tolerance = 12.0 * M_PI / 180;
  // Voting annulus (px): edge pixels outside it are ignored. r_max 0: the
  // limb minus 3 px (the mirror's rim is a circle, not a line).
  double r_min = 20.0;
  double r_max = 0.0;
  // Plausible horizontal distances of the scene's lines (e.g. up to the
  // room's diagonal): a pixel votes in a plane only where E^-1(R_i, Z) lies
  // in [distance_min, distance_max], and only for the dtheta that keep
  // D_main = E^-1(R_i, Z) cos(dtheta) >= distance_min. This gives each plane
  // its own band of radii (0: the E(D,Z) table's range).
  double distance_min = 0.0;
  double distance_max = 0.0;
  // Peaks: at least min_votes, the maximum within +-nms_r x +-nms_theta bins.
  int min_votes = 15;
  int nms_r = 4;
  int nms_theta = 4;
  int max_peaks = 200;
  // Explain-away (after NMS, strongest first): a peak keeps the edge pixels
  // within explain_tolerance px (radially) of its curve (Eqn 6) that no
  // stronger peak kept, and is dropped when fewer than min_votes remain.
  // Removes the secondary maxima along a line's ridge in the accumulator.
  bool explain_away = true;
  double explain_tolerance = 1.5;
  // Fill WholeImageResult::accumulator (the peaks do not need it).
  bool keep_accumulator = true;
  // The voting runs on OpenMP threads only above this many votes, and the
  // peak search over the planes only above this many accumulator bins
  // (below it the threads' start-up and the per-thread accumulators cost
  // more than they save); the result is the same either way.
  int64_t parallel_min_votes = 1 << 20;
  // Threads for the tables, the voting and the peak search (0: every core,
  // ThreadCount). The result is the same for every count.
  int num_threads = 0;
  // Vertical edges: pixels whose gradient is within vertical_tolerance of
  // tangential vote into a theta histogram (theta_bin bins); peaks of the
  // histogram smoothed by [1 2 1] with at least vertical_min_votes pixels in
  // their three bins, +-vertical_nms bins suppression.
  double vertical_tolerance = 12.0 * M_PI / 180;
  int vertical_min_votes = 15;
  int vertical_nms = 3;
  void Check(const std::string& what) const;
};

struct HorizontalPeak {
  int plane = 0;             // index into options.heights
  double height = 0.0;       // that plane's Z
  double r_main = 0.0;       // px (bin centre + sub-bin offset)
  double theta_main = 0.0;   // image azimuth, (-pi, pi]
  int votes = 0;
};

struct VerticalPeak {
  double theta = 0.0;  // image azimuth, (-pi, pi]
  int votes = 0;                     // pixels in the peak bin and its two neighbours
  double r_min = 0.0, r_max = 0.0;  // radial extent of those pixels
};

struct WholeImageResult {
  int n_planes = 0, n_theta = 0, n_r = 0;
  // Votes [plane][theta_main bin][R_main bin]; bin (k, j) is centred on
  // theta_main = (k + 0.5) theta_bin, R_main = (j + 0.5) r_bin. Empty when
  // options.keep_accumulator is false.
  std::vector<int32_t> accumulator;
  std::vector<HorizontalPeak> peaks;  // by votes, descending
  std::vector<int32_t> vertical_histogram;  // [theta bin]
  std::vector<float> vertical_r_min, vertical_r_max;  // radial extent per theta bin
  std::vector<VerticalPeak> vertical_peaks;
  // Edge pixels that cast horizontal votes (image polar coordinates).
  std::vector<float> voter_radius, voter_azimuth;
  int n_edge_pixels = 0;   // edge pixels in the annulus
  int64_t n_votes = 0;     // horizontal votes cast
};

// Precomputed tables for one sensor and one set of options; Run is const
// and thread-safe.
class PhWholeImage {
 public:
  PhWholeImage() = default;
  // Throws pano::Error for bad options (no heights, zero-size accumulator,
  // NaN) or heights outside the E(D,Z) table.
  static PhWholeImage Build(const RadiusTable& table, const WholeImageOptions& options);

  bool empty() const { return planes_.empty(); }
  const WholeImageOptions& options() const { return options_; }
  const PhTable& plane_table(int plane) const { return planes_.at(plane).table; }
  int n_theta() const { return n_theta_; }
  int n_r() const { return n_r_; }
  double theta_bin() const { return theta_bin_; }

  // The whole transform on the CPU (OpenMP; identical for any thread count).
  // Throws pano::Error for an empty edge map or mismatched / wrong-type mats.
  WholeImageResult Run(const EdgeMap& edges) const;

  // The steps, for the GPU path and benchmarks:
  // records of an edge map (raster order) plus the vertical histogram;
  void Prepare(const EdgeMap& edges, std::vector<PhVoteRecord>* records,
               WholeImageResult* result) const;
  // votes of records into the working accumulator (PaddedSize() ints:
  // [plane][theta_main bin][R_main bin, plus one column for out-of-range
  // votes], zeroed by the caller);
  size_t PaddedPlaneSize() const { return static_cast<size_t>(n_rows_padded_) * (n_r_ + 1); }
  size_t PaddedSize() const { return PaddedPlaneSize() * planes_.size(); }
  void VoteCpu(const std::vector<PhVoteRecord>& records, int32_t* padded) const;
  // peak and vertical-peak search on it.
  void Finish(int32_t* padded, WholeImageResult* result) const;

  // Integer tables, for the GPU path: plane p's table starts at
  // int_table().data() + p * int_plane_size(); rows of row_stride() ints.
  const std::vector<int32_t>& int_table() const { return int_table_; }
  size_t int_plane_size() const { return int_plane_size_; }
  int row_stride() const { return sub_steps_ * width_; }
  int n_rows_padded() const { return n_rows_padded_; }

 private:
  struct Plane {
    PhTable table;
    // PH^-1 (Eqn 6) for the explain-away step: [R_main row][sub step][d + M]
    // at dtheta = (d - s / sub_steps) theta_bin, NaN undefined.
    std::vector<float> curve;
  };
  struct EdgePixel;  // Prepare's per-pixel values (whole_image.cc)
  struct VoteScales;

  // Build's steps: sizes from the sensor and options (throws when too large);
  void SetGeometry(const Sensor& sensor, const WholeImageOptions& options);
  // the polar coordinates of every pixel of the annulus's bounding box;
  void FillPolarTable(const Sensor& sensor);
  // one plane's integer PH table, with which (row, m) are defined for every
  // sub step and the curve's normal angle there;
  void FillIntegerPlane(const PhTable& ph, double d_min, double d_max, int32_t* tab,
                        std::vector<unsigned char>* valid, std::vector<float>* psi) const;
  // the m range each (row, gradient angle) votes for;
  void FillOrientationRanges(const std::vector<unsigned char>& valid, const std::vector<float>& psi,
                             size_t plane);
  // PH^-1 for the explain-away step;
  void FillCurveTable(Plane* plane) const;

  // Prepare's steps.
  // Polar coordinates of pixel (u, v) in single precision: the image radius,
  // the azimuth in [0, 2 pi) and the radial direction's cosine and sine.
  // From the table inside the annulus's bounding box (the same values,
  // computed once), which holds every pixel that can vote.
  struct PolarPixel {
    float radius, azimuth, cos_r, sin_r;
  };
  PolarPixel Polar(int u, int v) const;
  bool InPolarTable(int u, int v) const {
    return static_cast<unsigned>(u - az_u0_) < static_cast<unsigned>(az_cols_) &&
           static_cast<unsigned>(v - az_v0_) < static_cast<unsigned>(az_rows_);
  }
  size_t PolarIndex(int u, int v) const { return static_cast<size_t>(v - az_v0_) * az_cols_ + (u - az_u0_); }
  PolarPixel PolarAt(int u, int v) const { return InPolarTable(u, v) ? polar_[PolarIndex(u, v)] : Polar(u, v); }
  void CheckEdgeMap(const EdgeMap& edges) const;
  void ResetResult(WholeImageResult* res) const;
  // An edge pixel that votes: where its records read the tables.
  struct PixelVotes {
    float radius, azimuth;
    size_t ranges;   // its orientation ranges in ranges_
    int32_t offset;  // table offset of m = 0 at its R row and sub step
    int fl;          // theta_main bin of m = 0
    uint16_t t8;     // weight of the next R row
  };
  // The vertical histogram, and (true) where the pixel's votes go.
  bool AddEdgePixel(const EdgePixel& e, const VoteScales& k, PixelVotes* pv, WholeImageResult* res) const;
  void AddVertical(const EdgePixel& e, double g_rad, const VoteScales& k, WholeImageResult* res) const;
  bool LocateVotes(const EdgePixel& e, int phi_bin, const VoteScales& k, PixelVotes* out) const;
  bool AddRecords(const PixelVotes& pv, std::vector<PhVoteRecord>* records, WholeImageResult* res) const;

  // Where each plane's bins lie in a working accumulator: n_theta rows of
  // cols[p] bins from offset[p], holding R bins j0[p] .. j0[p] + cols[p] - 1
  // (the out-of-range column n_r last when a vote can reach it).
  struct AccumulatorLayout {
    std::vector<size_t> offset;
    std::vector<int> j0, cols;
    size_t size = 0;
    static AccumulatorLayout Make(int n_theta, const std::vector<int>& j0, const std::vector<int>& cols);
    int RealBins(int p, int n_r) const { return std::min(cols[p], n_r - j0[p]); }  // without column n_r
  };
  // The R bins a plane's table can vote for (Build).
  void VotedBins(const int32_t* tab, int* j0, int* cols) const;

  // The voting and Finish's steps, for 32-bit (GPU, VoteCpu) and 16-bit
  // (Run, when no bin can overflow) accumulators.
  template <typename T>
  void VoteInto(const std::vector<PhVoteRecord>& records, const AccumulatorLayout& layout, T* padded) const;
  template <typename T>
  void FinishWith(const T* padded, const AccumulatorLayout& layout, WholeImageResult* result) const;
  template <typename T>
  void CopyAccumulator(const T* padded, const AccumulatorLayout& layout, WholeImageResult* res) const;
  template <typename T>
  void FindHorizontalPeaks(const T* padded, const AccumulatorLayout& layout, WholeImageResult* res) const;
  template <typename T>
  std::vector<HorizontalPeak> PlanePeaks(const T* padded, const AccumulatorLayout& layout, int p) const;
  template <typename T>
  bool IsPeak(const T* g, int cols, int n, int k, int j, int32_t v) const;
  template <typename T>
  HorizontalPeak RefinedPeak(const T* g, int cols, int n, int j0, int p, int k, int j, int32_t v) const;
  // Explain-away: keep the peaks whose curve still has min_votes unclaimed voters.
  struct VoterIndex;
  VoterIndex BucketVoters(const WholeImageResult& res) const;
  // A peak's curve (Eqn 6) in the PH^-1 table: rows c0, c1 (d = 0 at theta
  // bin kc), interpolated with weight tr; c0 and c1 null outside the table.
  struct CurveRows {
    const float *c0 = nullptr, *c1 = nullptr;
    float tr = 0.0f;
    int kc = 0;
  };
  void PeakCurve(const HorizontalPeak& pk, CurveRows* rows) const;
  void PeakSupport(const CurveRows& curve, const VoterIndex& index, const std::vector<unsigned char>& claimed,
                   std::vector<int>* support) const;
  void ExplainAway(WholeImageResult* result) const;
  void FindVerticalPeaks(WholeImageResult* res) const;
  VerticalPeak VerticalPeakAt(const WholeImageResult& res, const std::vector<int32_t>& sm, int k) const;

  WholeImageOptions options_;
  double cx_ = 0, cy_ = 0, aspect_ = 1;
  double r_min_ = 0, r_max_ = 0, theta_bin_ = 0;
  int n_theta_ = 0, n_r_ = 0, n_rows_ = 0, sub_steps_ = 0, half_width_ = 0, width_ = 0;
  int n_rows_padded_ = 0;  // theta rows of the working accumulator (n_theta)
  std::vector<Plane> planes_;
  std::vector<PolarPixel> polar_;  // [v - az_v0_][u - az_u0_]
  int az_u0_ = 0, az_v0_ = 0, az_cols_ = 0, az_rows_ = 0;
  std::vector<int32_t> int_table_;  // [plane][R row][sub step][m + M], 1/256 bin
  // The m range each (R row, gradient angle bin) votes for in each plane
  // (lo > hi: none), planes innermost: one edge pixel reads one cache line.
  struct VoteRange {
    int16_t lo, hi;
  };
  std::vector<VoteRange> ranges_;  // [R row][phi bin][plane]
  // The working accumulator: as PaddedSize() describes (VoteCpu, Finish, the
  // GPU), and Run's, each plane only over the R bins its table can reach (a
  // plane's band of distances is a narrow band of radii: a fraction of the
  // memory to zero, vote into and search).
  AccumulatorLayout padded_layout_, compact_layout_;
  size_t int_plane_size_ = 0;
};

// Largest |PH_nominal(R_i, dtheta) - R_main| (px) over the points of lines at
// the true height `true_z` (horizontal distances d_lo..d_hi, |dtheta| up to
// dtheta_lim) when they are voted with the table of a nominal height: the
// nominal-Z approximation error of the whole-image mode.
double NominalHeightError(const Sensor& sensor, const PhTable& nominal, double true_z, double d_lo,
                          double d_hi, double dtheta_lim);

}  // namespace pano
