// Bicubic Hermite interpolation of a charge map with 4th-order finite-difference node slopes.
#include "pvdf/mapping/interpolant.hpp"

#include "pvdf/core/assert.hpp"
#include "pvdf/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <functional>

// evaluate() is compiled twice, for any x86-64 and for x86-64-v3 (AVX2, FMA:
// +6 % locates/s measured, docs/lookup.md §3), and the loader picks the one the CPU runs (GCC
// function multiversioning). AVX-512 clones measured slower (−3 %): not built.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define PVDF_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define PVDF_CLONES
#endif

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
  // Only a validated map (validate(), map.hpp) reaches here: its arrays have the grid's shapes.
  const std::size_t n_points = nf_ * ny_ * nx_;
  PVDF_ASSERT(map.mask.size() == nx_ * ny_ && map.status.size() == n_points && map.charge_C.size() == n_points * ne_,
              "the map's mask, status and charge arrays must have the shapes of its grid (validate the map first)");
  PVDF_ASSERT(map.dcharge_dx_C_per_m.size() == map.dcharge_dy_C_per_m.size() &&
                  (map.dcharge_dx_C_per_m.empty() || map.dcharge_dx_C_per_m.size() == n_points * ne_),
              "the map's charge derivatives must be both absent or both [nf][ny][nx][ne]");
  x0_ = map.x_m.front();
  y0_ = map.y_m.front();
  hx_ = (map.x_m.back() - x0_) / double(nx_ - 1);
  hy_ = (map.y_m.back() - y0_) / double(ny_ - 1);
  PVDF_ASSERT(hx_ > 0 && hy_ > 0 && std::isfinite(hx_) && std::isfinite(hy_),
              "the map's axes must be ascending and finite (validate the map first)");
  ihx_ = 1.0 / hx_;
  ihy_ = 1.0 / hy_;
  for (double f : map.forces_N) log_f_.push_back(std::log(f));
  for (std::size_t f = 0; f < nf_; ++f) {
    PVDF_ASSERT(std::isfinite(log_f_[f]) && (f == 0 || log_f_[f] > log_f_[f - 1]),
                "the force levels must be > 0 and strictly ascending (validate the map first)");
  }

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

  // Per-cell polynomial coefficients: A = H·F·Hᵀ with F the 4×4 Hermite data of a cell
  // (rows: G(0,·), G(1,·), G_t(0,·), G_t(1,·); columns the same in s) and H the cubic Hermite →
  // monomial matrix, so that G(t, s) = Σ A[m][n] t^m s^n.
  static constexpr double H[4][4] = {{1, 0, 0, 0}, {0, 0, 1, 0}, {-3, 3, -2, -1}, {2, -2, 1, 1}};
  coef_.assign((nx_ - 1) * (ny_ - 1) * nf_ * 16 * ne_, 0.0);
  for (std::size_t j = 0; j + 1 < ny_; ++j) {
    for (std::size_t i = 0; i + 1 < nx_; ++i) {
      if (!cell_ok_[j * (nx_ - 1) + i]) continue;
      for (std::size_t f = 0; f < nf_; ++f) {
        double* out = &coef_[((j * (nx_ - 1) + i) * nf_ + f) * 16 * ne_];
        for (std::size_t k = 0; k < ne_; ++k) {
          double F[4][4];
          for (int a = 0; a < 2; ++a) {
            for (int b = 0; b < 2; ++b) {
              F[a][b] = at(f, i + std::size_t(a), j + std::size_t(b), k, 0);
              F[2 + a][b] = at(f, i + std::size_t(a), j + std::size_t(b), k, 1);
              F[a][2 + b] = at(f, i + std::size_t(a), j + std::size_t(b), k, 2);
              F[2 + a][2 + b] = at(f, i + std::size_t(a), j + std::size_t(b), k, 3);
            }
          }
          for (int m = 0; m < 4; ++m) {
            for (int n = 0; n < 4; ++n) {
              double v = 0;
              for (int a = 0; a < 4; ++a) {
                for (int b = 0; b < 4; ++b) v += H[m][a] * F[a][b] * H[n][b];
              }
              out[std::size_t(m * 4 + n) * ne_ + k] = v;
            }
          }
        }
      }
    }
  }
}

