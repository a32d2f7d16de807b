// `pvdfkit compare SCENE measured.csv` (FEM solves at the measured presses); called from cmd_compare.cpp.
#pragma once

#include "map_checks.hpp"

#include <string>
#include <vector>

namespace pvdf::app {

/// Compares measured presses with direct FEM solves of the scene at the same positions and
/// forces (warm-started probe sweep, no interpolation). Same outputs as `compare MAP`, plus the
/// deflection when the CSV has `deflection_m`; the same charge floor and statistics
/// (mapping::comparison_floor_C with the default channel noise, mapping::summarize_comparison).
/// Progress on stderr unless `quiet`. Returns the exit code.
int run_compare_scene(const std::string& scene_path, const std::string& measured_path, bool json,
                      const std::string& plot_path, const std::string& report_path, double min_charge_C = 0,
                      bool quiet = false);

}  // namespace pvdf::app
