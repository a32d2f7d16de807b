// Flamant stresses, strip charge and the closed-form stress-rate signal (seed 000 eq. 1, corrected).
#include "pvdf/restore/physics.hpp"

#include "pvdf/core/constants.hpp"

#include <cmath>

namespace pvdf::restore {

namespace {
}

FlamantStress flamant_stress(double p_N_per_m, double q_N_per_m, double x_m, double z_m) {
  const double r2 = x_m * x_m + z_m * z_m;
  const double c = -2.0 / (pi * r2 * r2);
  FlamantStress s;
  s.sxx_Pa = c * (p_N_per_m * x_m * x_m * z_m + q_N_per_m * x_m * x_m * x_m);
  s.szz_Pa = c * (p_N_per_m * z_m * z_m * z_m + q_N_per_m * x_m * z_m * z_m);
  s.txz_Pa = c * (p_N_per_m * x_m * z_m * z_m + q_N_per_m * x_m * x_m * z_m);
  return s;
}

double strip_charge_density_per_N(const Strip& strip, double poisson_ratio, ForceComponent c, double x_rel_m) {
  // A normal force presses along +z; the drag f_x opposes the motion of the layer (+x), so it is a
  // tangential line load along -x on the layer surface.
  const double p = c == ForceComponent::z ? 1.0 / strip.length_m : 0.0;
  const double q = c == ForceComponent::x ? -1.0 / strip.length_m : 0.0;
  const FlamantStress s = flamant_stress(p, q, x_rel_m, strip.depth_m);
  const double syy = poisson_ratio * (s.sxx_Pa + s.szz_Pa);  // plane strain
  return strip.k1_C_per_N * s.sxx_Pa + strip.k2_C_per_N * syy + strip.k3_C_per_N * s.szz_Pa;
}

double strip_signal_per_N(const Strip& strip, double poisson_ratio, double feedback_resistance_ohm,
                          double speed_m_per_s, ForceComponent c, double x_rel_m) {
  const double z0 = strip.depth_m;
  const double u = x_rel_m / z0;
  const double k1p = strip.k1_C_per_N + poisson_ratio * strip.k2_C_per_N;
  const double k3p = strip.k3_C_per_N + poisson_ratio * strip.k2_C_per_N;
  const double scale = 2.0 * strip.area_m2() * feedback_resistance_ohm * speed_m_per_s / (pi * z0 * z0 * strip.length_m);
  const double d = 1.0 + u * u;
  const double d3 = d * d * d;
  if (c == ForceComponent::z) return -scale * 2.0 * u * (k1p - 2.0 * k3p - k1p * u * u) / d3;
  return scale * (k3p + 3.0 * (k1p - k3p) * u * u - k1p * u * u * u * u) / d3;
}

double howe_cutkosky_eq1(const Strip& strip, double feedback_resistance_ohm, double speed_m_per_s, double mu,
                         double x_m) {
  // Eq. 1: v = A_r R_f u (-2/(pi z0)) P d/dx { (k3 + k2/2)(1 + mu x/z0)/[1+(x/z0)^2]^2
  //                                          + (k1 + k2/2)((x/z0)^2 + mu (x/z0)^3)/[1+(x/z0)^2]^2 },
  // evaluated by a central difference of the printed bracket (it is an oracle, not the model).
  const double z0 = strip.depth_m;
  const double P = 1.0 / strip.length_m;
  auto bracket = [&](double x) {
    const double u = x / z0;
    const double d = (1 + u * u) * (1 + u * u);
    return (strip.k3_C_per_N + strip.k2_C_per_N / 2) * (1 + mu * u) / d +
           (strip.k1_C_per_N + strip.k2_C_per_N / 2) * (u * u + mu * u * u * u) / d;
  };
  const double h = 1e-5 * z0;
  const double derivative = (bracket(x_m + h) - bracket(x_m - h)) / (2 * h);
  return strip.area_m2() * feedback_resistance_ohm * speed_m_per_s * (-2.0 / (pi * z0)) * P * derivative;
}

}  // namespace pvdf::restore
