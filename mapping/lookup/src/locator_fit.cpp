// The lookup's fits and choice (docs/lookup.md §1.4, 1.6–1.8): Levenberg–Marquardt on the
// interpolant, covariance, distinct solutions, their probabilities and the reported answer.
#include "locator_detail.hpp"
#include "pvdf/mapping/locator.hpp"

#include "pvdf/core/assert.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/mapping/interpolation_error.hpp"

namespace pvdf::mapping {

using detail::direction_key;
using detail::normalize;
using detail::solve_spd3;
using detail::Vec;

namespace detail {

/// Levenberg–Marquardt's current point: the model's charges and gradient there, χ², and the
/// weighted normal equations JᵀJ (upper triangle 00 01 02 11 12 22) and Jᵀr.
struct LmPoint {
  Vec model;  // entries 0..ne−1 written by evaluate() before any read
  std::array<std::array<double, 3>, max_electrodes> grad;
  double chi2 = 0;
  std::array<double, 6> JtJ;
  std::array<double, 3> Jtr;
};

}  // namespace detail

using detail::LmPoint;

namespace {

template <std::size_t NE>
PVDF_INLINE double chi2_of(const Vec& m, const double* q, const double* w, std::size_t ne_runtime) {
  const std::size_t ne = NE > 0 ? NE : ne_runtime;
  double s = 0;
  for (std::size_t k = 0; k < ne; ++k) {
    const double r = (m[k] - q[k]) * w[k];
    s += r * r;
  }
  return s;
}

template <std::size_t NE>
PVDF_INLINE void normal_equations(LmPoint& p, const double* q, const double* w, std::size_t ne_runtime) {
  const std::size_t ne = NE > 0 ? NE : ne_runtime;
  p.JtJ = {0, 0, 0, 0, 0, 0};
  p.Jtr = {0, 0, 0};
  for (std::size_t k = 0; k < ne; ++k) {
    const double g0 = p.grad[k][0] * w[k], g1 = p.grad[k][1] * w[k], g2 = p.grad[k][2] * w[k];
    const double r = (p.model[k] - q[k]) * w[k];
    p.JtJ[0] += g0 * g0;
    p.JtJ[1] += g0 * g1;
    p.JtJ[2] += g0 * g2;
    p.JtJ[3] += g1 * g1;
    p.JtJ[4] += g1 * g2;
    p.JtJ[5] += g2 * g2;
    p.Jtr[0] += g0 * r;
    p.Jtr[1] += g1 * r;
    p.Jtr[2] += g2 * r;
  }
}

/// vᵀ JᵀJ v.
PVDF_INLINE double quad_form(const std::array<double, 6>& JtJ, const std::array<double, 3>& v) {
  return JtJ[0] * v[0] * v[0] + JtJ[3] * v[1] * v[1] + JtJ[5] * v[2] * v[2] +
         2.0 * (JtJ[1] * v[0] * v[1] + JtJ[2] * v[0] * v[2] + JtJ[4] * v[1] * v[2]);
}

/// The damped step (JᵀJ + λ diag JᵀJ) step = −Jᵀr (with the force fixed its ln F row is 1);
/// one that leaves the plausible force range is projected: ln F goes to the bound and (x, y)
/// are solved with it held there (it keeps the fit from spinning against the bound). False when
/// the damped system is not positive definite.
PVDF_INLINE bool damped_step(const LmPoint& p, double lambda, bool fixed_force, double l, double log_lo, double log_hi,
                 std::array<double, 3>& step) {
  std::array<double, 6> A = p.JtJ;
  A[0] += lambda * p.JtJ[0] + 1e-300;
  A[3] += lambda * p.JtJ[3] + 1e-300;
  A[5] += lambda * p.JtJ[5] + 1e-300;
  if (fixed_force) A[5] = 1.0;
  step = solve_spd3(A, {-p.Jtr[0], -p.Jtr[1], -p.Jtr[2]});
  if (!(std::isfinite(step[0]) && std::isfinite(step[1]) && std::isfinite(step[2]))) return false;
  if (!fixed_force && (l + step[2] < log_lo || l + step[2] > log_hi)) {
    const double dl = (l + step[2] < log_lo ? log_lo : log_hi) - l;
    const double b0 = -p.Jtr[0] - A[2] * dl, b1 = -p.Jtr[1] - A[4] * dl;
    const double det = A[0] * A[3] - A[1] * A[1];
    if (det > 0) step = {(A[3] * b0 - A[1] * b1) / det, (A[0] * b1 - A[1] * b0) / det, dl};
  }
  return true;
}

/// Keeps steps within a few cells (the interpolant is only trusted where it is defined) and
/// within 1 in ln F: the factor ≤ 1 to apply.
PVDF_INLINE double step_limit(const std::array<double, 3>& step, double hx, double hy) {
  double limit = 1.0;
  if (std::abs(step[0]) > 4.0 * hx) limit = std::min(limit, 4.0 * hx / std::abs(step[0]));
  if (std::abs(step[1]) > 4.0 * hy) limit = std::min(limit, 4.0 * hy / std::abs(step[1]));
  if (std::abs(step[2]) > 1.0) limit = std::min(limit, 1.0 / std::abs(step[2]));
  return limit;
}

}  // namespace

PVDF_CLONES bool Locator::lm_evaluate(double x, double y, double l, bool fixed_force, const double* q, const double* w,
                          LmPoint& p) const {
  if (!interp_.evaluate(x, y, l, p.model.data(), p.grad.data())) return false;
  if (fixed_force) {  // only (x, y) move: drop the ln F column
    for (std::size_t k = 0; k < ne_; ++k) p.grad[k][2] = 0;
  }
  if (ne_ == 3) {  // fixed-size loops for the three-electrode film
    p.chi2 = chi2_of<3>(p.model, q, w, ne_);
    normal_equations<3>(p, q, w, ne_);
  } else {
    p.chi2 = chi2_of<0>(p.model, q, w, ne_);
    normal_equations<0>(p, q, w, ne_);
  }
  return true;
}

PVDF_CLONES bool Locator::final_step_ok(double x, double y, double l, const std::array<double, 3>& step, double lambda,
                            double log_lo, double log_hi) const {
  // A nearly undamped Gauss–Newton step this small is in the quadratic phase: the error left
  // after it is ≈ κ δ² / 2 (κ = |H| / σ_min(J) of the cell holding the point). Below 1e-4 cell
  // (the threshold on δ clamped to 1e-3…1e-2 cell, 1e-3 in ln F; the map's own interpolation
  // error is ~1e-3 cell) it is taken without evaluating the model there.
  if (!(lambda < 1e-2 && std::abs(step[2]) < 1e-3)) return false;
  const std::int32_t slot = slot_at(x, y);
  const double accept = slot >= 0 ? double(scan_[std::size_t(slot) * scan_stride_ + 6 * ne_ + 7]) : 1e-3;
  return std::abs(step[0]) < accept * interp_.hx() && std::abs(step[1]) < accept * interp_.hy() &&
         interp_.inside(x + step[0], y + step[1]) && l + step[2] >= log_lo && l + step[2] <= log_hi;
}

PVDF_CLONES bool Locator::held_by_edge(const std::array<double, 6>& JtJ, const std::array<double, 3>& Jtr, double x, double y,
                           double l, bool fixed_force, double log_lo, double log_hi) const {
  // The undamped Gauss–Newton step from the minimum would leave the map or the force range.
  std::array<double, 6> A = JtJ;
  A[0] *= 1.0 + 1e-9;
  A[3] *= 1.0 + 1e-9;
  A[5] *= 1.0 + 1e-9;
  if (fixed_force) A[5] = 1.0;
  const std::array<double, 3> step = solve_spd3(A, {-Jtr[0], -Jtr[1], -Jtr[2]});
  return std::isfinite(step[0]) && std::isfinite(step[1]) && std::isfinite(step[2]) &&
         (!interp_.inside(x + step[0], y + step[1]) || l + step[2] < log_lo || l + step[2] > log_hi);
}

PVDF_CLONES Locator::Fit Locator::levenberg_marquardt(const double* q, const double* w, double x, double y, double l,
                                                      bool fixed_force, double log_lo, double log_hi, const Fit* found,
                                                      int n_found) const {
  Fit fit;
  Vec w_map{};
  if (!map_error_.empty()) {
    // The map's own error joins the charge noise (σ_k² + e_k², e at the start: the weights are
    // held during the fit; finish() takes χ² with e at the end point). The fit weighs each
    // electrode by its total e_k² (the weights before the split, §1.11: the fits, and the 3σ
    // test between their end points, are those of the lookup before it); finish() takes χ²,
    // σ's and probabilities under the split model, with the common scale's correlation.
    Vec variance{}, total{};
    double scale2 = 0;
    if (map_variance_at(x, y, l, variance.data(), scale2, total.data())) {
      for (std::size_t k = 0; k < ne_; ++k) w_map[k] = 1.0 / std::sqrt(1.0 / (w[k] * w[k]) + total[k]);
      w = w_map.data();
    }
  }
  const double hx = interp_.hx(), hy = interp_.hy();
  // A point within 0.05 cell and 0.01 in ln F of a solution an earlier start already found is
  // heading into it: the fit stops there (two end points closer than a cell are never distinct
  // solutions). Asked of the start and of every trial point before the model is evaluated there.
  auto known = [&](double px, double py, double pl) {
    for (int d = 0; d < n_found; ++d) {
      if (found[d].ok && std::abs(px - found[d].x) < 0.05 * hx && std::abs(py - found[d].y) < 0.05 * hy &&
          std::abs(pl - found[d].l) < 0.01) {
        return true;
      }
    }
    return false;
  };
  if (known(x, y, l)) {
    fit.duplicate = true;
    return fit;
  }
  LmPoint p;
  if (!lm_evaluate(x, y, l, fixed_force, q, w, p)) return fit;
  double lambda = 1e-3;
  int it = 0;
  bool quadratic_exit = false;
  for (; it < options_.max_iterations; ++it) {
    std::array<double, 3> step;
    if (!damped_step(p, lambda, fixed_force, l, log_lo, log_hi, step)) {
      lambda *= 10;
      if (lambda > 1e12) break;
      continue;
    }
    const double limit = step_limit(step, hx, hy);
    if (final_step_ok(x, y, l, step, lambda, log_lo, log_hi)) {
      // Taken unevaluated; χ² from the linear model, χ² + 2 stepᵀJᵀr + stepᵀJᵀJ step (its
      // change is second order too).
      x += step[0];
      y += step[1];
      l += step[2];
      for (std::size_t k = 0; k < ne_; ++k) p.model[k] += p.grad[k][0] * step[0] + p.grad[k][1] * step[1] + p.grad[k][2] * step[2];
      p.chi2 = std::max(0.0, p.chi2 + 2.0 * (p.Jtr[0] * step[0] + p.Jtr[1] * step[1] + p.Jtr[2] * step[2]) +
                                 quad_form(p.JtJ, step));
      fit.converged = true;
      fit.blocked = false;
      quadratic_exit = true;
      ++it;
      break;
    }
    const double nx = x + limit * step[0], ny = y + limit * step[1], nl = l + limit * step[2];
    if (known(nx, ny, nl)) {
      fit.duplicate = true;
      return fit;
    }
    LmPoint trial;
    if (nl < log_lo || nl > log_hi || !lm_evaluate(nx, ny, nl, fixed_force, q, w, trial)) {
      fit.blocked = true;
      lambda *= 10;
      if (lambda > 1e12) {
        fit.converged = true;
        break;
      }
      continue;
    }
    if (trial.chi2 <= p.chi2) {
      // Converged when the step is far below any useful resolution (1e-5 of a cell, 1e-7 in
      // ln F) or the misfit no longer drops (relative 1e-8).
      const bool small = std::abs(limit * step[0]) < 1e-5 * hx && std::abs(limit * step[1]) < 1e-5 * hy &&
                         std::abs(limit * step[2]) < 1e-7;
      const bool tiny_gain = p.chi2 - trial.chi2 <= 1e-8 * (p.chi2 + 1e-30);
      x = nx;
      y = ny;
      l = nl;
      p = trial;
      lambda = std::max(lambda * 0.2, 1e-9);
      fit.blocked = false;
      if (small || p.chi2 < 1e-20 || tiny_gain) {
        fit.converged = true;
        ++it;
        break;
      }
    } else {
      lambda *= 8;
      if (lambda > 1e12) {  // no descent left: a minimum (possibly on the map's edge)
        fit.converged = true;
        break;
      }
    }
  }
  // Is the minimum held by the map's edge? (Only asked of fits that do not fit within noise —
  // outside_map or poor_fit — so it is skipped after a quadratic-phase exit within noise.)
  if ((!quadratic_exit || p.chi2 > (fixed_force ? chi2_limit_fixed_ : chi2_limit_free_)) &&
      held_by_edge(p.JtJ, p.Jtr, x, y, l, fixed_force, log_lo, log_hi)) {
    fit.blocked = true;
  }
  fit.x = x;
  fit.y = y;
  fit.l = l;
  fit.chi2 = p.chi2;
  fit.iterations = it;
  fit.jtj = p.JtJ;
  fit.model = p.model;
  fit.grad = p.grad;
  fit.ok = std::isfinite(p.chi2) && std::isfinite(x) && std::isfinite(y) && std::isfinite(l);
  return fit;
}

PVDF_CLONES bool Locator::map_variance_at(double x, double y, double l, double* variance_C2, double& scale2,
                                          double* total_C2) const {
  // Per electrode, in quadrature (independent shares, docs/lookup.md §1.10): the nodes' own
  // estimate, the interpolation error between nodes × the bubble 1 − (1 − 4t(1−t))(1 − 4s(1−s))
  // (zero at the nodes, one on the cell's mid-lines), between levels × 4w(1−w), and beyond them
  // the slope × the distance in ln F. Each share bilinear in the cell's corners and linear in
  // ln F between the levels (absolute errors; beyond the levels scaled by the F^p law). With
  // correlated_map_error each interpolation share is split (§1.11): its common relative scale α
  // (bilinear too) into scale2 = Σ α², and 1 − ρ of its variance stays independent per
  // electrode, ρ the scale's fraction of it at the nodes (so the total is kept).
  const std::size_t nx = interp_.nx(), ny = interp_.ny(), ne = ne_, nf = interp_.n_levels();
  const double u = (x - interp_.x0()) * interp_.inv_hx(), v = (y - interp_.y0()) * interp_.inv_hy();
  if (!(u >= 0 && v >= 0 && u <= double(nx - 1) && v <= double(ny - 1))) return false;
  const std::size_t i = std::min(std::size_t(u), nx - 2), j = std::min(std::size_t(v), ny - 2);
  const double a = u - double(i), b = v - double(j);
  const double wc[4] = {(1 - a) * (1 - b), a * (1 - b), (1 - a) * b, a * b};
  std::size_t f0 = 0;
  double w = 0;
  interp_.level_bracket(l, f0, w);
  const std::size_t f1 = nf > 1 ? f0 + 1 : f0;
  const double bubble = 1.0 - (1.0 - 4.0 * a * (1.0 - a)) * (1.0 - 4.0 * b * (1.0 - b));
  double level_share = 0, beyond = 0, scale = 1;
  std::size_t f_end = 0;
  if (l < interp_.min_log_force()) {
    beyond = nf > 1 ? interp_.min_log_force() - l : 0.0;
    scale = std::exp(interp_.force_exponent() * (l - interp_.min_log_force()));
  } else if (l > interp_.max_log_force()) {
    beyond = nf > 1 ? l - interp_.max_log_force() : 0.0;
    f_end = nf - 1;
    scale = std::exp(interp_.force_exponent() * (l - interp_.max_log_force()));
  } else if (nf > 1) {
    level_share = 4.0 * w * (1.0 - w);
  }
  const std::size_t cell = j * (nx - 1) + i;
  auto corners = [&](const float* c) { return wc[0] * c[0] + wc[1] * c[1] + wc[2] * c[2] + wc[3] * c[3]; };
  // The common-scale fractions of the three interpolation shares (0 without the split).
  double rho_nodes = 0, rho_levels = 0, rho_beyond = 0;
  scale2 = 0;
  if (!map_scale_.empty()) {  // per corner: ρ nodes, levels, beyond, then α nodes, levels, beyond
    const float* s0 = &map_scale_[(cell * nf + f0) * 24];
    const float* s1 = &map_scale_[(cell * nf + f1) * 24];
    const float* se = &map_scale_[(cell * nf + f_end) * 24];
    rho_nodes = (1 - w) * corners(s0) + w * corners(s1);
    const double alpha_nodes = bubble * ((1 - w) * corners(s0 + 12) + w * corners(s1 + 12));
    scale2 = alpha_nodes * alpha_nodes;
    if (level_share > 0) {
      rho_levels = corners(s0 + 4);
      const double alpha_levels = level_share * corners(s0 + 16);
      scale2 += alpha_levels * alpha_levels;
    }
    if (beyond > 0) {  // relative: no F^p scaling beyond the levels
      rho_beyond = corners(se + 8);
      const double alpha_beyond = beyond * corners(se + 20);
      scale2 += alpha_beyond * alpha_beyond;
    }
  }
  const float* c0 = &map_error_[(cell * nf + f0) * ne * 16];
  const float* c1 = &map_error_[(cell * nf + f1) * ne * 16];
  for (std::size_t k = 0; k < ne; ++k, c0 += 16, c1 += 16) {
    const double node = (1 - w) * corners(c0) + w * corners(c1);
    const double between_nodes = bubble * ((1 - w) * corners(c0 + 4) + w * corners(c1 + 4));
    const double b2 = between_nodes * between_nodes;
    variance_C2[k] = node * node + (1 - rho_nodes) * b2;
    if (total_C2) total_C2[k] = node * node + b2;
  }
  if (level_share > 0) {
    const float* c = &map_error_[(cell * nf + f0) * ne * 16];
    for (std::size_t k = 0; k < ne; ++k, c += 16) {
      const double between_levels = level_share * corners(c + 8);
      const double l2 = between_levels * between_levels;
      variance_C2[k] += (1 - rho_levels) * l2;
      if (total_C2) total_C2[k] += l2;
    }
  }
  if (beyond > 0) {
    const float* c = &map_error_[(cell * nf + f_end) * ne * 16];
    for (std::size_t k = 0; k < ne; ++k, c += 16) {
      const double off_levels = beyond * corners(c + 12);
      const double o2 = off_levels * off_levels;
      variance_C2[k] = scale * scale * (variance_C2[k] + (1 - rho_beyond) * o2);
      if (total_C2) total_C2[k] = scale * scale * (total_C2[k] + o2);
    }
  } else if (scale != 1) {
    for (std::size_t k = 0; k < ne; ++k) {
      variance_C2[k] *= scale * scale;
      if (total_C2) total_C2[k] *= scale * scale;
    }
  }
  return true;
}

bool Locator::charge_error(double x_m, double y_m, double force_N, double* error_C) const {
  if (!(force_N > 0) || !std::isfinite(force_N) || !interp_.inside(x_m, y_m)) return false;
  if (map_error_.empty()) {
    for (std::size_t k = 0; k < ne_; ++k) error_C[k] = 0.0;
    return true;
  }
  Vec rest{};
  double scale2 = 0;
  if (!map_variance_at(x_m, y_m, std::log(force_N), rest.data(), scale2, error_C)) return false;
  for (std::size_t k = 0; k < ne_; ++k) error_C[k] = std::sqrt(error_C[k]) * std::abs(gain_[k]);
  return true;
}

void Locator::set_map_error(const ChargeMap& map) {
  // Per usable cell, level and electrode, four shares at the cell's four corners (map_error_at),
  // absolute (C at the level's force), as floats: 64 bytes per electrode, next to each other for
  // the levels of a cell.
  const std::size_t nx = map.nx(), ny = map.ny(), nf = map.nf(), ne = map.ne();
  const std::size_t n = nf * ny * nx * ne;
  const bool node_estimate = !map.estimated_charge_error_C.empty();
  if (node_estimate && map.estimated_charge_error_C.size() != n) {
    throw InputError("map estimated_charge_error_C has " + std::to_string(map.estimated_charge_error_C.size()) +
                     " values; the grid needs " + std::to_string(n) + " ([nf][ny][nx][ne])");
  }
  if (!node_estimate && !options_.interpolation_error) return;
  InterpolationError between;
  if (options_.interpolation_error) between = estimate_interpolation_error(map);
  // A map whose node errors are totals (adaptive generation) already holds the error between its
  // nodes and between its levels: only the extrapolation beyond the levels is added here.
  if (map.charge_error_is_total() && node_estimate) {
    between.between_nodes_C.clear();
    between.between_levels_C.clear();
    between.between_nodes_rest_C.clear();
    between.between_levels_rest_C.clear();
    between.between_nodes_scale.clear();
    between.between_levels_scale.clear();
  }
  auto share = [](const std::vector<double>& values, std::size_t at) {
    if (values.empty()) return 0.0f;
    const double e = values[at];
    return std::isfinite(e) && e > 0 ? float(e) : 0.0f;
  };
  const bool correlated = options_.correlated_map_error && options_.interpolation_error;
  // The common-scale fraction of a share at a node (§1.11): ρ = α²|Q|² / (α²|Q|² + |rest|²),
  // the split of one and the same error vector (|s|² = α²|Q|² + |rest|²); 0 where it is empty.
  auto scale_fraction = [&](const std::vector<double>& alpha, const std::vector<double>& rest_C, std::size_t f,
                            std::size_t jj, std::size_t ii) {
    if (alpha.empty() || rest_C.empty()) return 0.0f;
    const double a = alpha[map.point(f, jj, ii)];
    double qq = 0, rr = 0;
    for (std::size_t k = 0; k < ne; ++k) {
      const double q = map.charge_C[map.charge_index(f, jj, ii, k)], r = rest_C[map.charge_index(f, jj, ii, k)];
      qq += q * q;
      rr += std::isfinite(r) ? r * r : 0.0;
    }
    const double s = std::isfinite(a) ? a * a * qq : 0.0;
    return s + rr > 0 ? float(s / (s + rr)) : 0.0f;
  };
  map_error_.assign((nx - 1) * (ny - 1) * nf * ne * 16, 0.0f);
  map_scale_.clear();
  if (correlated) map_scale_.assign((nx - 1) * (ny - 1) * nf * 24, 0.0f);
  for (std::size_t j = 0; j + 1 < ny; ++j) {
    for (std::size_t i = 0; i + 1 < nx; ++i) {
      if (!interp_.cell_usable(i, j)) continue;
      const std::size_t cell = j * (nx - 1) + i;
      for (std::size_t f = 0; f < nf; ++f) {
        for (std::size_t k = 0; k < ne; ++k) {
          float* out = &map_error_[((cell * nf + f) * ne + k) * 16];
          for (std::size_t c = 0; c < 4; ++c) {
            const std::size_t at = map.charge_index(f, j + c / 2, i + c % 2, k);
            out[c] = node_estimate ? share(map.estimated_charge_error_C, at) : 0.0f;
            out[4 + c] = share(between.between_nodes_C, at);
            out[8 + c] = share(between.between_levels_C, at);
            out[12 + c] = share(between.beyond_levels_C, at);
          }
        }
        if (correlated) {
          float* out = &map_scale_[(cell * nf + f) * 24];
          auto alpha = [](const std::vector<double>& values, std::size_t at) {
            return values.empty() || !std::isfinite(values[at]) ? 0.0f : float(std::abs(values[at]));
          };
          for (std::size_t c = 0; c < 4; ++c) {
            const std::size_t jj = j + c / 2, ii = i + c % 2, at = map.point(f, jj, ii);
            out[c] = scale_fraction(between.between_nodes_scale, between.between_nodes_rest_C, f, jj, ii);
            out[4 + c] = scale_fraction(between.between_levels_scale, between.between_levels_rest_C, f, jj, ii);
            out[8 + c] = scale_fraction(between.beyond_levels_scale, between.beyond_levels_rest_C, f, jj, ii);
            out[12 + c] = alpha(between.between_nodes_scale, at);
            out[16 + c] = alpha(between.between_levels_scale, at);
            out[20 + c] = alpha(between.beyond_levels_scale, at);
          }
        }
      }
    }
  }
}

std::array<double, 6> Locator::reported_jtj(const Fit& fit, const Query& Q) const {
  // JᵀWJ for the reported σ's: with the map's own error, each electrode's weight is
  // 1 / (σ_k² + e_k²), e_k the map error at the solution (docs/lookup.md §1.10), the Jacobian
  // the fit's last evaluated one (no evaluation here).
  // With a shared share (§1.11) the weight is the inverse of D + u uᵀ, D = diag(σ_k² + e_k²):
  // by Sherman–Morrison JᵀWJ = JᵀD⁻¹J − c·(JᵀD⁻¹u)(JᵀD⁻¹u)ᵀ, c = 1 / (1 + uᵀD⁻¹u).
  if (map_error_.empty() || !fit.has_variance) return fit.jtj;
  const auto& grad = fit.grad;
  std::array<double, 6> m{0, 0, 0, 0, 0, 0};
  std::array<double, 3> p{0, 0, 0};
  double qq = 0;
  for (std::size_t k = 0; k < ne_; ++k) {
    const double sigma = 1.0 / Q.w[k];
    const double w = 1.0 / std::sqrt(sigma * sigma + fit.variance[k]);
    const double g0 = grad[k][0] * w, g1 = grad[k][1] * w, g2 = Q.fixed_force ? 0.0 : grad[k][2] * w;
    const double mw = std::copysign(std::sqrt(fit.shared2[k]), fit.model[k]) * w;
    m[0] += g0 * g0;
    m[1] += g0 * g1;
    m[2] += g0 * g2;
    m[3] += g1 * g1;
    m[4] += g1 * g2;
    m[5] += g2 * g2;
    p[0] += g0 * mw;
    p[1] += g1 * mw;
    p[2] += g2 * mw;
    qq += mw * mw;
  }
  if (fit.has_shared) {
    const double c = 1.0 / (1.0 + qq);
    m[0] -= c * p[0] * p[0];
    m[1] -= c * p[0] * p[1];
    m[2] -= c * p[0] * p[2];
    m[3] -= c * p[1] * p[1];
    m[4] -= c * p[1] * p[2];
    m[5] -= c * p[2] * p[2];
  }
  return m;
}

PVDF_CLONES void Locator::covariance(Fit& fit, const Query& Q) const {
  // Covariance of (x, y, ln F): (JᵀWJ)⁻¹ with the weights already in J. Equilibrated first
  // (S = D JᵀWJ D, D = diag(JᵀWJ)^−½: the x, y columns (C/m) and the ln F column (C) differ by
  // ~1e3), so S has a unit diagonal; with the force known only the (x, y) block counts.
  const bool fixed_force = Q.fixed_force;
  const std::array<double, 6> m = reported_jtj(fit, Q);  // 00 01 02 11 12 22
  fit.singular = false;
  fit.sigma = {0, 0, 0};
  if (!(m[0] > 0 && m[3] > 0 && (fixed_force || m[5] > 0))) {  // a parameter the charges do not see
    fit.singular = true;
    return;
  }
  const double j00 = m[0], j11 = m[3], j22 = std::max(m[5], 1e-300);
  const double d0 = 1.0 / std::sqrt(j00), d1 = 1.0 / std::sqrt(j11), d2 = fixed_force ? 0.0 : 1.0 / std::sqrt(j22);
  const double s01 = m[1] * d0 * d1, s02 = m[2] * d0 * d2, s12 = m[4] * d1 * d2;
  // S is symmetric with a unit diagonal, so an LDLᵀ with diagonal pivoting starts with pivot 1;
  // its other two pivots (closed form) say whether S is invertible (each above 1e-12 of the
  // first), and only the diagonal of S⁻¹ (cofactor / determinant) is needed.
  const double a11 = 1.0 - s01 * s01, a22 = 1.0 - s02 * s02, a12 = s12 - s01 * s02;  // after pivot 0
  const double p1 = std::max(a11, a22), p2 = std::min(a11, a22) - a12 * a12 / p1;
  if (!(p1 > 1e-12 && std::abs(p2) > 1e-12)) {
    fit.singular = true;
    return;
  }
  const double c00 = 1.0 - s12 * s12, c11 = 1.0 - s02 * s02, c22 = 1.0 - s01 * s01;
  const double det = c00 - s01 * (s01 - s12 * s02) + s02 * (s01 * s12 - s02);
  const double inv_det = 1.0 / det;
  const double v0 = d0 * d0 * c00 * inv_det, v1 = d1 * d1 * c11 * inv_det, v2 = d2 * d2 * c22 * inv_det;
  fit.sigma = {v0 > 0 ? std::sqrt(v0) : 0.0, v1 > 0 ? std::sqrt(v1) : 0.0, v2 > 0 ? std::sqrt(v2) : 0.0};
  if (!(std::isfinite(fit.sigma[0]) && std::isfinite(fit.sigma[1]) && std::isfinite(fit.sigma[2]))) {
    fit.singular = true;
    fit.sigma = {0, 0, 0};
  }
}

bool Locator::distinct_minima(const double* q, const double* w, const Fit& a, const Fit& b, double separation,
                              double limit) const {
  if ((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) <= separation * separation) return false;
  // Two LM end points are different solutions when the misfit rises above the noise limit
  // somewhere between them (a barrier), or the straight path leaves the map.
  Vec model{};
  for (const double t : {0.5, 0.25, 0.75}) {  // the midpoint first: most barriers show there
    const double x = a.x + t * (b.x - a.x), y = a.y + t * (b.y - a.y), l = a.l + t * (b.l - a.l);
    if (!interp_.evaluate(x, y, l, model.data(), nullptr)) return true;
    // Best force at this position (the misfit is nearly quadratic in the amplitude).
    double mq = 0, mm = 0;
    for (std::size_t k = 0; k < ne_; ++k) {
      mq += model[k] * q[k] * w[k] * w[k];
      mm += model[k] * model[k] * w[k] * w[k];
    }
    const double s = mm > 0 ? mq / mm : 1.0;
    double chi2 = 0;
    for (std::size_t k = 0; k < ne_; ++k) {
      const double r = (s * model[k] - q[k]) * w[k];
      chi2 += r * r;
    }
    if (chi2 > limit) return true;
  }
  return false;
}

void Locator::add_map_error(const Query& Q, std::array<Fit, 8>& fits, int n_fits) const {
  // With the map's own error stored, each end point's χ² is taken under the charge noise plus
  // the map error there (σ_k² + e_k²): a press the map reproduces only to its own error still
  // fits, and a second solution is not hidden behind the first one's map error (§1.6).
  for (int s = 0; s < n_fits; ++s) {
    Fit& f = fits[std::size_t(s)];
    double scale2 = 0;
    if (!f.ok || f.duplicate || !map_variance_at(f.x, f.y, f.l, f.variance.data(), scale2)) continue;
    f.has_variance = true;
    for (std::size_t k = 0; k < ne_; ++k) f.shared2[k] = scale2 * f.model[k] * f.model[k];  // u = σ_α·Q
    // χ² = rᵀ(D + u uᵀ)⁻¹r = rᵀD⁻¹r − c (uᵀD⁻¹r)², c as in reported_jtj (§1.11).
    double chi2 = 0, ur = 0, uu = 0;
    for (std::size_t k = 0; k < ne_; ++k) {
      const double sigma = 1.0 / Q.w[k];
      const double d = sigma * sigma + f.variance[k];
      const double r = f.model[k] - Q.q[k];
      const double u = std::copysign(std::sqrt(f.shared2[k]), f.model[k]);
      chi2 += r * r / d;
      ur += u * r / d;
      uu += u * u / d;
    }
    f.has_shared = uu > 0;
    if (f.has_shared) chi2 -= ur * ur / (1.0 + uu);
    f.chi2 = std::max(chi2, 0.0);
  }
}

PVDF_CLONES Location Locator::finish(const Query& Q, std::array<Fit, 8>& fits, int n_starts) const {
  const double limit = Q.limit;
  if (!map_error_.empty()) add_map_error(Q, fits, n_starts);
  Location out;
  out.n_starts = n_starts;
  // Rank: fits within noise first, among them forces inside the map's levels first, then χ².
  auto extrapolated = [&](const Fit& f) {
    return f.l < interp_.min_log_force() - 1e-9 || f.l > interp_.max_log_force() + 1e-9;
  };
  auto better = [&](const Fit& a, const Fit& b) {
    const bool wa = a.chi2 <= limit, wb = b.chi2 <= limit;
    if (wa != wb) return wa;
    if (wa && extrapolated(a) != extrapolated(b)) return !extrapolated(a);
    return a.chi2 < b.chi2;
  };
  int best = -1, first_vague = -1;
  for (;;) {
    best = -1;
    for (int s = 0; s < n_starts; ++s) {
      const Fit& f = fits[std::size_t(s)];
      if (f.ok && !f.vague && (best < 0 || better(f, fits[std::size_t(best)]))) best = s;
    }
    if (best < 0) break;
    Fit& f = fits[std::size_t(best)];
    covariance(f, Q);
    if (f.chi2 > limit || !without_position(f, Q)) break;
    // Within noise but without a usable position: not a solution (§1.7); the next one is asked.
    f.vague = true;
    if (first_vague < 0) first_vague = best;
  }
  if (first_vague >= 0 && (best < 0 || fits[std::size_t(best)].chi2 > limit)) {
    // Only such fits were within noise: where the press is, the charges do not say.
    const Fit& v = fits[std::size_t(first_vague)];
    out.flags = flag::outside_map;
    out.held = {v.x, v.y, std::exp(v.l)};
    return out;
  }
  if (best < 0) {
    out.flags = flag::outside_map;
    return out;
  }
  Fit& b = fits[std::size_t(best)];
  if (b.chi2 <= limit) b.log_widen = valley_sigma(Q, b);
  fill_main(Q, b, out);
  if (b.chi2 > limit) {
    if (b.blocked) {
      out = Location{};
      out.n_starts = n_starts;
      out.flags = flag::outside_map;
      out.held = {b.x, b.y, std::exp(b.l)};
      return out;
    }
    out.flags |= flag::poor_fit;
    return out;
  }
  // Other minima that also fit within noise and lie elsewhere: ambiguous.
  std::array<int, 8> group{};
  int n_group = distinct_solutions(Q, fits, n_starts, best, group);
  if (n_group == 1) return out;
  {  // other solutions without a usable position are not reported (§1.7)
    int kept = 1;
    for (int g = 1; g < n_group; ++g) {
      Fit& f = fits[std::size_t(group[std::size_t(g)])];
      covariance(f, Q);
      if (without_position(f, Q)) continue;
      f.log_widen = valley_sigma(Q, f);
      group[std::size_t(kept++)] = group[std::size_t(g)];
    }
    n_group = kept;
    if (n_group == 1) return out;
  }
  // Every solution with its posterior probability; the most probable one is the main answer,
  // the others follow most probable first.
  std::array<double, 8> p{};
  double p_max = -std::numeric_limits<double>::infinity();
  for (int g = 0; g < n_group; ++g) {
    p[std::size_t(g)] = log_posterior_weight(Q, fits[std::size_t(group[std::size_t(g)])]);
    p_max = std::max(p_max, p[std::size_t(g)]);
  }
  double sum = 0;
  for (int g = 0; g < n_group; ++g) sum += (p[std::size_t(g)] = std::exp(p[std::size_t(g)] - p_max));
  for (int g = 0; g < n_group; ++g) p[std::size_t(g)] /= sum;
  for (int a = 1; a < n_group; ++a) {  // insertion sort of a handful, most probable first
    for (int c = a; c > 0 && p[std::size_t(c)] > p[std::size_t(c - 1)]; --c) {
      std::swap(p[std::size_t(c)], p[std::size_t(c - 1)]);
      std::swap(group[std::size_t(c)], group[std::size_t(c - 1)]);
    }
  }
  if (PVDF_ASSERTIONS) {  // the reported probabilities: finite, most probable first, summing to 1 (no work in Release)
    PVDF_ASSERT(n_group >= 2 && std::size_t(n_group) <= group.size() && std::size_t(n_group - 1) <= out.alternatives.size(),
                "an ambiguous answer has 2 .. 8 solutions, one main and the rest as alternatives");
    double total = 0;
    for (int g = 0; g < n_group; ++g) {
      PVDF_ASSERT(std::isfinite(p[std::size_t(g)]) && p[std::size_t(g)] >= 0 && (g == 0 || p[std::size_t(g)] <= p[std::size_t(g - 1)]),
                  "the solutions' probabilities must be finite, >= 0 and sorted, most probable first");
      total += p[std::size_t(g)];
    }
    PVDF_ASSERT(std::abs(total - 1) <= 1e-12, "the solutions' probabilities must sum to 1");
  }
  const int n_starts_made = out.n_starts;
  Fit& main = fits[std::size_t(group[0])];
  if (group[0] != best) {  // its σ's are known (above)
    out = Location{};
    out.n_starts = n_starts_made;
    fill_main(Q, main, out);
  }
  out.flags |= flag::ambiguous;
  out.n_solutions = n_group;
  out.probability = p[0];
  out.n_alternatives = n_group - 1;
  for (int a = 1; a < n_group; ++a) {
    const Fit& f = fits[std::size_t(group[std::size_t(a)])];
    out.alternatives[std::size_t(a - 1)] = {f.x, f.y, std::exp(f.l), std::sqrt(f.chi2), f.sigma[0], f.sigma[1],
                                            std::exp(f.l) * f.sigma[2], p[std::size_t(a)]};
  }
  out.alternative = out.alternatives[0];
  return out;
}

bool Locator::without_position(const Fit& f, const Query& Q) const {
  // Only fits of the angular fallback are asked: it runs when no coarse-search start fits within
  // noise, i.e. no cell's direction model reaches the charges (a press weaker than the force
  // range, or off the map); a fit it then finds within noise with a vague position is the weak
  // signal fitting anything, not a located press.
  if (!f.fallback || f.singular) return false;  // singular: σ unknown, reported ill_conditioned
  const double sigma = std::max(f.sigma[0], f.sigma[1]);
  const double cell = std::max(interp_.hx(), interp_.hy());
  const double half_map = 0.5 * std::min(double(interp_.nx() - 1) * interp_.hx(), double(interp_.ny() - 1) * interp_.hy());
  const bool on_bound = !Q.fixed_force && (f.l <= Q.log_lo + 1e-9 || f.l >= Q.log_hi - 1e-9);
  return (on_bound && sigma > cell) || sigma > half_map;
}

void Locator::fill_main(const Query& Q, const Fit& b, Location& out) const {
  out.x_m = b.x;
  out.y_m = b.y;
  out.force_N = std::exp(b.l);
  out.residual = std::sqrt(b.chi2);
  out.sigma_x_m = b.sigma[0];
  out.sigma_y_m = b.sigma[1];
  out.sigma_F_N = out.force_N * b.sigma[2];
  out.map_error_share = 0;
  if (b.has_variance) {  // Q.w = 1/σ per electrode; b.variance = e² at the answer
    double share = 0;
    for (std::size_t k = 0; k < ne_; ++k) {
      const double noise2 = 1.0 / (Q.w[k] * Q.w[k]);
      const double e2 = b.variance[k] + b.shared2[k];
      share += e2 / (noise2 + e2);
    }
    out.map_error_share = ne_ > 0 ? share / double(ne_) : 0.0;
  }
  out.iterations = b.iterations;
  out.n_solutions = 1;
  out.probability = 1.0;
  if (!b.converged) out.flags |= flag::not_converged;
  if (b.singular) out.flags |= flag::ill_conditioned;
  // The force is outside the map's levels (the scaling law carries the map there) only when it
  // is so by more than its own uncertainty: a press at a level's force is not flagged.
  const double tolerance = std::max(1e-3, 2.0 * b.sigma[2]);
  const bool off_levels = b.l < interp_.min_log_force() - tolerance || b.l > interp_.max_log_force() + tolerance;
  if (off_levels) out.flags |= flag::force_extrapolated;
  if (single_level_ && off_levels) out.flags |= flag::scaling_assumed;
}

double Locator::log_posterior_weight(const Query& Q, const Fit& f) const {
  // Laplace approximation of the posterior mass around a solution: exp(−χ²/2) times the volume
  // (2π)^(k/2) det(A)^(−1/2) of its Gaussian, A = JᵀWJ in (x, y[, ln F]), times the prior's
  // density there. The prior is uniform over the map's area and uniform in F over the force
  // range: in ln F its density is ∝ F. Where JᵀWJ is (nearly) singular the prior itself bounds
  // the posterior's width: A gets the precision of the uniform prior (12 / width²) added.
  const double wx = double(interp_.nx() - 1) * interp_.hx(), wy = double(interp_.ny() - 1) * interp_.hy();
  const double rx = 12.0 / (wx * wx), ry = 12.0 / (wy * wy);
  // A = JᵀWJ with the weights at the solution (the map's own error there, §1.10), as the σ's.
  const std::array<double, 6> m = reported_jtj(f, Q);  // 00 01 02 11 12 22
  const double a00 = m[0] + rx, a01 = m[1], a11 = m[3] + ry;
  double det = 0, floor = rx * ry;
  if (Q.fixed_force) {
    det = a00 * a11 - a01 * a01;
  } else {
    const double width_l = std::max(Q.log_hi - Q.log_lo, 1e-6), rl = 12.0 / (width_l * width_l);
    const double a02 = m[2], a12 = m[4], a22 = m[5] + rl;
    det = a00 * (a11 * a22 - a12 * a12) - a01 * (a01 * a22 - a12 * a02) + a02 * (a01 * a12 - a11 * a02);
    floor *= rl;
  }
  // The likelihood's normalisation ∏_k (σ_k² + e_k²)^(−½): with the map's own error e_k it
  // differs between solutions (none without it, where it is the same for all and dropped). Left
  // out, a solution where the map is poor gains its width (det A ∝ 1/s^(2·k)) for free, without
  // paying for the broader likelihood it stands on: it outranked exact fits where the map is good.
  double log_norm = 0;
  if (f.has_variance) {
    double uu = 0;  // with the shared share, det(D + u uᵀ) = det D · (1 + uᵀD⁻¹u)
    for (std::size_t k = 0; k < ne_; ++k) {
      const double sigma = 1.0 / Q.w[k];
      log_norm -= 0.5 * std::log((sigma * sigma + f.variance[k]) / (sigma * sigma));
      uu += f.shared2[k] / (sigma * sigma + f.variance[k]);
    }
    log_norm -= 0.5 * std::log1p(uu);
  }
  return -0.5 * f.chi2 + log_norm - 0.5 * std::log(std::max(det, floor)) + f.log_widen + (Q.fixed_force ? 0.0 : f.l);
}

int Locator::distinct_solutions(const Query& Q, const std::array<Fit, 8>& fits, int n_starts, int best,
                                std::array<int, 8>& group) const {
  const bool fixed_force = Q.fixed_force;
  const double limit = Q.limit;
  const double separation = options_.ambiguity_separation_cells * std::max(interp_.hx(), interp_.hy());
  // Two end points are one solution when they are within 3 σ of each other (Mahalanobis
  // distance in (x, y) from either one's JᵀWJ, ln F profiled out), or within 1e-3 cell
  // (convergence tolerance), or closer than the optional separation. Where the position
  // block is singular (a symmetry line or a flat spot) the misfit barrier between them decides.
  auto distinct_from = [&](const Fit& a, const Fit& f) {
    const double dx = f.x - a.x, dy = f.y - a.y;
    if (std::abs(dx) < 1e-3 * interp_.hx() && std::abs(dy) < 1e-3 * interp_.hy()) return false;
    if (separation > 0 && dx * dx + dy * dy <= separation * separation) return false;
    double d2 = std::numeric_limits<double>::infinity();
    bool singular = false;
    for (const Fit* g : {&a, &f}) {
      const auto& m = g->jtj;  // 00 01 02 11 12 22
      double s00 = m[0], s01 = m[1], s11 = m[3];
      if (!fixed_force && m[5] > 0) {
        s00 -= m[2] * m[2] / m[5];
        s01 -= m[2] * m[4] / m[5];
        s11 -= m[4] * m[4] / m[5];
      }
      const double det = s00 * s11 - s01 * s01;
      singular = singular || !(det > 1e-12 * (s00 * s11 + 1e-300));
      d2 = std::min(d2, s00 * dx * dx + 2 * s01 * dx * dy + s11 * dy * dy);
    }
    if (singular) return distinct_minima(Q.q.data(), Q.w.data(), a, f, 0.0, limit);
    return d2 > 9.0;
  };
  group[0] = best;
  int n = 1;
  for (int s = 0; s < n_starts; ++s) {
    const Fit& f = fits[std::size_t(s)];
    if (s == best || !f.ok || f.vague || f.chi2 > limit) continue;
    bool is_new = true;
    for (int d = 0; d < n && is_new; ++d) is_new = distinct_from(fits[std::size_t(group[std::size_t(d)])], f);
    if (is_new) group[std::size_t(n++)] = s;
  }
  return n;
}

}  // namespace pvdf::mapping
