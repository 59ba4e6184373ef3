// Step 1 and 4: chessboard corners in raw mirror images, and in views
// unwarped through a fitted model where the raw image fails.
#include <ceres/rotation.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <memory>

#include "panotrack/calibrate/calibrate.h"
#include "panotrack/calibrate/internal.h"
#include "panotrack/charuco/charuco.h"
#include "panotrack/core/angles.h"
#include "panotrack/core/error.h"
#include "panotrack/core/parallel.h"

namespace pano {

std::vector<Eigen::Vector3d> BoardPoints(const TargetBoard& board) {
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(static_cast<size_t>(board.cols) * board.rows);
  for (int j = 0; j < board.rows; ++j)
    for (int i = 0; i < board.cols; ++i) pts.push_back({i * board.square, j * board.square, 0.0});
  return pts;
}

bool EnoughCorners(const std::vector<int>& ids, const TargetBoard& board) {
  if (static_cast<int>(ids.size()) < kMinPartialCorners || board.cols < 1) return false;
  std::vector<int> rows, cols;
  for (int id : ids) {
    rows.push_back(id / board.cols);
    cols.push_back(id % board.cols);
  }
  auto distinct = [](std::vector<int> v) {
    std::sort(v.begin(), v.end());
    return std::unique(v.begin(), v.end()) - v.begin();
  };
  return distinct(rows) >= 2 && distinct(cols) >= 2;
}

void CheckBoardView(const BoardView& view, const TargetBoard& board) {
  const size_t n_points = static_cast<size_t>(board.cols) * board.rows;
  if (!view.Partial()) {
    if (view.corners.size() != n_points)
      throw Error(view.file + ": expected " + std::to_string(n_points) + " corners (the full " +
                  std::to_string(board.cols) + " x " + std::to_string(board.rows) + " grid), got " +
                  std::to_string(view.corners.size()) + " without corner ids");
    return;
  }
  if (view.ids.size() != view.corners.size())
    throw Error(view.file + ": " + std::to_string(view.corners.size()) + " corners but " +
                std::to_string(view.ids.size()) + " corner ids");
  std::vector<char> seen(n_points, 0);
  for (int id : view.ids) {
    if (id < 0 || static_cast<size_t>(id) >= n_points)
      throw Error(view.file + ": corner id " + std::to_string(id) + " outside the board's 0.." +
                  std::to_string(n_points - 1));
    if (seen[static_cast<size_t>(id)]++) throw Error(view.file + ": corner id " + std::to_string(id) + " given twice");
  }
  if (!EnoughCorners(view.ids, board))
    throw Error(view.file + ": " + std::to_string(view.ids.size()) + " corners; a partial view needs at least " +
                std::to_string(kMinPartialCorners) + " on 2 rows and 2 columns of the board");
}

namespace {

// findChessboardCornersSB draws on OpenCV's per-thread random generator, and
// whether it finds a board depends on that state: a fixed seed before every
// call makes detection independent of the thread that runs it and of what ran
// before (so results do not depend on the thread count).
void SeedDetector() { cv::theRNG().state = 0x5eed5eedULL; }

// OpenCV's reason for an error, on one line (what() adds the source file).
std::string OpenCvReason(const cv::Exception& e) {
  return "OpenCV: " + e.err + (e.func.empty() ? "" : " in " + e.func);
}

// A ChArUco detection as a view's corners and ids, in id order; false when
// too few corners (EnoughCorners).
bool CharucoCorners(const CharucoDetection& d, const TargetBoard& board, std::vector<Eigen::Vector2d>* corners,
                    std::vector<int>* ids) {
  if (!EnoughCorners(d.ids, board)) return false;
  std::vector<size_t> order(d.ids.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return d.ids[a] < d.ids[b]; });
  corners->clear();
  ids->clear();
  for (size_t k : order) {
    corners->push_back(d.corners[k]);
    ids->push_back(d.ids[k]);
  }
  return true;
}

// The board in a raw image; false when not found, and then `failure` says
// why when the search raised an error. A ChArUco board's corners come with
// their ids (a chessboard's: none, the full grid).
bool FindRaw(const cv::Mat& image, const TargetBoard& board, bool exhaustive, std::vector<Eigen::Vector2d>* corners,
             std::vector<int>* ids, std::string* failure) {
  if (board.IsCharuco()) {
    try {
      return CharucoCorners(DetectCharuco(image, board), board, corners, ids);
    } catch (const Error& e) {
      *failure = e.what();
      return false;
    }
  }
  std::vector<cv::Point2f> c;
  bool ok = false;
  // The quick search (without CALIB_CB_EXHAUSTIVE: a third of the time of
  // the exhaustive one, which the caller runs where this fails and the model
  // cannot help), with CALIB_CB_ACCURACY: these corners are the ones
  // `evaluate --no-refine` scores, and on rendered boards they lie 0.04 -
  // 0.10 px from the truth's pose fit against 0.10 - 0.21 px without it.
  // The quick search without it where it fails: it finds a few boards the
  // accurate one misses (one of 7 rendered paper-real boards).
  const int flags = cv::CALIB_CB_ACCURACY | (exhaustive ? cv::CALIB_CB_EXHAUSTIVE : 0);
  for (const int f : {flags, exhaustive ? -1 : 0}) {
    if (f < 0 || ok) break;
    try {
      SeedDetector();
      ok = cv::findChessboardCornersSB(image, cv::Size(board.cols, board.rows), c, f);
    } catch (const cv::Exception& e) {
      ok = false;
      if (failure->empty()) *failure = OpenCvReason(e);
    }
  }
  if (ok) failure->clear();
  if (!ok || c.size() != static_cast<size_t>(board.cols * board.rows)) return false;
  corners->clear();
  for (const cv::Point2f& p : c) corners->push_back({p.x, p.y});
  return true;
}

// FindRaw on the images `indices` (target file indices), in parallel; each
// result at the index's position.
struct RawSearch {
  std::vector<std::vector<Eigen::Vector2d>> corners;
  std::vector<std::vector<int>> ids;
  std::vector<std::string> failures;
  std::vector<char> ok;
};

RawSearch SearchRaw(const std::vector<cv::Mat>& images, const TargetBoard& board, const std::vector<int>& indices,
                    bool exhaustive, int threads) {
  const int n = static_cast<int>(indices.size());
  RawSearch r{std::vector<std::vector<Eigen::Vector2d>>(n), std::vector<std::vector<int>>(n),
              std::vector<std::string>(n), std::vector<char>(n, 0)};
  ParallelFor(
      n,
      [&](int k) {
        r.ok[k] = FindRaw(images[indices[k]], board, exhaustive, &r.corners[k], &r.ids[k], &r.failures[k]);
      },
      true, threads);
  return r;
}

}  // namespace

