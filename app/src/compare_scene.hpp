// `pvdfkit compare SCENE measured.csv` (FEM solves at the measured presses); called from cmd_compare.cpp.
#pragma once

#include "map_checks.hpp"

#include <string>
#include <vector>

namespace pvdf::app {

/// Compares measured presses with direct FEM solves of the scene at the same positions and
/// forces (warm-started probe sweep, no interpolation). Same outputs as `compare MAP`, plus the
/// deflection when the CSV has `deflection_m`; the comparison is mapping::compare_with_fem (the
/// charge floor and statistics of compare_with_map: comparison_floor_C, summarize_comparison).
/// Progress on stderr unless `quiet`. Returns the exit code.
int run_compare_scene(const std::string& scene_path, const std::string& measured_path, bool json,
                      const std::string& plot_path, const std::string& report_path, double min_charge_C = 0,
                      bool quiet = false);

}  // namespace pvdf::app
