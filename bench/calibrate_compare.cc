// calibrate_compare TARGETS.yaml: detects the board in the raw images once
// (findChessboardCornersSB, the same corners for every model), then fits
//   - panotrack's conic model (k1, k2 lens distortion),
//   - panotrack's sphere model,
//   - OpenCV's cv::omnidir::calibrate (Mei's unified model, k1 k2 p1 p2),
// and prints each one's Euclidean RMS reprojection error over all corners
// (rigid board poses), plus the full `Calibrate` pipeline (with the unwarped
// retry of images without a board) and its time.
#include <opencv2/calib3d.hpp>
#include <opencv2/ccalib/omnidir.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>

#include "panotrack/calibrate/calibrate.h"
#include "panotrack/calibrate/omnidir_peer.h"
#include "panotrack/io/targets.h"

namespace {

double Seconds(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// OpenCV omnidir on the same corners (calibrate/omnidir_peer.h); prints its
// parameters and returns the Euclidean RMS over the images it kept.
double OmnidirRms(const std::vector<pano::BoardView>& views, const pano::TargetBoard& board, cv::Size size,
                  int* used, double* seconds, int flags = 0) {
  const pano::OmnidirFit f = pano::FitOmnidir(views, board, size, flags);
  *used = f.images_used;
  *seconds = f.seconds;
  std::printf("  omnidir: fx %.2f fy %.2f s %.4f cx %.2f cy %.2f xi %.4f D [%.4f %.4f %.5f %.5f]\n",
              f.K.at<double>(0, 0), f.K.at<double>(1, 1), f.K.at<double>(0, 1), f.K.at<double>(0, 2),
              f.K.at<double>(1, 2), f.xi.at<double>(0), f.D.at<double>(0), f.D.at<double>(1), f.D.at<double>(2),
              f.D.at<double>(3));
  return f.rms_px;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: calibrate_compare TARGETS.yaml\n");
    return 2;
  }
  try {
    const pano::TargetSet t = pano::ReadTargets(argv[1]);
    const std::vector<cv::Mat> images = pano::LoadTargetImages(t);
    pano::CalibrateOptions conic;
    conic.model = pano::MirrorModel::kConic;
    const pano::DetectionResult det = pano::DetectBoards(t, images, conic);
    const int W = det.image_width, H = det.image_height;
    std::printf("%s: %zu images, board found in %zu by findChessboardCornersSB on the raw image (%.2f s)\n",
                argv[1], t.images.size(), det.views.size(), det.seconds);

    auto t0 = std::chrono::steady_clock::now();
    const pano::CalibrationResult rc = pano::CalibrateViews(det.views, t.board, W, H, t.units, conic);
    const double tc = Seconds(t0);
    std::printf("%s", pano::Summary(rc).c_str());
    pano::CalibrateOptions sphere;
    t0 = std::chrono::steady_clock::now();
    const pano::CalibrationResult rs = pano::CalibrateViews(det.views, t.board, W, H, t.units, sphere);
    const double ts = Seconds(t0);
    pano::CalibrateOptions conic_ls = conic;
    conic_ls.huber_px = 0.0;  // omnidir's objective: plain least squares,
    conic_ls.full_weight_px = 0.0;  // every corner weighted the same
    const pano::CalibrationResult rcl = pano::CalibrateViews(det.views, t.board, W, H, t.units, conic_ls);
    pano::CalibrateOptions conic0 = conic;
    conic0.distortion_terms = 0;
    const pano::CalibrationResult rc0 = pano::CalibrateViews(det.views, t.board, W, H, t.units, conic0);
    int used = 0;
    double to = 0;
    const double omni = OmnidirRms(det.views, t.board, cv::Size(W, H), &used, &to);

    // The whole pipeline: detection, fit, unwarped retry, refit.
    t0 = std::chrono::steady_clock::now();
    const pano::CalibrationResult full = pano::Calibrate(t, images, conic);
    const double tf = Seconds(t0);

    std::printf("\nsame %zu raw-detected boards (%zu corners):\n", det.views.size(),
                det.views.size() * t.board.cols * t.board.rows);
    std::printf("  panotrack conic (k1,k2)   RMS %.4f px  fit %.2f s\n", rc.rms_px, tc);
    std::printf("  panotrack conic, least sq. RMS %.4f px\n", rcl.rms_px);
    std::printf("  panotrack conic (no dist) RMS %.4f px\n", rc0.rms_px);
    std::printf("  panotrack sphere          RMS %.4f px  fit %.2f s\n", rs.rms_px, ts);
    std::printf("  OpenCV omnidir (Mei)      RMS %.4f px  fit %.2f s  (%d boards kept)\n", omni, to, used);
    {
      // omnidir without its skew and/or tangential terms (our model has neither).
      for (int fl : {static_cast<int>(cv::omnidir::CALIB_FIX_SKEW), cv::omnidir::CALIB_FIX_P1 | cv::omnidir::CALIB_FIX_P2,
                     cv::omnidir::CALIB_FIX_SKEW | cv::omnidir::CALIB_FIX_P1 | cv::omnidir::CALIB_FIX_P2}) {
        int u2 = 0;
        double t2 = 0;
        const double r2 = OmnidirRms(det.views, t.board, cv::Size(W, H), &u2, &t2, fl);
        std::printf("  OpenCV omnidir, %-14s RMS %.4f px\n",
                    fl == cv::omnidir::CALIB_FIX_SKEW ? "skew fixed" : fl == (cv::omnidir::CALIB_FIX_P1 | cv::omnidir::CALIB_FIX_P2) ? "p1 p2 fixed" : "skew, p fixed", r2);
      }
    }
    std::printf("full pipeline (conic, with unwarped retry): %zu of %zu boards, RMS %.4f px, "
                "detection %.2f s + fit %.2f s = %.2f s\n",
                full.views.size(), t.images.size(), full.rms_px, full.seconds_detect, full.seconds_fit, tf);
    {
      // The corners the pipeline refined on the board plane (step 5), given
      // to every model: the fair comparison for the refined pipeline.
      std::vector<pano::BoardView> refined = full.views;
      for (pano::BoardView& v : refined) v.has_pose = false;
      const pano::CalibrationResult rc2 = pano::CalibrateViews(refined, t.board, W, H, t.units, conic);
      const pano::CalibrationResult rcl2 = pano::CalibrateViews(refined, t.board, W, H, t.units, conic_ls);
      const pano::CalibrationResult rs2 = pano::CalibrateViews(refined, t.board, W, H, t.units, sphere);
      int u3 = 0;
      double t3 = 0;
      const double omni2 = OmnidirRms(refined, t.board, cv::Size(W, H), &u3, &t3);
      std::printf("\nsame %zu boards, corners refined through the model (step 5):\n", refined.size());
      std::printf("  panotrack conic (k1,k2)   RMS %.4f px\n", rc2.rms_px);
      std::printf("  panotrack conic, least sq. RMS %.4f px\n", rcl2.rms_px);
      std::printf("  panotrack sphere          RMS %.4f px\n", rs2.rms_px);
      std::printf("  OpenCV omnidir (Mei)      RMS %.4f px  (%d boards kept)\n", omni2, u3);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "calibrate_compare: %s\n", e.what());
    return 1;
  }
  return 0;
}
