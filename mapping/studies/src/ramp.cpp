// The force-ramp test of a candidate press and the share of a film it leaves ambiguous
// (docs/lookup.md §2, "Force ramps").
#include "pvdf/mapping/ramp.hpp"

#include "pvdf/mapping/locator.hpp"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <limits>

namespace pvdf::mapping {
namespace {

constexpr double inf = std::numeric_limits<double>::infinity();

/// The profiled ramp misfit at a fixed position: per sample the best ln F (Gauss–Newton from
/// u[i], clamped to [lo, hi]); χ² summed, and the position's Gauss–Newton system with the
/// per-sample ln F eliminated (a = Σ J_pᵀ P J_p, b = Σ J_pᵀ P r, P the projection away from
/// ∂Q/∂ln F). False when the position or a sample leaves the usable cells.
bool profile(const MapInterpolant& in, const double* q, int n, const double* sigma, double x, double y,
             std::vector<double>& u, double lo, double hi, double& chi2, std::array<double, 3>& a,
             std::array<double, 2>& b) {
  const std::size_t ne = in.n_electrodes();
  std::array<double, max_electrodes> m{};
  std::array<std::array<double, 3>, max_electrodes> d{};
  chi2 = 0;
  a = {0, 0, 0};
  b = {0, 0};
  for (int i = 0; i < n; ++i) {
    const double* qi = q + std::size_t(i) * ne;
    for (int it = 0; it < 8; ++it) {
      if (!in.evaluate(x, y, u[i], m.data(), d.data())) return false;
      double g = 0, h = 0;
      for (std::size_t k = 0; k < ne; ++k) {
        const double r = (m[k] - qi[k]) / sigma[k], j = d[k][2] / sigma[k];
        g += j * r;
        h += j * j;
      }
      if (!(h > 0)) break;
      const double step = -g / h;
      const double next = std::clamp(u[i] + step, lo, hi);
      if (std::abs(next - u[i]) < 1e-10) break;
      u[i] = next;
    }
    if (!in.evaluate(x, y, u[i], m.data(), d.data())) return false;
    std::array<double, max_electrodes> r{}, jx{}, jy{}, ju{};
    double uu = 0, ux = 0, uy = 0, ur = 0;
    for (std::size_t k = 0; k < ne; ++k) {
      r[k] = (m[k] - qi[k]) / sigma[k];
      jx[k] = d[k][0] / sigma[k];
      jy[k] = d[k][1] / sigma[k];
      ju[k] = d[k][2] / sigma[k];
      chi2 += r[k] * r[k];
      uu += ju[k] * ju[k];
      ux += ju[k] * jx[k];
      uy += ju[k] * jy[k];
      ur += ju[k] * r[k];
    }
    const double inv = uu > 0 ? 1.0 / uu : 0.0;
    for (std::size_t k = 0; k < ne; ++k) {
      const double px = jx[k] - ju[k] * ux * inv, py = jy[k] - ju[k] * uy * inv, pr = r[k] - ju[k] * ur * inv;
      a[0] += px * px;
      a[1] += px * py;
      a[2] += py * py;
      b[0] += px * pr;
      b[1] += py * pr;
    }
  }
  return std::isfinite(chi2);
}

/// Standard normal quantile of 1 − alpha (bisection on erfc; alpha in (0, 0.5)).
double normal_upper_quantile(double alpha) {
  double lo = 0, hi = 40;
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(mid / std::sqrt(2.0)) > alpha ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace

double chi2_quantile(double dof, double alpha) {
  assert(dof > 0 && alpha > 0 && alpha < 0.5);
  const double z = normal_upper_quantile(alpha), c = 2.0 / (9.0 * dof);
  const double t = 1.0 - c + z * std::sqrt(c);
  return dof * t * t * t;
}

RampFit fit_ramp(const MapInterpolant& in, const double* q, int n, const double* sigma, double x_m, double y_m,
                 double start_force_N, double min_force_N, double max_force_N) {
  assert(n >= 1 && start_force_N > 0 && min_force_N > 0 && max_force_N > min_force_N);
  const std::size_t ne = in.n_electrodes();
  const double lo = std::log(min_force_N), hi = std::log(max_force_N), p = in.force_exponent();
  // Starts: the peak's force for the last sample, the others by their magnitude (Q ∝ F^p).
  const auto norm = [&](const double* v) {
    double s = 0;
    for (std::size_t k = 0; k < ne; ++k) s += v[k] * v[k];
    return std::sqrt(s);
  };
  const double peak_norm = norm(q + std::size_t(n - 1) * ne);
  std::vector<double> u(static_cast<std::size_t>(n)), trial_u;
  for (int i = 0; i < n; ++i) {
    const double ratio = norm(q + std::size_t(i) * ne) / peak_norm;
    u[std::size_t(i)] = std::clamp(std::log(start_force_N) + (ratio > 0 ? std::log(ratio) / p : 0.0), lo, hi);
  }
  RampFit fit;
  fit.x_m = x_m;
  fit.y_m = y_m;
  std::array<double, 3> a{};
  std::array<double, 2> b{};
  if (!profile(in, q, n, sigma, x_m, y_m, u, lo, hi, fit.chi2, a, b)) {
    fit.chi2 = inf;
    return fit;
  }
  // Levenberg–Marquardt on the position: the valley is long where the position's weak
  // direction trades against the force, hence the damping (Marquardt scaling).
  double lambda = 1e-3;
  for (int it = 0; it < 60 && lambda < 1e8; ++it) {
    const double a00 = a[0] * (1 + lambda) + 1e-300, a11 = a[2] * (1 + lambda) + 1e-300, a01 = a[1];
    const double det = a00 * a11 - a01 * a01;
    if (!(det > 0)) break;
    const double dx = -(a11 * b[0] - a01 * b[1]) / det, dy = -(a00 * b[1] - a01 * b[0]) / det;
    trial_u = u;
    double chi2 = 0;
    std::array<double, 3> ta{};
    std::array<double, 2> tb{};
    if (profile(in, q, n, sigma, fit.x_m + dx, fit.y_m + dy, trial_u, lo, hi, chi2, ta, tb) && chi2 < fit.chi2) {
      const double gain = fit.chi2 - chi2;
      fit.x_m += dx;
      fit.y_m += dy;
      fit.chi2 = chi2;
      u.swap(trial_u);
      a = ta;
      b = tb;
      ++fit.iterations;
      lambda = std::max(lambda / 3, 1e-9);
      if (gain < 1e-6 * (1 + chi2)) break;
    } else {
      lambda *= 4;
    }
  }
  return fit;
}

RampAmbiguity ramp_ambiguity_share(const ChargeMap& map, const RampOptions& o) {
  assert(o.n_samples >= 2 && o.ramp_start > 0 && o.ramp_start <= 1);
  RampAmbiguity out;
  LocatorOptions lo;
  lo.noise_C = o.noise_C;
  lo.use_calibration = false;  // the ramp is the map's own charges
  lo.interpolation_error = false;  // ... read at its nodes: no interpolation error to add to σ
  const Locator locator(map, lo);
  const MapInterpolant& in = locator.interpolant();
  const std::size_t ne = map.ne();
  const std::vector<double>& sigma = locator.noise_C();
  out.peak_force_N = o.peak_force_N > 0 ? o.peak_force_N : map.forces_N.back();
  out.dof = o.n_samples * int(ne - 1) - 2;
  out.limit = chi2_quantile(out.dof, o.alpha);
  const double margin = out.limit - out.dof;
  // ramp forces are fitted down to the ramp's start below the lookup's plausible range
  const double f_lo = 0.5 * o.ramp_start * map.forces_N.front(), f_hi = 2.0 * map.forces_N.back();

  std::vector<double> ramp(std::size_t(o.n_samples) * ne), hold(ramp.size());
  std::vector<double> separation;
  std::size_t n_peak = 0, n_after = 0, n_hold = 0, n_own_rejected = 0;
  const double own_radius_m = 0.25 * std::min(in.hx(), in.hy());
  // interior nodes: a press on the map's outer row has its solution held at the edge
  for (std::size_t j = 1; j + 1 < map.ny(); ++j) {
    for (std::size_t i = 1; i + 1 < map.nx(); ++i) {
      if (!in.node_usable(i, j)) continue;
      const double x = map.x_m[i], y = map.y_m[j];
      bool ok = true;
      for (int s = 0; s < o.n_samples && ok; ++s) {
        const double f = o.ramp_start + (1 - o.ramp_start) * s / double(o.n_samples - 1);
        ok = in.evaluate(x, y, std::log(f * out.peak_force_N), &ramp[std::size_t(s) * ne], nullptr);
      }
      if (!ok) continue;
      const double* peak = &ramp[std::size_t(o.n_samples - 1) * ne];
      for (int s = 0; s < o.n_samples; ++s) std::copy(peak, peak + ne, &hold[std::size_t(s) * ne]);
      const Location r = locator.locate(peak);
      if (!r.has_position()) continue;
      // the solutions, the node's own one (nearest the node) first
      std::vector<std::array<double, 3>> sol{{r.x_m, r.y_m, r.force_N}};
      for (int a = 0; a < r.n_alternatives; ++a) {
        const auto& alt = r.alternatives[std::size_t(a)];
        sol.push_back({alt.x_m, alt.y_m, alt.force_N});
      }
      std::size_t own = 0;
      for (std::size_t s = 1; s < sol.size(); ++s) {
        if (std::hypot(sol[s][0] - x, sol[s][1] - y) < std::hypot(sol[own][0] - x, sol[own][1] - y)) own = s;
      }
      if (std::hypot(sol[own][0] - x, sol[own][1] - y) > own_radius_m) {
        ++out.nodes_truth_missed;  // the lookup did not find the press itself: nothing to test
        continue;
      }
      ++out.nodes;
      std::swap(sol[0], sol[own]);
      int kept = 0, kept_hold = 0;
      double smallest = inf;
      for (std::size_t s = 0; s < sol.size(); ++s) {
        const RampFit f = fit_ramp(in, ramp.data(), o.n_samples, sigma.data(), sol[s][0], sol[s][1], sol[s][2], f_lo, f_hi);
        const RampFit h = fit_ramp(in, hold.data(), o.n_samples, sigma.data(), sol[s][0], sol[s][1], sol[s][2], f_lo, f_hi);
        const bool rejected = !(f.chi2 <= margin);
        kept += !rejected;
        kept_hold += h.chi2 <= margin;
        if (s == 0) n_own_rejected += rejected;
        else smallest = std::min(smallest, f.chi2 / margin);
      }
      if (sol.size() > 1) {
        ++n_peak;
        separation.push_back(smallest);
      }
      n_after += kept > 1;
      n_hold += kept_hold > 1;
    }
  }
  if (out.nodes > 0) {
    out.ambiguous_at_peak = double(n_peak) / double(out.nodes);
    out.ambiguous_after_ramp = double(n_after) / double(out.nodes);
    out.ambiguous_after_hold = double(n_hold) / double(out.nodes);
    out.own_rejected = double(n_own_rejected) / double(out.nodes);
  }
  if (!separation.empty()) {
    std::nth_element(separation.begin(), separation.begin() + std::ptrdiff_t(separation.size() / 2), separation.end());
    out.median_separation = separation[separation.size() / 2];
  }
  return out;
}

}  // namespace pvdf::mapping
