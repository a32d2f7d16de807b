// PNG figures of the restoration pipeline, analogues of seed 000 Figs 11-14.
#pragma once

#include "pvdf/restore/filter.hpp"
#include "pvdf/restore/scan_io.hpp"

#include <string>

namespace pvdf::restore {

/// Figs 11/12: the two strip signals m1(x), m2(x) of a scan (and the reference forces, if known).
void plot_scan(const std::string& path, const Scan& scan, const std::string& title);
/// Fig. 13: the inverse filters h11, h12, h21, h22 against lag (mm, modelling delay removed).
void plot_filters(const std::string& path, const InverseFilter& filter);
/// |G_ij| against spatial frequency and the GCV curve when present.
void plot_transfer(const std::string& path, const InverseFilter& filter);
/// Fig. 14: restored f_x, f_z (and mu) against x, with the reference forces when `scan` has them
/// (blurred by the filter's target Gaussian when resolution_m > 0, so both are on the same scale).
/// Both panels share one x range (the scan's); the title names the filter by its target
/// resolution (or its absence).
void plot_restored(const std::string& path, const RestoredForces& forces, const Scan& scan, const std::string& title,
                   double resolution_m = 0);
/// The same, with the title naming the filter in full: regularization, β and its rule, target
/// resolution (figures of two filters restoring one scan can then be told apart).
void plot_restored(const std::string& path, const RestoredForces& forces, const Scan& scan, const std::string& title,
                   const InverseFilter& filter);

}  // namespace pvdf::restore
