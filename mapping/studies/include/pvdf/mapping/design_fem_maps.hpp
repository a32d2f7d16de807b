// FEM maps as the map source of a design study (design_study.hpp): each candidate's charge map by
// the map engine (generate_map) at one force level, written to a folder, with a progress bar and
// ETA per phase on stderr. Target pvdf::mapping_design_fem, built only with the FEM.
#pragma once

#include "pvdf/mapping/design_study.hpp"

#include <functional>
#include <string>
#include <vector>

namespace pvdf::mapping {

/// Settings of the FEM maps of a design study (public members with defaults).
struct DesignFemMaps {
  /// The one force level of each map (N); other forces follow by the F^(2/3) law (docs/design.md §1).
  double force_N = 1.0;
  /// Requested relative charge error; 0 = each scene's model.tolerance.
  double tolerance = 0;
  /// Worker threads per map; 0 = all cores.
  int threads = 0;
  /// Where each map is written, as `<label>_<spacing>mm.h5` (created when missing).
  std::string maps_dir = "design-out/maps";
  /// No progress bar and no per-map line on stderr.
  bool quiet = false;
  /// The progress bar's label; empty: "design: <phase> maps, positions".
  std::string progress_label;
  /// Where the resident memory after each block of positions is appended (also when quiet), or null.
  std::vector<MemorySample>* memory = nullptr;
  /// Told of map points that did not converge (left out of the map); may be empty.
  std::function<void(const std::string&)> warn;
};

/// The FEM map source: each phase's progress total is its maps' planned positions
/// (mapping::planned_positions), each map is generated, written to `maps_dir` and reported in one
/// line on stderr (solves, time, model, estimated charge error, file). Sets `map_source` "fem" and
/// `map_file`. Throws pvdf::InputError like generate_map.
DesignMapSource fem_design_maps(const DesignFemMaps& settings);

}  // namespace pvdf::mapping
