// map_from_atlas and check_atlas_fits_scene (pvdf/mapping/atlas.hpp, docs/atlas.md §4): a layout's
// charge map read from the atlas, no solve. The electrodes are thin metal films that do not enter
// the mechanics, so every press's charge density q is the atlas's; each electrode's charge is the
// integral of q over its outline.
#include "pvdf/mapping/atlas.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/mapping/generate.hpp"
#include "pvdf/version.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace pvdf::mapping {

void fill_film_provenance(ChargeAtlas& atlas, const pvdf::Scene& scene);  // atlas_generate.cpp

void check_atlas_fits_scene(const ChargeAtlas& atlas, const std::string& atlas_path, const pvdf::Scene& scene) {
  ChargeAtlas mine;
  fill_film_provenance(mine, scene);
  auto refuse = [&](const std::string& what, const std::string& atlas_value, const std::string& scene_value) {
    throw pvdf::InputError(atlas_path + ": /provenance " + what + " = " + atlas_value + " differs from " + scene.source +
                           "'s " + scene_value + "; make an atlas of this film with `pvdfkit atlas " + scene.source + "`");
  };
  std::ostringstream ta, ts;
  ta.precision(17);
  ts.precision(17);
  ta << atlas.thickness_m;
  ts << mine.thickness_m;
  if (!(std::abs(atlas.thickness_m - mine.thickness_m) <= 1e-12 * mine.thickness_m)) refuse("thickness_m", ta.str(), ts.str());
  if (atlas.film_json != mine.film_json) refuse("film", atlas.film_json, mine.film_json);
  if (atlas.material_json != mine.material_json) refuse("material", atlas.material_json, mine.material_json);
  if (atlas.probe_json != mine.probe_json) refuse("probe", atlas.probe_json, mine.probe_json);
}

