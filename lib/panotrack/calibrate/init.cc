// Step 2: initial sensor and board poses.
//
// A central (single-viewpoint) approximation first, after Scaramuzza's
// OCamCalib: a pixel at (u', v') from the centre, radius rho, sees along the
// ray (u', v', g(rho)) with g a polynomial (a0 + a2 rho^2 + a3 rho^3 + a4 rho^4).
// For a board point (x, y, 0) with pose [r1 r2 r3 | t], the cross product of
// the ray with R X + t vanishes; its third component
//   u' (r21 x + r22 y + t2) - v' (r11 x + r12 y + t1) = 0
// does not involve g: per board, the null vector of an n x 6 matrix gives
// r11, r12, r21, r22, t1, t2 up to scale, orthonormality gives r31, r32 up to
// one sign and the scale. The sign is the one for which g grows with rho
// (a convex mirror seen from below shows higher elevations farther out).
// The other two components are linear in the polynomial and every t3: one
// least-squares solve. Then the mirror model is fitted to the polynomial's
// elevation-versus-radius curve (multi-start over shapes), and the mirror's
// scale comes from the boards' heights (known poses) or the best of a few
// scale guesses after a short joint refinement (unknown poses). The unified
// profile, central itself, takes the central model's poses and fits its
// (f, xi) to the same curve.
#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "panotrack/calibrate/calibrate.h"
#include "panotrack/calibrate/internal.h"
#include "panotrack/core/angles.h"
#include "panotrack/core/error.h"
#include "panotrack/core/parallel.h"

namespace pano {

using namespace calib_internal;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Central model: rays (u, v, g(rho)) in units of rho_ref pixels.
struct CentralModel {
  double cx = 0, cy = 0, rho_ref = 1;
  Eigen::Vector4d a = Eigen::Vector4d::Zero();  // a0, a2, a3, a4 in x = rho / rho_ref
  double g(double x) const { return a(0) + x * x * (a(1) + x * (a(2) + x * a(3))); }
  double rho_min = 0, rho_max = 0;  // observed, normalised
};

// Least squares with column scaling.
Eigen::VectorXd SolveScaled(const Eigen::MatrixXd& A, const Eigen::VectorXd& b) {
  Eigen::VectorXd d = A.colwise().norm().transpose();
  for (int i = 0; i < d.size(); ++i) d(i) = d(i) > 0 ? 1.0 / d(i) : 1.0;
  const Eigen::MatrixXd As = A * d.asDiagonal();
  Eigen::VectorXd x = As.bdcSvd(Eigen::ComputeThinU | Eigen::ComputeThinV).solve(b);
  return d.asDiagonal() * x;
}

Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& M) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
  if (R.determinant() < 0) {
    Eigen::Matrix3d U = svd.matrixU();
    U.col(2) *= -1;
    R = U * svd.matrixV().transpose();
  }
  return R;
}

std::array<double, 6> PoseFromRt(const Eigen::Matrix3d& R, const Eigen::Vector3d& t) {
  std::array<double, 6> p{};
  const Eigen::Matrix3d Rc = R;  // column-major, as ceres expects
  ceres::RotationMatrixToAngleAxis(Rc.data(), p.data());
  p[3] = t.x();
  p[4] = t.y();
  p[5] = t.z();
  return p;
}

// Per board: in-plane pose (r11 r12 r21 r22 t1 t2) and the two candidates
// for (r31, r32); t in board units.
struct PlanarPose {
  Eigen::Vector3d r1, r2;  // columns, r31/r32 for candidate +
  double t1 = 0, t2 = 0;
  bool ok = false;
};

