// Internal to pvdf::fem: the tension-field (wrinkling) membrane law (docs/fem.md §3.3). A thin film
// cannot carry compression: it wrinkles at no cost. The relaxed energy of an orthotropic
// St Venant–Kirchhoff membrane replaces the plane-stress energy W(e) = ½ e·C·e of the elastic strain
// e (Voigt [e11, e22, 2e12]) by
//   taut      (both principal stresses of C·e > 0):  W(e), S = C·e, tangent C;
//   slack     (e negative semidefinite):              0, S = 0, tangent 0;
//   wrinkled  (otherwise):  min over wrinkle directions t and β ≥ 0 of W(e + β t⊗t),
// i.e. the wrinkles take up the strain β along t = (−sin θ, cos θ), and the stress left is uniaxial
// along n ⊥ t: S = σ n⊗n, σ > 0. For fixed θ the minimum over β is closed form, so the law is a
// one-dimensional minimisation over θ, solved to round-off; the tangent is its exact second
// derivative (envelope theorem + implicit θ(e)).
#pragma once

#include <array>
#include <cmath>

namespace pvdf::fem::detail {

enum class MembraneState : unsigned char { taut = 0, wrinkled = 1, slack = 2 };

/// The relaxed law at one point.
struct RelaxedMembrane {
  MembraneState state = MembraneState::taut;
  std::array<double, 3> S{0, 0, 0};  ///< relaxed stress resultant (N/m), Voigt [S11, S22, S12]
  double W = 0;                      ///< relaxed energy density (J/m²)
  double D[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};  ///< ∂S/∂e (filled when asked for)
  double wrinkle_angle_rad = 0;      ///< θ of the wrinkle direction t (wrinkled state)
};

/// The principal values {larger, smaller} of a symmetric 2×2 stress resultant in Voigt form
/// [S11, S22, S12] (N/m): mean ± radius of its Mohr circle.
inline std::array<double, 2> principal_values(double s11, double s22, double s12) {
  const double mean = 0.5 * (s11 + s22), rad = std::hypot(0.5 * (s11 - s22), s12);
  return {mean + rad, mean - rad};
}

/// Relaxed law for the plane-stress stiffness C (N/m, Voigt, engineering shear; symmetric positive
/// definite) at the elastic strain e. want_tangent: fill D.
RelaxedMembrane relaxed_membrane(const double C[3][3], const std::array<double, 3>& e, bool want_tangent);

/// The Newton tangent (never the residual or the energy) gets ε·C added where the film is wrinkled
/// or slack: the relaxed tangent is singular there (no stiffness across the wrinkles), the
/// regularized one keeps the linear solves well posed, and the solution is still the exact relaxed
/// equilibrium because the residual is exact. ε·E·h is this fraction of the load's tension scale
/// (FilmSolver::tension_field_regularization), so that it stays small against the real stiffness
/// of a lightly loaded slack film.
constexpr double tension_field_tangent_regularization = 1e-3;

}  // namespace pvdf::fem::detail
