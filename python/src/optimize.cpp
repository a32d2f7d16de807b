// The electrode layout search in Python: optimize_layouts, what `pvdfkit design --optimize` does
// (docs/design.md §7), with the command's defaults, checks and messages (mapping::check_optimize_options
// and check_optimize_maps, spelled as keyword arguments), and its JSON as OptimizeSummary.to_dict().
#include "arguments.hpp"
#include "bindings.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/mapping/design.hpp"
#include "pvdf/mapping/optimize.hpp"
#ifdef PVDF_PYTHON_WITH_FEM
#include "pvdf/mapping/atlas_provider.hpp"
#endif

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>

namespace pvdf::python {
namespace {

using pvdf::mapping::CountResult;
using pvdf::mapping::OrientedRect;

/// A search's summary with what its JSON names: the settings, the map source and the scene's source.
struct OptimizeResult {
  pvdf::mapping::OptimizeSummary summary;
  pvdf::mapping::OptimizeOptions options;
  pvdf::mapping::OptimizeMaps maps;
  std::string scene_source;
};

/// A layout as an (n, 5) array: x_m, y_m (centre), width_m, height_m (m), angle_rad (width axis from x, CCW).
py::array_t<double> layout_array(const std::vector<OrientedRect>& layout) {
  py::array_t<double> out({py::ssize_t(layout.size()), py::ssize_t(5)});
  double* p = out.mutable_data();
  for (const auto& r : layout) {
    *p++ = r.center_m[0];
    *p++ = r.center_m[1];
    *p++ = r.width_m;
    *p++ = r.height_m;
    *p++ = r.angle_rad;
  }
  return out;
}

py::object json_object(const nlohmann::json& j) { return py::module_::import("json").attr("loads")(j.dump()); }

/// One value per electrode count: `value(count)` where a layout was found, NaN elsewhere.
template <class F>
py::array_t<double> per_count(const OptimizeResult& r, F value) {
  std::vector<double> v;
  for (const CountResult& c : r.summary.counts) v.push_back(c.found ? value(c) : std::numeric_limits<double>::quiet_NaN());
  return to_array(v);
}

/// call(), its InputError's message put after `f` (the function's name, as the arguments' own messages).
template <class Call>
auto prefixed(const std::string& f, Call call) {
  try {
    return call();
  } catch (const pvdf::InputError& e) {
    throw pvdf::InputError(f + e.what());
  }
}

OptimizeResult run(py::object scene_arg, py::object atlas, py::object synthetic, py::object spacing_m,
                   py::object electrodes_min, py::object electrodes_max, py::object size_min_m, py::object size_max_m,
                   py::object square, py::object rotate, py::object min_gap_m, py::object clamp_margin_m, py::object seed,
                   py::object budget, py::object search_stride, py::object force_N, py::object min_force_N,
                   py::object max_force_N, py::object noise_C, py::object target_m, py::object force_known,
                   py::object adc_bits, py::object full_scale_C) {
  const std::string f = "optimize_layouts: ";
  // The library's messages name each option as this function's keyword ("budget = 0"), after the
  // function's name (prefixed).
  const pvdf::mapping::OptionNaming naming = [](const std::string& key, const std::string& value) {
    return key + " = " + (value.empty() ? std::string("True") : value);
  };
  // Step 1: every argument checked before the search, by the command's rules.
  OptimizeResult r;
  r.maps.atlas_path = atlas.is_none() ? std::string() : arg::path(atlas, f + "atlas");
  r.maps.synthetic = arg::flag(synthetic, f + "synthetic");
  if (!spacing_m.is_none()) {
    r.maps.spacing_m = arg::number_in(spacing_m, f + "spacing_m", 1e-4, 0.02, "m (the range of synthetic-map)");
  }
  prefixed(f, [&] { pvdf::mapping::check_optimize_maps(r.maps, naming); });
  pvdf::mapping::OptimizeOptions& o = r.options;
  o.design = design_options_arg(force_N, min_force_N, max_force_N, noise_C, target_m, force_known, adc_bits, full_scale_C, f);
  const auto whole = [&](py::object value, const char* key, long long lo, long long hi) {
    return arg::integer_in(value, f + key, lo, hi);
  };
  const long long int_max = std::numeric_limits<int>::max();
  o.electrodes_min = int(whole(electrodes_min, "electrodes_min", -int_max, int_max));
  o.electrodes_max = int(whole(electrodes_max, "electrodes_max", -int_max, int_max));
  o.size_min_m = arg::number(size_min_m, f + "size_min_m", "(m), e.g. 0.001");
  o.size_max_m = arg::number(size_max_m, f + "size_max_m", "(m), e.g. 0.004");
  o.square = arg::flag(square, f + "square");
  o.rotate = arg::flag(rotate, f + "rotate");
  o.min_gap_m = arg::number(min_gap_m, f + "min_gap_m", "(m), e.g. 0.0005");
  o.clamp_margin_m = arg::number(clamp_margin_m, f + "clamp_margin_m", "(m), e.g. 0.001");
  o.seed = std::uint64_t(whole(seed, "seed", 0, std::numeric_limits<long long>::max()));
  o.budget = std::size_t(whole(budget, "budget", 0, std::numeric_limits<long long>::max()));
  o.search_stride = int(whole(search_stride, "search_stride", -int_max, int_max));
  o.naming = naming;
  prefixed(f, [&] { pvdf::mapping::check_optimize_options(o); });
  const pvdf::Scene scene = arg::scene(scene_arg, f + "scene");
  r.scene_source = scene.source;

  // Step 2: the maps' source, then the search (the GIL released: it calls no Python).
  pvdf::mapping::MapProvider provider;
  if (r.maps.synthetic) {
    provider = pvdf::mapping::synthetic_map_provider(r.maps.spacing_m, o.design.force_N);
  } else {
#ifdef PVDF_PYTHON_WITH_FEM
    provider = prefixed(f, [&] { return pvdf::mapping::atlas_map_provider(r.maps.atlas_path, scene, o); });
#else
    throw pvdf::InputError(f + "atlas: this pvdfkit was built without the FEM (PVDF_WITH_FEM=OFF) and cannot read "
                           "atlases; give synthetic=True for a preview");
#endif
  }
  py::gil_scoped_release release;
  r.summary = prefixed(f, [&] { return pvdf::mapping::optimize_layouts(scene.original, scene.source, provider, o); });
  return r;
}

}  // namespace

void bind_optimize(py::module_& m) {
  py::class_<OptimizeResult>(m, "OptimizeSummary", R"doc(What a layout search found (pvdfkit.optimize_layouts).

``to_dict()`` is the object ``pvdfkit design --optimize --json`` prints, key for key (without the
command's ``files`` and ``verify``). Per electrode count, ascending: ``n_electrodes``, ``found``,
``usable_fraction``, ``coverage``, ``median_sigma_pos_m`` (m) as arrays (NaN where no layout met
the constraints), ``layouts`` (each an (n, 5) array ``[x_m, y_m, width_m, height_m, angle_rad]`` or
None), ``scenes`` (the winners as scene dicts) and ``summaries`` (DesignSummary on the full map);
``best_*`` the best count's.)doc")
      .def("to_dict", [](const OptimizeResult& r) {
        return json_object(pvdf::mapping::optimize_summary_json(r.summary, r.options, r.maps, r.scene_source));
      }, "the object `pvdfkit design --optimize --json` prints, as a dict (without its files and verify)")
      .def_property_readonly("n_electrodes", [](const OptimizeResult& r) {
        std::vector<std::int64_t> v;
        for (const CountResult& c : r.summary.counts) v.push_back(c.n_electrodes);
        return to_array(v);
      }, "the electrode counts searched, ascending")
      .def_property_readonly("found", [](const OptimizeResult& r) {
        std::vector<std::uint8_t> v;
        for (const CountResult& c : r.summary.counts) v.push_back(c.found ? 1 : 0);
        return to_array(v).attr("astype")("bool");
      }, "per count: a layout met the constraints")
      .def_property_readonly("usable_fraction", [](const OptimizeResult& r) {
        return per_count(r, [](const CountResult& c) { return c.summary.usable_fraction; });
      }, "per count: the winner's usable fraction on the full map (0..1, the figure of merit)")
      .def_property_readonly("coverage", [](const OptimizeResult& r) {
        return per_count(r, [](const CountResult& c) { return c.summary.coverage; });
      }, "per count: the winner's coverage (sigma_pos <= target) (0..1)")
      .def_property_readonly("median_sigma_pos_m", [](const OptimizeResult& r) {
        return per_count(r, [](const CountResult& c) { return c.summary.median_sigma_pos_m; });
      }, "per count: the winner's median position bound (m; inf where unbounded)")
      .def_property_readonly("layouts", [](const OptimizeResult& r) {
        py::list out;
        for (const CountResult& c : r.summary.counts) out.append(c.found ? py::object(layout_array(c.layout)) : py::none());
        return out;
      }, "per count: the winner as an (n, 5) array [x_m, y_m, width_m, height_m, angle_rad], or None")
      .def_property_readonly("scenes", [](const OptimizeResult& r) {
        py::list out;
        for (const CountResult& c : r.summary.counts) out.append(c.found ? json_object(c.scene) : py::none());
        return out;
      }, "per count: the scene with the winner's electrodes (a dict load_scene reads), or None")
      .def_property_readonly("summaries", [](const OptimizeResult& r) {
        py::list out;
        for (const CountResult& c : r.summary.counts) out.append(c.found ? py::cast(c.summary) : py::none());
        return out;
      }, "per count: the winner's DesignSummary on the full map (maps as arrays), or None")
      .def_property_readonly("reference", [](const OptimizeResult& r) {
        return r.summary.reference_evaluated ? py::cast(r.summary.reference) : py::none();
      }, "the scene's own layout evaluated on the full map (DesignSummary), or None")
      .def_property_readonly("best_n_electrodes", [](const OptimizeResult& r) -> py::object {
        const auto& s = r.summary;
        if (s.counts.empty() || !s.counts[s.best].found) return py::none();
        return py::int_(s.counts[s.best].n_electrodes);
      }, "the electrode count of the best layout found (mapping::ranks_before), or None")
      .def_property_readonly("best_layout", [](const OptimizeResult& r) -> py::object {
        const auto& s = r.summary;
        if (s.counts.empty() || !s.counts[s.best].found) return py::none();
        return layout_array(s.counts[s.best].layout);
      }, "the best layout found as an (n, 5) array [x_m, y_m, width_m, height_m, angle_rad], or None")
      .def_property_readonly("best_scene", [](const OptimizeResult& r) -> py::object {
        const auto& s = r.summary;
        if (s.counts.empty() || !s.counts[s.best].found) return py::none();
        return json_object(s.counts[s.best].scene);
      }, "the scene with the best layout's electrodes (a dict), or None")
      .def_property_readonly("seconds", [](const OptimizeResult& r) { return r.summary.seconds; }, "wall time (s)")
      .def("__repr__", [](const OptimizeResult& r) {
        std::string text = "<OptimizeSummary " + std::to_string(r.summary.counts.size()) + " electrode counts";
        const auto& s = r.summary;
        if (!s.counts.empty() && s.counts[s.best].found) text += ", best " + std::to_string(s.counts[s.best].n_electrodes);
        return text + ">";
      });

  m.def("optimize_layouts", &run, py::arg("scene"), py::arg("atlas") = py::none(), py::arg("synthetic") = false,
        py::arg("spacing_m") = py::none(), py::arg("electrodes_min") = 3, py::arg("electrodes_max") = 6,
        py::arg("size_min_m") = 0.001, py::arg("size_max_m") = 0.004, py::arg("square") = false, py::arg("rotate") = true,
        py::arg("min_gap_m") = 0.0005, py::arg("clamp_margin_m") = 0.001, py::arg("seed") = 1, py::arg("budget") = 300,
        py::arg("search_stride") = 1, py::arg("force_N") = 1.0, py::arg("min_force_N") = 0.25,
        py::arg("max_force_N") = 4.0, py::arg("noise_C") = 5e-14, py::arg("target_m") = 0.5e-3,
        py::arg("force_known") = false, py::arg("adc_bits") = 12, py::arg("full_scale_C") = 0.0,
        R"doc(Searches electrode layouts on the scene's film (what ``pvdfkit design --optimize`` does, docs/design.md
section 7, with its defaults, checks and messages): for each count in [electrodes_min, electrodes_max]
(3..16) the rectangles (centres, sides in [size_min_m, size_max_m] m, angles unless rotate=False;
squares with square=True) that rank best by ``design``'s rule (usable area, then coverage, then the
median sigma_pos), at least min_gap_m apart and clamp_margin_m inside the clamp (m), by differential
evolution with `budget` evaluations per count (1..1e6) from `seed` (>= 0; equal seeds, equal results).
Maps: atlas (a file of ``pvdfkit atlas`` / make_atlas fitting the scene's film) or synthetic=True (the
analytic stand-in at spacing_m, default 0.001 m); search_stride >= 1 evaluates every N-th node during
the search. force_N, min/max_force_N, noise_C (default 5e-14 C, the command's), target_m, force_known,
adc_bits, full_scale_C: as pvdfkit.design. Returns an OptimizeSummary; bad input raises InputError.)doc");
}

}  // namespace pvdf::python
