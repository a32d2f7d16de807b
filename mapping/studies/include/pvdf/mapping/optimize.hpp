// Electrode layout search (`pvdfkit design --optimize`, docs/design.md §7): for each electrode
// count in a range, the rectangles (centres, sizes, angles) that rank best by the design objective
// (mapping::ranks_before: usable area, then coverage, then median σ_pos) under no-overlap, gap and
// clamp-margin constraints, found by differential evolution. The charge map of a candidate comes
// from a caller's function (an atlas in the app, the synthetic stand-in in tests): no deal.II here.
#pragma once

#include "pvdf/core/scene.hpp"
#include "pvdf/mapping/design.hpp"
#include "pvdf/mapping/differential_evolution.hpp"
#include "pvdf/mapping/layout_geometry.hpp"
#include "pvdf/mapping/map.hpp"

#include <nlohmann/json.hpp>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace pvdf::mapping {

/// The charge map of a candidate layout (a scene whose electrodes are the candidate's).
using MapProvider = std::function<ChargeMap(const pvdf::Scene&)>;


/// Settings of a layout search (public members with defaults).
struct OptimizeOptions {
  int electrodes_min = 3, electrodes_max = 6;  ///< electrode counts searched (≥ 3: a press has 3 unknowns)
  double size_min_m = 0.001;                   ///< smallest electrode side (m)
  double size_max_m = 0.004;                   ///< largest electrode side (m)
  bool square = false;                         ///< w = h (else w and h independent in the bounds)
  bool rotate = true;                          ///< angles searched (else every electrode at 0)
  double min_gap_m = 0.0005;                   ///< smallest distance between two electrodes (m)
  double clamp_margin_m = 0.001;               ///< every corner at least this far inside the clamp outline (m)
  std::uint64_t seed = 1;                      ///< equal seeds and inputs give equal results
  std::size_t budget = 300;                    ///< objective evaluations (maps + analyses) per electrode count
  std::size_t population = 0;                  ///< DE population; 0 = DifferentialEvolutionOptions' default
  /// During the search, evaluate on every search_stride-th grid node in x and y (a coarser map from
  /// the same nodes); 1 = the full map. The winners are always re-evaluated on the full map.
  int search_stride = 1;
  DesignOptions design;                        ///< the objective's settings (force, noise, ADC, target)
  /// Keep every evaluated layout in CountResult::evaluated (for tests and plots).
  bool keep_evaluated = false;
  /// Called after each evaluation: (count index, counts, evaluations done in this count, budget).
  std::function<void(std::size_t, std::size_t, std::size_t, std::size_t)> progress;
  /// How the messages of check_optimize_options and optimize_layouts name an option (see OptionNaming).
  OptionNaming naming;
};

/// The one check of a search's settings, for the command and the Python package alike: throws
/// InputError naming the option (as options.naming spells it), its value, the rule and the fix.
void check_optimize_options(const OptimizeOptions& options);

/// Where a search's charge maps come from: a charge-density atlas file (docs/atlas.md), or the
/// synthetic stand-in (a preview).
struct OptimizeMaps {
  std::string atlas_path;     ///< the atlas file; empty = none
  bool synthetic = false;     ///< the analytic stand-in (synthetic_map_for_scene) instead
  double spacing_m = 0;       ///< synthetic maps' grid spacing (m); 0 = 0.001. The atlas fixes its own.
  double tolerance = 0;       ///< requested charge error; 0 = none given (the atlas fixes its own)
  std::string kind() const { return synthetic ? "synthetic" : "atlas"; }
};

/// Throws InputError (options named by `naming`, see OptionNaming) unless exactly one map source is
/// given, the atlas file exists, and neither a spacing nor a tolerance is given with an atlas (the
/// atlas fixes both).
void check_optimize_maps(const OptimizeMaps& maps, const OptionNaming& naming = {});

/// The synthetic maps of a search: synthetic_map_for_scene at `spacing_m` (0 = 0.001 m), one force
/// level `force_N`, the command's noise 5e-14 C on every channel.
MapProvider synthetic_map_provider(double spacing_m, double force_N);

/// The best layout found for one electrode count.
struct CountResult {
  int n_electrodes = 0;
  bool found = false;                          ///< a layout met the constraints (else the rest is empty)
  DifferentialEvolutionStatus status = DifferentialEvolutionStatus::budget_spent;
  std::vector<OrientedRect> layout;            ///< the winner's rectangles
  nlohmann::json scene;                        ///< the reference scene with the winner's electrodes
  DesignSummary summary;                       ///< the winner evaluated on the full map
  double search_usable_fraction = 0;           ///< its usable fraction during the search (search_stride grid)
  std::size_t n_evaluations = 0, n_trials = 0, n_generations = 0, n_rejected = 0;
  double seconds = 0;                          ///< wall time of this count (search + full evaluation)
  std::vector<std::vector<OrientedRect>> evaluated;  ///< every evaluated layout (keep_evaluated only)
};

/// What a search found.
struct OptimizeSummary {
  std::vector<CountResult> counts;             ///< one per electrode count, ascending
  bool reference_evaluated = false;            ///< the reference scene's own layout could be evaluated
  DesignSummary reference;                     ///< it, on the full map
  std::size_t best = 0;                        ///< index into counts of the best found layout (ranks_before)
  double seconds = 0;
};

/// The layout of rectangles as the scene's electrodes (names E1, E2, …; angle_deg), other keys kept.
nlohmann::json scene_with_layout(const nlohmann::json& scene, const std::vector<OrientedRect>& layout);

/// The map on every stride-th node in x and y (stride 1: the map itself); provenance and
/// electrodes kept. Used for cheap evaluations during a search.
ChargeMap coarsen_map(const ChargeMap& map, int stride);

/// Searches layouts of each count in [electrodes_min, electrodes_max] on the film of `scene`
/// (JSON; its electrodes are the starting layout when their count and shapes fit).
/// @param[in] scene     reference scene (JSON), `source` names it in messages
/// @param[in] provider  the charge map of a candidate scene
/// Throws InputError for bad options (check_optimize_options) or an invalid reference scene.
OptimizeSummary optimize_layouts(const nlohmann::json& scene, const std::string& source, const MapProvider& provider,
                                 const OptimizeOptions& options);

/// The summary as JSON, the one form of `pvdfkit design --optimize --json` (which adds its `files` and
/// `verify`) and of the Python OptimizeSummary.to_dict(): settings, the reference layout, per count
/// layout, figures, evaluations and seconds; the best count; `scene` (its source), `maps` and `atlas`.
nlohmann::json optimize_summary_json(const OptimizeSummary& summary, const OptimizeOptions& options,
                                     const OptimizeMaps& maps, const std::string& scene_source);

}  // namespace pvdf::mapping