PlanarPose SolveInPlane(const BoardView& v, const std::vector<Eigen::Vector3d>& pts,
                        const CentralModel& cm, double board_size) {
  const int n = static_cast<int>(v.corners.size());
  Eigen::MatrixXd M(n, 6);
  for (int j = 0; j < n; ++j) {
    const Eigen::Vector3d& P = pts[v.PointId(j)];
    const double u = (v.corners[j].x() - cm.cx) / cm.rho_ref, w = (v.corners[j].y() - cm.cy) / cm.rho_ref;
    const double x = P.x() / board_size, y = P.y() / board_size;
    M.row(j) << -w * x, -w * y, u * x, u * y, -w, u;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(M, Eigen::ComputeThinV);
  Eigen::VectorXd h = svd.matrixV().col(5);
  PlanarPose pp;
  const Eigen::VectorXd sv = svd.singularValues();
  if (!(sv(4) > 1e-9 * sv(0))) return pp;  // degenerate (e.g. all corners on a line through the centre)
  double a = h(0) / board_size, b = h(1) / board_size, c = h(2) / board_size, d = h(3) / board_size;
  double t1 = h(4), t2 = h(5);
  const double B = a * b + c * d;
  const double C = (b * b + d * d) - (a * a + c * c);
  const double p2 = 0.5 * (C + std::sqrt(C * C + 4.0 * B * B));
  double p = std::sqrt(std::max(0.0, p2)), q;
  if (p > 1e-12 * std::sqrt(a * a + b * b + c * c + d * d)) {
    q = -B / p;
  } else {
    p = 0.0;
    q = std::sqrt(std::max(0.0, -C));
  }
  const double mu = std::sqrt(a * a + c * c + p * p);
  if (!(mu > 0) || !std::isfinite(mu)) return pp;
  a /= mu, b /= mu, c /= mu, d /= mu, p /= mu, q /= mu, t1 /= mu, t2 /= mu;
  // Sign: the board's horizontal position must lie along the pixels' azimuths.
  double s = 0.0;
  for (int j = 0; j < n; ++j) {
    const double u = v.corners[j].x() - cm.cx, w = v.corners[j].y() - cm.cy;
    const Eigen::Vector3d& P = pts[v.PointId(j)];
    s += (a * P.x() + b * P.y() + t1) * u + (c * P.x() + d * P.y() + t2) * w;
  }
  if (s < 0) a = -a, b = -b, c = -c, d = -d, t1 = -t1, t2 = -t2;
  pp.r1 = {a, c, p};
  pp.r2 = {b, d, q};
  pp.t1 = t1;
  pp.t2 = t2;
  pp.ok = std::isfinite(a + b + c + d + p + q + t1 + t2);
  return pp;
}

// Rows of the g / t3 system for one board. Columns: [a0 a2 a3 a4] then the
// board's t3 / board_size at column t3_col (degree: how many a's are used).
void AddCentralRows(const BoardView& v, const std::vector<Eigen::Vector3d>& pts, const CentralModel& cm,
                    const Eigen::Vector3d& r1, const Eigen::Vector3d& r2, double t1, double t2,
                    double board_size, int n_a, int t3_col, std::vector<Eigen::VectorXd>* rows,
                    std::vector<double>* rhs, int n_cols) {
  for (size_t j = 0; j < v.corners.size(); ++j) {
    const double u = (v.corners[j].x() - cm.cx) / cm.rho_ref, w = (v.corners[j].y() - cm.cy) / cm.rho_ref;
    const double x2 = u * u + w * w, x = std::sqrt(x2);
    const double X = pts[v.PointId(j)].x(), Y = pts[v.PointId(j)].y();
    const double A = (r1.y() * X + r2.y() * Y + t2) / board_size;
    const double Bx = (r1.x() * X + r2.x() * Y + t1) / board_size;
    const double Cz = (r1.z() * X + r2.z() * Y) / board_size;
    const double pw[4] = {1.0, x2, x2 * x, x2 * x2};
    // w (Cz + t3) - g A = 0  and  g Bx - u (Cz + t3) = 0
    Eigen::VectorXd r(n_cols);
    r.setZero();
    for (int k = 0; k < n_a; ++k) r(k) = -A * pw[k];
    r(t3_col) = w;
    rows->push_back(r);
    rhs->push_back(-w * Cz);
    r.setZero();
    for (int k = 0; k < n_a; ++k) r(k) = Bx * pw[k];
    r(t3_col) = -u;
    rows->push_back(r);
    rhs->push_back(u * Cz);
  }
}

Eigen::VectorXd SolveRows(const std::vector<Eigen::VectorXd>& rows, const std::vector<double>& rhs) {
  Eigen::MatrixXd A(rows.size(), rows.front().size());
  Eigen::VectorXd b(rows.size());
  for (size_t i = 0; i < rows.size(); ++i) {
    A.row(i) = rows[i].transpose();
    b(i) = rhs[i];
  }
  return SolveScaled(A, b);
}

// Elevation of the reflected ray of normalised radius x (zv = 1 units).
struct ElevationCost {
  ElevationCost(double rho, double elev) : rho_(rho), elev_(elev) {}
  template <typename T>
  bool operator()(const T* x, T* r) const {
    SensorParams<T> p;
    p.focal_px = x[0];
    p.curvature_radius = x[1];
    p.conic_constant = x[2];
    p.vertex_distance = T(1);
    if (!(x[0] > T(0)) || !(x[1] > T(0))) return false;
    const T m = T(rho_) / x[0];
    if (!(m < MaxNormalizedRadius(p))) return false;
    T ps, pz, ds, dz;
    if (!ReflectMeridian(p, m, &ps, &pz, &ds, &dz)) return false;
    using std::atan2;
    r[0] = atan2(dz, ds) - T(elev_);
    return true;
  }
  double rho_, elev_;
};

struct ShapeFit {
  double f = 0, R = 0, k = 0;  // zv = 1
  double h = 0;                // effective viewpoint height (zv = 1 units)
  double cost = kInf;
};

// Fits f (and k for the conic) with zv = 1 and R = R0 held to the central
// model's elevation curve; rho in pixels. To first order only f R / zv is
// seen in the curve (the far-camera limit fits about as well as the truth),
// so the caller tries several R0 along that valley and lets the full
// reprojection problem choose.
ShapeFit FitShape(const std::vector<double>& rho, const std::vector<double>& elev, bool conic, double R0) {
  ShapeFit best;
  const double rho_max = *std::max_element(rho.begin(), rho.end());
  const std::vector<double> ks = conic ? std::vector<double>{0.0, -0.6, -1.0, -1.8, -3.0} : std::vector<double>{0.0};
  for (double k0 : ks) {
    {
      SensorParams<double> p;
      p.curvature_radius = R0;
      p.conic_constant = k0;
      p.vertex_distance = 1.0;
      const double m_max = MaxNormalizedRadius(p);
      double x[3] = {std::isfinite(m_max) ? 1.15 * rho_max / m_max : rho_max / 0.8, R0, k0};
      ceres::Problem problem;
      problem.AddParameterBlock(x, 3);
      problem.SetManifold(x, conic ? new ceres::SubsetManifold(3, {1}) : new ceres::SubsetManifold(3, {1, 2}));
      for (size_t i = 0; i < rho.size(); ++i)
        problem.AddResidualBlock(new ceres::AutoDiffCostFunction<ElevationCost, 1, 3>(
                                     new ElevationCost(rho[i], elev[i])),
                                 nullptr, x);
      ceres::Solver::Options so;
      so.max_num_iterations = 100;
      so.linear_solver_type = ceres::DENSE_QR;
      so.logging_type = ceres::SILENT;
      ceres::Solver::Summary sum;
      double c0;
      if (!problem.Evaluate(ceres::Problem::EvaluateOptions(), &c0, nullptr, nullptr, nullptr)) continue;
      ceres::Solve(so, &problem, &sum);
      if (sum.termination_type == ceres::FAILURE || !(sum.final_cost < best.cost) ||
          !std::isfinite(x[0] + x[1] + x[2]))
        continue;
      best.f = x[0];
      best.R = x[1];
      best.k = x[2];
      best.cost = sum.final_cost;
    }
  }
  if (std::isfinite(best.cost)) {
    // Effective viewpoint: where the reflected rays of the observed radii cross the axis.
    SensorParams<double> p;
    p.focal_px = best.f;
    p.curvature_radius = best.R;
    p.conic_constant = best.k;
    p.vertex_distance = 1.0;
    double sum = 0;
    int n = 0;
    for (double r : rho) {
      double ps, pz, ds, dz;
      if (ReflectMeridian(p, r / best.f, &ps, &pz, &ds, &dz) && std::abs(ds) > 1e-9) {
        sum += pz - ps * dz / ds;
        ++n;
      }
    }
    best.h = n ? sum / n : 1.0;
  }
  return best;
}

// Short joint refinement; returns the RMS (infinity when it cannot start).
double QuickFit(const std::vector<BoardView>& views, const std::vector<Eigen::Vector3d>& pts,
                std::array<double, kNumSensor>* s, std::vector<std::array<double, 6>>* poses,
                bool poses_known, const CalibrateOptions& options, int iterations, double cap, int threads) {
  ceres::Problem problem;
  problem.AddParameterBlock(s->data(), kNumSensor);
  std::vector<int> fixed = FixedSensorIndices(poses_known, options);
  // Distortion stays off in the initialisation.
  for (int k : {kK1, kK2})
    if (!std::binary_search(fixed.begin(), fixed.end(), k)) fixed.push_back(k);
  std::sort(fixed.begin(), fixed.end());
  problem.SetManifold(s->data(), new ceres::SubsetManifold(kNumSensor, fixed));
  size_t n_bad = 0, n = 0;
  for (size_t i = 0; i < views.size(); ++i) {
    problem.AddParameterBlock((*poses)[i].data(), 6);
    if (poses_known) problem.SetParameterBlockConstant((*poses)[i].data());
    for (size_t j = 0; j < views[i].corners.size(); ++j) {
      CornerCost c(pts[views[i].PointId(j)], views[i].corners[j], cap);
      double r[2];
      ++n;
      if (!c(s->data(), (*poses)[i].data(), r)) {
        ++n_bad;
        continue;
      }
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CornerCost, 2, kNumSensor, 6>(
                                   new CornerCost(pts[views[i].PointId(j)], views[i].corners[j], cap)),
                               new ceres::HuberLoss(3.0), s->data(), (*poses)[i].data());
    }
  }
  if (n_bad * 5 > n) return kInf;
  ceres::Solver::Options so;
  so.max_num_iterations = iterations;
  so.linear_solver_type = poses_known ? ceres::DENSE_QR : ceres::DENSE_SCHUR;
  so.logging_type = ceres::SILENT;
  so.num_threads = threads;
  ceres::Solver::Summary sum;
  ceres::Solve(so, &problem, &sum);
  if (sum.termination_type == ceres::FAILURE) return kInf;
  double s2 = 0;
  size_t m = 0;
  for (size_t i = 0; i < views.size(); ++i)
    for (size_t j = 0; j < views[i].corners.size(); ++j) {
      CornerCost c(pts[views[i].PointId(j)], views[i].corners[j], cap);
      double r[2];
      if (!c(s->data(), (*poses)[i].data(), r)) {
        s2 += 1e4;  // invisible corner: heavy penalty
      } else {
        s2 += r[0] * r[0] + r[1] * r[1];
      }
      ++m;
    }
  const double rms = std::sqrt(s2 / m);
  return std::isfinite(rms) ? rms : kInf;
}

}  // namespace

