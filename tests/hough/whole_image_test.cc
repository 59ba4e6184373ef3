// Whole-image mode on a ray-traced panorama of a room with known horizontal
// and vertical edges; nominal-height error; thread-count independence; the
// GPU path against the CPU path; bad input.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <string>

#include "panotrack/core/error.h"
#include "panotrack/hough/whole_image.h"
#include "panotrack/hough/whole_image_gpu.h"
#include "hough_fixtures.h"
#include "test_skip.h"
#include "scene_render.h"
#include "test_rng.h"

namespace pano {
namespace {

// Polar image samples of a world segment's visible part (inside the voting
// annulus and the frame).
struct VisibleEdge {
  std::vector<double> radius, azimuth;
  double length_px = 0;
  double z = 0;  // sensor-frame height
};

VisibleEdge Visible(const Sensor& s, const test::RoomScene& scene, const Eigen::Vector3d& a,
                    const Eigen::Vector3d& b, double r_lo, double r_hi) {
  VisibleEdge e;
  e.z = a.z() - scene.sensor_height;
  bool prev = false;
  Eigen::Vector2d prev_px = Eigen::Vector2d::Zero();
  for (int k = 0; k <= 800; ++k) {
    const Eigen::Vector3d pw = a + (b - a) * (k / 800.0);
    Eigen::Vector2d px;
    bool ok = s.project(SensorFromWorld(scene.pose, scene.sensor_height, pw), &px) &&
              s.inside_image(px, 2.0);
    double r = 0, az = 0;
    if (ok) {
      s.to_polar(px.x(), px.y(), &r, &az);
      ok = r > r_lo + 2 && r < r_hi - 2;
    }
    if (ok) {
      e.radius.push_back(r);
      e.azimuth.push_back(az);
      if (prev) e.length_px += (px - prev_px).norm();
      prev_px = px;
    }
    prev = ok;
  }
  return e;
}

// Fraction of the edge's samples within tol px (radially) of the peak's curve.
double CurveFit(const PhWholeImage& ph, const HorizontalPeak& pk, const VisibleEdge& e, double tol) {
  if (e.radius.empty()) return 0;
  int good = 0;
  for (size_t k = 0; k < e.radius.size(); ++k) {
    const double r = CurveRadius(ph.plane_table(pk.plane), pk.r_main,
                                 test::AngleDiff(e.azimuth[k], pk.theta_main));
    if (std::abs(r - e.radius[k]) <= tol) ++good;
  }
  return double(good) / e.radius.size();
}

struct Fixture {
  Sensor sensor = test::PaperSyntheticSensor();
  std::shared_ptr<const RadiusTable> table = test::BuildTestTable(sensor);
  WholeImageOptions options;
  PhWholeImage ph;
  Fixture() {
    // Nominal planes from the sensor alone, none at a scene edge's height: the
    // sphere's effective viewpoint is about 11 units above the pinhole, so one
    // plane well below it, two just below / above it (lines near the horizon
    // radius) and one well above; distances 20..600 (twice the room diagonal).
    options.heights = {-30.0, 9.0, 13.0, 60.0};
    options.distance_min = 20.0;
    options.distance_max = 600.0;
    ph = PhWholeImage::Build(*table, options);
  }
};

TEST_CASE("whole-image mode finds every horizontal edge longer than 20 px", "[whole_image]") {
  Fixture f;
  const test::RoomScene scene = test::PaperRoom();
  const cv::Mat img = test::RenderRoom(f.sensor, scene);
  const EdgeMap edges = ComputeEdgeMap(img);
  const WholeImageResult res = f.ph.Run(edges);
  const double r_lo = f.options.r_min, r_hi = f.sensor.limb_radius() - 3.0;
  CHECK(res.n_edge_pixels > 1000);
  // Truth: the visible horizontal edges, and whether each peak explains one.
  int n_truth = 0, n_found = 0;
  std::vector<bool> peak_used(res.peaks.size(), false);
  for (const test::HSegment& seg : test::HorizontalEdges(scene)) {
    const VisibleEdge e = Visible(f.sensor, scene, seg.a, seg.b, r_lo, r_hi);
    if (e.length_px <= 20.0) continue;
    ++n_truth;
    // Found: a peak whose curve runs within 2 px (1 px bins plus the
    // nominal-height error) of at least 80 % of the edge.
    double best = 0;
    for (size_t i = 0; i < res.peaks.size(); ++i) {
      const double fit = CurveFit(f.ph, res.peaks[i], e, 2.0);
      best = std::max(best, fit);
      if (fit >= 0.5) peak_used[i] = true;
    }
    INFO("edge z " << e.z << " length " << e.length_px << " px: best curve fit " << best);
    CHECK(best >= 0.8);
    if (best >= 0.8) ++n_found;
  }
  const int n_false = static_cast<int>(std::count(peak_used.begin(), peak_used.end(), false));
  WARN("whole image: " << res.n_edge_pixels << " edge pixels, " << res.n_votes << " votes, "
                       << res.peaks.size() << " peaks; horizontal edges > 20 px in view: " << n_truth
                       << ", found " << n_found << ", false detections " << n_false);
  CHECK(n_truth >= 10);
  CHECK(n_found == n_truth);
  CHECK(n_false <= 4);

  // Vertical edges: room corners and rectangle sides, found in the theta histogram.
  std::vector<Eigen::Vector2d> verticals = {{scene.x0, scene.y0}, {scene.x1, scene.y0},
                                            {scene.x1, scene.y1}, {scene.x0, scene.y1}};
  for (const auto& r : scene.rects) {
    verticals.push_back(r.a);
    verticals.push_back(r.b);
  }
  int n_vert = 0, n_vert_found = 0;
  for (const auto& xy : verticals) {
    // Visible extent of the vertical edge (the rectangles' from z0 to z1 are
    // approximated by the room height: only the bearing is compared).
    const Eigen::Vector3d ps = SensorFromWorld(scene.pose, scene.sensor_height, {xy.x(), xy.y(), 0.0});
    const double az = f.sensor.image_azimuth(std::atan2(ps.y(), ps.x()));
    ++n_vert;
    bool hit = false;
    for (const VerticalPeak& vp : res.vertical_peaks)
      if (std::abs(test::AngleDiff(vp.theta, az)) <= 1.5 * f.ph.theta_bin()) hit = true;
    n_vert_found += hit;
  }
  WARN("vertical edges: " << n_vert << " in the scene, " << n_vert_found << " found, "
                          << res.vertical_peaks.size() << " vertical peaks");
  CHECK(n_vert_found >= n_vert - 2);
}

TEST_CASE("nominal-height approximation error of the whole-image mode", "[nominal_z]") {
  Fixture f;
  // Exact plane: only the table error remains.
  const double exact = NominalHeightError(f.sensor, f.ph.plane_table(0), -30.0, 40.0, 250.0, 1.2);
  CHECK(exact < 0.004);
  // Lines of the paper's room voted in the nominal planes -30 (below the
  // pinhole) and 60 (above), D_main 40..250, |dtheta| <= 60 degrees.
  for (double z : {-25.0, -20.0, -15.0, -10.0}) {
    const double err = NominalHeightError(f.sensor, f.ph.plane_table(0), z, 40.0, 250.0, M_PI / 3);
    WARN("nominal Z -30, true Z " << z << ": worst |PH_nominal - R_main| " << err << " px");
    CHECK(err > exact);  // the approximation is measured, not zero
    CHECK(err < 0.6);
  }
  for (double z : {15.0, 30.0, 45.0, 70.0, 90.0}) {
    const double err = NominalHeightError(f.sensor, f.ph.plane_table(3), z, 40.0, 250.0, M_PI / 3);
    WARN("nominal Z 60, true Z " << z << ": worst |PH_nominal - R_main| " << err << " px");
    CHECK(err < 1.2);
  }
}

TEST_CASE("whole-image results are identical for 1, 2 and 4 threads", "[threads]") {
  Fixture f;
  f.options.parallel_min_votes = 0;  // vote on all threads even for one small image
  const cv::Mat img = test::RenderRoom(f.sensor, test::PaperRoom());
  const EdgeMap edges = ComputeEdgeMap(img);
  auto run = [&](int threads) {
    WholeImageOptions o = f.options;
    o.num_threads = threads;
    return PhWholeImage::Build(*f.table, o).Run(edges);
  };
  const WholeImageResult r1 = run(1), r2 = run(2), r4 = run(4);
  REQUIRE(r1.n_votes > 100000);
  CHECK(r1.accumulator == r2.accumulator);
  CHECK(r1.accumulator == r4.accumulator);
  REQUIRE(r1.peaks.size() == r4.peaks.size());
  for (size_t i = 0; i < r1.peaks.size(); ++i) {
    CHECK(r1.peaks[i].r_main == r4.peaks[i].r_main);
    CHECK(r1.peaks[i].theta_main == r4.peaks[i].theta_main);
    CHECK(r1.peaks[i].votes == r4.peaks[i].votes);
  }
  CHECK(r1.vertical_histogram == r4.vertical_histogram);
}

// The straightforward vote of the records (one bin per record and theta_main
// bin, R_main from the integer table, Eqn 7): what the optimised voting (16-
// or 32-bit, theta-ordered, in parallel) must reproduce exactly.
std::vector<int32_t> ReferenceVote(const PhWholeImage& ph, const std::vector<PhVoteRecord>& records) {
  const int NT = ph.n_theta(), NR = ph.n_r();
  std::vector<int32_t> acc(static_cast<size_t>(ph.options().heights.size()) * NT * NR, 0);
  for (const PhVoteRecord& rec : records)
    for (int j = 0; j < rec.count; ++j) {
      const int32_t* a = ph.int_table().data() + rec.plane * ph.int_plane_size() + rec.offset + j;
      const int32_t* b = a + ph.row_stride();
      const int v = (*a * (256 - rec.t) + *b * rec.t) >> 16;
      const int k = (rec.k_start + j) % NT;
      if (v < NR) ++acc[(static_cast<size_t>(rec.plane) * NT + k) * NR + v];
    }
  return acc;
}

// The edge pixels the transform must see, by a dense raster scan: those in
// the annulus with a non-zero gradient, in raster order (radius, azimuth in
// single precision, as WholeImageResult keeps the voters').
struct ScannedPixels {
  std::vector<float> radius, azimuth;
};
ScannedPixels DenseScan(const Sensor& s, const WholeImageOptions& o, const EdgeMap& e) {
  ScannedPixels out;
  const double r_max = s.limb_radius() - 3.0;
  for (int v = 0; v < e.mask.rows; ++v)
    for (int u = 0; u < e.mask.cols; ++u) {
      if (!e.mask.at<uint8_t>(v, u)) continue;
      const double du = u - s.params.cx, dv = (v - s.params.cy) / s.params.aspect;
      const float r = static_cast<float>(std::sqrt(du * du + dv * dv));
      if (r < o.r_min || r > r_max) continue;
      if (e.dx.at<int16_t>(v, u) == 0 && e.dy.at<int16_t>(v, u) == 0) continue;
      double t = std::atan2(dv, du);
      if (t < 0) t += 2 * M_PI;
      out.radius.push_back(r);
      out.azimuth.push_back(static_cast<float>(t));
    }
  return out;
}

// True if the voters are the scanned pixels' subsequence (raster order kept).
bool VotersInScanOrder(const WholeImageResult& r, const ScannedPixels& scan) {
  size_t i = 0;
  for (size_t k = 0; k < r.voter_radius.size(); ++k) {
    while (i < scan.radius.size() &&
           (scan.radius[i] != r.voter_radius[k] || scan.azimuth[i] != r.voter_azimuth[k]))
      ++i;
    if (i == scan.radius.size()) return false;
    ++i;
  }
  return true;
}

TEST_CASE("optimised whole-image voting equals the straightforward vote, any thread count",
          "[reference_vote]") {
  PANO_SEEDED_RNG(2026);
  Fixture f;
  f.options.parallel_min_votes = 0;  // the parallel voting and peak search too
  f.options.num_threads = 1;
  f.ph = PhWholeImage::Build(*f.table, f.options);
  WholeImageOptions two = f.options;
  two.num_threads = 2;
  const PhWholeImage ph2 = PhWholeImage::Build(*f.table, two);
  // The rendered room (few records: 16-bit counts), and a dense random edge
  // map (more than 2^15 records: 32-bit counts) with random gradients.
  std::vector<EdgeMap> maps = {ComputeEdgeMap(test::RenderRoom(f.sensor, test::PaperRoom()))};
  EdgeMap dense;
  dense.mask = cv::Mat(f.sensor.image_height, f.sensor.image_width, CV_8U);
  dense.dx = cv::Mat(dense.mask.size(), CV_16S);
  dense.dy = cv::Mat(dense.mask.size(), CV_16S);
  std::uniform_int_distribution<int> grad(-300, 300), pick(0, 99);
  for (int v = 0; v < dense.mask.rows; ++v)
    for (int u = 0; u < dense.mask.cols; ++u) {
      dense.mask.at<uint8_t>(v, u) = pick(rng) < 90 ? 255 : 0;
      dense.dx.at<int16_t>(v, u) = static_cast<int16_t>(grad(rng));
      dense.dy.at<int16_t>(v, u) = static_cast<int16_t>(grad(rng));
    }
  maps.push_back(dense);
  for (size_t m = 0; m < maps.size(); ++m) {
    INFO("edge map " << m);
    std::vector<PhVoteRecord> records;
    WholeImageResult prepared;
    f.ph.Prepare(maps[m], &records, &prepared);
    const ScannedPixels scan = DenseScan(f.sensor, f.options, maps[m]);
    CHECK(prepared.n_edge_pixels == static_cast<int>(scan.radius.size()));
    CHECK(VotersInScanOrder(prepared, scan));
    CHECK((m == 0 ? records.size() < 32768 : records.size() > 32768));
    const std::vector<int32_t> reference = ReferenceVote(f.ph, records);
    const WholeImageResult r1 = f.ph.Run(maps[m]);
    const WholeImageResult r2 = ph2.Run(maps[m]);
    REQUIRE(r1.n_votes > 100000);
    CHECK(r1.accumulator == reference);  // integer votes: tolerance zero
    CHECK(r2.accumulator == reference);
    REQUIRE(r1.peaks.size() == r2.peaks.size());
    for (size_t i = 0; i < r1.peaks.size(); ++i) {
      CHECK(r1.peaks[i].r_main == r2.peaks[i].r_main);
      CHECK(r1.peaks[i].theta_main == r2.peaks[i].theta_main);
      CHECK(r1.peaks[i].votes == r2.peaks[i].votes);
    }
    CHECK(r1.voter_radius == r2.voter_radius);
    CHECK(r1.vertical_histogram == r2.vertical_histogram);
    // The 32-bit steps the GPU path uses give the same peaks as Run.
    std::vector<int32_t> padded(f.ph.PaddedSize(), 0);
    f.ph.VoteCpu(records, padded.data());
    f.ph.Finish(padded.data(), &prepared);
    CHECK(prepared.accumulator == reference);
    REQUIRE(prepared.peaks.size() == r1.peaks.size());
    for (size_t i = 0; i < r1.peaks.size(); ++i) {
      CHECK(prepared.peaks[i].r_main == r1.peaks[i].r_main);
      CHECK(prepared.peaks[i].theta_main == r1.peaks[i].theta_main);
    }
    WARN("edge map " << m << ": " << scan.radius.size() << " edge pixels, " << records.size() << " records, "
                     << r1.n_votes << " votes, " << r1.peaks.size() << " peaks");
  }
}

// The peaks by the definition: every bin of at least min_votes that no bin
// of its +-nms_theta (circular) x +-nms_r neighbourhood beats (a bin before
// it in index order beats it when equal), by votes, ties in index order.
struct BinPeak {
  int plane, k, j, votes;
};
std::vector<BinPeak> ReferencePeaks(const WholeImageResult& r, const WholeImageOptions& o) {
  const int NT = r.n_theta, NR = r.n_r;
  std::vector<BinPeak> peaks;
  for (int p = 0; p < r.n_planes; ++p)
    for (int k = 0; k < NT; ++k)
      for (int j = 0; j < NR; ++j) {
        auto at = [&](int kk, int jj) { return r.accumulator[(static_cast<size_t>(p) * NT + kk) * NR + jj]; };
        const int v = at(k, j);
        bool peak = v >= o.min_votes;
        for (int dk = -o.nms_theta; dk <= o.nms_theta && peak; ++dk)
          for (int dj = -o.nms_r; dj <= o.nms_r && peak; ++dj) {
            const int kk = ((k + dk) % NT + NT) % NT, jj = j + dj;
            if (jj < 0 || jj >= NR || (dk == 0 && dj == 0)) continue;
            const bool before = kk < k || (kk == k && jj < j);
            if (at(kk, jj) > v || (at(kk, jj) == v && before)) peak = false;
          }
        if (peak) peaks.push_back({p, k, j, v});
      }
  std::stable_sort(peaks.begin(), peaks.end(),
                   [](const BinPeak& a, const BinPeak& b) { return a.votes > b.votes; });
  return peaks;
}

TEST_CASE("whole-image peaks equal the peaks by definition (16- and 32-bit counts, any neighbourhood)",
          "[reference_vote]") {
  PANO_SEEDED_RNG(2027);
  Fixture f;
  const cv::Mat room = test::RenderRoom(f.sensor, test::PaperRoom());
  cv::Mat noisy(room.size(), room.type());
  cv::randn(noisy, 0, 12);
  noisy += room;
  const std::vector<EdgeMap> maps = {ComputeEdgeMap(room), ComputeEdgeMap(noisy)};
  struct Nms {
    int r, theta, min_votes;
  };
  for (const Nms& nms : {Nms{4, 4, 15}, Nms{0, 3, 8}, Nms{2, 0, 10}, Nms{1, 6, 20}}) {
    WholeImageOptions o = f.options;
    o.explain_away = false;
    o.max_peaks = 100000;
    o.nms_r = nms.r;
    o.nms_theta = nms.theta;
    o.min_votes = nms.min_votes;
    const PhWholeImage ph = PhWholeImage::Build(*f.table, o);
    for (size_t m = 0; m < maps.size(); ++m) {
      INFO("nms_r " << nms.r << ", nms_theta " << nms.theta << ", edge map " << m);
      std::vector<PhVoteRecord> records;
      WholeImageResult padded32;
      ph.Prepare(maps[m], &records, &padded32);
      std::vector<int32_t> padded(ph.PaddedSize(), 0);
      ph.VoteCpu(records, padded.data());
      ph.Finish(padded.data(), &padded32);
      const WholeImageResult run = ph.Run(maps[m]);  // 16-bit counts for the room, compact planes
      for (const WholeImageResult* r : std::vector<const WholeImageResult*>{&padded32, &run}) {
        const std::vector<BinPeak> want = ReferencePeaks(*r, o);
        REQUIRE(want.size() > 5);
        REQUIRE(r->peaks.size() == want.size());
        for (size_t i = 0; i < want.size(); ++i) {
          const HorizontalPeak& pk = r->peaks[i];
          CHECK(pk.plane == want[i].plane);
          CHECK(pk.votes == want[i].votes);
          // The refined position (RefineOffset) stays within a bin of the bin's centre.
          CHECK(std::abs(pk.r_main / o.r_bin - (want[i].j + 0.5)) <= 1.0 + 1e-9);
          CHECK(std::abs(test::AngleDiff(pk.theta_main, (want[i].k + 0.5) * ph.theta_bin())) <=
                ph.theta_bin() + 1e-9);
        }
      }
    }
  }
}

TEST_CASE("GPU whole-image transform equals the CPU's (batch of frames)", "[gpu_matches_cpu]") {
  std::string reason;
  if (!CudaAvailable(&reason)) {
    test::Skip("hough/gpu_matches_cpu needs a CUDA device: " + reason);
    return;
  }
  Fixture f;
  std::vector<EdgeMap> frames;
  test::RoomScene scene = test::PaperRoom();
  for (int i = 0; i < 3; ++i) {
    scene.pose = {60.0 + 25.0 * i, 90.0 + 10.0 * i, 0.2 * i};
    frames.push_back(ComputeEdgeMap(test::RenderRoom(f.sensor, scene)));
  }
  std::vector<WholeImageResult> gpu;
  GpuTiming timing;
  REQUIRE(HoughWholeImageGpu(f.ph, frames, &gpu, &reason, &timing));
  INFO(reason);
  REQUIRE(gpu.size() == frames.size());
  for (size_t i = 0; i < frames.size(); ++i) {
    const WholeImageResult cpu = f.ph.Run(frames[i]);
    CHECK(cpu.n_votes == gpu[i].n_votes);
    CHECK(cpu.accumulator == gpu[i].accumulator);  // integer votes: tolerance zero
    REQUIRE(cpu.peaks.size() == gpu[i].peaks.size());
    for (size_t k = 0; k < cpu.peaks.size(); ++k) {
      CHECK(cpu.peaks[k].r_main == gpu[i].peaks[k].r_main);
      CHECK(cpu.peaks[k].theta_main == gpu[i].peaks[k].theta_main);
    }
  }
  WARN("GPU batch of 3: kernel " << timing.kernel_ms << " ms, upload " << timing.upload_ms
                                 << " ms, download " << timing.download_ms << " ms");
}

TEST_CASE("whole-image mode rejects bad input with one-line errors", "[bad_input]") {
  Fixture f;
  auto one_line = [](const std::function<void()>& fn) {
    try {
      fn();
      FAIL("no error");
    } catch (const Error& e) {
      CHECK(std::string(e.what()).find('\n') == std::string::npos);
    }
  };
  one_line([&] { f.ph.Run(EdgeMap()); });                       // empty edge map
  one_line([&] { ComputeEdgeMap(cv::Mat()); });                 // empty image
  one_line([&] { ComputeEdgeMap(cv::Mat(10, 10, CV_32F)); });   // wrong depth
  EdgeMap bad = ComputeEdgeMap(cv::Mat(50, 50, CV_8U, cv::Scalar(7)));
  bad.dx = cv::Mat(40, 50, CV_16S);
  one_line([&] { f.ph.Run(bad); });  // mismatched sizes
  WholeImageOptions o = f.options;
  o.r_bin = 0;  // zero-size accumulator
  one_line([&] { PhWholeImage::Build(*f.table, o); });
  o = f.options;
  o.theta_bin = 0;
  one_line([&] { PhWholeImage::Build(*f.table, o); });
  o = f.options;
  o.heights = {std::nan("")};
  one_line([&] { PhWholeImage::Build(*f.table, o); });
  o = f.options;
  o.heights.clear();
  one_line([&] { PhWholeImage::Build(*f.table, o); });
  o = f.options;
  o.orientation_tolerance = std::nan("");
  one_line([&] { PhWholeImage::Build(*f.table, o); });
  one_line([&] { PhWholeImage().Run(bad); });  // not built
  // An edge map without edges is valid: no votes, no peaks.
  const WholeImageResult none = f.ph.Run(ComputeEdgeMap(cv::Mat(500, 500, CV_8U, cv::Scalar(9))));
  CHECK(none.n_votes == 0);
  CHECK(none.peaks.empty());
}

}  // namespace
}  // namespace pano
