// How much of a map's film is ambiguous with three charges: the share of the map's usable nodes
// whose own charges fit more than one press, with the force unknown and with each remedy
// (docs/lookup.md §2). Used by `pvdfkit map`; `pvdfkit design` quantifies a fourth electrode.
#pragma once

#include "pvdf/mapping/map.hpp"

#include <cstddef>

namespace pvdf::mapping {

struct AmbiguityShare {
  std::size_t nodes = 0;          ///< usable nodes tested (middle force level)
  double force_N = 0;             ///< the level tested
  double min_force_N = 0, max_force_N = 0;  ///< the default force range of the lookup
  double force_unknown = 0;       ///< share of nodes with more than one solution, force unknown
  double force_known = 0;         ///< the same with the force known (a force reading)
  double force_within_25 = 0;     ///< the same with the force known within ±25 % (a force range)
};

/// Locates the map's own noise-free charges at every usable node of the middle force level
/// (noise model: the map's noise_C) and counts the presses with more than one solution.
AmbiguityShare ambiguity_share(const ChargeMap& map);

}  // namespace pvdf::mapping