DetectionResult DetectBoards(const TargetSet& targets, const std::vector<cv::Mat>& images,
                             const CalibrateOptions& options, bool defer_to_unwarped) {
  const auto t0 = std::chrono::steady_clock::now();
  if (images.size() != targets.images.size()) throw Error("corner detection: internal: image count");
  DetectionResult det;
  if (images.empty()) return det;
  det.image_width = images.front().cols;
  det.image_height = images.front().rows;
  const int n = static_cast<int>(images.size());
  std::vector<int> all(n);
  std::iota(all.begin(), all.end(), 0);
  RawSearch found = SearchRaw(images, targets.board, all, false, options.Threads());
  // The exhaustive search where the quick one failed, unless deferred: the
  // boards found are enough for a fit whose unwarped views find the rest
  // (faster, and surer for boards squeezed near the limb, where both raw
  // searches fail).
  const int n_found = static_cast<int>(std::count(found.ok.begin(), found.ok.end(), 1));
  const bool defer = defer_to_unwarped && options.unwarp_fallback && n_found >= std::max(4, n / 2);
  det.exhaustive_deferred = defer && !targets.board.IsCharuco();
  if (!targets.board.IsCharuco() && !defer) {
    std::vector<int> retry;
    for (int i = 0; i < n; ++i)
      if (!found.ok[i]) retry.push_back(i);
    RawSearch again = SearchRaw(images, targets.board, retry, true, options.Threads());
    for (size_t k = 0; k < retry.size(); ++k) {
      const int i = retry[k];
      found.ok[i] = again.ok[k];
      found.corners[i] = std::move(again.corners[k]);
      found.ids[i] = std::move(again.ids[k]);
      // The first search's error stands when both raised one.
      if (again.ok[k]) found.failures[i].clear();
      else if (found.failures[i].empty()) found.failures[i] = std::move(again.failures[k]);
    }
  }
  for (int i = 0; i < n; ++i) {
    if (found.ok[i]) {
      det.views.push_back(calib_internal::ViewOfImage(targets, i, found.corners[i], "raw"));
      det.views.back().ids = found.ids[i];
      continue;
    }
    det.not_found.push_back(i);
    det.not_found_files.push_back(targets.images[i].file);
    if (!found.failures[i].empty())
      det.warnings.push_back(targets.images[i].file + ": the " + (targets.board.IsCharuco() ? "ChArUco" : "chessboard") +
                             " search failed (" + found.failures[i] + ")");
  }
  det.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return det;
}