namespace calib_internal {

bool InitialPoseFromSensor(const BoardView& view, const TargetBoard& board, const Sensor& sensor,
                           std::array<double, 6>* pose) {
  const std::vector<Eigen::Vector3d> pts = BoardPoints(board);
  const double board_size = board.square * std::max(board.cols, board.rows);
  CentralModel cm;
  cm.cx = sensor.params.cx;
  cm.cy = sensor.params.cy;
  cm.rho_ref = 1.0;
  for (const Eigen::Vector2d& c : view.corners) cm.rho_ref = std::max(cm.rho_ref, std::hypot(c.x() - cm.cx, c.y() - cm.cy));
  const PlanarPose pp = SolveInPlane(view, pts, cm, board_size);
  if (!pp.ok) return false;
  // Rays of the corners through the fitted sensor.
  const size_t n = view.corners.size();
  std::vector<Eigen::Vector3d> o(n), d(n);
  for (size_t j = 0; j < n; ++j)
    if (!sensor.backproject(view.corners[j], &o[j], &d[j])) return false;
  double best = kInf;
  for (double sgn : {1.0, -1.0}) {
    Eigen::Vector3d r1 = pp.r1, r2 = pp.r2;
    r1.z() *= sgn;
    r2.z() *= sgn;
    // Each corner's height on its ray at its horizontal distance gives t3.
    std::vector<double> t3;
    for (size_t j = 0; j < n; ++j) {
      const double X = pts[view.PointId(j)].x(), Y = pts[view.PointId(j)].y();
      const double D = std::hypot(r1.x() * X + r2.x() * Y + pp.t1, r1.y() * X + r2.y() * Y + pp.t2);
      const double os = std::hypot(o[j].x(), o[j].y()), ds = std::hypot(d[j].x(), d[j].y());
      if (!(ds > 1e-9)) continue;
      t3.push_back(o[j].z() + (D - os) * d[j].z() / ds - (r1.z() * X + r2.z() * Y));
    }
    if (t3.empty() || t3.size() < n / 2) continue;
    double mean = 0, var = 0;
    for (double v : t3) mean += v;
    mean /= t3.size();
    for (double v : t3) var += (v - mean) * (v - mean);
    if (var < best) {
      best = var;
      Eigen::Matrix3d M;
      M.col(0) = r1;
      M.col(1) = r2;
      M.col(2) = r1.cross(r2);
      *pose = PoseFromRt(NearestRotation(M), Eigen::Vector3d(pp.t1, pp.t2, mean));
    }
  }
  return std::isfinite(best);
}

bool PoseFromRays(const BoardView& view, const TargetBoard& board, const Sensor& sensor,
                  std::array<double, 6>* pose) {
  const std::vector<Eigen::Vector3d> pts = BoardPoints(board);
  const double scale = board.square * std::max(board.cols, board.rows);  // conditions the solve
  const size_t n = view.corners.size();
  std::vector<Eigen::Vector3d> o(n), d(n);
  for (size_t j = 0; j < n; ++j)
    if (!sensor.backproject(view.corners[j], &o[j], &d[j])) return false;
  // d x (H p) = 0 with p = (X / scale, Y / scale, 1) and H = [r1 r2 t] up to
  // a factor; h holds H row by row.
  Eigen::MatrixXd A(3 * n, 9);
  A.setZero();
  for (size_t j = 0; j < n; ++j) {
    const Eigen::Vector3d& X = pts[view.PointId(j)];
    const Eigen::RowVector3d p(X.x() / scale, X.y() / scale, 1.0);
    const Eigen::Vector3d& b = d[j];
    A.block<1, 3>(3 * j, 3) = -b.z() * p;
    A.block<1, 3>(3 * j, 6) = b.y() * p;
    A.block<1, 3>(3 * j + 1, 0) = b.z() * p;
    A.block<1, 3>(3 * j + 1, 6) = -b.x() * p;
    A.block<1, 3>(3 * j + 2, 0) = -b.y() * p;
    A.block<1, 3>(3 * j + 2, 3) = b.x() * p;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  const Eigen::VectorXd h = svd.matrixV().col(8);
  Eigen::Matrix3d H;
  H << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  const double k = 0.5 * (H.col(0).norm() + H.col(1).norm());
  if (!(k > 1e-12) || !H.allFinite()) return false;
  Eigen::Vector3d r1 = H.col(0) / k, r2 = H.col(1) / k, t = H.col(2) * scale / k;
  // In front along the rays.
  int ahead = 0;
  for (size_t j = 0; j < n; ++j) {
    const Eigen::Vector3d& X = pts[view.PointId(j)];
    ahead += d[j].dot(r1 * X.x() + r2 * X.y() + t - o[j]) > 0 ? 1 : -1;
  }
  if (ahead < 0) {
    r1 = -r1;
    r2 = -r2;
    t = -t;
  }
  Eigen::Matrix3d M;
  M.col(0) = r1;
  M.col(1) = r2;
  M.col(2) = r1.cross(r2);
  const Eigen::Matrix3d R = NearestRotation(M);
  // The translation again with the rotation fixed and the rays' own origins:
  // d x (R X + t - o) = 0, linear in t.
  Eigen::MatrixXd At(3 * n, 3);
  Eigen::VectorXd bt(3 * n);
  for (size_t j = 0; j < n; ++j) {
    Eigen::Matrix3d Dx;
    Dx << 0, -d[j].z(), d[j].y(), d[j].z(), 0, -d[j].x(), -d[j].y(), d[j].x(), 0;
    At.block<3, 3>(3 * j, 0) = Dx;
    bt.segment<3>(3 * j) = Dx * (o[j] - R * pts[view.PointId(j)]);
  }
  const Eigen::Vector3d t2 = At.colPivHouseholderQr().solve(bt);
  if (!t2.allFinite()) return false;
  *pose = PoseFromRt(R, t2);
  return true;
}

}  // namespace calib_internal

namespace {

// What the initialisation at every centre candidate shares.
struct InitInput {
  const std::vector<BoardView>& views;
  std::vector<Eigen::Vector3d> pts;  // board points
  double board_size;                 // the board's longer side: the unit of the linear solves
  int width, height;
  bool poses_known, conic;
  const CalibrateOptions& options;
};

// The central approximation at one centre: its polynomial, and the boards'
// poses (unknown poses) or the azimuth offset and the viewpoint height
// (known poses).
struct CentralFit {
  CentralModel cm;
  std::vector<Eigen::Matrix3d> Rs;
  std::vector<Eigen::Vector3d> ts;
  double azimuth_offset = 0.0;
  double h_view = 0.0;
};

// Centre candidates: the image centre first; the 8 around it are tried only
// when it fails.
std::vector<std::pair<double, double>> CentreCandidates(int width, int height) {
  const double cx0 = 0.5 * (width - 1), cy0 = 0.5 * (height - 1);
  const double step = 0.04 * std::min(width, height);
  std::vector<std::pair<double, double>> centres = {{cx0, cy0}};
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx)
      if (dx || dy) centres.push_back({cx0 + dx * step, cy0 + dy * step});
  return centres;
}

// The central model's centre and radius normalisation (by the farthest
// corner); false when a corner lies on the centre.
bool CentreModelAt(const std::vector<BoardView>& views, double cx, double cy, CentralModel* cm) {
  cm->cx = cx;
  cm->cy = cy;
  double rmin = kInf, rmax = 0;
  for (const BoardView& v : views)
    for (const Eigen::Vector2d& c : v.corners) {
      const double r = std::hypot(c.x() - cm->cx, c.y() - cm->cy);
      rmin = std::min(rmin, r);
      rmax = std::max(rmax, r);
    }
  cm->rho_ref = rmax;
  cm->rho_min = rmin / rmax;
  cm->rho_max = 1.0;
  return rmin > 1.0;
}

// The sign of a board's (r31, r32) for which g grows with the radius over
// the board's corners (a convex mirror seen from below).
PlanarPose WithRisingElevation(const BoardView& v, const InitInput& in, const CentralModel& cm,
                               const PlanarPose& pp) {
  double best_slope = -kInf;
  PlanarPose chosen = pp;
  for (double sgn : {1.0, -1.0}) {
    PlanarPose c = pp;
    c.r1.z() *= sgn;
    c.r2.z() *= sgn;
    std::vector<Eigen::VectorXd> rows;
    std::vector<double> rhs;
    AddCentralRows(v, in.pts, cm, c.r1, c.r2, c.t1, c.t2, in.board_size, 2, 2, &rows, &rhs, 3);
    const Eigen::VectorXd sol = SolveRows(rows, rhs);
    // Slope of g over this board's radii (g = a0 + a2 x^2).
    double xmin = kInf, xmax = 0;
    for (const Eigen::Vector2d& q : v.corners) {
      const double x = std::hypot(q.x() - cm.cx, q.y() - cm.cy) / cm.rho_ref;
      xmin = std::min(xmin, x);
      xmax = std::max(xmax, x);
    }
    const double slope = sol(1) * (xmax * xmax - xmin * xmin);
    if (std::isfinite(slope) && slope > best_slope) {
      best_slope = slope;
      chosen = c;
    }
  }
  return chosen;
}

std::string CentreName(const CentralModel& cm) {
  std::ostringstream o;
  o << "centre (" << cm.cx << ", " << cm.cy << ")";
  return o.str();
}

// Unknown poses: every board's in-plane pose, then the polynomial and every
// board's height in one least-squares solve. False (with the reason logged)
// on failure.
bool CentralWithUnknownPoses(const InitInput& in, CentralFit* fit, std::ostringstream* log) {
  CentralModel& cm = fit->cm;
  const size_t nv = in.views.size();
  std::vector<PlanarPose> pp(nv);
  for (size_t i = 0; i < nv; ++i) {
    pp[i] = SolveInPlane(in.views[i], in.pts, cm, in.board_size);
    if (!pp[i].ok) {
      *log << CentreName(cm) << ": " << in.views[i].file << ": degenerate in-plane pose; ";
      return false;
    }
    pp[i] = WithRisingElevation(in.views[i], in, cm, pp[i]);
  }
  const int n_a = 4, n_cols = n_a + static_cast<int>(nv);
  std::vector<Eigen::VectorXd> rows;
  std::vector<double> rhs;
  for (size_t i = 0; i < nv; ++i)
    AddCentralRows(in.views[i], in.pts, cm, pp[i].r1, pp[i].r2, pp[i].t1, pp[i].t2, in.board_size, n_a,
                   n_a + static_cast<int>(i), &rows, &rhs, n_cols);
  const Eigen::VectorXd sol = SolveRows(rows, rhs);
  if (!sol.allFinite()) {
    *log << CentreName(cm) << ": central least squares not finite; ";
    return false;
  }
  cm.a = sol.head<4>();
  fit->Rs.resize(nv);
  fit->ts.resize(nv);
  for (size_t i = 0; i < nv; ++i) {
    Eigen::Matrix3d M;
    M.col(0) = pp[i].r1;
    M.col(1) = pp[i].r2;
    M.col(2) = pp[i].r1.cross(pp[i].r2);
    fit->Rs[i] = NearestRotation(M);
    fit->ts[i] = {pp[i].t1, pp[i].t2, sol(n_a + i) * in.board_size};
  }
  return true;
}

// Known poses: the azimuth offset (the circular mean of the corners' azimuth
// differences), then the polynomial and the viewpoint height in one
// least-squares solve. False (with the reason logged) on failure.
bool CentralWithKnownPoses(const InitInput& in, CentralFit* fit, std::ostringstream* log) {
  CentralModel& cm = fit->cm;
  double sx = 0, sy = 0;
  for (const BoardView& v : in.views) {
    Eigen::Matrix3d R;
    ceres::AngleAxisToRotationMatrix(v.rvec.data(), R.data());
    for (size_t j = 0; j < v.corners.size(); ++j) {
      const Eigen::Vector3d X = R * in.pts[v.PointId(j)] + v.tvec;
      const double d = WrapAngle(std::atan2(v.corners[j].y() - cm.cy, v.corners[j].x() - cm.cx) -
                                 std::atan2(X.y(), X.x()));
      sx += std::cos(d);
      sy += std::sin(d);
    }
  }
  fit->azimuth_offset = in.options.fit_azimuth_offset ? std::atan2(sy, sx) : 0.0;
  std::vector<Eigen::VectorXd> rows;
  std::vector<double> rhs;
  for (const BoardView& v : in.views) {
    Eigen::Matrix3d R;
    ceres::AngleAxisToRotationMatrix(v.rvec.data(), R.data());
    for (size_t j = 0; j < v.corners.size(); ++j) {
      const Eigen::Vector3d X = R * in.pts[v.PointId(j)] + v.tvec;
      const double D = std::hypot(X.x(), X.y()) / in.board_size, Z = X.z() / in.board_size;
      const double x = std::hypot(v.corners[j].x() - cm.cx, v.corners[j].y() - cm.cy) / cm.rho_ref;
      // g(x) D + x h = x Z
      Eigen::VectorXd r(5);
      r << D, x * x * D, x * x * x * D, x * x * x * x * D, x;
      rows.push_back(r);
      rhs.push_back(x * Z);
    }
  }
  const Eigen::VectorXd sol = SolveRows(rows, rhs);
  if (!sol.allFinite()) {
    *log << CentreName(cm) << ": central least squares not finite; ";
    return false;
  }
  cm.a = sol.head<4>();
  fit->h_view = sol(4) * in.board_size;
  return true;
}

// The central approximation at the centre (cx, cy). False (with the reason
// logged) when it fails there.
bool CentralAt(const InitInput& in, double cx, double cy, CentralFit* fit, std::ostringstream* log) {
  if (!CentreModelAt(in.views, cx, cy, &fit->cm)) {
    *log << CentreName(fit->cm) << ": a corner lies on the centre; ";
    return false;
  }
  return in.poses_known ? CentralWithKnownPoses(in, fit, log) : CentralWithUnknownPoses(in, fit, log);
}

// The central model's elevation over the observed radii (rho in pixels).
void ElevationCurve(const CentralModel& cm, std::vector<double>* rho, std::vector<double>* elev,
                    std::ostringstream* log) {
  bool monotone = true;
  double prev = -kInf;
  for (int k = 0; k <= 40; ++k) {
    const double x = cm.rho_min + (cm.rho_max - cm.rho_min) * k / 40.0;
    const double e = std::atan2(cm.g(x), x);
    monotone = monotone && e > prev;
    prev = e;
    rho->push_back(x * cm.rho_ref);
    elev->push_back(e);
  }
  if (!monotone) *log << CentreName(cm) << ": central elevation curve not monotone; ";
}

// One start of the short joint refinement: a mirror shape group (R/zv) at
// one scale guess.
struct Start {
  double R0 = 0.0;  // the shape group's R/zv (the unified profile: its starting xi)
  ShapeFit shape;
  InitialEstimate est;
  std::array<double, kNumSensor> s{};
  double rms = kInf;
};

// The mirror's scale guesses for a shape: from the viewpoint height (known
// poses), else fractions of the boards' median distance.
std::vector<double> ScaleGuesses(const InitInput& in, const CentralFit& fit, const ShapeFit& shape) {
  if (in.poses_known && fit.h_view > 0 && shape.h > 0) return {fit.h_view / shape.h};
  std::vector<double> dist;
  if (in.poses_known) {
    for (const BoardView& v : in.views) dist.push_back(v.tvec.norm());
  } else {
    for (const Eigen::Vector3d& t : fit.ts) dist.push_back(t.norm());
  }
  std::nth_element(dist.begin(), dist.begin() + dist.size() / 2, dist.end());
  std::vector<double> scales;
  for (double c : {0.03, 0.1, 0.3}) scales.push_back(dist[dist.size() / 2] * c / (1.0 + shape.R));
  return scales;
}

// The start of one shape at one scale: the sensor and the boards' poses.
Start MakeStart(const InitInput& in, const CentralFit& fit, double R0, const ShapeFit& shape, double sc) {
  Start st;
  st.R0 = R0;
  st.shape = shape;
  InitialEstimate& est = st.est;
  est.sensor.model = in.options.model;
  est.sensor.image_width = in.width;
  est.sensor.image_height = in.height;
  SensorParams<double>& p = est.sensor.params;
  p.focal_px = shape.f;
  p.cx = fit.cm.cx;
  p.cy = fit.cm.cy;
  p.aspect = 1.0;
  p.azimuth_offset = fit.azimuth_offset;
  p.curvature_radius = shape.R * sc;
  p.conic_constant = in.conic ? shape.k : 0.0;
  p.vertex_distance = sc;
  est.poses.resize(in.views.size());
  for (size_t i = 0; i < in.views.size(); ++i)
    est.poses[i] = in.poses_known ? PackPose(in.views[i])
                                  : PoseFromRt(fit.Rs[i], fit.ts[i] + Eigen::Vector3d(0, 0, sc * shape.h));
  st.s = BlockFromParams(p);
  return st;
}

// The unified profile's elevation at image radius rho: x = (f, xi).
struct UnifiedElevationCost {
  UnifiedElevationCost(double rho, double elev) : rho_(rho), elev_(elev) {}
  template <typename T>
  bool operator()(const T* x, T* r) const {
    if (!(x[0] > T(0)) || !(x[1] >= T(0))) return false;
    SensorParams<T> p;
    p.unified = true;
    p.focal_px = x[0];
    p.xi = x[1];
    T ds, dz;
    if (!UnifiedDirection(p, T(rho_) / x[0], &ds, &dz)) return false;
    using std::atan2;
    r[0] = atan2(dz, ds) - T(elev_);
    return true;
  }
  double rho_, elev_;
};

// The unified profile's (f, xi) fitted to the central model's elevation
// curve from xi = xi0 (f started where the highest elevation falls on the
// farthest radius). False when it does not fit.
bool FitUnifiedShape(const std::vector<double>& rho, const std::vector<double>& elev, double xi0, double* f,
                     double* xi) {
  const size_t last = rho.size() - 1;
  const double m0 = std::cos(elev[last]) / (xi0 - std::sin(elev[last]));
  if (!(m0 > 0.0) || !std::isfinite(m0)) return false;
  double x[2] = {rho[last] / m0, xi0};
  ceres::Problem problem;
  for (size_t i = 0; i < rho.size(); ++i)
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<UnifiedElevationCost, 1, 2>(
                                 new UnifiedElevationCost(rho[i], elev[i])),
                             nullptr, x);
  double c0;
  if (!problem.Evaluate(ceres::Problem::EvaluateOptions(), &c0, nullptr, nullptr, nullptr)) return false;
  ceres::Solver::Options so;
  so.max_num_iterations = 100;
  so.linear_solver_type = ceres::DENSE_QR;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary sum;
  ceres::Solve(so, &problem, &sum);
  if (sum.termination_type == ceres::FAILURE || !std::isfinite(x[0] + x[1]) || !(x[0] > 0.0) ||
      !(x[1] >= 0.0 && x[1] <= 10.0))
    return false;
  *f = x[0];
  *xi = x[1];
  return true;
}

