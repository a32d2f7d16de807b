// PVDF film material: orthotropic plane-stress elasticity in the drawn (1) / transverse (2)
// axes, off-axis moduli (seed 001 eqs 3–5 and by tensor rotation), and the rotated stiffness
// Q̄(θ) the finite-element solver uses.
#pragma once

#include <Eigen/Core>

#include <string>
#include <vector>

namespace pvdf {

/// Linear elastic, piezoelectric thin film in plane stress. Axis 1 is the drawn direction,
/// axis 2 the transverse in-plane direction, axis 3 the thickness (poling) direction.
/// The independent Poisson ratio is nu12; nu21 = nu12·E2/E1 follows from the symmetry of the
/// compliance (a strain energy exists). A tabulated nu21 that disagrees is kept only for
/// reporting (`nu21_table`), never used in the constitutive law: see docs/material.md.
struct Material {
  double E1_Pa = 2.2e9;             ///< Young's modulus along the draw (seed 001 Table 1)
  double E2_Pa = 1.8e9;             ///< Young's modulus across the draw
  double G12_Pa = 0.58e9;           ///< in-plane shear modulus
  double nu12 = 0.35;               ///< Poisson ratio: strain in 2 per strain in 1, stress along 1
  double nu21_table = 0.28;         ///< tabulated nu21 (seed 001), for the reciprocity check only
  bool nu21_given = false;          ///< true when the scene sets nu21
  double draw_angle_rad = 0.0;      ///< angle from the global x axis to the draw direction (CCW)
  double d31_C_per_N = 6.5e-12;     ///< piezoelectric strain coefficient along the draw (measured, seed 001)
  double d32_C_per_N = 0.65e-12;    ///< piezoelectric strain coefficient across the draw
  bool isotropic = false;           ///< written as {E_Pa, nu} in the scene

  /// nu21 used by the constitutive law: nu12·E2/E1.
  double nu21() const { return nu12 * E2_Pa / E1_Pa; }

  /// Plane-stress compliance S in material axes, Voigt order [11, 22, 12] with engineering
  /// shear strain γ12: ε = S σ. Units 1/Pa.
  Eigen::Matrix3d compliance() const;
  /// Plane-stress stiffness Q = S⁻¹ in material axes (Pa), σ = Q ε.
  Eigen::Matrix3d stiffness() const;
  /// Stiffness Q̄(θ) in global axes for the draw direction at `draw_angle_rad` from x:
  /// σ_global = Q̄ ε_global (engineering shear). Membrane stiffness is thickness·Q̄,
  /// bending stiffness thickness³/12·Q̄.
  Eigen::Matrix3d stiffness_global() const;
  /// Same, for an explicit angle θ of the draw direction from x (rad).
  Eigen::Matrix3d stiffness_global(double theta_rad) const;

  /// Checks the plane-stress stiffness is positive definite (|nu12| < sqrt(E1/E2) etc.).
  /// Returns an empty string when it is, otherwise the reason.
  std::string positive_definiteness_problem() const;
};

/// Engineering-strain transformation T_ε(θ): ε_material = T_ε ε_global, Voigt [xx, yy, xy]
/// with engineering shear, for material axis 1 at angle θ (rad, CCW) from global x.
Eigen::Matrix3d strain_to_material(double theta_rad);
/// Stress transformation T_σ(θ): σ_material = T_σ σ_global (tensor shear component).
Eigen::Matrix3d stress_to_material(double theta_rad);

/// Off-axis engineering constants in axes (x, y) where x makes angle β with the draw direction.
struct OffAxisModuli {
  double angle_rad = 0;
  double Ex_Pa = 0;
  double Ey_Pa = 0;
  double Gxy_Pa = 0;
  double nuxy = 0;  ///< −ε_y/ε_x under uniaxial σ_x
  double nuyx = 0;  ///< −ε_x/ε_y under uniaxial σ_y
};

/// Off-axis moduli by rotating the compliance tensor (the reference; reciprocal nu21).
OffAxisModuli off_axis_moduli(const Material& material, double beta_rad);

/// Off-axis moduli by seed 001 eqs 3–5 as printed, with m = cos β and n = sin β (the text's
/// "ν = sin β" is an OCR/print slip). `nu21` is the value put into the k=2 branch (the paper's
/// Table 1 gives 0.28; the reciprocal value is nu12·E2/E1). With `correct_eq5` the sign of
/// the E_k/E_j term in eq 5 is fixed (printed: 1 − E_k/E_j − E_k/G12; right:
/// 1 + E_k/E_j − E_k/G12); without it, the printed formula is evaluated as is.
OffAxisModuli off_axis_moduli_printed(const Material& material, double beta_rad, double nu21,
                                      bool correct_eq5);

}  // namespace pvdf
