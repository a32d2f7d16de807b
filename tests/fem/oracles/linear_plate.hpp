// Closed-form linear oracles for a clamped circular film: the Kirchhoff plate under uniform pressure
// and under a load spread on a central disk, and the pre-tensioned linear membrane. Valid only for
// deflections far below the thickness (plate) or for a pretension that dominates (membrane).
#pragma once

#include <cmath>

namespace pvdf::fem::oracles {

/// Flexural rigidity D = E h³ / (12 (1 − ν²)), N·m.
inline double flexural_rigidity_Nm(double youngs_modulus_Pa, double thickness_m, double poisson_ratio) {
  return youngs_modulus_Pa * thickness_m * thickness_m * thickness_m / (12 * (1 - poisson_ratio * poisson_ratio));
}

/// Clamped plate, uniform pressure q (Pa): w(r) = q (a² − r²)² / (64 D) (Timoshenko & Woinowsky-Krieger §15).
inline double clamped_plate_pressure_deflection_m(double r_m, double pressure_Pa, double radius_m, double D_Nm) {
  const double s = radius_m * radius_m - r_m * r_m;
  return pressure_Pa * s * s / (64 * D_Nm);
}

/// Clamped plate, total force P (N) spread uniformly on the central disk r < c (m).
/// Derived here by integrating D r (∇²w)' = ∫₀^r q ρ dρ with w, w', w'' continuous at r = c and
/// w = w' = 0 at r = a:
///   r ≤ c: w = P/(16πD) [a² − ¾c² + c² ln(c/a) + r⁴/(4c²) − c²r²/(2a²) + 2r² ln(c/a)],
///   r ≥ c: w = P/(16πD) [(a² − r²)(1 + c²/(2a²)) + (2r² + c²) ln(r/a)].
/// c → 0 gives the point load P/(16πD)[a² − r² + 2r² ln(r/a)], centre P a²/(16πD);
/// c = a gives the uniform pressure q = P/(πa²).
inline double clamped_plate_disk_load_deflection_m(double r_m, double force_N, double load_radius_m, double radius_m,
                                                   double D_Nm) {
  const double a = radius_m, c = load_radius_m, r = r_m, pre = force_N / (16 * M_PI * D_Nm);
  if (r <= c) {
    const double l = std::log(c / a);
    return pre * (a * a - 0.75 * c * c + c * c * l + r * r * r * r / (4 * c * c) - c * c * r * r / (2 * a * a) +
                  2 * r * r * l);
  }
  return pre * ((a * a - r * r) * (1 + c * c / (2 * a * a)) + (2 * r * r + c * c) * std::log(r / a));
}

/// Linear membrane with a uniform pretension N0 (N/m) and no bending, force P on the disk r < c:
/// N0 ∇²w = −q gives w = P/(2π N0) ln(a/r) for r ≥ c and P/(2π N0)[ln(a/c) + (c² − r²)/(2c²)] inside.
inline double tensioned_membrane_disk_load_deflection_m(double r_m, double force_N, double load_radius_m,
                                                        double radius_m, double pretension_N_per_m) {
  const double pre = force_N / (2 * M_PI * pretension_N_per_m);
  const double c = load_radius_m;
  if (r_m >= c) return pre * std::log(radius_m / r_m);
  return pre * (std::log(radius_m / c) + (c * c - r_m * r_m) / (2 * c * c));
}

}  // namespace pvdf::fem::oracles
