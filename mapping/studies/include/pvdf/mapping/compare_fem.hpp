// Measured presses against direct FEM solves of a scene at the same presses (`pvdfkit compare SCENE
// measured.csv`): the record of compare_with_map, with the FEM's charges where the map's would be.
// Target pvdf::mapping_fem_compare (needs pvdf::fit, so only where the solver is built).
#pragma once

#include "pvdf/core/scene.hpp"
#include "pvdf/fem/probe_sweep.hpp"
#include "pvdf/mapping/analysis.hpp"

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace pvdf::mapping {

struct FemComparison {
  std::vector<std::string> electrode_names;   ///< the scene's, in its order
  Comparison comparison;                      ///< map_charge_C holds the FEM charges (C); every press in_map
  std::vector<double> deflection_measured_m;  ///< [press]; NaN where the CSV has no deflection_m
  std::vector<double> deflection_fem_m;       ///< [press]
  pvdf::fem::SweepSetup setup;                ///< the sweep's reference setup (model, estimated errors)
};

/// Reads `measured_path` (pvdf::fit::read_measured, the one measured-CSV reader), refuses a press
/// closer than a probe radius to the rim (InputError naming the file and line), solves the scene at
/// every press (warm-started probe sweep, unit gains) and compares: the charge floor is
/// comparison_floor_C with `min_charge_C`, else 3 × default_noise_C per electrode; the statistics
/// summarize_comparison's. `progress(done, total)` follows the solves when given.
FemComparison compare_with_fem(const pvdf::Scene& scene, const std::string& measured_path, double min_charge_C = 0,
                               const std::function<void(std::size_t, std::size_t)>& progress = {});

}  // namespace pvdf::mapping
