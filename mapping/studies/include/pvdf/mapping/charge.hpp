// Electrode charge from membrane stress: the tensor formula Q = ∫(d31·σ11 + d32·σ22) dA over a
// sampled field, and seed 001 eq. 2 as printed, for comparison. The law itself is
// pvdf::piezo_charge_C (pvdf/core/piezo.hpp), which the solver uses for its electrode charges.
#pragma once

#include <cstddef>
#include <vector>

namespace pvdf::mapping {

/// One quadrature point of the membrane-force field over an electrode.
struct MembraneForceSample {
  double weight_m2 = 0;   ///< quadrature weight (area it represents), m²
  double N11_N_per_m = 0; ///< membrane force along the draw direction (material axis 1), N/m
  double N22_N_per_m = 0; ///< membrane force across the draw direction (material axis 2), N/m
};

/// Charge collected by an electrode: Q = Σ_q w_q (d31·σ11 + d32·σ22) with σ = N/h, the
/// through-thickness mean stress in the film's material axes (C). Short-circuit charge of a
/// poled film whose electrode covers the samples; the shear stress σ12 gives no charge in the
/// C2v symmetry of β-PVDF (d36 = 0). Throws InputError for thickness_m <= 0 or a negative weight.
/// @param samples       quadrature points covering the electrode (weights sum to its area)
/// @param thickness_m   film thickness h (m)
/// @param d31_C_per_N   piezoelectric coefficient along the draw (C/N)
/// @param d32_C_per_N   piezoelectric coefficient across the draw (C/N)
double electrode_charge_C(const MembraneForceSample* samples, std::size_t n_samples, double thickness_m,
                          double d31_C_per_N, double d32_C_per_N);
double electrode_charge_C(const std::vector<MembraneForceSample>& samples, double thickness_m, double d31_C_per_N,
                          double d32_C_per_N);

/// Seed 001 eq. 2 as printed: Q = (d31·cos β + d32·sin β)·σr·Se (C). β is the angle between
/// the draw direction and the line from the load to the electrode. Kept for comparison only:
/// the linear cos β / sin β weighting does not follow from the tensor transformation.
double charge_eq2_printed_C(double d31_C_per_N, double d32_C_per_N, double beta_rad, double sigma_r_Pa,
                            double area_m2);

/// The same situation by tensor transformation: a radial stress σr and hoop stress σθ whose
/// radial direction makes angle β with the draw direction give σ11 = σr cos²β + σθ sin²β,
/// σ22 = σr sin²β + σθ cos²β, so Q = (d31·σ11 + d32·σ22)·Se (C). With σθ = 0 this is
/// (d31 cos²β + d32 sin²β)·σr·Se — the corrected eq. 2 (docs/mapping.md §3).
double charge_radial_tensor_C(double d31_C_per_N, double d32_C_per_N, double beta_rad, double sigma_r_Pa,
                              double sigma_theta_Pa, double area_m2);

}  // namespace pvdf::mapping