ChargeMap map_from_atlas(const ChargeAtlas& atlas, const pvdf::Scene& scene, const std::string& atlas_path) {
  check_atlas_fits_scene(atlas, atlas_path, scene);
  if (scene.electrodes.empty()) throw pvdf::InputError(scene.source + ": no electrodes; a map needs at least one");
  ChargeMap map;
  map.scene_json = scene.original.is_null() ? pvdf::scene_to_json(scene).dump() : scene.original.dump();
  map.pvdfkit_version = pvdf::version_string;
  map.model = atlas.model;
  map.tolerance = atlas.tolerance;
  map.rim_margin_m = atlas.rim_margin_m;
  map.description = "pvdfkit map --atlas " + atlas_path + " (charge-density atlas, docs/atlas.md)";
  map.x_m = atlas.x_m;
  map.y_m = atlas.y_m;
  map.mask = atlas.mask;
  map.forces_N = atlas.forces_N;
  const std::size_t ne = scene.electrodes.size(), nc = atlas.n_cells();
  std::vector<pvdf::fem::AtlasElectrode> readings;
  for (const auto& e : scene.electrodes) {
    map.electrode_names.push_back(e.name);
    map.electrode_centers_m.push_back(e.centroid_m());
    const std::vector<pvdf::Point2> outline = e.outline(64);
    // The atlas serves electrodes at least keep_out_m inside the clamp (its estimates speak for that
    // region only): every vertex, and points along every edge, must lie there.
    if (atlas.keep_out_m > 0) {
      const auto& film = scene.membrane.outline;
      for (std::size_t v = 0; v < outline.size(); ++v) {
        const auto& a = outline[v];
        const auto& b = outline[(v + 1) % outline.size()];
        for (int s = 0; s < 16; ++s) {
          const double t = s / 16.0;
          const pvdf::Point2 p{a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])};
          if (!film.contains(p, atlas.keep_out_m * (1 - 1e-9))) {
            std::ostringstream msg;
            msg << scene.source << ": electrode " << e.name << " reaches within " << atlas.keep_out_m * 1e3
                << " mm of the clamp (at (" << p[0] << ", " << p[1] << ") m), the atlas's keep-out band (" << atlas_path
                << ", keep_out_m); move it inward or make an atlas with a smaller --keep-out-m";
            throw pvdf::InputError(msg.str());
          }
        }
      }
    }
    readings.push_back(pvdf::fem::atlas_electrode(atlas.grid, atlas.geometry, outline));
    double twice_area = 0;  // of the outline integrated (a circle's 64-gon, not pi r^2)
    for (std::size_t v = 0; v < outline.size(); ++v) {
      const auto& a = outline[v];
      const auto& b = outline[(v + 1) % outline.size()];
      twice_area += a[0] * b[1] - b[0] * a[1];
    }
    const double area = std::abs(twice_area) / 2, read = readings.back().area_m2;
    if (std::abs(read - area) > 1e-6 * area + 1e-12) {  // part of the outline lies beyond the atlas's cells
      throw pvdf::InputError(scene.source + ": electrode " + e.name + " reaches beyond the film (" +
                             std::to_string(read / area * 100) + " % of its area within it); move it inside the film");
    }
  }
  map.noise_C.assign(ne, 0.05e-12);
  map.allocate();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::fill(map.charge_C.begin(), map.charge_C.end(), nan);
  map.estimated_charge_error_C.assign(map.charge_C.size(), nan);
  double worst = 0;
  std::vector<double> q(ne), err(ne);
  for (std::size_t f = 0; f < map.nf(); ++f) {
    for (std::size_t j = 0; j < map.ny(); ++j) {
      for (std::size_t i = 0; i < map.nx(); ++i) {
        const std::size_t p = atlas.point(f, j, i);
        map.status[p] = atlas.status[p];
        map.deflection_at_load_m[p] = atlas.deflection_at_load_m[p];
        if (atlas.status[p] != std::uint8_t(PointStatus::ok)) continue;
        // The press's FE error, relative to its largest charge (the reference electrodes' estimate,
        // max_r err_r / max_r |Q_r|), applied to the layout's largest charge at that press.
        const double relative_fe = atlas.estimated_relative_error[p];
        const double* m = &atlas.moments[p * nc * 3];
        double scale = 0, largest_error = 0;
        for (std::size_t k = 0; k < ne; ++k) {
          pvdf::fem::integrate_atlas_electrode(readings[k], m, q[k], err[k]);
          scale = std::max(scale, std::abs(q[k]));
        }
        const double fe_error = std::isfinite(relative_fe) ? relative_fe * scale : nan;
        for (std::size_t k = 0; k < ne; ++k) {
          map.charge_C[map.charge_index(f, j, i, k)] = q[k];
          map.estimated_charge_error_C[map.charge_index(f, j, i, k)] = fe_error + err[k];
          largest_error = std::max(largest_error, fe_error + err[k]);
        }
        // A press without an FE estimate leaves the map's largest error unknown (NaN), not smaller.
        if (!std::isfinite(fe_error)) worst = nan;
        if (scale > 0 && !std::isnan(worst)) worst = std::max(worst, largest_error / scale);
      }
    }
  }
  map.estimated_relative_error = worst;
  validate(map, "map from " + atlas_path);
  return map;
}

std::vector<std::uint8_t> atlas_map_provenance(const ChargeMap& map, std::size_t* n_flagged) {
  const std::size_t n_points = map.nf() * map.ny() * map.nx(), ne = map.ne();
  std::vector<std::uint8_t> flags(n_points, 0);
  std::size_t n = 0;
  if (map.estimated_charge_error_C.size() == map.charge_C.size()) {
    for (std::size_t p = 0; p < n_points; ++p) {
      if (map.status[p] != std::uint8_t(PointStatus::ok)) continue;
      double largest_charge = 0, largest_error = 0;
      for (std::size_t k = 0; k < ne; ++k) {
        largest_charge = std::max(largest_charge, std::abs(map.charge_C[p * ne + k]));
        const double e = map.estimated_charge_error_C[p * ne + k];
        largest_error = std::isnan(e) || std::isnan(largest_error) ? e + largest_error : std::max(largest_error, e);
      }
      // NaN errors (no estimate) are flagged too: the tolerance is then not shown to be met.
      if (!(largest_error <= map.tolerance * largest_charge)) {
        flags[p] |= provenance::tolerance_not_met;
        ++n;
      }
    }
  }
  if (n_flagged != nullptr) *n_flagged = n;
  return flags;
}

}  // namespace pvdf::mapping