// The unified profile's starts at this centre: (f, xi) fitted to the
// central model's elevation curve from a few xi; the boards' poses are the
// central model's own (its viewpoint is the profile's), known poses moved to
// the central model's viewpoint height.
std::vector<Start> MakeUnifiedStarts(const InitInput& in, const CentralFit& fit, std::ostringstream* log) {
  std::vector<double> rho, elev;
  ElevationCurve(fit.cm, &rho, &elev, log);
  std::vector<Start> starts;
  for (double xi0 : {0.6, 1.0, 1.6}) {
    double f = 0.0, xi = 0.0;
    if (!FitUnifiedShape(rho, elev, xi0, &f, &xi)) {
      *log << CentreName(fit.cm) << " xi " << xi0 << ": the unified profile does not fit the central model; ";
      continue;
    }
    Start st;
    st.R0 = xi0;
    st.shape.f = f;
    InitialEstimate& est = st.est;
    est.sensor.model = MirrorModel::kUnified;
    est.sensor.image_width = in.width;
    est.sensor.image_height = in.height;
    SensorParams<double>& p = est.sensor.params;
    p.unified = true;
    p.focal_px = f;
    p.xi = xi;
    p.cx = fit.cm.cx;
    p.cy = fit.cm.cy;
    p.aspect = 1.0;
    p.azimuth_offset = fit.azimuth_offset;
    est.poses.resize(in.views.size());
    for (size_t i = 0; i < in.views.size(); ++i) {
      if (in.poses_known) {
        est.poses[i] = PackPose(in.views[i]);
        est.poses[i][5] -= fit.h_view;
      } else {
        est.poses[i] = PoseFromRt(fit.Rs[i], fit.ts[i]);
      }
    }
    st.s = BlockFromParams(p);
    starts.push_back(st);
  }
  return starts;
}