std::vector<BoardView> FindBoardsExhaustive(const TargetSet& targets, const std::vector<cv::Mat>& images,
                                            const std::vector<int>& missing, int threads) {
  if (targets.board.IsCharuco()) return {};
  const RawSearch found = SearchRaw(images, targets.board, missing, true, threads);
  std::vector<BoardView> views;
  for (size_t k = 0; k < missing.size(); ++k)
    if (found.ok[k]) views.push_back(calib_internal::ViewOfImage(targets, missing[k], found.corners[k], "raw"));
  return views;
}

namespace {

// One virtual perspective view: the pixel maps into the raw image.
struct VirtualView {
  cv::Mat mapx, mapy;
  int n_valid = 0;
};

VirtualView MakeView(const Sensor& sensor, double az, double el, double distance, int size, double fv) {
  // The maps are smooth: computed on a coarse grid (every 8 pixels) and
  // interpolated; invalid nodes (off the mirror or the image) poison their
  // neighbourhood so that remap fills it with the border value.
  const int step = 8, n = size / step + 1;
  cv::Mat cx(n, n, CV_32F), cy(n, n, CV_32F);
  const double zv = sensor.params.vertex_distance;
  const Eigen::Vector3d fwd(std::cos(az) * std::cos(el), std::sin(az) * std::cos(el), std::sin(el));
  const Eigen::Vector3d right(std::sin(az), -std::cos(az), 0.0);
  const Eigen::Vector3d down = fwd.cross(right);
  VirtualView vv;
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) {
      const double pc = c * step, pr = r * step;
      const Eigen::Vector3d d = (fv * fwd + (pc - 0.5 * (size - 1)) * right + (pr - 0.5 * (size - 1)) * down).normalized();
      const Eigen::Vector3d P = Eigen::Vector3d(0, 0, zv) + distance * d;
      Eigen::Vector2d px;
      if (sensor.project(P, &px) && sensor.inside_image(px)) {
        cx.at<float>(r, c) = static_cast<float>(px.x());
        cy.at<float>(r, c) = static_cast<float>(px.y());
        ++vv.n_valid;
      } else {
        cx.at<float>(r, c) = -1e5f;
        cy.at<float>(r, c) = -1e5f;
      }
    }
  vv.n_valid *= step * step;
  // Node (r, c) sits at pixel (r * step, c * step): bilinear between nodes.
  cv::Mat fx(size, size, CV_32F), fy(size, size, CV_32F);
  for (int r = 0; r < size; ++r) {
    const int r0 = std::min(r / step, n - 2);
    const float wr = static_cast<float>(r - r0 * step) / step;
    for (int c = 0; c < size; ++c) {
      const int c0 = std::min(c / step, n - 2);
      const float wc = static_cast<float>(c - c0 * step) / step;
      auto lerp = [&](const cv::Mat& m) {
        return (1 - wr) * ((1 - wc) * m.at<float>(r0, c0) + wc * m.at<float>(r0, c0 + 1)) +
               wr * ((1 - wc) * m.at<float>(r0 + 1, c0) + wc * m.at<float>(r0 + 1, c0 + 1));
      };
      const float x = lerp(cx), y = lerp(cy);
      fx.at<float>(r, c) = x < -1.0f ? -1000.f : x;
      fy.at<float>(r, c) = y < -1.0f ? -1000.f : y;
    }
  }
  vv.mapx = fx;
  vv.mapy = fy;
  return vv;
}

