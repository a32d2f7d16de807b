// Scan files: CSV `x_m,m1_V,m2_V` (or `t_s,m1_V,m2_V` with the scan speed), optionally with the
// reference forces `fx_ref_N,fz_ref_N`; restored forces as CSV `x_m,fx_N,fz_N,mu,mu_valid,fx_N_per_m,fz_N_per_m`.
#pragma once

#include "pvdf/restore/scanner.hpp"

#include <string>
#include <vector>

namespace pvdf::restore {

/// Reads a scan. Columns: `x_m` (scanner position, m) or `t_s` (time, s; then `speed_m_per_s` > 0 is
/// required and x = t * speed), `m1_V`, `m2_V`; optional `fx_ref_N`, `fz_ref_N`. The grid must be
/// uniform and increasing (a step differing from the mean step by > 1 % is reported with its line
/// number), with at least 16 rows. Malformed rows are InputErrors naming the line (pvdf::read_csv).
Scan read_scan_csv(const std::string& path, double speed_m_per_s = 0.0);

/// Writes a scan atomically (`x_m,m1_V,m2_V[,fx_ref_N,fz_ref_N]`, 17 significant digits).
void write_scan_csv(const std::string& path, const Scan& scan, const std::string& comment = "");

/// Restored forces on the scan grid x_m (surface positions).
///  * fx_N_per_m, fz_N_per_m: line forces, N per metre of scan (the surface force per unit length along
///    the scan direction, integrated across the contact line); integrate over x for newtons.
///  * fx_N, fz_N: the force carried by each sample interval, N = N/m x sample spacing (a concentrated
///    edge's force is the sum over its lobe).
/// Both are loads in excess of the flat-surface level: a stress-rate sensor cannot see a steady load.
/// mu is defined where f_z exceeds the threshold (`mu_valid` = 1), and written as 0 with `mu_valid` = 0
/// elsewhere (never NaN).
struct RestoredForces {
  std::vector<double> x_m, fx_N, fz_N, mu;
  std::vector<int> mu_valid;
  std::vector<double> fx_N_per_m, fz_N_per_m;
  /// The level subtracted to put flat stretches at zero (N/m; empty when the baseline was not fixed).
  std::vector<double> baseline_fx_N_per_m, baseline_fz_N_per_m;
  double flat_fraction = 0;  ///< fraction of the samples judged flat (where the baseline was fitted)
  double mu_threshold_N = 0; ///< per sample
  double sample_spacing_m = 0;
  /// Largest f_z (N/m; 0 when none is positive), and Σ f_x, Σ f_z over the samples (N).
  double peak_fz_N_per_m() const;
  double total_fx_N() const;
  double total_fz_N() const;
};

/// Writes `x_m,fx_N,fz_N,mu,mu_valid,fx_N_per_m,fz_N_per_m` atomically.
void write_forces_csv(const std::string& path, const RestoredForces& forces, const std::string& comment = "");

}  // namespace pvdf::restore
