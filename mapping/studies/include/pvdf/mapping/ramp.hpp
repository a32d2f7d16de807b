// Does a press's force ramp single out one of the positions its peak charges allow? The ramp
// test of one candidate and, as a design metric, the share of a film it leaves ambiguous
// (docs/lookup.md §2, "Force ramps").
#pragma once

#include "pvdf/mapping/interpolant.hpp"
#include "pvdf/mapping/map.hpp"

#include <cstddef>
#include <vector>

namespace pvdf::mapping {

/// One position fitted to a whole ramp of samples, each sample with its own force.
struct RampFit {
  double x_m = 0, y_m = 0;  ///< the refined position (m)
  double chi2 = 0;          ///< Σ over samples and electrodes of ((Q_k − q_k)/σ_k)²; +inf off the map
  int iterations = 0;       ///< Levenberg–Marquardt steps taken on the position
};

/// Fits one position (x, y) and one force per sample to n_samples rows of charges
/// `charges_C` (row-major [n_samples][n_electrodes], C, in the map's own scale: undo a
/// calibration first), starting at (x_m, y_m) and, per sample, at the force that matches the
/// sample's magnitude given `start_force_N` for the last (peak) sample. The forces are
/// profiled out (Gauss–Newton in ln F per sample, within [min_force_N, max_force_N]); the
/// position takes Levenberg–Marquardt steps on the Schur complement. `sigma_C`: 1-σ noise per
/// electrode (C). Under the hypothesis "a press at a fixed position whose force ramps", chi2
/// follows χ² with n_samples·(n_electrodes − 1) − 2 degrees of freedom.
RampFit fit_ramp(const MapInterpolant& interpolant, const double* charges_C, int n_samples, const double* sigma_C,
                 double x_m, double y_m, double start_force_N, double min_force_N, double max_force_N);

/// The χ² quantile 1 − alpha for `dof` degrees of freedom (Wilson–Hilferty; relative error at
/// alpha = 1e-3: 0.6 % for dof = 10, < 0.1 % for dof ≥ 50).
double chi2_quantile(double dof, double alpha);

struct RampOptions {
  int n_samples = 30;           ///< samples of the ramp, the peak the last
  double ramp_start = 0.25;     ///< the first sample's force as a fraction of the peak's
  double alpha = 1e-3;          ///< false-rejection rate of the ramp test
  double peak_force_N = 0.0;    ///< 0 = the map's highest level
  std::vector<double> noise_C;  ///< 1-σ noise per electrode (C); empty = the map's
};

struct RampAmbiguity {
  std::size_t nodes = 0;           ///< usable interior nodes tested (the lookup found the press itself at the peak)
  std::size_t nodes_truth_missed = 0;  ///< usable nodes where it did not (not tested)
  double peak_force_N = 0;         ///< the ramp's peak
  int dof = 0;                     ///< degrees of freedom of the ramp test
  double limit = 0;                ///< its rejection threshold (χ² quantile 1 − alpha)
  double ambiguous_at_peak = 0;    ///< share of nodes whose peak charges fit more than one press
  double ambiguous_after_ramp = 0; ///< share of nodes with more than one solution the ramp keeps
  double ambiguous_after_hold = 0; ///< the same for as many samples held at the peak force: what
                                   ///< averaging alone removes (solutions within noise, not exact)
  double own_rejected = 0;         ///< share of nodes whose own solution the test would reject (noise-free: a defect)
  double median_separation = 0;    ///< over ambiguous nodes: median of the smallest λ/(limit − dof) of the others
};

/// The design metric: the map's own noise-free ramp (n_samples forces from ramp_start·F to F,
/// the map interpolant at every usable node off the grid's outer rows) is located at its peak
/// with the force unknown (default force range; the lookup's noise model, with the map's
/// error estimates when it stores them); every other solution s is tested against the whole
/// ramp with fit_ramp (σ = the noise alone), its noise-free χ² being the non-centrality λ_s of
/// the noisy test statistic. A solution counts as rejected when dof + λ_s exceeds the limit
/// (the noisy test rejects it more often than not). The same test with the samples held at
/// the peak force is the baseline: it removes solutions that fit only within noise, not
/// exactly. For an exact membrane map (Q = F^(2/3)·G(x, y)) the ramp removes no more than the
/// hold (its lower forces average less): it cannot separate exact solutions, whatever the
/// noise. Nodes whose own press the lookup does not find at the peak are counted apart
/// (nodes_truth_missed). The map is taken as exact: its own error counts like a wrong position
/// (docs/lookup.md §2).
RampAmbiguity ramp_ambiguity_share(const ChargeMap& map, const RampOptions& options = {});

}  // namespace pvdf::mapping
