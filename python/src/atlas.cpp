// The charge-density atlas in Python (docs/atlas.md): make_atlas (what `pvdfkit atlas` does) and
// map_from_atlas (what `pvdfkit map SCENE --atlas FILE` does), same checks and messages.
#include "arguments.hpp"
#include "bindings.hpp"
#include "pvdf/core/io.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/mapping/atlas.hpp"
#include "pvdf/mapping/atlas_report.hpp"

namespace pvdf::python {

void bind_atlas(py::module_& m) {
  m.def("make_atlas", [](py::object scene_arg, py::object path_arg, py::object spacing_m, py::object forces_N,
                         py::object tolerance, py::object cell_m, py::object threads, py::object n_setup_checks,
                         py::object keep_out_m) {
          // Each argument by the rule of `pvdfkit atlas`'s flag (app/src/cmd_atlas.cpp).
          const std::string f = "make_atlas: ";
          const pvdf::Scene scene = arg::scene(scene_arg, f + "scene");
          const std::string path = arg::path(path_arg, f + "path");
          pvdf::check_output_path(path, f + "path");  // before the sweep, not after it
          pvdf::mapping::AtlasOptions o;
          o.spacing_m = arg::number_in(spacing_m, f + "spacing_m", 1e-5, 0.1, "m (the unit is metres: 2 mm is 0.002)");
          o.forces_N = force_levels(forces_N, f + "forces_N", scene);
          o.tolerance = tolerance_arg(tolerance, f + "tolerance").value_or(0.0);  // 0: the scene's model.tolerance
          o.cell_m = arg::number_in(cell_m, f + "cell_m", 1e-5, 0.05, "m (1 mm is 0.001)");
          o.threads = int(arg::integer_in(threads, f + "threads", 0, 1024, "(0 = all cores)"));
          o.n_setup_checks = int(arg::integer_in(n_setup_checks, f + "n_setup_checks", 0, 3, "(as pvdfkit atlas --setup-checks)"));
          o.keep_out_m = arg::number_in(keep_out_m, f + "keep_out_m", 0, 0.1, "m (1 mm is 0.001)");
          o.description = "pvdfkit.make_atlas " + path;
          pvdf::mapping::AtlasReport r;
          nlohmann::json report;
          {
            py::gil_scoped_release release;
            const pvdf::mapping::ChargeAtlas atlas = pvdf::mapping::generate_atlas(scene, o, &r);
            pvdf::mapping::write_atlas(path, atlas);
            report = pvdf::mapping::atlas_report_json(r, atlas, path);
          }
          // The dict of `pvdfkit atlas --json`, key for key (one serializer).
          return py::module_::import("json").attr("loads")(report.dump());
        },
        py::arg("scene"), py::arg("path"), py::arg("spacing_m") = 0.002, py::arg("forces_N") = std::vector<double>{1.0},
        py::arg("tolerance") = py::none(), py::arg("cell_m") = 0.001, py::arg("threads") = 0,
        py::arg("n_setup_checks") = 3, py::arg("keep_out_m") = 0.001,
        "Charge-density atlas of the scene's film written to `path` (HDF5, docs/atlas.md), with the defaults and "
        "checks of ``pvdfkit atlas``; returns the report dict of ``pvdfkit atlas --json`` (same keys: counts, model, "
        "tolerance, mesh, cells, timings in s, output). spacing_m (m, in [1e-5, 0.1]); forces_N (N, each in (0, 1e4], "
        "distinct); tolerance None = the scene's, else in [1e-8, 0.5]; cell_m (m, in [1e-5, 0.05]); threads 0 = all "
        "cores; n_setup_checks 0-3 as --setup-checks; keep_out_m (m, in [0, 0.1]) as --keep-out-m: electrodes are "
        "served at least this far inside the clamp.");
  m.def("map_from_atlas", [](py::object scene_arg, const std::string& atlas_path) {
          const pvdf::Scene scene = arg::scene(scene_arg, "map_from_atlas: scene");
          const pvdf::mapping::ChargeAtlas atlas = pvdf::mapping::read_atlas(atlas_path);
          return pvdf::mapping::map_from_atlas(atlas, scene, atlas_path);
        },
        py::arg("scene"), py::arg("atlas_path"),
        "The ChargeMap of the scene's electrodes integrated over the atlas (no solve); raises InputError when the "
        "atlas's film, thickness, material or probe differ from the scene's.");
}

}  // namespace pvdf::python