// Detects the board in one view; corners mapped back to the raw image.
// False when not found, and then `failure` says why when the search raised an error.
// A ChArUco board's corners come with their ids (`ids`); those whose
// neighbourhood leaves the mirror in the view are dropped.
bool DetectInView(const cv::Mat& image, const TargetBoard& board, const VirtualView& vv, int size,
                  std::vector<cv::Point2f>* raw, std::vector<int>* ids, std::string* failure) {
  if (vv.n_valid < size * size / 10) return false;
  cv::Mat view;
  cv::remap(image, view, vv.mapx, vv.mapy, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(128));
  std::vector<cv::Point2f> c;
  std::vector<int> c_ids;
  bool ok = false;
  if (board.IsCharuco()) {
    try {
      const CharucoDetection d = DetectCharuco(view, board);
      for (size_t k = 0; k < d.corners.size(); ++k) {
        c.push_back(cv::Point2f(static_cast<float>(d.corners[k].x()), static_cast<float>(d.corners[k].y())));
        c_ids.push_back(d.ids[k]);
      }
    } catch (const Error& e) {
      *failure = e.what();
      return false;
    }
  } else {
    try {
      SeedDetector();
      // Without CALIB_CB_ACCURACY (three times the time): the corners are
      // refined in the raw image and then through the model.
      ok = cv::findChessboardCornersSB(view, cv::Size(board.cols, board.rows), c, cv::CALIB_CB_NORMALIZE_IMAGE);
    } catch (const cv::Exception& e) {
      ok = false;
      *failure = OpenCvReason(e);
    }
    if (!ok || c.size() != static_cast<size_t>(board.cols * board.rows)) return false;
  }
  raw->clear();
  ids->clear();
  for (size_t k = 0; k < c.size(); ++k) {
    const cv::Point2f& q = c[k];
    const int x0 = std::clamp(static_cast<int>(std::floor(q.x)), 0, size - 2);
    const int y0 = std::clamp(static_cast<int>(std::floor(q.y)), 0, size - 2);
    const float fx = q.x - x0, fy = q.y - y0;
    float mx = 0, my = 0;
    bool inside = true;
    for (int dy = 0; dy <= 1; ++dy)
      for (int dx = 0; dx <= 1; ++dx) {
        const float w = (dx ? fx : 1 - fx) * (dy ? fy : 1 - fy);
        const float ax = vv.mapx.at<float>(y0 + dy, x0 + dx), ay = vv.mapy.at<float>(y0 + dy, x0 + dx);
        inside = inside && ax >= -100.f;
        mx += w * ax;
        my += w * ay;
      }
    if (!inside) {
      if (!board.IsCharuco()) return false;
      continue;
    }
    raw->push_back({mx, my});
    if (board.IsCharuco()) ids->push_back(c_ids[k]);
  }
  return !board.IsCharuco() || EnoughCorners(*ids, board);
}

}  // namespace

namespace {

// Most likely board centre in the raw image: the densest cluster of saddle
// points (local maxima of -det(Hessian), the chessboard's X junctions).
bool SaddleClusterCentre(const cv::Mat& image, cv::Point* centre) {
  cv::Mat f;
  image.convertTo(f, CV_32F, 1.0 / 255.0);
  cv::GaussianBlur(f, f, cv::Size(0, 0), 2.0);
  cv::Mat xx, yy, xy;
  cv::Sobel(f, xx, CV_32F, 2, 0, 5);
  cv::Sobel(f, yy, CV_32F, 0, 2, 5);
  cv::Sobel(f, xy, CV_32F, 1, 1, 5);
  const cv::Mat s = xy.mul(xy) - xx.mul(yy);
  double mx = 0;
  cv::minMaxLoc(s, nullptr, &mx);
  if (!(mx > 0)) return false;
  cv::Mat dil;
  cv::dilate(s, dil, cv::Mat(), cv::Point(-1, -1), 3);
  const cv::Mat peaks = (s >= dil) & (s > 0.05 * mx);
  cv::Mat pf, dens;
  peaks.convertTo(pf, CV_32F, 1.0 / 255.0);
  const int win = std::max(31, std::min(image.cols, image.rows) / 4) | 1;
  cv::boxFilter(pf, dens, -1, cv::Size(win, win), cv::Point(-1, -1), false);
  double dm = 0;
  cv::minMaxLoc(dens, nullptr, &dm, nullptr, centre);
  if (dm < 4) return false;
  // Mean shift over the saddle points to the cluster's centroid.
  std::vector<cv::Point> pk;
  cv::findNonZero(peaks, pk);
  cv::Point2d c(*centre);
  for (int it = 0; it < 10; ++it) {
    cv::Point2d sum(0, 0);
    int n = 0;
    for (const cv::Point& p : pk)
      if (std::hypot(p.x - c.x, p.y - c.y) < win) {
        sum += cv::Point2d(p.x, p.y);
        ++n;
      }
    if (n == 0) break;
    c = sum / n;
  }
  *centre = cv::Point(static_cast<int>(std::lround(c.x)), static_cast<int>(std::lround(c.y)));
  return true;
}

bool CornersInView(const cv::Mat& image, const TargetBoard& board, const Sensor& sensor, double az, double el,
                   double distance, std::vector<cv::Point2f>* raw, std::vector<int>* ids, std::string* failure) {
  const int size = 800;
  const double fov = 130.0 * M_PI / 180.0;
  const double fv = 0.5 * size / std::tan(0.5 * fov);
  const VirtualView vv = MakeView(sensor, az, el, distance, size, fv);
  return DetectInView(image, board, vv, size, raw, ids, failure);
}

}  // namespace

