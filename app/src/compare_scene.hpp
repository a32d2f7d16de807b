// `pvdfkit compare SCENE measured.csv` (FEM solves at the measured presses) and the coarse-map
// warning of `compare MAP measured.csv`; called from cmd_compare.cpp.
#pragma once

#include "pvdf/mapping/analysis.hpp"
#include "pvdf/mapping/map.hpp"

#include <string>
#include <vector>

namespace pvdf::app {

/// True when `path` holds a JSON scene (first non-blank byte '{') rather than an HDF5 map.
bool is_scene_file(const std::string& path);

/// Compares measured presses with direct FEM solves of the scene at the same positions and
/// forces (warm-started probe sweep, no interpolation). Same outputs as `compare MAP`, plus the
/// deflection when the CSV has `deflection_m`. Returns the exit code.
int run_compare_scene(const std::string& scene_path, const std::string& measured_path, bool json,
                      const std::string& plot_path, const std::string& report_path);

/// Warns (stderr) about every compared press closer to an electrode centre than twice the map's
/// spacing, where the map's interpolation error alone reaches tens of % (docs/fem-vs-experiment.md §4).
/// Returns the number of such presses.
int warn_if_map_too_coarse(const pvdf::mapping::ChargeMap& map, const std::vector<pvdf::mapping::MeasuredPress>& presses);

}  // namespace pvdf::app
