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
  m.def("make_atlas", [](py::object scene_arg, const std::string& path, double spacing_m, std::vector<double> forces_N,
                         double tolerance, double cell_m, int threads, py::object n_setup_checks) {
          const pvdf::Scene scene = arg::scene(scene_arg, "make_atlas: scene");
          pvdf::check_output_path(path, "make_atlas: path");  // before the sweep, not after it
          pvdf::mapping::AtlasOptions o;
          o.spacing_m = spacing_m;
          o.forces_N = std::move(forces_N);
          o.tolerance = tolerance;
          o.cell_m = cell_m;
          o.threads = threads;
          o.n_setup_checks = int(arg::integer_in(n_setup_checks, "make_atlas: n_setup_checks", 0, 3,
                                                 "(as pvdfkit atlas --setup-checks)"));
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
        py::arg("tolerance") = 0.0, py::arg("cell_m") = 0.001, py::arg("threads") = 0,
        py::arg("n_setup_checks") = 3,
        "Charge-density atlas of the scene's film written to `path` (HDF5, docs/atlas.md); returns the report dict of "
        "``pvdfkit atlas --json`` (same keys: counts, model, tolerance, mesh, cells, timings in s, output). "
        "tolerance 0 = the scene's; threads 0 = all cores; n_setup_checks 0-3 as --setup-checks.");
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
