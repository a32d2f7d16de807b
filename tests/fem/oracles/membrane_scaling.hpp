// Exact scaling laws of the pure von Kármán membrane (no pretension, no bending, fixed load
// footprint, any linear — also anisotropic — material): w ∝ F^(1/3), u and membrane forces ∝ F^(2/3),
// and stored energy = ¼ × work of the dead load. Used as conservation/scaling oracles for any solver.
//
// Why: the membrane energy is homogeneous of degree 4 under (w, u) → (λw, λ²u), so at equilibrium
// d/dλ at λ = 1 of [U(λw, λ²u) − L(λw)] = 4U − L = 0, with L = ∫ q w dA. For a probe of force F on a
// disk, L = F·δ̄ (δ̄ = mean deflection over the footprint; → F·δ for a point load); for a uniform
// pressure p, L = p·V with V the volume swept by the film. Pretension, bending, Green–Lagrange terms
// (½u'²) and follower loads break the homogeneity, and with it these laws — measurably.
#pragma once

#include <cmath>

namespace pvdf::fem::oracles {

/// Deflection at force F given the deflection w_ref at F_ref (same point, same footprint), m.
inline double membrane_scaled_deflection_m(double w_ref_m, double force_ref_N, double force_N) {
  return w_ref_m * std::cbrt(force_N / force_ref_N);
}
/// Membrane force (or stress, or in-plane displacement) at force F from its value at F_ref.
inline double membrane_scaled_force(double n_ref, double force_ref_N, double force_N) {
  const double t = std::cbrt(force_N / force_ref_N);
  return n_ref * t * t;
}
/// Stored strain energy of the pure membrane from the load work: U = L/4 (J).
/// Probe: pass L = F·δ̄ (N·m); pressure: L = p·V (Pa·m³).
inline double membrane_strain_energy_J(double load_work_J) { return 0.25 * load_work_J; }
/// The same identity for a linear structure (Clapeyron): U = L/2. A solver in between the two
/// regimes (bending + membrane) must give a ratio U/L in (1/4, 1/2).
inline double linear_strain_energy_J(double load_work_J) { return 0.5 * load_work_J; }

}  // namespace pvdf::fem::oracles
