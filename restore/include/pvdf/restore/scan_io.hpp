// Scan files: CSV `x_m,m1_V,m2_V` (or `t_s,m1_V,m2_V` with the scan speed), optionally with the
// reference forces `fx_ref_N,fz_ref_N`; restored forces as CSV `x_m,fx_N,fz_N,mu`.
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

/// Restored forces on the scan grid; mu is defined where f_z exceeds the threshold (`mu_valid` = 1),
/// and written as 0 with `mu_valid` = 0 elsewhere (never NaN).
struct RestoredForces {
  std::vector<double> x_m, fx_N, fz_N, mu;
  std::vector<int> mu_valid;
  double mu_threshold_N = 0;
};

/// Writes `x_m,fx_N,fz_N,mu,mu_valid` atomically.
void write_forces_csv(const std::string& path, const RestoredForces& forces, const std::string& comment = "");

}  // namespace pvdf::restore
