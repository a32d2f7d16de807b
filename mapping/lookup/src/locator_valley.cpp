// The σ's of a solution whose misfit valley is wider than its linearisation (docs/lookup.md
// §1.6): the profile of χ² along the weak position direction, the other parameters re-fitted.
#include "locator_detail.hpp"
#include "pvdf/mapping/locator.hpp"

namespace pvdf::mapping {

using detail::Vec;

namespace {

/// Inverse of the symmetric 3×3 matrix m (upper triangle 00 01 02 11 12 22) into c (same
/// layout); false when it is not positive definite.
bool inverse_spd3(const std::array<double, 6>& m, std::array<double, 6>& c) {
  const double c00 = m[3] * m[5] - m[4] * m[4], c01 = m[2] * m[4] - m[1] * m[5], c02 = m[1] * m[4] - m[2] * m[3];
  const double c11 = m[0] * m[5] - m[2] * m[2], c12 = m[1] * m[2] - m[0] * m[4], c22 = m[0] * m[3] - m[1] * m[1];
  const double det = m[0] * c00 + m[1] * c01 + m[2] * c02;
  if (!(m[0] > 0 && c22 > 0 && det > 0)) return false;
  const double inv = 1.0 / det;
  c = {c00 * inv, c01 * inv, c02 * inv, c11 * inv, c12 * inv, c22 * inv};
  return true;
}

}  // namespace

bool Locator::valley_point(const Query& Q, const double* w, const Fit& f, const std::array<double, 2>& v, double t,
                           double& s, double& l, double& chi2) const {
  // Minimises χ² over the offset s across the valley (unit vector u ⟂ v) and ln F (unless the
  // force is known) at the fixed offset t along v: three Gauss–Newton steps from (s, l). The
  // map's shared error (§1.11) is held at the solution's, u uᵀ, as the per-electrode weights
  // are: χ² = rᵀD⁻¹r − c (uᵀD⁻¹r)², c = 1 / (1 + uᵀD⁻¹u) (Sherman–Morrison).
  const std::array<double, 2> u{-v[1], v[0]};
  std::array<double, max_electrodes> uw{};
  double uu = 0;
  for (std::size_t k = 0; k < ne_; ++k) {
    uw[k] = f.has_shared ? std::copysign(std::sqrt(f.shared2[k]), f.model[k]) * w[k] : 0.0;
    uu += uw[k] * uw[k];
  }
  const double c = uu > 0 ? 1.0 / (1.0 + uu) : 0.0;
  Vec model{};
  std::array<std::array<double, 3>, max_electrodes> grad{};
  for (int it = 0; it <= 3; ++it) {
    const double x = f.x + t * v[0] + s * u[0], y = f.y + t * v[1] + s * u[1];
    if (!interp_.evaluate(x, y, l, model.data(), grad.data())) return false;
    double a00 = 0, a01 = 0, a11 = 0, b0 = 0, b1 = 0, ps = 0, pl = 0, pr = 0;
    chi2 = 0;
    for (std::size_t k = 0; k < ne_; ++k) {
      const double r = (model[k] - Q.q[k]) * w[k];
      const double js = (grad[k][0] * u[0] + grad[k][1] * u[1]) * w[k];
      const double jl = Q.fixed_force ? 0.0 : grad[k][2] * w[k];
      const double mw = uw[k];
      chi2 += r * r;
      a00 += js * js;
      a01 += js * jl;
      a11 += jl * jl;
      b0 += js * r;
      b1 += jl * r;
      ps += mw * js;
      pl += mw * jl;
      pr += mw * r;
    }
    if (c > 0) {
      chi2 = std::max(0.0, chi2 - c * pr * pr);
      a00 -= c * ps * ps;
      a01 -= c * ps * pl;
      a11 -= c * pl * pl;
      b0 -= c * ps * pr;
      b1 -= c * pl * pr;
    }
    if (it == 3) break;
    double ds = 0, dl = 0;
    if (Q.fixed_force) {
      if (!(a00 > 0)) return false;
      ds = -b0 / a00;
    } else {
      const double det = a00 * a11 - a01 * a01;
      if (!(det > 1e-14 * a00 * a11 && det > 0)) return false;
      ds = -(a11 * b0 - a01 * b1) / det;
      dl = -(a00 * b1 - a01 * b0) / det;
    }
    s += ds;
    l = std::clamp(l + dl, Q.log_lo, Q.log_hi);
  }
  return std::isfinite(chi2);
}

double Locator::valley_sigma(const Query& Q, Fit& f) const {
  // The linearised σ's, (JᵀWJ)⁻¹, hold where the misfit is quadratic over the 1-σ region. Where
  // the weak position direction's σ is a sizeable part of a cell (the scale on which the map
  // bends), the valley can bend and widen within it: then the profile of χ² along that
  // direction — at each offset t the other parameters re-fitted (profile likelihood) — is
  // walked out on both sides to Δχ² = 1, and each σ becomes the larger of the linearised one
  // and the profile point's offset in that parameter. Returns ln(profile half-width / linear
  // σ) along the direction (≥ 0), the widening of the solution's posterior volume (§1.8).
  if (options_.valley_sigma_cells <= 0 || f.singular) return 0.0;
  // The weights of the reported σ's and χ²: the charge noise with the map's own error at the
  // solution (§1.10), held along the profile.
  Vec w{};
  for (std::size_t k = 0; k < ne_; ++k) w[k] = f.has_variance ? 1.0 / std::sqrt(1.0 / (Q.w[k] * Q.w[k]) + f.variance[k]) : Q.w[k];
  std::array<double, 6> m = reported_jtj(f, Q), c{};
  if (Q.fixed_force) {
    m[2] = m[4] = 0;
    m[5] = 1;
  }
  if (!inverse_spd3(m, c)) return 0.0;
  // Weak direction of the position block of the covariance (ln F marginalised).
  const double half = 0.5 * (c[0] + c[3]), dev = std::sqrt(0.25 * (c[0] - c[3]) * (c[0] - c[3]) + c[1] * c[1]);
  const double lambda = half + dev;
  std::array<double, 2> v{c[1], lambda - c[0]};
  if (std::abs(c[1]) < 1e-300 * lambda) v = c[0] >= c[3] ? std::array<double, 2>{1, 0} : std::array<double, 2>{0, 1};
  const double vn = std::hypot(v[0], v[1]);
  if (!(vn > 0) || !(lambda > 0)) return 0.0;
  v = {v[0] / vn, v[1] / vn};
  const double sigma_v = std::sqrt(lambda);
  if (sigma_v < options_.valley_sigma_cells * std::max(interp_.hx(), interp_.hy())) return 0.0;
  // Along the linear valley line the other parameters move by (C a / σ_v²) t, a = (v, 0).
  const std::array<double, 3> ca{c[0] * v[0] + c[1] * v[1], c[1] * v[0] + c[3] * v[1], c[2] * v[0] + c[4] * v[1]};
  const double slope_s = (-v[1] * ca[0] + v[0] * ca[1]) / lambda, slope_l = Q.fixed_force ? 0.0 : ca[2] / lambda;
  const double reach = 0.5 * std::max(double(interp_.nx() - 1) * interp_.hx(), double(interp_.ny() - 1) * interp_.hy());
  std::array<double, 3> extent{0, 0, 0};
  double half_width = 0;
  for (const double side : {1.0, -1.0}) {
    // Out from the solution: t = σ_v first, then longer steps while Δχ² < 1 (at most 6 profile
    // points; off the map or the force range ends the walk there).
    double t_in = 0, d_in = 0, t = sigma_v, s_in = 0, l_in = f.l, t_out = sigma_v;
    double s_at = 0, l_at = f.l;
    for (int step = 0; step < 6 && t <= reach; ++step) {
      double s = slope_s * t * side, l = std::clamp(f.l + slope_l * t * side, Q.log_lo, Q.log_hi), chi2 = 0;
      if (!valley_point(Q, w.data(), f, v, side * t, s, l, chi2)) break;
      const double d = chi2 - f.chi2;
      if (d >= 1.0) {
        // Δχ² = 1 between the last point inside and this one (linear in √Δχ²).
        const double a = (1.0 - std::sqrt(std::max(d_in, 0.0))) / (std::sqrt(d) - std::sqrt(std::max(d_in, 0.0)));
        t_out = t_in + a * (t - t_in);
        s_at = s_in + a * (s - s_in);
        l_at = l_in + a * (l - l_in);
        break;
      }
      t_in = t;
      d_in = d;
      s_in = s;
      l_in = l;
      t_out = t;
      s_at = s;
      l_at = l;
      t *= std::clamp(1.0 / std::sqrt(std::max(d, 1e-2)), 1.25, 3.0);
    }
    // Not crossed within `reach` or the map: the extent reached is kept (a lower bound of the valley's).
    const double x = side * t_out * v[0] - s_at * v[1], y = side * t_out * v[1] + s_at * v[0];
    extent[0] = std::max(extent[0], std::abs(x));
    extent[1] = std::max(extent[1], std::abs(y));
    extent[2] = std::max(extent[2], std::abs(l_at - f.l));
    half_width += 0.5 * t_out;
  }
  for (int a = 0; a < 3; ++a) f.sigma[std::size_t(a)] = std::max(f.sigma[std::size_t(a)], extent[std::size_t(a)]);
  if (Q.fixed_force) f.sigma[2] = 0;
  return std::max(0.0, std::log(half_width / sigma_v));
}

}  // namespace pvdf::mapping
