#include "panotrack/charuco/charuco.h"

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/core.hpp>

#include <algorithm>
#include <opencv2/imgproc.hpp>

#include "panotrack/core/error.h"

namespace pano {

namespace {

cv::Ptr<cv::aruco::CharucoBoard> MakeBoard(const TargetBoard& board) {
  if (!board.IsCharuco()) throw Error("ChArUco: the board's type is " + board.type + ", not charuco");
  CheckTargetBoard(board);
  const cv::Ptr<cv::aruco::Dictionary> dict = cv::aruco::getPredefinedDictionary(ArucoDictionaryId(board.dictionary));
  // OpenCV counts squares; the target counts inner corners.
  return cv::aruco::CharucoBoard::create(board.cols + 1, board.rows + 1, static_cast<float>(board.square),
                                         static_cast<float>(board.marker), dict);
}

}  // namespace

cv::Mat DrawCharucoBoard(const TargetBoard& board, int pixels_per_square, int margin_px) {
  if (pixels_per_square < 8 || pixels_per_square > 4096)
    throw Error("ChArUco image: expected 8..4096 pixels per square, got " + std::to_string(pixels_per_square));
  if (margin_px < 0) throw Error("ChArUco image: expected a non-negative margin");
  const cv::Ptr<cv::aruco::CharucoBoard> b = MakeBoard(board);
  cv::Mat image;
  try {
    b->draw(cv::Size((board.cols + 1) * pixels_per_square + 2 * margin_px,
                     (board.rows + 1) * pixels_per_square + 2 * margin_px),
            image, margin_px, 1);
  } catch (const cv::Exception& e) {
    throw Error("ChArUco image: OpenCV: " + e.err);
  }
  return image;
}

namespace {

// One orientation: markers, then the corners between them.
CharucoDetection DetectOriented(const cv::Mat& grey, const cv::Ptr<cv::aruco::CharucoBoard>& b) {
  cv::Ptr<cv::aruco::DetectorParameters> params = cv::aruco::DetectorParameters::create();
  // A mirror image squeezes the markers towards its limb: accept small ones
  // (perimeter down to 1 % of the image's larger side rather than 3 %).
  params->minMarkerPerimeterRate = 0.01;
  CharucoDetection out;
  std::vector<std::vector<cv::Point2f>> marker_corners, rejected;
  std::vector<int> marker_ids;
  cv::aruco::detectMarkers(grey, b->dictionary, marker_corners, marker_ids, params, rejected);
  // Markers of another board or a misread code: the board's ids only.
  std::vector<std::vector<cv::Point2f>> kept_corners;
  std::vector<int> kept_ids;
  for (size_t k = 0; k < marker_ids.size(); ++k)
    if (std::find(b->ids.begin(), b->ids.end(), marker_ids[k]) != b->ids.end()) {
      kept_corners.push_back(marker_corners[k]);
      kept_ids.push_back(marker_ids[k]);
    }
  out.markers = static_cast<int>(kept_ids.size());
  if (kept_ids.empty()) return out;
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  cv::aruco::interpolateCornersCharuco(kept_corners, kept_ids, grey, b, corners, ids);
  for (size_t k = 0; k < corners.size(); ++k) {
    out.corners.push_back({corners[k].x, corners[k].y});
    out.ids.push_back(ids[k]);
  }
  return out;
}

}  // namespace

CharucoDetection DetectCharuco(const cv::Mat& grey, const TargetBoard& board) {
  const cv::Ptr<cv::aruco::CharucoBoard> b = MakeBoard(board);
  try {
    // A mirror shows the board reflected, and ArUco codes do not read in a
    // reflection: the image flipped left to right first (a catadioptric
    // image), then as it is (an image already flipped, a perspective view).
    cv::Mat flipped;
    cv::flip(grey, flipped, 1);
    CharucoDetection best = DetectOriented(flipped, b);
    for (Eigen::Vector2d& c : best.corners) c.x() = grey.cols - 1 - c.x();
    const CharucoDetection direct = DetectOriented(grey, b);
    if (direct.corners.size() > best.corners.size()) best = direct;
    return best;
  } catch (const cv::Exception& e) {
    throw Error("ChArUco detection: OpenCV: " + e.err);
  }
}

}  // namespace pano
