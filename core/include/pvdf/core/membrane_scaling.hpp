// Scaling laws of a clamped film that carries a point-like load as a pure membrane (no bending,
// no pretension; Föppl–Hencky): membrane forces, strains, in-plane displacements and electrode
// charges grow as F^(2/3), the deflection as F^(1/3). Exact for the von Kármán membrane, a close
// approximation for these films otherwise (docs/fem.md §5). One home for the solver's warm
// starts and continuation, the map generator's scaled force levels and its scaling check, the
// interpolants' default force exponent, the hardware simulator's map-driven presses and the bending rule.
#pragma once

#include <cmath>

namespace pvdf {

/// The exponent 2/3 of Q ∝ F^(2/3): the default force exponent of the map interpolants, the
/// triangulation and the synthetic map model (which may fit or set another).
inline constexpr double membrane_charge_exponent = 2.0 / 3.0;

/// (F/F0)^(2/3): the factor on charges, membrane forces, strains and in-plane displacements when
/// the force changes by `force_ratio` = F/F0 (> 0).
inline double membrane_charge_factor(double force_ratio) { return std::cbrt(force_ratio * force_ratio); }

/// (F/F0)^(1/3): the factor on the deflection when the force changes by `force_ratio` = F/F0 (> 0).
inline double membrane_deflection_factor(double force_ratio) { return std::cbrt(force_ratio); }

/// Membrane force scale N ~ E·h·(F/(E·h·a))^(2/3) (N/m) of a clamped membrane of radius a (m) and
/// membrane stiffness E·h (N/m) carrying F (N): the size of the membrane forces under a probe,
/// up to an O(1) factor.
/// (std::pow here, as the solver's continuation has always computed it: a last-bit change of its
/// starting tension changes the Newton path.)
inline double membrane_force_scale_N_per_m(double stiffness_N_per_m, double force_N, double radius_m) {
  return stiffness_N_per_m * std::pow(force_N / (stiffness_N_per_m * radius_m), 2.0 / 3.0);
}

/// Membrane deflection scale w ~ a·(F/(E·h·a))^(1/3) (m) of the same membrane: its sag under the
/// probe up to an O(1) factor (the scene check of a force too small to deflect the film).
inline double membrane_deflection_scale_m(double stiffness_N_per_m, double force_N, double radius_m) {
  return radius_m * std::cbrt(force_N / (stiffness_N_per_m * radius_m));
}

}  // namespace pvdf
