#include "panotrack/render/targets_render.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>

#include "panotrack/charuco/charuco.h"
#include "panotrack/core/error.h"
#include "panotrack/core/parallel.h"
#include "panotrack/io/calibration.h"
#include "panotrack/io/trajectory.h"
#include "panotrack/render/writers.h"

namespace pano {

namespace {

Eigen::Matrix3d RotationOf(const std::array<double, 3>& r) {
  const Eigen::Vector3d v(r[0], r[1], r[2]);
  const double a = v.norm();
  if (a < 1e-15) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(a, v / a).toRotationMatrix();
}

std::array<double, 3> RvecOf(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  const Eigen::Vector3d v = aa.axis() * aa.angle();
  return {v.x(), v.y(), v.z()};
}

}  // namespace

std::vector<BoardPose> ReadBoardPoses(const std::string& path) {
  std::vector<BoardPose> out;
  for (const std::array<double, 6>& v : ReadBoardPoseRows(path)) out.push_back({{v[0], v[1], v[2]}, {v[3], v[4], v[5]}});
  return out;
}

std::vector<Eigen::Vector3d> BoardCornersSensor(const TargetBoard& b, const BoardPose& pose) {
  const Eigen::Matrix3d R = RotationOf(pose.rvec);
  const Eigen::Vector3d t(pose.tvec[0], pose.tvec[1], pose.tvec[2]);
  std::vector<Eigen::Vector3d> out;
  for (int j = 0; j < b.rows; ++j)
    for (int i = 0; i < b.cols; ++i) out.push_back(R * Eigen::Vector3d(i * b.square, j * b.square, 0.0) + t);
  return out;
}

double BoardVisibleFraction(const Sensor& sensor, const TargetBoard& board, const BoardPose& pose,
                            double inner, double outer) {
  const Eigen::Matrix3d R = RotationOf(pose.rvec);
  const Eigen::Vector3d t(pose.tvec[0], pose.tvec[1], pose.tvec[2]);
  const Eigen::Vector3d centre =
      R * Eigen::Vector3d(0.5 * (board.cols - 1) * board.square, 0.5 * (board.rows - 1) * board.square, 0) + t;
  const Eigen::Vector3d mirror(0, 0, sensor.params.vertex_distance);
  if (!(R.col(2).dot(centre - mirror) > 0.0)) return 0.0;  // must show its -z side
  const double limb = sensor.limb_radius();
  const std::vector<Eigen::Vector3d> corners = BoardCornersSensor(board, pose);
  int seen = 0;
  for (const Eigen::Vector3d& p : corners) {
    Eigen::Vector2d px;
    if (!sensor.project(p, &px) || !sensor.inside_image(px, 3.0)) continue;
    double r, az;
    sensor.to_polar(px.x(), px.y(), &r, &az);
    if (r >= inner * limb && r <= outer * limb) ++seen;
  }
  return static_cast<double>(seen) / static_cast<double>(corners.size());
}

bool BoardFullyVisible(const Sensor& sensor, const TargetBoard& board, const BoardPose& pose,
                       double inner, double outer) {
  const Eigen::Matrix3d R = RotationOf(pose.rvec);
  const Eigen::Vector3d t(pose.tvec[0], pose.tvec[1], pose.tvec[2]);
  const Eigen::Vector3d centre =
      R * Eigen::Vector3d(0.5 * (board.cols - 1) * board.square, 0.5 * (board.rows - 1) * board.square, 0) + t;
  const Eigen::Vector3d mirror(0, 0, sensor.params.vertex_distance);
  if (!(R.col(2).dot(centre - mirror) > 0.0)) return false;  // must show its -z side
  const double limb = sensor.limb_radius();
  for (const Eigen::Vector3d& p : BoardCornersSensor(board, pose)) {
    Eigen::Vector2d px;
    if (!sensor.project(p, &px) || !sensor.inside_image(px, 3.0)) return false;
    double r, az;
    sensor.to_polar(px.x(), px.y(), &r, &az);
    if (r < inner * limb || r > outer * limb) return false;
  }
  return true;
}

std::vector<BoardPose> AutoBoardPoses(const Sensor& sensor, const TargetBoard& board, int n,
                                      uint64_t seed, double min_visible) {
  if (n < 1) throw Error("--auto: expected a positive number of images");
  if (!(min_visible > 0.0 && min_visible <= 1.0))
    throw Error("--min-visible: expected a fraction in (0, 1], got " + std::to_string(min_visible));
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const double w = (board.cols + 1) * board.square, h = (board.rows + 1) * board.square;
  const double diag = std::hypot(w, h);
  // Near boards at every height from 20 degrees below the mirror to 60 above
  // it: with unknown board poses the focal length and the mirror's size are
  // told apart only by corners that span the mirror's radial mapping out to
  // the limb, where it bends most, and by parallax (docs/calibration.md).
  const double d_min = std::max(0.8 * sensor.mirror_distance(), 0.33 * diag), d_max = d_min + 0.63 * diag;
  const Eigen::Vector3d mirror(0, 0, sensor.params.vertex_distance);
  std::vector<BoardPose> out;
  for (int k = 0; k < n; ++k) {
    bool ok = false;
    for (int attempt = 0; attempt < 20000 && !ok; ++attempt) {
      const double beta = 2.0 * M_PI * (k + 0.8 * (uni(rng) - 0.5)) / n;
      const double D = d_min + (d_max - d_min) * uni(rng);
      const double elev = (-20.0 + 80.0 * uni(rng)) * M_PI / 180.0;
      const Eigen::Vector3d C(D * std::cos(beta), D * std::sin(beta), mirror.z() + D * std::tan(elev));
      const Eigen::Vector3d z = (C - mirror).normalized();
      Eigen::Vector3d x(std::sin(beta), -std::cos(beta), 0.0);
      x = (x - x.dot(z) * z).normalized();
      const Eigen::Vector3d y = z.cross(x);
      Eigen::Matrix3d R0;
      R0.col(0) = x;
      R0.col(1) = y;
      R0.col(2) = z;
      const double deg = M_PI / 180.0;
      // One draw per statement: the order of a call's arguments is the
      // compiler's choice, and the boards must not depend on it (this is
      // the order the images were first rendered in).
      const double about_z = (uni(rng) - 0.5) * 40 * deg;
      const double about_y = (uni(rng) - 0.5) * 50 * deg;
      const double about_x = (uni(rng) - 0.5) * 50 * deg;
      const Eigen::Matrix3d Rp = (Eigen::AngleAxisd(about_x, Eigen::Vector3d::UnitX()) *
                                  Eigen::AngleAxisd(about_y, Eigen::Vector3d::UnitY()) *
                                  Eigen::AngleAxisd(about_z, Eigen::Vector3d::UnitZ()))
                                     .toRotationMatrix();
      const Eigen::Matrix3d R = R0 * Rp;
      const Eigen::Vector3d cb(0.5 * (board.cols - 1) * board.square, 0.5 * (board.rows - 1) * board.square, 0);
      const Eigen::Vector3d t = C - R * cb;
      BoardPose p{RvecOf(R), {t.x(), t.y(), t.z()}};
      if (min_visible >= 1.0 ? BoardFullyVisible(sensor, board, p)
                             : BoardVisibleFraction(sensor, board, p) >= min_visible) {
        out.push_back(p);
        ok = true;
      }
    }
    if (!ok)
      throw Error("--board: a " + std::to_string(board.cols) + " x " + std::to_string(board.rows) +
                  " board of square " + std::to_string(board.square) +
                  " cannot be placed fully in view; try smaller squares");
  }
  return out;
}

cv::Mat RenderBoard(const RayTable& table, const TargetBoard& board, const BoardPose& pose,
                    const RenderOptions& options, int index) {
  const Sensor& sensor = table.sensor();
  const int W = sensor.image_width, H = sensor.image_height;
  const Eigen::Matrix3d R = RotationOf(pose.rvec);
  const Eigen::Vector3d t(pose.tvec[0], pose.tvec[1], pose.tvec[2]);
  const Eigen::Vector3d n = R.col(2);
  const double bg = options.background > 0.0 ? options.background : 0.45;
  const double sq = board.square;
  const double x_lo = -2.0 * sq, x_hi = (board.cols + 1) * sq, y_lo = -2.0 * sq, y_hi = (board.rows + 1) * sq;
  // A ChArUco board: its printed image (kTexel pixels per square), 0..1.
  constexpr int kTexel = 48;
  cv::Mat texture;
  if (board.IsCharuco()) DrawCharucoBoard(board, kTexel, 0).convertTo(texture, CV_32F, 1.0 / 255.0);
  const auto& rays = table.rays();
  const auto& starts = table.starts();
  const float inv_n = 1.0f / static_cast<float>(table.supersample() * table.supersample());
  cv::Mat img(H, W, CV_32FC1, cv::Scalar(0));
  cv::Mat mask(H, W, CV_8UC1, cv::Scalar(0));
  // Ray-plane arithmetic only: the rows cannot throw.
#pragma omp parallel for schedule(dynamic, 4) num_threads(ThreadCount(options.num_threads))
  for (int v = 0; v < H; ++v) {
    for (int u = 0; u < W; ++u) {
      const int b = starts[static_cast<size_t>(v) * W + u], e = starts[static_cast<size_t>(v) * W + u + 1];
      if (b == e) continue;
      mask.at<uint8_t>(v, u) = 255;
      float sum = 0.0f;
      for (int k = b; k < e; ++k) {
        const RayTable::Ray& r = rays[static_cast<size_t>(k)];
        const Eigen::Vector3d o(r.ps * r.c - r.e * r.s, r.ps * r.s + r.e * r.c, r.pz), d(r.ds * r.c, r.ds * r.s, r.dz);
        double shade = bg;
        const double den = n.dot(d);
        if (den != 0.0) {
          const double tau = n.dot(t - o) / den;
          if (tau > 0.0) {
            const Eigen::Vector3d X = R.transpose() * (o + tau * d - t);
            if (X.x() >= x_lo && X.x() <= x_hi && X.y() >= y_lo && X.y() <= y_hi) {
              shade = 0.92;  // margin
              if (!texture.empty()) {
                // Texel centres at half-integers; bilinear, clamped at the edge.
                const double tx = (X.x() / sq + 1.0) * kTexel - 0.5, ty = (X.y() / sq + 1.0) * kTexel - 0.5;
                if (tx > -1.0 && ty > -1.0 && tx < texture.cols && ty < texture.rows) {
                  const int x0 = static_cast<int>(std::floor(tx)), y0 = static_cast<int>(std::floor(ty));
                  const double fx = tx - x0, fy = ty - y0;
                  auto texel = [&](int x, int y) {
                    return static_cast<double>(texture.at<float>(std::clamp(y, 0, texture.rows - 1),
                                                                 std::clamp(x, 0, texture.cols - 1)));
                  };
                  const double ink = (1 - fy) * ((1 - fx) * texel(x0, y0) + fx * texel(x0 + 1, y0)) +
                                   fy * ((1 - fx) * texel(x0, y0 + 1) + fx * texel(x0 + 1, y0 + 1));
                  shade = 0.08 + 0.84 * ink;
                }
              } else if (X.x() >= -sq && X.x() <= board.cols * sq && X.y() >= -sq && X.y() <= board.rows * sq) {
                const long i = static_cast<long>(std::floor(X.x() / sq)), j = static_cast<long>(std::floor(X.y() / sq));
                if (((i + j) % 2 + 2) % 2 == 0) shade = 0.08;  // (-1, -1) is black
              }
            }
          }
        }
        sum += static_cast<float>(std::clamp(shade * options.illumination, 0.0, 1.0));
      }
      img.at<float>(v, u) = 255.0f * sum * inv_n;
    }
  }
  return FinishImage(img, options, index, mask);
}

void WriteTargetImages(const std::string& dir, const Calibration& calib, const TargetBoard& board,
                       const std::vector<BoardPose>& poses, const RenderOptions& options,
                       const TargetsWriteOptions& wo) {
  options.Check("targets");
  calib.sensor.Check("--calib");
  if (board.cols < 2 || board.rows < 2 || !(board.square > 0.0))
    throw Error("--board: expected cols,rows >= 2 inner corners and a positive square size");
  CheckTargetBoard(board, "--board");
  if (poses.empty()) throw Error("targets: no board poses");
  StagingDir sd(dir, wo.overwrite);
  const RayTable table(calib.sensor, options.supersample, /*camera_radius_px=*/0.0, options.num_threads);
  TargetSet set;
  set.units = calib.units;
  set.board = board;
  for (size_t i = 0; i < poses.size(); ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "cal_%03zu.png", i);
    const cv::Mat img = RenderBoard(table, board, poses[i], options, static_cast<int>(i));
    WritePng(sd.File(name), img);
    TargetImage ti;
    ti.file = name;
    ti.has_pose = true;
    ti.rvec = poses[i].rvec;
    ti.tvec = poses[i].tvec;
    set.images.push_back(ti);
    if (wo.on_progress) wo.on_progress(static_cast<int>(i) + 1, static_cast<int>(poses.size()));
  }
  WriteTargets(sd.File("targets.yaml"), set, true);
  WriteTargets(sd.File("targets_unknown.yaml"), set, false);
  Calibration truth = calib;
  truth.lut.clear();
  truth.comment = "Ground truth: the calibration panosim used to render these images.";
  WriteCalibration(sd.File("truth.yaml"), truth);
  sd.Commit();
}

}  // namespace pano
