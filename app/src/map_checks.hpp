// Checks shared by `compare` and `rays`, built with or without the FEM modules.
#pragma once

#include "pvdf/mapping/analysis.hpp"
#include "pvdf/mapping/map.hpp"

#include <string>
#include <vector>

namespace pvdf::app {

/// True when `path` holds a JSON scene (first non-blank byte '{') rather than an HDF5 map.
bool is_scene_file(const std::string& path);

/// Warns (stderr) about every compared press of mapping::presses_map_cannot_resolve (closer to an
/// electrode centre than twice the map's spacing). Returns the number of such presses.
int warn_if_map_too_coarse(const pvdf::mapping::ChargeMap& map, const std::vector<pvdf::mapping::MeasuredPress>& presses);

/// Refuses (InputError naming the CSV and its line) a measured press no bench produces: a force
/// outside (0, 1e4] N (mN typed for N?) or a charge beyond 1e-6 C (pC typed for C?). Run before
/// any work on the presses (compare, calibrate).
void check_measured_plausible(const std::vector<pvdf::mapping::MeasuredPress>& presses, const std::string& source,
                              const std::vector<std::string>& electrode_names);

/// The charges of --charges-C (locate, isocharge), one per electrode in the map's order, refused
/// (naming that order) when their count differs, and refused with the likely cause when they are
/// a thousand times larger than any charge of the map (pC typed where C is meant).
std::vector<double> parse_charges(const std::string& text, const pvdf::mapping::ChargeMap& map);

}  // namespace pvdf::app
