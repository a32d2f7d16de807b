// The charge-density atlas in Python (docs/atlas.md): make_atlas (what `pvdfkit atlas` does) and
// map_from_atlas (what `pvdfkit map SCENE --atlas FILE` does), same checks and messages.
#include "arguments.hpp"
#include "bindings.hpp"
#include "pvdf/core/io.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/mapping/atlas.hpp"

namespace pvdf::python {

void bind_atlas(py::module_& m) {
  m.def("make_atlas", [](py::object scene_arg, const std::string& path, double spacing_m, std::vector<double> forces_N,
                         double tolerance, double cell_m, int threads) {
          const pvdf::Scene scene = arg::scene(scene_arg, "make_atlas: scene");
          pvdf::check_output_path(path, "make_atlas: path");  // before the sweep, not after it
          pvdf::mapping::AtlasOptions o;
          o.spacing_m = spacing_m;
          o.forces_N = std::move(forces_N);
          o.tolerance = tolerance;
          o.cell_m = cell_m;
          o.threads = threads;
          pvdf::mapping::AtlasReport r;
          {
            py::gil_scoped_release release;
            const pvdf::mapping::ChargeAtlas atlas = pvdf::mapping::generate_atlas(scene, o, &r);
            pvdf::mapping::write_atlas(path, atlas);
          }
          py::dict d;
          d["n_positions"] = r.n_positions;
          d["n_solved_positions"] = r.n_solved_positions;
          d["n_failed"] = r.n_failed;
          d["n_tolerance_not_met"] = r.n_tolerance_not_met;
          d["estimated_relative_error"] = r.estimated_relative_error;
          d["wall_s"] = r.wall_s;
          return d;
        },
        py::arg("scene"), py::arg("path"), py::arg("spacing_m") = 0.002, py::arg("forces_N") = std::vector<double>{1.0},
        py::arg("tolerance") = 0.0, py::arg("cell_m") = 0.001, py::arg("threads") = 0,
        "Charge-density atlas of the scene's film written to `path` (HDF5, docs/atlas.md); returns a report dict. "
        "tolerance 0 = the scene's; threads 0 = all cores.");
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
