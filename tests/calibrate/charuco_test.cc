// ChArUco boards: the printed image's geometry, detection in a mirror image
// (reflected), and the calibration from rendered boards that run past the
// mirror's limb (partial views), from a folder of images.
#include <catch2/catch.hpp>

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <string>

#include "panotrack/calibrate/calibrate.h"
#include "panotrack/charuco/charuco.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/targets.h"
#include "panotrack/render/targets_render.h"
#include "panotrack/pipeline/target_input.h"
#include "synthetic.h"
#include "test_paths.h"

namespace pano {
namespace {

TargetBoard Charuco(int cols, int rows, double square, double marker) {
  TargetBoard b;
  b.type = "charuco";
  b.cols = cols;
  b.rows = rows;
  b.square = square;
  b.marker = marker;
  b.dictionary = "DICT_4X4_50";
  return b;
}

TEST_CASE("the printed ChArUco board: corner ids where the board frame says, in a mirror too",
          "[charuco_board]") {
  const TargetBoard board = Charuco(5, 4, 3.0, 2.2);
  const int ppsq = 40, margin = 20;
  const cv::Mat image = DrawCharucoBoard(board, ppsq, margin);
  CHECK(image.cols == 6 * ppsq + 2 * margin);
  CHECK(image.rows == 5 * ppsq + 2 * margin);
  CHECK(image.at<uint8_t>(margin + 5, margin + 5) == 0);  // the origin's top-left square is black
  for (const bool mirrored : {false, true}) {
    INFO((mirrored ? "reflected image" : "image as printed"));
    cv::Mat shown = image;
    if (mirrored) cv::flip(image, shown, 1);
    const CharucoDetection d = DetectCharuco(shown, board);
    CHECK(d.markers == CharucoMarkerCount(board));
    REQUIRE(d.ids.size() == 20u);
    for (size_t k = 0; k < d.ids.size(); ++k) {
      const int i = d.ids[k] % board.cols, j = d.ids[k] / board.cols;
      double x = margin + (i + 1) * ppsq - 0.5, y = margin + (j + 1) * ppsq - 0.5;
      if (mirrored) x = image.cols - 1 - x;
      // Measured: 0.6-0.7 px off on these hard-edged squares (cornerSubPix).
      CHECK(d.corners[k].x() == Approx(x).margin(1.0));
      CHECK(d.corners[k].y() == Approx(y).margin(1.0));
    }
  }
  TargetBoard chess = board;
  chess.type = "chessboard";
  CHECK_THROWS_WITH(DrawCharucoBoard(chess, ppsq), Catch::Contains("not charuco"));
}

TEST_CASE("partial views: corner ids through the weights and the fit", "[partial_views]") {
  // Synthetic corners (known poses), then every other view cut to the
  // corners of its left half: the fit is the same to within the noise.
  std::mt19937_64 rng(17);
  TargetBoard board;
  board.cols = 9;
  board.rows = 6;
  board.square = 3.0;
  const Sensor truth = ReadCalibration(test::SourcePath("calib/paper-real.yaml")).sensor;
  auto set = test::MakeSyntheticSet(truth, board, 6, 12.0, 30.0, -30.0, 10.0, 0.05, rng);
  REQUIRE(set.views.size() == 6);
  for (size_t v = 0; v < set.views.size(); v += 2) {
    BoardView& view = set.views[v];
    std::vector<Eigen::Vector2d> kept;
    std::vector<int> ids;
    for (int id = static_cast<int>(view.corners.size()) - 1; id >= 0; --id)  // any order will do
      if (id % board.cols < 5) {
        kept.push_back(view.corners[static_cast<size_t>(id)]);
        ids.push_back(id);
      }
    view.corners = kept;
    view.ids = ids;
  }
  const CalibrationResult r = CalibrateViews(set.views, board, truth.image_width, truth.image_height, "cm",
                                             CalibrateOptions());
  CHECK(r.rms_px < 0.08);
  CHECK(r.calib.sensor.params.focal_px == Approx(truth.params.focal_px).epsilon(0.002));
  CHECK(r.calib.sensor.mirror_distance() == Approx(truth.mirror_distance()).epsilon(0.002));
  REQUIRE(r.residuals.size() == 6);
  CHECK(r.residuals[0].size() == 30);

  // Too few corners, repeated or out-of-range ids: errors that name the view.
  std::vector<BoardView> bad = set.views;
  bad[0].ids.resize(7);
  bad[0].corners.resize(7);
  CHECK_THROWS_WITH(CalibrateViews(bad, board, truth.image_width, truth.image_height, "cm", CalibrateOptions()),
                    Catch::Contains("synthetic_0") && Catch::Contains("at least 8"));
  bad = set.views;
  bad[0].ids[1] = bad[0].ids[0];
  CHECK_THROWS_WITH(CalibrateViews(bad, board, truth.image_width, truth.image_height, "cm", CalibrateOptions()),
                    Catch::Contains("given twice"));
  bad = set.views;
  bad[0].ids[0] = 54;
  CHECK_THROWS_WITH(CalibrateViews(bad, board, truth.image_width, truth.image_height, "cm", CalibrateOptions()),
                    Catch::Contains("outside the board"));
  // One row only: no pose from it.
  CHECK_FALSE(EnoughCorners({0, 1, 2, 3, 4, 5, 6, 7, 8}, board));
  CHECK(EnoughCorners({0, 1, 2, 3, 9, 10, 11, 12}, board));
}

TEST_CASE("ChArUco boards past the mirror's limb calibrate from a folder of images", "[charuco]") {
  // 10 boards (9 x 6 inner corners, 3 cm squares, 2.2 cm markers) rendered
  // through the paper's sphere at 640 x 480 with 2 grey levels of noise,
  // each with at least 40 % of its corners in view.
  const Calibration truth = ReadCalibration(test::SourcePath("calib/paper-real.yaml"));
  const std::string dir = test::ScratchDir("calibrate_charuco") + "/t";
  const TargetBoard board = Charuco(9, 6, 3.0, 2.2);
  const std::vector<BoardPose> poses = AutoBoardPoses(truth.sensor, board, 10, 1, 0.4);
  RenderOptions ro;
  ro.noise_sigma = 2.0;
  ro.seed = 1;
  TargetsWriteOptions wo;
  wo.overwrite = true;
  WriteTargetImages(dir, truth, board, poses, ro, wo);
  int fully_visible = 0;
  for (const BoardPose& p : poses) fully_visible += BoardFullyVisible(truth.sensor, board, p, 0.0, 1.0);

  TargetInputBoard input;
  input.board_given = true;
  input.board = board;
  const TargetSet from_folder = ReadTargetInput(dir, input);
  REQUIRE(from_folder.images.size() == 10);
  CalibrateOptions o;
  o.num_threads = 2;
  const CalibrationResult r = Calibrate(from_folder, LoadTargetImages(from_folder), o);

  // The folder gives exactly the target file's input, and so its calibration
  // (to the last digits the thread schedule leaves, as in [concurrent]).
  const TargetSet from_file = ReadTargets(dir + "/targets_unknown.yaml");
  REQUIRE(from_file.images.size() == from_folder.images.size());
  for (size_t k = 0; k < from_file.images.size(); ++k) {
    CHECK(from_folder.images[k].file == from_file.images[k].file);
    CHECK(from_folder.images[k].resolved == from_file.images[k].resolved);
  }
  CHECK(TargetsToYaml(from_folder) == TargetsToYaml(from_file));
  const CalibrationResult from_yaml = Calibrate(from_file, LoadTargetImages(from_file), o);
  REQUIRE(from_yaml.parameters.size() == r.parameters.size());
  for (size_t k = 0; k < r.parameters.size(); ++k)
    CHECK(from_yaml.parameters[k].value == Approx(r.parameters[k].value).epsilon(1e-9));
  CHECK(from_yaml.rms_px == Approx(r.rms_px).epsilon(1e-9));
  REQUIRE(from_yaml.views.size() == r.views.size());

  // Boards partly outside the mirror: a chessboard is never found there.
  int partial = 0, raw = 0, past_limb = 0;
  size_t fewest = 54;
  for (const BoardView& v : r.views) {
    partial += v.corners.size() < 54;
    raw += v.method == "raw";
    past_limb += !BoardFullyVisible(truth.sensor, board, poses[static_cast<size_t>(v.image_index)], 0.0, 1.0);
    fewest = std::min(fewest, v.corners.size());
  }
  const Sensor& s = r.calib.sensor;
  WARN("ChArUco: " << r.views.size() << " of 10 boards used (" << raw << " raw, " << partial
                   << " partial, fewest corners " << fewest << ", " << past_limb << " past the limb; "
                   << fully_visible << " fully in view), RMS " << r.rms_px << " px, focal " << s.params.focal_px << ", mirror "
                   << s.params.curvature_radius << " at " << s.mirror_distance());
  // Measured: 8 boards (4 raw, the rest in unwarped views), all partial
  // (markers near the limb are too small to read), 1 past the limb; RMS
  // 0.0956 px; focal 621.0 (truth 590, +5.3 %), mirror radius 4.61 (4.9,
  // -5.9 %) at 14.83 (15.1, -1.8 %). Before the unwarped boards were
  // searched again through the final model: RMS 0.109 px, focal 607.3
  // (+2.9 %), radius 4.68 (-4.5 %): with estimated poses the boards leave a
  // valley of focal length and mirror size, along which the new corners
  // move the fit.
  CHECK(r.views.size() == 8);
  CHECK(partial >= 1);
  CHECK(past_limb >= 1);
  CHECK(r.rms_px < 0.12);
  CHECK(s.params.focal_px == Approx(truth.sensor.params.focal_px).epsilon(0.06));
  CHECK(s.params.cx == Approx(truth.sensor.params.cx).margin(0.3));
  CHECK(s.params.cy == Approx(truth.sensor.params.cy).margin(0.3));
  CHECK(s.params.curvature_radius == Approx(truth.sensor.params.curvature_radius).epsilon(0.065));
  CHECK(s.mirror_distance() == Approx(truth.sensor.mirror_distance()).epsilon(0.027));
}

}  // namespace
}  // namespace pano
