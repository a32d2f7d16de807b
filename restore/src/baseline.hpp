// Internal: the flat-surface level of a restored record (docs/restore.md, "the mean load").
#pragma once

#include "pvdf/restore/scan_io.hpp"

namespace pvdf::restore::detail {

/// Fits smooth baselines (Gaussian scale `scale_m`) to fx_N_per_m and fz_N_per_m through the samples
/// judged flat: f_z within max(2.5 x the robust noise, 2 % of the largest |f_z|) of the current baseline,
/// at least 2 resolutions (and 3 samples) from any sample that is not. Four passes. Fills
/// baseline_fx_N_per_m, baseline_fz_N_per_m and flat_fraction; does not subtract.
void fit_flat_baseline(RestoredForces& forces, double scale_m, double resolution_m);

}  // namespace pvdf::restore::detail