// Every start at this centre: the mirror shape of each R/zv group fitted to
// the central model's elevation curve, at each of its scale guesses.
std::vector<Start> MakeStarts(const InitInput& in, const CentralFit& fit, std::ostringstream* log) {
  std::vector<double> rho, elev;
  ElevationCurve(fit.cm, &rho, &elev, log);
  std::vector<Start> starts;
  for (double R0 : {0.1, 0.25, 0.5, 1.0, 2.0}) {
    const ShapeFit shape = FitShape(rho, elev, in.conic, R0);
    if (!std::isfinite(shape.cost)) {
      *log << CentreName(fit.cm) << " R/zv " << R0 << ": no mirror shape fits the central model; ";
      continue;
    }
    for (const double sc : ScaleGuesses(in, fit, shape)) starts.push_back(MakeStart(in, fit, R0, shape, sc));
  }
  return starts;
}

// The starts' short refinements, in parallel.
void RefineStarts(const InitInput& in, std::vector<Start>* starts) {
  ParallelFor(
      static_cast<int>(starts->size()),
      [&](int k) {
        Start& st = (*starts)[k];
        st.rms = QuickFit(in.views, in.pts, &st.s, &st.est.poses, in.poses_known, in.options, 30,
                          CapRadiusPx(in.width, in.height), 1);
      },
      true, in.options.Threads());
}

