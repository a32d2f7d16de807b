// Hencky's power-series solution of the clamped circular membrane under uniform pressure
// (von Kármán membrane strains, no bending, no pretension), computed here from the classical
// recursion — the independent check of the axisymmetric oracle and of Chien's K(ν = 0.3) = 0.6534.
//
// Derivation used (no formula copied): with S = N_r and N_θ = (r S)', compatibility of
// ε_r = u' + ½w'², ε_θ = u/r gives r²S'' + 3rS' + ½ E h w'² = 0 (ν drops out), and vertical
// equilibrium gives S w' = −q r/2. With ρ = r/a and S = κ s(ρ), κ = ½ (E h q² a²)^(1/3):
//     s'' + 3 s'/ρ + 1/s² = 0,   s'(0) = 0,   (1 − ν) s(1) + s'(1) = 0  (u(a) = 0),
//     w(ρ) = a (q a/(E h))^(1/3) ∫_ρ^1 t/s(t) dt,   so  w0 = K a (q a/(E h))^(1/3),  K = ∫_0^1 ρ/s dρ.
// With s = Σ b_n ρ^{2n}: s²·(s'' + 3s'/ρ) = −1 gives b_{k+1} = t_k / (4(k+1)(k+2)), where
// t_0 = −1/b_0², t_k = −(Σ_{i=1..k} (s²)_i t_{k−i}) / b_0²; b_0 follows from the rim condition.
#pragma once

#include <cmath>
#include <stdexcept>
#include <vector>

namespace pvdf::fem::oracles {

/// Hencky's series for one Poisson ratio (dimensionless).
struct HenckySeries {
  double poisson_ratio = 0.3;
  std::vector<double> b;  ///< s(ρ) = Σ b[n] ρ^(2n); b[0] = s(0)
  double K = 0;           ///< w0 = K a (q a / (E h))^(1/3)
  double tail = 0;        ///< |last terms| at ρ = 1, a truncation indicator

  /// s(ρ) and s'(ρ), ρ in [0, 1].
  double s(double rho) const {
    double sum = 0, p = 1;
    for (double bn : b) {
      sum += bn * p;
      p *= rho * rho;
    }
    return sum;
  }
  double ds(double rho) const {
    double sum = 0, p = rho;  // d/dρ ρ^{2n} = 2n ρ^{2n−1}
    for (std::size_t n = 1; n < b.size(); ++n) {
      sum += 2.0 * n * b[n] * p;
      p *= rho * rho;
    }
    return sum;
  }
  /// ∫_ρ^1 t/s(t) dt by 40-point composite Gauss–Legendre (the series s is smooth on [0, 1]).
  double deflection_factor(double rho) const {
    static const double x[4] = {0.3399810435848563, 0.8611363115940526, -0.3399810435848563, -0.8611363115940526};
    static const double w[4] = {0.6521451548625461, 0.3478548451374538, 0.6521451548625461, 0.3478548451374538};
    const int n_panels = 200;
    double sum = 0;
    const double h = (1 - rho) / n_panels;
    for (int k = 0; k < n_panels; ++k) {
      const double mid = rho + (k + 0.5) * h;
      for (int j = 0; j < 4; ++j) {
        const double t = mid + 0.5 * h * x[j];
        sum += 0.5 * h * w[j] * t / s(t);
      }
    }
    return sum;
  }

  // --- physical values for a pressure q (Pa) on a film (a, h, E) ---
  static double kappa(double q_Pa, double a_m, double h_m, double E_Pa) {
    return 0.5 * std::cbrt(E_Pa * h_m * q_Pa * q_Pa * a_m * a_m);
  }
  /// Centre deflection, m.
  double centre_deflection_m(double q_Pa, double a_m, double h_m, double E_Pa) const {
    return K * a_m * std::cbrt(q_Pa * a_m / (E_Pa * h_m));
  }
  /// Deflection at radius r, m.
  double deflection_m(double r_m, double q_Pa, double a_m, double h_m, double E_Pa) const {
    return deflection_factor(r_m / a_m) * a_m * std::cbrt(q_Pa * a_m / (E_Pa * h_m));
  }
  /// N_r(r), N/m.
  double radial_force_N_per_m(double r_m, double q_Pa, double a_m, double h_m, double E_Pa) const {
    return kappa(q_Pa, a_m, h_m, E_Pa) * s(r_m / a_m);
  }
  /// N_θ(r) = (r N_r)', N/m.
  double hoop_force_N_per_m(double r_m, double q_Pa, double a_m, double h_m, double E_Pa) const {
    const double rho = r_m / a_m;
    return kappa(q_Pa, a_m, h_m, E_Pa) * (s(rho) + rho * ds(rho));
  }
};

namespace detail {
// Series coefficients for a given b0 (n_terms of them).
inline std::vector<double> hencky_coefficients(double b0, int n_terms) {
  std::vector<double> b(n_terms, 0.0), s2(n_terms, 0.0), t(n_terms, 0.0);
  b[0] = b0;
  s2[0] = b0 * b0;
  t[0] = -1.0 / s2[0];
  b[1] = t[0] / 8.0;
  for (int k = 1; k + 1 < n_terms; ++k) {
    s2[k] = 0;
    for (int i = 0; i <= k; ++i) s2[k] += b[i] * b[k - i];
    double acc = 0;
    for (int i = 1; i <= k; ++i) acc += s2[i] * t[k - i];
    t[k] = -acc / s2[0];
    b[k + 1] = t[k] / (4.0 * (k + 1) * (k + 2));
  }
  return b;
}
}  // namespace detail

/// Solves for b0 (bisection on the rim condition) and K for Poisson ratio ν.
inline HenckySeries hencky_series(double poisson_ratio, int n_terms = 120) {
  if (!(poisson_ratio > -1 && poisson_ratio < 0.5) || n_terms < 10)
    throw std::invalid_argument("hencky_series: need -1 < nu < 0.5 and n_terms >= 10");
  HenckySeries out;
  out.poisson_ratio = poisson_ratio;
  auto rim = [&](double b0) {
    out.b = detail::hencky_coefficients(b0, n_terms);
    return (1 - poisson_ratio) * out.s(1.0) + out.ds(1.0);
  };
  // rim(b0) grows with b0 (a stiffer centre stress needs a larger radial stretch); bracket it.
  double lo = 0.5, hi = 4.0;
  if (!(rim(lo) < 0 && rim(hi) > 0)) throw std::runtime_error("hencky_series: b0 not bracketed in [0.5, 4]");
  for (int it = 0; it < 200 && hi - lo > 1e-15 * hi; ++it) {
    const double mid = 0.5 * (lo + hi);
    (rim(mid) < 0 ? lo : hi) = mid;
  }
  rim(0.5 * (lo + hi));
  out.tail = std::abs(out.b[n_terms - 1]) + std::abs(out.b[n_terms - 2]);
  out.K = out.deflection_factor(0.0);
  return out;
}

}  // namespace pvdf::fem::oracles
