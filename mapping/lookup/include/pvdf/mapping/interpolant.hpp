// A smooth interpolant of a charge map in (x, y, F) with analytic gradients: bicubic Hermite in
// position, and in force the membrane law Q = F^(2/3)·G with G linear in ln F between levels.
#pragma once

#include "pvdf/core/membrane_scaling.hpp"
#include "pvdf/mapping/map.hpp"

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace pvdf::mapping {

/// Most electrodes the runtime handles with fixed-size storage (no allocation per locate).
inline constexpr std::size_t max_electrodes = 8;

/// Interpolant of a map. For each force level f the reduced charge G_f = Q / F_f^p (p = 2/3, the
/// pure-membrane exponent) is interpolated by bicubic Hermite patches whose node derivatives
/// are 4th-order finite differences (or the map's derivative datasets); across levels G is
/// linear in ln F, and constant beyond the first/last level (the scaling law, exact for a pure
/// membrane). A cell is usable when its four nodes are inside the mask with status ok at every
/// level. Each usable cell stores its 16 polynomial coefficients per level and electrode
/// (precomputed from the Hermite data), so an evaluation is a Horner scheme on one contiguous
/// block. Immutable after construction: evaluate() is thread-safe and allocation-free.
class MapInterpolant {
 public:
  /// Throws InputError if the map has more than max_electrodes electrodes.
  explicit MapInterpolant(const ChargeMap& map);

  /// Charges q[k] (C) and their derivatives dq[k] = {∂/∂x (C/m), ∂/∂y (C/m), ∂/∂ln F (C)} for
  /// a press of force exp(log_force) at (x_m, y_m). Returns false (outputs untouched) when the
  /// position is not in a usable cell. `dq` may be null.
  bool evaluate(double x_m, double y_m, double log_force, double* q, std::array<double, 3>* dq) const;
  /// True when (x_m, y_m) lies in a usable cell.
  bool inside(double x_m, double y_m) const {
    const double u = (x_m - x0_) * ihx_, v = (y_m - y0_) * ihy_;
    if (!(u >= 0) || !(v >= 0) || u > double(nx_ - 1) || v > double(ny_ - 1)) return false;
    const std::size_t i = std::min(std::size_t(u), nx_ - 2), j = std::min(std::size_t(v), ny_ - 2);
    return cell_ok_[j * (nx_ - 1) + i] != 0;
  }
  /// Asks the memory system for the coefficients evaluate() will read at (x_m, y_m, ln F) (all
  /// levels of the cell: cheap, and right for any force); no effect off the map.
  void prefetch(double x_m, double y_m) const {
    const double u = (x_m - x0_) * ihx_, v = (y_m - y0_) * ihy_;
    if (!(u >= 0) || !(v >= 0) || u > double(nx_ - 1) || v > double(ny_ - 1)) return;
    const std::size_t i = std::min(std::size_t(u), nx_ - 2), j = std::min(std::size_t(v), ny_ - 2);
    const char* p = reinterpret_cast<const char*>(&coef_[(j * (nx_ - 1) + i) * nf_ * 16 * ne_]);
    const std::size_t bytes = nf_ * 16 * ne_ * sizeof(double);
    for (std::size_t b = 0; b < bytes; b += 64) __builtin_prefetch(p + b);
  }
  /// True when the cell (i, j) (lower-left node i, j) is usable.
  bool cell_usable(std::size_t i, std::size_t j) const { return cell_ok_[j * (nx_ - 1) + i] != 0; }

  std::size_t n_electrodes() const { return ne_; }
  std::size_t nx() const { return nx_; }
  std::size_t ny() const { return ny_; }
  std::size_t n_levels() const { return nf_; }
  double x0() const { return x0_; }
  double y0() const { return y0_; }
  double hx() const { return hx_; }
  double hy() const { return hy_; }
  double inv_hx() const { return ihx_; }  ///< 1 / hx
  double inv_hy() const { return ihy_; }  ///< 1 / hy
  double force_exponent() const { return p_; }
  double min_log_force() const { return log_f_.front(); }
  /// The force levels around ln F: G = (1 − w) G_f0 + w G_f0+1 (w clamped to [0, 1]: constant
  /// beyond the first and last level); f0 = 0, w = 0 for a one-level map.
  void level_bracket(double log_force, std::size_t& f0, double& w) const {
    f0 = 0;
    w = 0;
    if (nf_ < 2 || log_force <= log_f_.front()) return;
    if (log_force >= log_f_.back()) {
      f0 = nf_ - 2;
      w = 1;
      return;
    }
    while (f0 + 2 < nf_ && log_force > log_f_[f0 + 1]) ++f0;
    w = (log_force - log_f_[f0]) / (log_f_[f0 + 1] - log_f_[f0]);
  }
  double max_log_force() const { return log_f_.back(); }
  /// Reduced charge G (C/N^p) of node (i, j), level f, electrode k.
  double node_value(std::size_t f, std::size_t i, std::size_t j, std::size_t k) const {
    return data_[((f * ny_ + j) * nx_ + i) * ne_ * 4 + k * 4];
  }
  bool node_usable(std::size_t i, std::size_t j) const { return node_ok_[j * nx_ + i] != 0; }

 private:
  std::size_t nx_ = 0, ny_ = 0, nf_ = 0, ne_ = 0;
  double x0_ = 0, y0_ = 0, hx_ = 1, hy_ = 1, ihx_ = 1, ihy_ = 1;
  double p_ = pvdf::membrane_charge_exponent;
  std::vector<double> log_f_;
  std::vector<double> data_;  ///< [f][j][i][k][4]: G, hx·Gx, hy·Gy, hx·hy·Gxy
  /// [cell j*(nx−1)+i][f][m*4+n][k]: coefficient of t^m s^n of G in cell units (t, s ∈ [0, 1]).
  std::vector<double> coef_;
  std::vector<std::uint8_t> node_ok_, cell_ok_;
};

}  // namespace pvdf::mapping
