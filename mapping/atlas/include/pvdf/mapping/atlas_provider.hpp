// The charge maps of a layout search (`design --optimize`, pvdf/mapping/optimize.hpp) read from a
// charge-density atlas: for the command and the Python package alike.
#pragma once

#include "pvdf/core/scene.hpp"
#include "pvdf/mapping/atlas.hpp"
#include "pvdf/mapping/optimize.hpp"

#include <memory>
#include <string>

namespace pvdf::mapping {

/// Reads the atlas at `atlas_path`, checks that it fits `scene` (check_atlas_fits_scene: film,
/// thickness, material, probe) and that the search's clamp margin (options.clamp_margin_m, named
/// as options.naming spells it) is not below the atlas's keep-out band, where it serves no
/// electrode (InputError before the search starts), and returns the provider of
/// optimize_layouts: map_from_atlas of each candidate scene. `atlas` (optional) receives the
/// atlas read (its grid and tolerance).
MapProvider atlas_map_provider(const std::string& atlas_path, const pvdf::Scene& scene, const OptimizeOptions& options,
                               std::shared_ptr<const ChargeAtlas>* atlas = nullptr);

}  // namespace pvdf::mapping