namespace {

/// Value and gradient (cell units) of the NE electrodes (NE = 0: runtime count) of one level of
/// one cell: c holds the 16 coefficients × ne, [m*4+n][k] for t^m s^n. Horner in s, then in t.
template <std::size_t NE>
inline void horner_cell(const double* c, std::size_t ne_runtime, double t, double s, double* g, double* gt,
                        double* gs) {
  const std::size_t ne = NE > 0 ? NE : ne_runtime;
  for (std::size_t k = 0; k < ne; ++k) {
    double b[4], db[4];
    for (int m = 0; m < 4; ++m) {
      const double* a = c + std::size_t(m * 4) * ne + k;
      const double a0 = a[0], a1 = a[ne], a2 = a[2 * ne], a3 = a[3 * ne];
      b[m] = ((a3 * s + a2) * s + a1) * s + a0;
      db[m] = (3 * a3 * s + 2 * a2) * s + a1;
    }
    g[k] = ((b[3] * t + b[2]) * t + b[1]) * t + b[0];
    gt[k] = (3 * b[3] * t + 2 * b[2]) * t + b[1];
    gs[k] = ((db[3] * t + db[2]) * t + db[1]) * t + db[0];
  }
}

/// The evaluation of one point for NE electrodes (NE = 0: runtime count): the two levels around
/// ln F by Horner, blended linearly in ln F, times F^p. A template so that the three-electrode
/// film gets fixed-size loops throughout (−30 % time per evaluation measured).
template <std::size_t NE>
inline void evaluate_cell(const double* cell, std::size_t ne_runtime, std::size_t nf, std::size_t f0, double w, double dw,
                          double t, double s, double p, double log_force, double ihx, double ihy, double* q,
                          std::array<double, 3>* dq) {
  const std::size_t ne = NE > 0 ? NE : ne_runtime;
  constexpr std::size_t cap = NE > 0 ? NE : max_electrodes;
  const std::size_t level_stride = 16 * ne;
  double ga[cap], gxa[cap], gya[cap], gb[cap], gxb[cap], gyb[cap];
  // G_f0 and G_f0+1 (one of them alone where w is 0 or 1, or with one level).
  const double *g0 = ga, *gx0 = gxa, *gy0 = gya, *g1 = ga, *gx1 = gxa, *gy1 = gya;
  if (w < 1) horner_cell<NE>(cell + f0 * level_stride, ne, t, s, ga, gxa, gya);
  if (nf > 1 && w > 0) {
    horner_cell<NE>(cell + (f0 + 1) * level_stride, ne, t, s, gb, gxb, gyb);
    g1 = gb;
    gx1 = gxb;
    gy1 = gyb;
    if (w >= 1) {
      g0 = gb;
      gx0 = gxb;
      gy0 = gyb;
    }
  }
  const double amplitude = std::exp(p * log_force);
  for (std::size_t k = 0; k < ne; ++k) {
    const double g = (1 - w) * g0[k] + w * g1[k];
    q[k] = amplitude * g;
    if (dq != nullptr) {
      dq[k][0] = amplitude * ihx * ((1 - w) * gx0[k] + w * gx1[k]);
      dq[k][1] = amplitude * ihy * ((1 - w) * gy0[k] + w * gy1[k]);
      dq[k][2] = p * q[k] + amplitude * dw * (g1[k] - g0[k]);
    }
  }
}

}  // namespace

PVDF_CLONES bool MapInterpolant::evaluate(double x_m, double y_m, double log_force, double* q, std::array<double, 3>* dq) const {
  const double u = (x_m - x0_) * ihx_, v = (y_m - y0_) * ihy_;
  if (!(u >= 0) || !(v >= 0) || u > double(nx_ - 1) || v > double(ny_ - 1) || !std::isfinite(log_force)) return false;
  const std::size_t i = std::min(std::size_t(u), nx_ - 2), j = std::min(std::size_t(v), ny_ - 2);
  if (!cell_ok_[j * (nx_ - 1) + i]) return false;
  const double t = u - double(i), s = v - double(j);

  // Bracket the force level in ln F.
  std::size_t f0 = 0;
  double w = 0, dw = 0;  // G = (1 − w) G_f0 + w G_f0+1, dw = ∂w/∂ln F (0 where w is clamped)
  level_bracket(log_force, f0, w);
  PVDF_ASSERT(w >= 0 && w <= 1 && (nf_ == 1 ? f0 == 0 : f0 + 1 < nf_), "the force bracket must lie between two levels");
  if (nf_ > 1 && log_force > log_f_.front() && log_force < log_f_.back()) dw = 1.0 / (log_f_[f0 + 1] - log_f_[f0]);
  const double* cell = &coef_[(j * (nx_ - 1) + i) * nf_ * 16 * ne_];
  switch (ne_) {
    case 3: evaluate_cell<3>(cell, ne_, nf_, f0, w, dw, t, s, p_, log_force, ihx_, ihy_, q, dq); break;
    case 4: evaluate_cell<4>(cell, ne_, nf_, f0, w, dw, t, s, p_, log_force, ihx_, ihy_, q, dq); break;
    default: evaluate_cell<0>(cell, ne_, nf_, f0, w, dw, t, s, p_, log_force, ihx_, ihy_, q, dq); break;
  }
  return true;
}

}  // namespace pvdf::mapping
