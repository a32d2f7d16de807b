// How well the lookup locates presses on a given charge map, beside the seed-001 triangulation:
// Monte-Carlo presses whose true charges are the map's own interpolant, noise added per level,
// median position errors and locates per CPU second (a self-consistency check: it measures noise
// sensitivity and the triangulation's model error, not the map's interpolation error).
#pragma once

#include "pvdf/mapping/map.hpp"

#include <cstddef>
#include <functional>
#include <vector>

namespace pvdf::mapping {

struct LookupAccuracyOptions {
  std::size_t n_presses = 500;  ///< random presses wanted (the same presses at every noise level)
  double radius_m = 0.015;      ///< presses within this distance of the film centre (m)
  std::vector<double> noise_C;  ///< 1-sigma charge noise per electrode, one study row per level (C, each > 0)
  unsigned seed = 1;            ///< seed of the presses and of the noise
  std::size_t min_presses = 10; ///< fewer mapped presses than this within the radius: no rows
};

/// One noise level: medians over the presses that got a position (m), and speeds.
struct LookupAccuracyRow {
  double noise_C = 0;
  double median_error_force_known_m = 0;    ///< lookup given the true force
  double median_sigma_force_known_m = 0;    ///< its reported 1-sigma, sqrt(sigma_x² + sigma_y²)
  double median_error_force_unknown_m = 0;  ///< lookup with the force free: nearest reported answer
  double median_error_triangulation_m = 0;  ///< seed 001 eq. 6 triangulation given the true force
  int n_ambiguous = 0;                      ///< presses flagged ambiguous (force unknown)
  double lookup_per_cpu_s = 0;              ///< force-unknown locates per CPU second
  double triangulation_per_cpu_s = 0;       ///< triangulations per CPU second
};

struct LookupAccuracy {
  std::size_t n_presses = 0;  ///< presses drawn (< min_presses: `rows` is empty)
  double min_force_N = 0, max_force_N = 0;  ///< force range of the presses: the map's levels
  std::vector<LookupAccuracyRow> rows;      ///< one per noise level, in the order given
};

/// Runs the study on `map` (raw, uncalibrated lookup for truth and answers). Presses are uniform in
/// the square of half-width radius_m, kept when within the radius and inside the map; forces are
/// log-uniform between the map's smallest and largest level. `on_row`, when given, is called after
/// each noise level with the study so far. Throws pvdf::InputError when a noise level is not > 0.
LookupAccuracy lookup_accuracy(const ChargeMap& map, const LookupAccuracyOptions& options,
                               const std::function<void(const LookupAccuracy&)>& on_row = {});

}  // namespace pvdf::mapping
