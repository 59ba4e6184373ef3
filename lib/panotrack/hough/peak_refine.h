// Internal: accumulator smoothing and sub-bin peak refinement shared by the
// tracking and whole-image modes. Grids are row-major, ny rows of nx.
#pragma once

#include <algorithm>
#include <cmath>

namespace pano {

// out = [1 2 1]^T [1 2 1] / 16 applied to g (zero outside the grid).
template <typename T>
void SmoothBinomial3x3(const T* g, int ny, int nx, T* out) {
  for (int y = 0; y < ny; ++y) {
    for (int x = 0; x < nx; ++x) {
      T s = T(0);
      for (int dy = -1; dy <= 1; ++dy) {
        const int yy = y + dy;
        if (yy < 0 || yy >= ny) continue;
        const T wy = dy == 0 ? T(2) : T(1);
        const T* row = g + static_cast<size_t>(yy) * nx;
        T r = T(2) * row[x];
        if (x > 0) r += row[x - 1];
        if (x + 1 < nx) r += row[x + 1];
        s += wy * r;
      }
      out[static_cast<size_t>(y) * nx + x] = s / T(16);
    }
  }
}

// SmoothBinomial3x3 of the ny x nx block of g whose rows lie g_stride apart,
// zero outside the block, without its per-cell branches: a row pass into
// h_scratch (ny * nx values), then a column pass into out (ny x nx,
// contiguous). Each output is the same sum in the same order, so the result
// is bit-identical to SmoothBinomial3x3 of the block.
template <typename T>
void SmoothBinomial3x3Separable(const T* g, int ny, int nx, size_t g_stride, T* h_scratch, T* out) {
  if (ny <= 0 || nx <= 0) return;
  for (int y = 0; y < ny; ++y) {
    const T* row = g + static_cast<size_t>(y) * g_stride;
    T* h = h_scratch + static_cast<size_t>(y) * nx;
    if (nx == 1) {
      h[0] = T(2) * row[0];
      continue;
    }
    h[0] = T(2) * row[0] + row[1];
    for (int x = 1; x + 1 < nx; ++x) h[x] = (T(2) * row[x] + row[x - 1]) + row[x + 1];
    h[nx - 1] = T(2) * row[nx - 1] + row[nx - 2];
  }
  // s = 0; s += 1 * h[y-1]; s += 2 * h[y]; s += 1 * h[y+1] (each where it exists).
  for (int y = 0; y < ny; ++y) {
    const T* hm = h_scratch + static_cast<size_t>(y > 0 ? y - 1 : y) * nx;
    const T* h0 = h_scratch + static_cast<size_t>(y) * nx;
    const T* hp = h_scratch + static_cast<size_t>(y + 1 < ny ? y + 1 : y) * nx;
    T* o = out + static_cast<size_t>(y) * nx;
    if (y > 0 && y + 1 < ny) {
      for (int x = 0; x < nx; ++x) o[x] = (((T(0) + hm[x]) + T(2) * h0[x]) + hp[x]) / T(16);
    } else if (y > 0) {
      for (int x = 0; x < nx; ++x) o[x] = ((T(0) + hm[x]) + T(2) * h0[x]) / T(16);
    } else if (y + 1 < ny) {
      for (int x = 0; x < nx; ++x) o[x] = ((T(0) + T(2) * h0[x]) + hp[x]) / T(16);
    } else {
      for (int x = 0; x < nx; ++x) o[x] = (T(0) + T(2) * h0[x]) / T(16);
    }
  }
}

struct PeakFit {
  double x = 0.0, y = 0.0;  // refined position in bins (column, row)
  float value = 0.0f;       // grid value at the integer peak
  bool at_border = false;
};

// Sub-bin offset of the peak at (iy, ix) from its 3x3 neighbourhood f[dy][dx]:
// least-squares quadratic a + b x + c y + d x^2 + e x y + f y^2, its
// stationary point when that is a maximum within one bin; otherwise a
// parabola per axis (each clamped to half a bin).
inline void RefineOffset(const double f[3][3], double* ox, double* oy) {
  double b = 0, c = 0, d = 0, ff = 0;
  for (int k = 0; k < 3; ++k) {
    b += f[k][2] - f[k][0];
    c += f[2][k] - f[0][k];
    d += f[k][2] - 2.0 * f[k][1] + f[k][0];
    ff += f[2][k] - 2.0 * f[1][k] + f[0][k];
  }
  b /= 6.0;
  c /= 6.0;
  d /= 6.0;
  ff /= 6.0;
  const double e = (f[2][2] - f[0][2] - f[2][0] + f[0][0]) / 4.0;
  const double det = 4.0 * d * ff - e * e;
  if (d < 0.0 && det > 0.0) {
    const double x = (-b * 2.0 * ff + c * e) / det;
    const double y = (-c * 2.0 * d + b * e) / det;
    if (std::abs(x) <= 1.0 && std::abs(y) <= 1.0) {
      *ox = x;
      *oy = y;
      return;
    }
  }
  auto parabola = [](double m, double z, double p) {
    const double den = m - 2.0 * z + p;
    if (!(den < 0.0)) return 0.0;
    return std::clamp(0.5 * (m - p) / den, -0.5, 0.5);
  };
  *ox = parabola(f[1][0], f[1][1], f[1][2]);
  *oy = parabola(f[0][1], f[1][1], f[2][1]);
}

// Neighbourhood of (iy, ix); rows wrap when wrap_y (a full circle of theta),
// cells outside the grid repeat the centre (so that axis gets no offset).
template <typename T>
void Neighbourhood(const T* g, int ny, int nx, int iy, int ix, bool wrap_y, double f[3][3]) {
  const double centre = static_cast<double>(g[static_cast<size_t>(iy) * nx + ix]);
  for (int dy = -1; dy <= 1; ++dy) {
    int yy = iy + dy;
    if (wrap_y) yy = (yy + ny) % ny;
    for (int dx = -1; dx <= 1; ++dx) {
      const int xx = ix + dx;
      double v = centre;
      if (yy >= 0 && yy < ny && xx >= 0 && xx < nx) v = static_cast<double>(g[static_cast<size_t>(yy) * nx + xx]);
      f[dy + 1][dx + 1] = v;
    }
  }
}

// Global maximum (first in row-major order on ties), refined.
template <typename T>
PeakFit FindAndRefinePeak(const T* g, int ny, int nx) {
  PeakFit out;
  size_t best = 0;
  const size_t n = static_cast<size_t>(ny) * nx;
  for (size_t i = 1; i < n; ++i)
    if (g[i] > g[best]) best = i;
  const int iy = static_cast<int>(best / nx), ix = static_cast<int>(best % nx);
  out.value = static_cast<float>(g[best]);
  out.at_border = (ny > 1 && (iy == 0 || iy == ny - 1)) || (nx > 1 && (ix == 0 || ix == nx - 1));
  double f[3][3];
  Neighbourhood(g, ny, nx, iy, ix, false, f);
  double ox = 0, oy = 0;
  RefineOffset(f, &ox, &oy);
  out.x = ix + ox;
  out.y = iy + oy;
  return out;
}

// FindAndRefinePeak of an ny x nx grid that is zero outside one block: the
// by x bx values at `block` (rows `stride` apart) whose first cell is grid
// cell (y0, x0). The same result as FindAndRefinePeak of the whole grid
// whenever the block's maximum is positive (otherwise the peak is the
// block's first maximum, not the grid's). Positions are grid positions.
template <typename T>
PeakFit FindAndRefinePeakInBlock(const T* block, int by, int bx, size_t stride, int y0, int x0,
                                 int ny, int nx) {
  PeakFit out;
  int best_y = 0, best_x = 0;
  T best_v = block[0];
  for (int y = 0; y < by; ++y) {
    const T* row = block + static_cast<size_t>(y) * stride;
    for (int x = 0; x < bx; ++x)
      if (row[x] > best_v) {
        best_v = row[x];
        best_y = y;
        best_x = x;
      }
  }
  const int iy = y0 + best_y, ix = x0 + best_x;
  out.value = static_cast<float>(best_v);
  out.at_border = (ny > 1 && (iy == 0 || iy == ny - 1)) || (nx > 1 && (ix == 0 || ix == nx - 1));
  // Neighbourhood as FindAndRefinePeak's: outside the grid the centre repeats.
  const double centre = static_cast<double>(best_v);
  double f[3][3];
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int yy = iy + dy, xx = ix + dx;
      double v = centre;
      if (yy >= 0 && yy < ny && xx >= 0 && xx < nx) {
        const int ry = yy - y0, rx = xx - x0;
        v = ry >= 0 && ry < by && rx >= 0 && rx < bx
                ? static_cast<double>(block[static_cast<size_t>(ry) * stride + rx])
                : 0.0;
      }
      f[dy + 1][dx + 1] = v;
    }
  double ox = 0, oy = 0;
  RefineOffset(f, &ox, &oy);
  out.x = ix + ox;
  out.y = iy + oy;
  return out;
}

}  // namespace pano
