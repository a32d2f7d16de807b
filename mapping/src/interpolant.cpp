// Bicubic Hermite interpolation of a charge map with 4th-order finite-difference node slopes.
#include "pvdf/mapping/interpolant.hpp"

#include "pvdf/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <functional>

namespace pvdf::mapping {

namespace {

/// Derivative at index i of a line of samples f(i) with validity ok(i), spacing h: the most
/// accurate stencil whose points are all valid (5-point central, 5-point one-sided, then
/// 3-point, then 2-point; 0 if the node is isolated).
double slope(const std::function<double(long)>& f, const std::function<bool(long)>& ok, long i, double h) {
  auto all = [&](long a, long b) {
    for (long m = a; m <= b; ++m) {
      if (!ok(m)) return false;
    }
    return true;
  };
  if (all(i - 2, i + 2)) return (f(i - 2) - 8 * f(i - 1) + 8 * f(i + 1) - f(i + 2)) / (12 * h);
  if (all(i, i + 4)) return (-25 * f(i) + 48 * f(i + 1) - 36 * f(i + 2) + 16 * f(i + 3) - 3 * f(i + 4)) / (12 * h);
  if (all(i - 4, i)) return (25 * f(i) - 48 * f(i - 1) + 36 * f(i - 2) - 16 * f(i - 3) + 3 * f(i - 4)) / (12 * h);
  if (all(i - 1, i + 1)) return (f(i + 1) - f(i - 1)) / (2 * h);
  if (all(i, i + 2)) return (-3 * f(i) + 4 * f(i + 1) - f(i + 2)) / (2 * h);
  if (all(i - 2, i)) return (3 * f(i) - 4 * f(i - 1) + f(i - 2)) / (2 * h);
  if (all(i, i + 1)) return (f(i + 1) - f(i)) / h;
  if (all(i - 1, i)) return (f(i) - f(i - 1)) / h;
  return 0.0;
}

}  // namespace

MapInterpolant::MapInterpolant(const ChargeMap& map)
    : nx_(map.nx()), ny_(map.ny()), nf_(map.nf()), ne_(map.ne()) {
  if (ne_ > max_electrodes) {
    throw InputError("map has " + std::to_string(ne_) + " electrodes; the lookup handles at most " +
                     std::to_string(max_electrodes));
  }
  if (nx_ < 2 || ny_ < 2 || nf_ < 1 || ne_ < 1) throw InputError("map grid is too small for interpolation (need 2 x 2 nodes)");
  x0_ = map.x_m.front();
  y0_ = map.y_m.front();
  hx_ = (map.x_m.back() - x0_) / double(nx_ - 1);
  hy_ = (map.y_m.back() - y0_) / double(ny_ - 1);
  for (double f : map.forces_N) log_f_.push_back(std::log(f));

  node_ok_.assign(nx_ * ny_, 0);
  for (std::size_t j = 0; j < ny_; ++j) {
    for (std::size_t i = 0; i < nx_; ++i) {
      bool ok = map.mask[j * nx_ + i] != 0;
      for (std::size_t f = 0; ok && f < nf_; ++f) ok = map.status[map.point(f, j, i)] == std::uint8_t(PointStatus::ok);
      node_ok_[j * nx_ + i] = ok ? 1 : 0;
    }
  }
  cell_ok_.assign((nx_ - 1) * (ny_ - 1), 0);
  for (std::size_t j = 0; j + 1 < ny_; ++j) {
    for (std::size_t i = 0; i + 1 < nx_; ++i) {
      cell_ok_[j * (nx_ - 1) + i] = node_ok_[j * nx_ + i] && node_ok_[j * nx_ + i + 1] && node_ok_[(j + 1) * nx_ + i] &&
                                    node_ok_[(j + 1) * nx_ + i + 1];
    }
  }

  const bool exact_slopes = !map.dcharge_dx_C_per_m.empty();
  data_.assign(nf_ * ny_ * nx_ * ne_ * 4, 0.0);
  auto at = [&](std::size_t f, std::size_t i, std::size_t j, std::size_t k, int c) -> double& {
    return data_[((f * ny_ + j) * nx_ + i) * ne_ * 4 + k * 4 + std::size_t(c)];
  };
  auto okx = [&](std::size_t j) {
    return [this, j](long i) { return i >= 0 && i < long(nx_) && node_ok_[j * nx_ + std::size_t(i)] != 0; };
  };
  auto oky = [&](std::size_t i) {
    return [this, i](long j) { return j >= 0 && j < long(ny_) && node_ok_[std::size_t(j) * nx_ + i] != 0; };
  };
  for (std::size_t f = 0; f < nf_; ++f) {
    const double scale = std::pow(map.forces_N[f], -p_);
    for (std::size_t j = 0; j < ny_; ++j) {
      for (std::size_t i = 0; i < nx_; ++i) {
        if (!node_ok_[j * nx_ + i]) continue;
        for (std::size_t k = 0; k < ne_; ++k) {
          at(f, i, j, k, 0) = map.charge_C[map.charge_index(f, j, i, k)] * scale;
          if (exact_slopes) {
            at(f, i, j, k, 1) = map.dcharge_dx_C_per_m[map.charge_index(f, j, i, k)] * scale * hx_;
            at(f, i, j, k, 2) = map.dcharge_dy_C_per_m[map.charge_index(f, j, i, k)] * scale * hy_;
          }
        }
      }
    }
    for (std::size_t k = 0; k < ne_; ++k) {
      if (!exact_slopes) {
        for (std::size_t j = 0; j < ny_; ++j) {
          for (std::size_t i = 0; i < nx_; ++i) {
            if (!node_ok_[j * nx_ + i]) continue;
            at(f, i, j, k, 1) = hx_ * slope([&](long m) { return at(f, std::size_t(m), j, k, 0); }, okx(j), long(i), hx_);
            at(f, i, j, k, 2) = hy_ * slope([&](long m) { return at(f, i, std::size_t(m), k, 0); }, oky(i), long(j), hy_);
          }
        }
      }
      // Cross derivative: the y-slope of the (scaled) x-slopes.
      for (std::size_t j = 0; j < ny_; ++j) {
        for (std::size_t i = 0; i < nx_; ++i) {
          if (!node_ok_[j * nx_ + i]) continue;
          at(f, i, j, k, 3) = hy_ * slope([&](long m) { return at(f, i, std::size_t(m), k, 1); }, oky(i), long(j), hy_);
        }
      }
    }
  }
}

bool MapInterpolant::inside(double x_m, double y_m) const {
  const double u = (x_m - x0_) / hx_, v = (y_m - y0_) / hy_;
  if (!(u >= 0) || !(v >= 0) || u > double(nx_ - 1) || v > double(ny_ - 1)) return false;
  const std::size_t i = std::min(std::size_t(u), nx_ - 2), j = std::min(std::size_t(v), ny_ - 2);
  return cell_ok_[j * (nx_ - 1) + i] != 0;
}

/// Tensor-product cubic Hermite weights at (t, s) for the 4 corners × {G, Gt, Gs, Gts}: value
/// weights w, and their t- and s-derivatives wt, ws. Corner order (a, b) = (0,0), (1,0), (0,1), (1,1).
struct HermiteBasis {
  double w[4][4], wt[4][4], ws[4][4];
  HermiteBasis(double t, double s) {
    const double t2 = t * t, t3 = t2 * t, s2 = s * s, s3 = s2 * s;
    const double A[2] = {2 * t3 - 3 * t2 + 1, -2 * t3 + 3 * t2};
    const double C[2] = {t3 - 2 * t2 + t, t3 - t2};
    const double dA[2] = {6 * t2 - 6 * t, -6 * t2 + 6 * t};
    const double dC[2] = {3 * t2 - 4 * t + 1, 3 * t2 - 2 * t};
    const double B[2] = {2 * s3 - 3 * s2 + 1, -2 * s3 + 3 * s2};
    const double D[2] = {s3 - 2 * s2 + s, s3 - s2};
    const double dB[2] = {6 * s2 - 6 * s, -6 * s2 + 6 * s};
    const double dD[2] = {3 * s2 - 4 * s + 1, 3 * s2 - 2 * s};
    for (int b = 0; b < 2; ++b) {
      for (int a = 0; a < 2; ++a) {
        const int c = b * 2 + a;
        w[c][0] = A[a] * B[b], w[c][1] = C[a] * B[b], w[c][2] = A[a] * D[b], w[c][3] = C[a] * D[b];
        wt[c][0] = dA[a] * B[b], wt[c][1] = dC[a] * B[b], wt[c][2] = dA[a] * D[b], wt[c][3] = dC[a] * D[b];
        ws[c][0] = A[a] * dB[b], ws[c][1] = C[a] * dB[b], ws[c][2] = A[a] * dD[b], ws[c][3] = C[a] * dD[b];
      }
    }
  }
};

namespace {

/// Value and gradient (in cell units) of NE electrodes (NE = 0: runtime ne) in a cell whose
/// four corner records (NE × {G, hx·Gx, hy·Gy, hx·hy·Gxy} each) start at `corner`.
template <std::size_t NE>
inline void hermite_cell(const HermiteBasis& h, const double* const corner[4], std::size_t ne_runtime, double* g,
                         double* gt, double* gs) {
  const std::size_t ne = NE > 0 ? NE : ne_runtime;
  for (std::size_t k = 0; k < ne; ++k) {
    double v = 0, vt = 0, vs = 0;
    for (int c = 0; c < 4; ++c) {
      const double* n = corner[c] + 4 * k;
      v += h.w[c][0] * n[0] + h.w[c][1] * n[1] + h.w[c][2] * n[2] + h.w[c][3] * n[3];
      vt += h.wt[c][0] * n[0] + h.wt[c][1] * n[1] + h.wt[c][2] * n[2] + h.wt[c][3] * n[3];
      vs += h.ws[c][0] * n[0] + h.ws[c][1] * n[1] + h.ws[c][2] * n[2] + h.ws[c][3] * n[3];
    }
    g[k] = v;
    gt[k] = vt;
    gs[k] = vs;
  }
}

}  // namespace

bool MapInterpolant::evaluate_level(std::size_t f, std::size_t i, std::size_t j, double t, double s, double* g,
                                    double* gx, double* gy) const {
  return evaluate_level(f, i, j, HermiteBasis(t, s), g, gx, gy);
}

bool MapInterpolant::evaluate_level(std::size_t f, std::size_t i, std::size_t j, const HermiteBasis& h, double* g,
                                    double* gx, double* gy) const {
  const std::size_t stride = ne_ * 4;
  const double* base = &data_[((f * ny_ + j) * nx_ + i) * stride];
  const double* const corner[4] = {base, base + stride, base + nx_ * stride, base + (nx_ + 1) * stride};
  switch (ne_) {
    case 3: hermite_cell<3>(h, corner, ne_, g, gx, gy); break;
    case 4: hermite_cell<4>(h, corner, ne_, g, gx, gy); break;
    default: hermite_cell<0>(h, corner, ne_, g, gx, gy); break;
  }
  const double ihx = 1.0 / hx_, ihy = 1.0 / hy_;
  for (std::size_t k = 0; k < ne_; ++k) {
    gx[k] *= ihx;
    gy[k] *= ihy;
  }
  return true;
}

bool MapInterpolant::evaluate(double x_m, double y_m, double log_force, double* q, std::array<double, 3>* dq) const {
  const double u = (x_m - x0_) / hx_, v = (y_m - y0_) / hy_;
  if (!(u >= 0) || !(v >= 0) || u > double(nx_ - 1) || v > double(ny_ - 1) || !std::isfinite(log_force)) return false;
  const std::size_t i = std::min(std::size_t(u), nx_ - 2), j = std::min(std::size_t(v), ny_ - 2);
  if (!cell_ok_[j * (nx_ - 1) + i]) return false;
  const double t = u - double(i), s = v - double(j);

  // Bracket the force level in ln F.
  std::size_t f0 = 0;
  double w = 0, dw = 0;  // G = (1 − w) G_f0 + w G_f0+1, dw = ∂w/∂ln F
  if (nf_ > 1) {
    if (log_force <= log_f_.front()) {
      f0 = 0;
    } else if (log_force >= log_f_.back()) {
      f0 = nf_ - 2;
      w = 1;
    } else {
      while (f0 + 2 < nf_ && log_force > log_f_[f0 + 1]) ++f0;
      const double span = log_f_[f0 + 1] - log_f_[f0];
      w = (log_force - log_f_[f0]) / span;
      dw = 1.0 / span;
    }
  }
  const HermiteBasis basis(t, s);
  std::array<double, max_electrodes> g0, gx0, gy0;
  if (w < 1) {
    evaluate_level(f0, i, j, basis, g0.data(), gx0.data(), gy0.data());
  }
  std::array<double, max_electrodes> g1{}, gx1{}, gy1{};
  if (nf_ > 1 && w > 0) {
    evaluate_level(f0 + 1, i, j, basis, g1.data(), gx1.data(), gy1.data());
    if (w >= 1) {
      g0 = g1;
      gx0 = gx1;
      gy0 = gy1;
    }
  } else {
    g1 = g0;  // w = 0 (or one level): only level f0 contributes
    gx1 = gx0;
    gy1 = gy0;
  }
  const double amplitude = std::exp(p_ * log_force);
  for (std::size_t k = 0; k < ne_; ++k) {
    const double g = (1 - w) * g0[k] + w * g1[k];
    q[k] = amplitude * g;
    if (dq != nullptr) {
      dq[k][0] = amplitude * ((1 - w) * gx0[k] + w * gx1[k]);
      dq[k][1] = amplitude * ((1 - w) * gy0[k] + w * gy1[k]);
      dq[k][2] = p_ * q[k] + amplitude * dw * (g1[k] - g0[k]);
    }
  }
  return true;
}

}  // namespace pvdf::mapping
