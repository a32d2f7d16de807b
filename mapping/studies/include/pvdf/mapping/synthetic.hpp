// An analytic, membrane-like charge model and maps sampled from it: test oracles, examples and
// benchmarks for the lookup before (and besides) FEM-generated maps. Not a physical prediction.
#pragma once

#include "pvdf/core/membrane_scaling.hpp"
#include "pvdf/mapping/map.hpp"

#include <array>
#include <string>
#include <vector>

namespace pvdf::mapping {

/// Q_k(p, F) = scale·(F/1 N)^(force_exponent + force_skew·x/R)·(1 − rim_strength·|p|²/R²)
///            ·P_k·(ρ_k² + core²)^(−exponent/2),
/// ρ_k² = (u/a)² + (v·a)², (u, v) = p − e_k in the film's material axes (draw direction at
/// draw_angle_rad), a = √anisotropy, and the piezoelectric direction factor
/// P_k = (u² + r·v² + ½(1 + r)·core²)/(u² + v² + core²), r = d32_over_d31: a radial stress
/// at angle β from the draw gives d31 cos²β + d32 sin²β (docs/mapping.md §3), smoothed at the
/// electrode. Smooth, anisotropic, decaying like d^−exponent away from each electrode (seed 001
/// eq. 6 with C2 ≈ exponent), and Q ∝ F^(2/3) unless force_skew ≠ 0 (a position-dependent
/// departure from the membrane scaling law, to exercise force levels).
struct SyntheticModel {
  std::vector<std::string> names{"A", "B", "C"};
  std::vector<std::array<double, 2>> centers_m{{0.0, 0.010}, {-0.00866025403784439, -0.005}, {0.00866025403784439, -0.005}};
  double film_radius_m = 0.045;
  double scale_C = 6.0e-13;  ///< sets ≈ 40 pC at 5 mm from an electrode under 1 N (seed 001 Fig. 6)
  double core_m = 0.002;
  double exponent = 0.8;
  double anisotropy = 1.3;
  double draw_angle_rad = 0.0;
  double force_exponent = pvdf::membrane_charge_exponent;
  double force_skew = 0.0;
  double d32_over_d31 = 0.1;   ///< seed 001: 0.65 / 6.5 pC/N
  double rim_strength = 0.5;   ///< 0: no rim term (a pure power law when also core→0, r = 1, a = 1)

  /// Charge of electrode k for a press of force_N at (x_m, y_m) (C).
  double charge_C(double x_m, double y_m, double force_N, std::size_t k) const;
  std::size_t n_electrodes() const { return names.size(); }
};

/// Samples `model` on a regular grid of spacing `spacing_m` covering the film, masking
/// positions closer than `rim_margin_m` to the rim, at the given force levels. Every electrode's
/// default noise is `noise_C`. The scene copy is a minimal JSON naming the model.
ChargeMap build_synthetic_map(const SyntheticModel& model, double spacing_m, double rim_margin_m,
                              const std::vector<double>& forces_N, double noise_C);

}  // namespace pvdf::mapping
