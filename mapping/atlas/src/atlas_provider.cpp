// atlas_map_provider (pvdf/mapping/atlas_provider.hpp): an atlas as the map source of a layout search.
#include "pvdf/mapping/atlas_provider.hpp"

namespace pvdf::mapping {

MapProvider atlas_map_provider(const std::string& atlas_path, const pvdf::Scene& scene,
                               std::shared_ptr<const ChargeAtlas>* atlas_out) {
  auto atlas = std::make_shared<const ChargeAtlas>(read_atlas(atlas_path));
  check_atlas_fits_scene(*atlas, atlas_path, scene);
  if (atlas_out != nullptr) *atlas_out = atlas;
  return [atlas, atlas_path](const pvdf::Scene& s) { return map_from_atlas(*atlas, s, atlas_path); };
}

}  // namespace pvdf::mapping
