// Electrode charge formulas (seed 001 eq. 2 and its tensor-transformation correction). The charge
// law itself lives in pvdf/core/piezo.hpp (the solver uses the same function); this file sums a
// sampled field and compares the printed eq. 2 with the tensor form.
#include "pvdf/mapping/charge.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/piezo.hpp"

#include <cmath>
#include <string>

namespace pvdf::mapping {

double electrode_charge_C(const MembraneForceSample* samples, std::size_t n_samples, double thickness_m,
                          double d31_C_per_N, double d32_C_per_N) {
  if (!(thickness_m > 0) || !std::isfinite(thickness_m)) {
    throw InputError("electrode charge: thickness_m = " + std::to_string(thickness_m) + " must be finite and > 0");
  }
  // Σ w (d31 N11 + d32 N22) / h, accumulated as two sums (∫N11 dA, ∫N22 dA) to keep the
  // round-off small; the law is linear, so it applies to the integrals directly.
  double sum11 = 0, sum22 = 0;
  for (std::size_t q = 0; q < n_samples; ++q) {
    if (!(samples[q].weight_m2 >= 0)) {
      throw InputError("electrode charge: sample " + std::to_string(q) + " has weight " +
                       std::to_string(samples[q].weight_m2) + " m^2; weights must be >= 0");
    }
    sum11 += samples[q].weight_m2 * samples[q].N11_N_per_m;
    sum22 += samples[q].weight_m2 * samples[q].N22_N_per_m;
  }
  return pvdf::piezo_charge_density_C_per_m2(sum11, sum22, thickness_m, d31_C_per_N, d32_C_per_N);
}

double electrode_charge_C(const std::vector<MembraneForceSample>& samples, double thickness_m, double d31_C_per_N,
                          double d32_C_per_N) {
  return electrode_charge_C(samples.data(), samples.size(), thickness_m, d31_C_per_N, d32_C_per_N);
}

double charge_eq2_printed_C(double d31_C_per_N, double d32_C_per_N, double beta_rad, double sigma_r_Pa,
                            double area_m2) {
  return (d31_C_per_N * std::cos(beta_rad) + d32_C_per_N * std::sin(beta_rad)) * sigma_r_Pa * area_m2;
}

double charge_radial_tensor_C(double d31_C_per_N, double d32_C_per_N, double beta_rad, double sigma_r_Pa,
                              double sigma_theta_Pa, double area_m2) {
  const double c = std::cos(beta_rad), s = std::sin(beta_rad);
  const double sigma11 = sigma_r_Pa * c * c + sigma_theta_Pa * s * s;
  const double sigma22 = sigma_r_Pa * s * s + sigma_theta_Pa * c * c;
  // The charge law with stresses: N = σ·h, so with h = 1 the resultants are the stresses.
  return pvdf::piezo_charge_C(area_m2, sigma11, sigma22, 1.0, d31_C_per_N, d32_C_per_N);
}

}  // namespace pvdf::mapping
