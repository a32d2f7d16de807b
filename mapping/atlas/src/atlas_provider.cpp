// atlas_map_provider (pvdf/mapping/atlas_provider.hpp): an atlas as the map source of a layout search.
#include "pvdf/mapping/atlas_provider.hpp"

#include "pvdf/core/error.hpp"

#include <cstdio>

namespace pvdf::mapping {

MapProvider atlas_map_provider(const std::string& atlas_path, const pvdf::Scene& scene, const OptimizeOptions& options,
                               std::shared_ptr<const ChargeAtlas>* atlas_out) {
  auto atlas = std::make_shared<const ChargeAtlas>(read_atlas(atlas_path));
  check_atlas_fits_scene(*atlas, atlas_path, scene);
  // Without this, every candidate reaching into the band would be refused by map_from_atlas one by
  // one and scored as the worst, and the search would go on in silence.
  if (options.clamp_margin_m < atlas->keep_out_m * (1 - 1e-9)) {
    char value[32], band[32];
    std::snprintf(value, sizeof value, "%g", options.clamp_margin_m);
    std::snprintf(band, sizeof band, "%g", atlas->keep_out_m);
    const std::string margin = options.naming ? options.naming("clamp_margin_m", value) : "clamp_margin_m = " + std::string(value);
    throw InputError(margin + " m is inside the keep-out band of " + atlas_path + " (" + band +
                     " m from the clamp, where the atlas serves no electrode); give at least " + band +
                     " m, or make an atlas with a narrower --keep-out-m");
  }
  if (atlas_out != nullptr) *atlas_out = atlas;
  return [atlas, atlas_path](const pvdf::Scene& s) { return map_from_atlas(*atlas, s, atlas_path); };
}

}  // namespace pvdf::mapping
