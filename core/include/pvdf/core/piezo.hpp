// The charge law of a poled single-layer PVDF film with electrodes on both faces, in one place
// for the solver, the charge maps and the tests (docs/fem.md §2, "Why bending stress does not
// enter the charge").
#pragma once

namespace pvdf {

/// Short-circuit charge collected by an electrode of area A (m²) under the mean membrane forces
/// N11, N22 (N/m, material axes: 1 = draw direction) of a film of thickness h (m):
///   Q = A·(d31·N11 + d32·N22)/h  (C),
/// i.e. ∫ (d31 σ11 + d32 σ22) dA with σ = N/h the through-thickness mean stress (seed 001 eq. 2
/// in tensor form). The bending stress is odd in the thickness coordinate and gives no charge;
/// the shear N12 gives none in the C2v symmetry of β-PVDF (d36 = 0). The law is linear in N, so
/// with area 1 and force integrals ∫N11 dA, ∫N22 dA (N·m) it returns the charge directly.
inline double piezo_charge_C(double area_m2, double N11_N_per_m, double N22_N_per_m, double thickness_m,
                             double d31_C_per_N, double d32_C_per_N) {
  return area_m2 * (d31_C_per_N * N11_N_per_m + d32_C_per_N * N22_N_per_m) / thickness_m;
}

/// The same law as a density: (d31·N11 + d32·N22)/h (C/m²) at a point.
inline double piezo_charge_density_C_per_m2(double N11_N_per_m, double N22_N_per_m, double thickness_m,
                                            double d31_C_per_N, double d32_C_per_N) {
  return (d31_C_per_N * N11_N_per_m + d32_C_per_N * N22_N_per_m) / thickness_m;
}

}  // namespace pvdf
