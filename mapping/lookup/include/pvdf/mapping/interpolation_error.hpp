// The error a charge map makes *between* its nodes and force levels, estimated from the map's own
// numbers (docs/lookup.md §1.10): hierarchical surpluses against the grid of every other node,
// carried to the map's spacing with a locally measured convergence rate, and the curvature of
// the reduced charge across the force levels. The Locator adds it to its noise model.
#pragma once

#include "pvdf/mapping/map.hpp"

#include <vector>

namespace pvdf::mapping {

/// Settings of the estimate (public members with defaults; docs/lookup.md §1.10).
struct InterpolationErrorOptions {
  /// The error of the interpolant falls by the ratio ρ = W(4h) / W(2h) per halving of the
  /// spacing, measured per node (W: the largest surplus within ±2 nodes); ρ is clamped to
  /// [min_ratio, max_ratio]: 16 is the bicubic scheme's 4th order (a larger measured ratio is
  /// pre-asymptotic and is not extrapolated), 1 an error that does not fall at all.
  double min_ratio = 1.0;
  double max_ratio = 16.0;
  /// Where no ratio can be measured (no 4h cell covers the window, e.g. next to the mask's
  /// edge): first order, conservative against the measured 1.5–10 of smooth regions.
  double default_ratio = 2.0;
};

/// The estimate, per node, level and electrode ([nf][ny][nx][ne], C at the level's force; 0 at
/// unusable nodes).
struct InterpolationError {
  /// The largest error of the bicubic interpolant in the cells around the node (at their
  /// centres and edge midpoints): the largest hierarchical surplus within ±1 node divided by
  /// the convergence ratio.
  std::vector<double> between_nodes_C;
  /// The largest error of the interpolation in ln F between level f and f + 1 (0 at the last
  /// level and for a one-level map): curvature of the reduced charge G = Q/F^p across the
  /// levels × Δ²/8, or with two levels a quarter of |G₁ − G₀| (no curvature measurable).
  std::vector<double> between_levels_C;
  /// Beyond the first (f = 0) and the last level (f = nf − 1) the map holds G constant (the
  /// scaling law); the error grows like this × |ln F − ln F_level| (C per unit of ln F; 0 at
  /// the other levels and for a one-level map).
  std::vector<double> beyond_levels_C;
  /// The convergence ratio ρ used at each node (clamped; default_ratio where not measured).
  std::vector<double> convergence_ratio;
};

/// Estimates the map's interpolation error from its own charges (any ChargeMap the Locator
/// accepts; the cost is about two interpolant constructions). Deterministic: the same charges
/// give the same bits, so an HDF5 map and its flat export give the same estimate.
InterpolationError estimate_interpolation_error(const ChargeMap& map, const InterpolationErrorOptions& options = {});

}  // namespace pvdf::mapping
