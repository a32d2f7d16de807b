// The sensor physics of seed 000 eq. 1 (corrected): Flamant line loads on an elastic half-space, the
// strip charge k1*sxx + k2*syy + k3*szz, and the stress-rate signal a scanning strip produces.
#pragma once

#include <array>

namespace pvdf::restore {

/// In-plane Flamant stresses (plane strain) at a point of an elastic half-space z > 0.
struct FlamantStress {
  double sxx_Pa = 0;
  double szz_Pa = 0;
  double txz_Pa = 0;
};

/// Flamant solution (Johnson, Contact Mechanics, eq. 2.19): line loads at the surface origin,
/// `p_N_per_m` pressing into the layer (along +z, depth), `q_N_per_m` tangential along +x.
/// Stress at the field point (x_m, z_m), z_m > 0 (compression negative):
///   sxx = -2/pi (p x^2 z + q x^3)/r^4, szz = -2/pi (p z^3 + q x z^2)/r^4, txz = -2/pi (p x z^2 + q x^2 z)/r^4.
/// Independent of the elastic moduli; the out-of-plane stress is syy = nu (sxx + szz).
FlamantStress flamant_stress(double p_N_per_m, double q_N_per_m, double x_m, double z_m);

/// Which surface force a response belongs to. `x` is the tangential (friction) force, positive
/// when it opposes the scan motion (drag), so mu = f_x / f_z > 0; `z` is the normal force, positive pressing.
enum class ForceComponent { x = 0, z = 1 };

/// One PVDF strip in the skin: its depth below the contact surface, its lateral offset along the scan
/// direction (sensor frame), its electrode size and its piezoelectric constants k1, k2, k3 (charge per
/// area per stress along x, y, z: C/N = C/m^2/Pa). Defaults: a horizontal film poled along z,
/// d31 = 23, d32 = 3, d33 = -33 pC/N.
struct Strip {
  double depth_m = 1.0e-3;
  double offset_m = 0.0;
  double width_m = 1.0e-3;    ///< electrode extent along x (area only; the strip is treated as a point in x)
  double length_m = 20.0e-3;  ///< electrode extent along y = length of the contact line the load is spread on
  double k1_C_per_N = 23e-12;
  double k2_C_per_N = 3e-12;
  double k3_C_per_N = -33e-12;
  double area_m2() const { return width_m * length_m; }
};

/// The sensing head: two strips in an elastic layer, read by transimpedance amplifiers.
struct Sensor {
  std::array<Strip, 2> strips;
  double poisson_ratio = 0.5;             ///< of the silicone layer (plane strain: syy = nu (sxx + szz))
  double feedback_resistance_ohm = 1e9;   ///< R_f of the current amplifier: v = R_f dq/dt
};

/// Charge per electrode area (C/m^2) on `strip` per newton of surface force `c`, when the load acts on
/// the surface at relative position x_rel_m = (strip position) - (load position) along x. The force is
/// spread over the strip length (line load F / length_m). Computed from flamant_stress.
double strip_charge_density_per_N(const Strip& strip, double poisson_ratio, ForceComponent c, double x_rel_m);

/// The stress-rate signal (V per N of force) of a strip scanned at `speed_m_per_s` (the load moves
/// relative to the strip so that dx_rel/dt = +speed): v = A R_f speed d/dx_rel[charge density].
/// Closed form (docs/restore.md), u = x_rel / depth, k1' = k1 + nu k2, k3' = k3 + nu k2:
///   f_z: v = -C * 2u (k1' - 2 k3' - k1' u^2) / (1+u^2)^3
///   f_x: v = +C * (k3' + 3 (k1' - k3') u^2 - k1' u^4) / (1+u^2)^3,
///   C = 2 A R_f speed / (pi depth^2 length).
double strip_signal_per_N(const Strip& strip, double poisson_ratio, double feedback_resistance_ohm,
                          double speed_m_per_s, ForceComponent c, double x_rel_m);

/// Seed 000 eq. 1 as printed, with the OCR repairs stated in docs/restore.md (the leading "mu" is the
/// scan speed, the load per unit length P is restored, x is measured from the strip to the load),
/// for a load f_z = P*length with friction f_x = mu f_z and nu = 1/2. Used by the tests as a second
/// oracle. Returns V per N of normal force.
double howe_cutkosky_eq1(const Strip& strip, double feedback_resistance_ohm, double speed_m_per_s, double mu,
                         double x_rel_m);

}  // namespace pvdf::restore
