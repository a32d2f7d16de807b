// The error a charge map makes *between* its nodes and force levels, estimated from the map's own
// numbers (docs/lookup.md §1.10): hierarchical surpluses against the grids of every other node,
// carried to the map's spacing with a locally measured convergence ratio, and the curvature of
// the reduced charge across the force levels. The Locator adds it to its noise model.
#pragma once

#include "pvdf/mapping/map.hpp"

#include <vector>

namespace pvdf::mapping {

/// The estimate, per node, level and electrode ([nf][ny][nx][ne], C at the level's force; 0 at
/// unusable nodes).
struct InterpolationError {
  /// The error of the bicubic interpolant in the cells around the node (largest at their centres
  /// and edge midpoints): the node's hierarchical surplus S₁ (the error there of the interpolants
  /// of the grids of every other node, spacing 2h) over ρ₀ = min(16, ρ₁²), ρ₁ the ratio of the
  /// surpluses one level coarser (4h) to S₁ around the node (2 where not measurable).
  std::vector<double> between_nodes_C;
  /// The largest error of the interpolation in ln F between level f and f + 1 (0 at the last
  /// level and for a one-level map): curvature of the reduced charge G = Q/F^p across the
  /// levels × Δ²/8, or with two levels a quarter of |G₁ − G₀| (no curvature measurable).
  std::vector<double> between_levels_C;
  /// Beyond the first (f = 0) and the last level (f = nf − 1) the map holds G constant (the
  /// scaling law); the error grows like this × |ln F − ln F_level| (C per unit of ln F; 0 at
  /// the other levels and for a one-level map).
  std::vector<double> beyond_levels_C;

  /// The same errors split into a common relative scale of all of a node's charges and the rest
  /// (docs/lookup.md §1.11). Each error is a signed vector over the electrodes s (G units, the
  /// same coarser grid or the same levels for every electrode); its least-squares scale of the
  /// node's reduced charges G is α = s·G / G·G, and s − α·G the rest. A scale error moves every
  /// charge by the same factor, which a free force absorbs (∂Q/∂ln F ≈ p·Q) without moving
  /// (x, y); the rest does not. Scale: [nf][ny][nx], unitless (beyond the levels: per unit of
  /// ln F); the rest: [nf][ny][nx][ne], C at the level's force, like the totals above. Each is
  /// the largest over the coarser grids (levels) it is taken from, as the totals are.
  std::vector<double> between_nodes_scale, between_levels_scale, beyond_levels_scale;
  std::vector<double> between_nodes_rest_C, between_levels_rest_C, beyond_levels_rest_C;
};

/// Estimates the map's interpolation error from its own charges (any ChargeMap the Locator
/// accepts; the cost is about two interpolant constructions). Deterministic: the same charges
/// give the same bits, so an HDF5 map and its flat export give the same estimate.
InterpolationError estimate_interpolation_error(const ChargeMap& map);

/// The nodes (ox + n·i, oy + n·j) of `map`: the grid of spacing n·h with that offset (all levels,
/// electrodes, status, mask, derivatives; no deflections or estimates). Fewer than two nodes on
/// an axis: x_m or y_m shorter than 2 (not a usable map).
ChargeMap every_nth_node(const ChargeMap& map, std::size_t n, std::size_t ox, std::size_t oy);

/// |hierarchical surplus| of the reduced charge G = Q/F^p (C/N^p) per [f][j][i][k]: the largest
/// |G − I₂ₕG| over the grids of every other node (spacing 2h, the four offsets) that do not hold
/// the node, I₂ₕ the MapInterpolant of that grid; NaN where none covers the node.
std::vector<double> hierarchical_surplus_G(const ChargeMap& map);

}  // namespace pvdf::mapping