bool DetectBoardUnwarped(const cv::Mat& image, const TargetBoard& board, const Sensor& sensor,
                         double distance, double height, std::vector<Eigen::Vector2d>* corners,
                         int num_threads, std::string* failure, std::vector<int>* ids) {
  if (board.IsCharuco() && !ids) throw Error("ChArUco detection in unwarped views: internal: no ids");
  // Virtual pinhole views (100 degrees wide) from the mirror's vertex: aimed
  // first at the densest cluster of saddle points (and 20 degrees below and
  // above it), then 8 azimuth sectors at the boards' typical elevation.
  const double zv = sensor.params.vertex_distance;
  std::vector<std::pair<double, double>> dirs;  // (azimuth, elevation)
  cv::Point c;
  if (SaddleClusterCentre(image, &c)) {
    Eigen::Vector3d o, d;
    if (sensor.backproject(Eigen::Vector2d(c.x, c.y), &o, &d)) {
      const Eigen::Vector3d P = o + distance * d;
      const double az = std::atan2(P.y(), P.x()), el = std::atan2(P.z() - zv, std::hypot(P.x(), P.y()));
      const double d20 = 20.0 * M_PI / 180.0;
      for (double e : {el, el - d20, el + d20}) dirs.push_back({az, e});
      for (double a : {az - d20, az + d20}) dirs.push_back({a, el});
    }
  }
  const double el0 = std::atan2(height - zv, distance);
  for (int k = 0; k < 8; ++k) dirs.push_back({k * M_PI / 4.0, el0});
  const int n = static_cast<int>(dirs.size());
  std::vector<std::vector<cv::Point2f>> found(n);
  std::vector<std::vector<int>> found_ids(n);
  std::vector<std::string> failures(n);
  std::vector<char> ok(n, 0);
  // In batches of one view per thread so that an early success stops the
  // search (the first view in order that shows the board wins, whatever the
  // batch). Without a thread count: one at a time when the caller already
  // runs in parallel.
  const int batch = num_threads > 0 ? ThreadCount(num_threads) : InParallelRegion() ? 1 : ThreadCount(0);
  for (int b0 = 0; b0 < n; b0 += batch) {
    const int b1 = std::min(n, b0 + batch);
    ParallelFor(
        b1 - b0,
        [&](int j) {
          const int k = b0 + j;
          ok[k] = CornersInView(image, board, sensor, dirs[k].first, dirs[k].second, distance, &found[k],
                                &found_ids[k], &failures[k]);
        },
        true, batch);
    for (int k = b0; k < b1; ++k) {
      if (!ok[k]) continue;
      std::vector<cv::Point2f>& raw = found[k];
      if (board.IsCharuco()) {
        // Corners as mapped back: the refinement through the model follows.
        corners->clear();
        for (const cv::Point2f& p : raw) corners->push_back({p.x, p.y});
        *ids = found_ids[k];
        return true;
      }
      // Window: a third of the smallest square side in the raw image, 2..5 px.
      double min_side = 1e9;
      for (int j = 0; j < board.rows; ++j)
        for (int i = 0; i + 1 < board.cols; ++i)
          min_side = std::min<double>(min_side, cv::norm(raw[j * board.cols + i + 1] - raw[j * board.cols + i]));
      for (int j = 0; j + 1 < board.rows; ++j)
        for (int i = 0; i < board.cols; ++i)
          min_side = std::min<double>(min_side, cv::norm(raw[(j + 1) * board.cols + i] - raw[j * board.cols + i]));
      const int win = std::clamp(static_cast<int>(min_side / 3.0), 2, 5);
      std::vector<cv::Point2f> refined = raw;
      cv::cornerSubPix(image, refined, cv::Size(win, win), cv::Size(-1, -1),
                       cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 0.01));
      corners->clear();
      for (size_t i = 0; i < raw.size(); ++i) {
        // Keep the mapped position where the refinement jumps (another corner, an edge).
        const cv::Point2f& p = cv::norm(refined[i] - raw[i]) < 0.5 * win ? refined[i] : raw[i];
        corners->push_back({p.x, p.y});
      }
      return true;
    }
  }
  if (failure)
    for (const std::string& f : failures)
      if (!f.empty()) {
        *failure = f;
        break;
      }
  return false;
}