// The best start so far, and the best start of every R/zv group (conic).
struct StartRanking {
  double best_rms = kInf;
  InitialEstimate best;
  std::vector<std::pair<double, InitialEstimate>> groups;
};

// Ranks the refined starts in start order (so that the result does not
// depend on the thread count), one R/zv group at a time.
void RankStarts(const InitInput& in, const CentralModel& cm, std::vector<Start>* starts, StartRanking* rank,
                std::ostringstream* log) {
  for (size_t k = 0; k < starts->size();) {
    double group_rms = kInf;
    InitialEstimate group_best;
    const double R0 = (*starts)[k].R0;
    for (; k < starts->size() && (*starts)[k].R0 == R0; ++k) {
      Start& st = (*starts)[k];
      if (st.est.sensor.model == MirrorModel::kUnified)
        *log << CentreName(cm) << " unified from xi " << R0 << ": RMS " << st.rms << " px; ";
      else
        *log << CentreName(cm) << " shape f " << st.shape.f << " R/zv " << st.shape.R << " k " << st.shape.k
             << " scale " << st.est.sensor.params.vertex_distance << ": RMS " << st.rms << " px; ";
      st.est.sensor.params = ParamsFromBlock(st.s.data());
      if (in.conic && st.rms < group_rms) {
        // The conic's landscape has several basins along the valley where
        // only f R / zv is seen (far camera with a flat mirror, near
        // single-viewpoint hyperboloid...), and 30 iterations do not rank
        // them reliably: the caller refines the best start of every group.
        group_rms = st.rms;
        group_best = st.est;
      }
      if (st.rms < rank->best_rms) {
        rank->best_rms = st.rms;
        rank->best = st.est;
      }
    }
    if (std::isfinite(group_rms)) {
      group_best.summary = "start R/zv " + std::to_string(R0) + " (RMS after 30 iterations " +
                           std::to_string(group_rms) + " px)";
      rank->groups.push_back({group_rms, group_best});
    }
  }
}

}  // namespace

