// Orthotropic plane-stress PVDF film: compliance, stiffness, rotations, off-axis moduli.
#include "pvdf/core/material.hpp"

#include <Eigen/Dense>

#include <cmath>
#include <sstream>

namespace pvdf {

Eigen::Matrix3d Material::compliance() const {
  // ε1 = σ1/E1 − ν21 σ2/E2, ε2 = −ν12 σ1/E1 + σ2/E2, γ12 = τ12/G12; with ν21/E2 = ν12/E1.
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
  S(0, 0) = 1.0 / E1_Pa;
  S(1, 1) = 1.0 / E2_Pa;
  S(0, 1) = S(1, 0) = -nu12 / E1_Pa;
  S(2, 2) = 1.0 / G12_Pa;
  return S;
}

Eigen::Matrix3d Material::stiffness() const {
  // Closed form of S⁻¹ (plane stress): Q11 = E1/(1−ν12ν21), Q22 = E2/(1−ν12ν21),
  // Q12 = ν12 E2/(1−ν12ν21), Q66 = G12.
  const double nu21_r = nu21();
  const double denom = 1.0 - nu12 * nu21_r;
  Eigen::Matrix3d Q = Eigen::Matrix3d::Zero();
  Q(0, 0) = E1_Pa / denom;
  Q(1, 1) = E2_Pa / denom;
  Q(0, 1) = Q(1, 0) = nu12 * E2_Pa / denom;
  Q(2, 2) = G12_Pa;
  return Q;
}

Eigen::Matrix3d strain_to_material(double theta_rad) {
  const double c = std::cos(theta_rad), s = std::sin(theta_rad);
  Eigen::Matrix3d T;
  T << c * c, s * s, c * s,
       s * s, c * c, -c * s,
       -2 * c * s, 2 * c * s, c * c - s * s;
  return T;
}

Eigen::Matrix3d stress_to_material(double theta_rad) {
  const double c = std::cos(theta_rad), s = std::sin(theta_rad);
  Eigen::Matrix3d T;
  T << c * c, s * s, 2 * c * s,
       s * s, c * c, -2 * c * s,
       -c * s, c * s, c * c - s * s;
  return T;
}

Eigen::Matrix3d Material::stiffness_global(double theta_rad) const {
  // Energy invariance: σ_g = T_εᵀ σ_m and ε_m = T_ε ε_g give Q̄ = T_εᵀ Q T_ε.
  const Eigen::Matrix3d T = strain_to_material(theta_rad);
  return T.transpose() * stiffness() * T;
}

Eigen::Matrix3d Material::stiffness_global() const { return stiffness_global(draw_angle_rad); }

std::string Material::positive_definiteness_problem() const {
  std::ostringstream os;
  if (!(E1_Pa > 0) || !(E2_Pa > 0) || !(G12_Pa > 0)) {
    os << "moduli must be > 0";
    return os.str();
  }
  if (!(nu12 * nu21() < 1.0)) {
    os << "nu12 = " << nu12 << " gives nu12*nu21 = " << nu12 * nu21()
       << " >= 1 (nu21 = nu12*E2/E1): the film would have no positive strain energy; "
       << "use |nu12| < sqrt(E1/E2) = " << std::sqrt(E1_Pa / E2_Pa);
    return os.str();
  }
  return {};
}

OffAxisModuli off_axis_moduli(const Material& material, double beta_rad) {
  // The x axis makes angle β with the draw direction, so the draw direction lies at −β from x.
  // Rotating the compliance: ε_g = T_ε⁻¹ S T_ε⁻ᵀ σ_g.
  const Eigen::Matrix3d T = strain_to_material(-beta_rad);
  const Eigen::Matrix3d Tinv = T.inverse();
  const Eigen::Matrix3d Sg = Tinv * material.compliance() * Tinv.transpose();
  OffAxisModuli r;
  r.angle_rad = beta_rad;
  r.Ex_Pa = 1.0 / Sg(0, 0);
  r.Ey_Pa = 1.0 / Sg(1, 1);
  r.Gxy_Pa = 1.0 / Sg(2, 2);
  r.nuxy = -Sg(1, 0) / Sg(0, 0);
  r.nuyx = -Sg(0, 1) / Sg(1, 1);
  return r;
}

OffAxisModuli off_axis_moduli_printed(const Material& material, double beta_rad, double nu21,
                                      bool correct_eq5) {
  const double m = std::cos(beta_rad), n = std::sin(beta_rad);
  const double m2 = m * m, n2 = n * n, m4 = m2 * m2, n4 = n2 * n2;
  const double E1 = material.E1_Pa, E2 = material.E2_Pa, G12 = material.G12_Pa;
  const double nu12 = material.nu12;

  // Seed 001 eq 3: c = x → (k, j, p) = (1, 2, 12); c = y → (2, 1, 21).
  auto denominator = [&](double Ek, double Ej, double nup) {
    return m4 + (Ek / G12 - 2.0 * nup) * m2 * n2 + (Ek / Ej) * n4;
  };
  // Seed 001 eq 5; the printed bracket is [1 − Ek/Ej − Ek/G12].
  auto poisson = [&](double Ek, double Ej, double nup) {
    const double sign = correct_eq5 ? +1.0 : -1.0;
    return (nup * (m4 + n4) - (1.0 + sign * Ek / Ej - Ek / G12) * m2 * n2) /
           denominator(Ek, Ej, nup);
  };
  OffAxisModuli r;
  r.angle_rad = beta_rad;
  r.Ex_Pa = E1 / denominator(E1, E2, nu12);
  r.Ey_Pa = E2 / denominator(E2, E1, nu21);
  // Seed 001 eq 4.
  r.Gxy_Pa = G12 / (m4 + n4 + 2.0 * (2.0 * G12 / E1 * (1.0 + 2.0 * nu12) + 2.0 * G12 / E2 - 1.0) * m2 * n2);
  r.nuxy = poisson(E1, E2, nu12);
  r.nuyx = poisson(E2, E1, nu21);
  return r;
}

}  // namespace pvdf