namespace {

// A board point's id after flipping the board's x and/or y.
int FlippedId(int id, int cols, int rows, bool fx, bool fy) {
  const int i = id % cols, j = id / cols;
  return (fy ? rows - 1 - j : j) * cols + (fx ? cols - 1 - i : i);
}

double Spearman(const std::vector<double>& a, const std::vector<double>& b) {
  auto ranks = [](const std::vector<double>& v) {
    std::vector<size_t> idx(v.size());
    std::iota(idx.begin(), idx.end(), 0);
    std::sort(idx.begin(), idx.end(), [&](size_t x, size_t y) { return v[x] < v[y]; });
    std::vector<double> r(v.size());
    for (size_t k = 0; k < idx.size(); ++k) r[idx[k]] = static_cast<double>(k);
    return r;
  };
  const std::vector<double> ra = ranks(a), rb = ranks(b);
  const double n = static_cast<double>(a.size());
  double d2 = 0;
  for (size_t k = 0; k < ra.size(); ++k) d2 += (ra[k] - rb[k]) * (ra[k] - rb[k]);
  return 1.0 - 6.0 * d2 / (n * (n * n - 1.0));
}

}  // namespace

void OrderCornersByKnownPose(const TargetBoard& board, double cx, double cy, std::vector<BoardView>* views) {
  const std::vector<Eigen::Vector3d> pts = BoardPoints(board);
  for (BoardView& v : *views) {
    // A ChArUco corner's id is its own: the order is known. A chessboard's
    // ids (a partial view) count in the detector's order, as a full grid's
    // indices do.
    if (!v.has_pose || (v.Partial() && board.IsCharuco())) continue;
    Eigen::Matrix3d R;
    ceres::AngleAxisToRotationMatrix(v.rvec.data(), R.data());
    double best = 1e300;
    int best_flip = 0;
    for (int f = 0; f < 4; ++f) {
      // Azimuth residual about its circular mean (the azimuth offset).
      const size_t n = v.corners.size();
      std::vector<double> d(n), rho(n), elev(n);
      double sx = 0, sy = 0;
      for (size_t k = 0; k < n; ++k) {
        const Eigen::Vector3d X =
            R * pts[static_cast<size_t>(FlippedId(v.PointId(k), board.cols, board.rows, f & 1, f & 2))] + v.tvec;
        const Eigen::Vector2d& c = v.corners[k];
        d[k] = std::atan2(c.y() - cy, c.x() - cx) - std::atan2(X.y(), X.x());
        sx += std::cos(d[k]);
        sy += std::sin(d[k]);
        rho[k] = std::hypot(c.x() - cx, c.y() - cy);
        elev[k] = std::atan2(X.z(), std::hypot(X.x(), X.y()));
      }
      const double mean = std::atan2(sy, sx);
      double ss = 0;
      for (double dk : d) {
        const double e = WrapAngle(dk - mean);
        ss += e * e;
      }
      const double az_rms = std::sqrt(ss / static_cast<double>(n));
      // Radii grow with elevation for the right order.
      const double score = az_rms + 0.5 * (1.0 - Spearman(rho, elev));
      if (score < best) {
        best = score;
        best_flip = f;
      }
    }
    std::vector<int> ids(v.corners.size());
    for (size_t k = 0; k < ids.size(); ++k)
      ids[k] = FlippedId(v.PointId(k), board.cols, board.rows, best_flip & 1, best_flip & 2);
    if (v.Partial()) {
      v.ids = ids;
      continue;
    }
    // A full grid stays in board order.
    std::vector<Eigen::Vector2d> ordered(v.corners.size());
    for (size_t k = 0; k < ids.size(); ++k) ordered[static_cast<size_t>(ids[k])] = v.corners[k];
    v.corners = ordered;
  }
}

}  // namespace pano