InitialEstimate Initialize(const std::vector<BoardView>& views, const TargetBoard& board, int width,
                           int height, bool poses_known, const CalibrateOptions& options) {
  if (views.empty()) throw Error("initialisation: no boards");
  const InitInput in{views, BoardPoints(board), board.square * std::max(board.cols, board.rows),
                     width, height, poses_known,
                     options.model == MirrorModel::kConic || options.model == MirrorModel::kAsphere, options};
  std::ostringstream log;
  StartRanking rank;
  for (const auto& [cx, cy] : CentreCandidates(width, height)) {
    CentralFit fit;
    if (!CentralAt(in, cx, cy, &fit, &log)) continue;
    std::vector<Start> starts =
        options.model == MirrorModel::kUnified ? MakeUnifiedStarts(in, fit, &log) : MakeStarts(in, fit, &log);
    RefineStarts(in, &starts);
    RankStarts(in, fit.cm, &starts, &rank, &log);
    if (rank.best_rms < 3.0) break;  // good enough: no other centre needed
  }
  if (!std::isfinite(rank.best_rms) || rank.best_rms > 10.0 * options.max_rms_px)
    throw Error("initialisation failed: no start reached a usable fit (best RMS " +
                (std::isfinite(rank.best_rms) ? std::to_string(rank.best_rms) + " px" : std::string("none")) +
                "); tried: " + log.str());
  InitialEstimate best = rank.best;
  best.summary = "best start RMS " + std::to_string(rank.best_rms) + " px; " + log.str();
  for (const auto& g : rank.groups)
    if (g.first > rank.best_rms) best.alternatives.push_back(g.second);
  return best;
}

}  // namespace pano
