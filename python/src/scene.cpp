// Scenes: read with the C++ reader (same validation, same messages), inspected from Python.
#include "arguments.hpp"
#include "bindings.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/json_reader.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/core/scene_geometry.hpp"

#include <cmath>

namespace pvdf::python {
namespace {

/// The film outline as a closed polygon (m), `n` points for curved outlines.
std::vector<std::array<double, 2>> outline_points(const pvdf::FilmOutline& o, int n = 256) {
  using Shape = pvdf::FilmOutline::Shape;
  std::vector<std::array<double, 2>> p;
  if (o.shape == Shape::polygon) {
    p = o.vertices_m;
  } else if (o.shape == Shape::rectangle) {
    const double a = o.size_m[0] / 2, b = o.size_m[1] / 2;
    p = {{-a, -b}, {a, -b}, {a, b}, {-a, b}};
  } else {
    const double a = o.shape == Shape::circle ? o.radius_m : o.semi_axes_m[0];
    const double b = o.shape == Shape::circle ? o.radius_m : o.semi_axes_m[1];
    for (int i = 0; i < n; ++i) {
      const double t = 2 * pi * i / n;
      p.push_back({a * std::cos(t), b * std::sin(t)});
    }
  }
  if (!p.empty()) p.push_back(p.front());
  return p;
}

}  // namespace

void bind_scene(py::module_& m) {
  using pvdf::Scene;
  py::class_<Scene>(m, "Scene", R"doc(A sensor scene: film, material, electrodes, probe, loads, mesh and model options.

Make one with pvdfkit.load_scene (a file or a dict) or pvdfkit.default_scene(); the keys and
their SI units are those of the scene files (docs/scene.md). A Scene is read-only: change the
dict from ``to_dict()`` and load it again.)doc")
      .def_readonly("source", &Scene::source, "file (or name) the scene came from, used in messages")
      .def_readonly("warnings", &Scene::warnings, "non-fatal remarks (e.g. the nu21 reciprocity check)")
      .def_property_readonly("electrode_names", [](const Scene& s) {
        std::vector<std::string> n;
        for (const auto& e : s.electrodes) n.push_back(e.name);
        return n;
      })
      .def_property_readonly("electrode_centroids_m", [](const Scene& s) {
        std::vector<std::array<double, 2>> c;
        for (const auto& e : s.electrodes) c.push_back(e.centroid_m());
        return to_array(c);
      }, "centroid of each electrode (m), shape (n_electrodes, 2)")
      .def_property_readonly("electrode_outlines_m", [](const Scene& s) {
        py::list out;
        for (const auto& e : s.electrodes) {
          auto p = e.outline();
          if (!p.empty()) p.push_back(p.front());
          out.append(to_array(p));
        }
        return out;
      }, "closed outline of each electrode (m): a list of (n, 2) arrays")
      .def_property_readonly("film_outline_m", [](const Scene& s) { return to_array(outline_points(s.membrane.outline)); },
                             "closed outline of the clamped film (m), shape (n, 2)")
      .def_property_readonly("film_area_m2", [](const Scene& s) { return s.membrane.outline.area_m2(); })
      .def_property_readonly("thickness_m", [](const Scene& s) { return s.membrane.thickness_m; })
      .def_property_readonly("probe_radius_m", [](const Scene& s) { return s.probe.radius_m; })
      .def_property_readonly("draw_angle_rad", [](const Scene& s) { return s.material.draw_angle_rad; })
      .def("_json_text", [](const Scene& s) { return pvdf::scene_to_json(s).dump(); })
      .def("with_probe_load", [](const Scene& s, py::object x_m, py::object y_m, py::object force_N) {
             // The rules of the scene's loads[] (as `pvdfkit solve --load` applies them).
             const std::string f = "Scene.with_probe_load: ";
             const double x = arg::number(x_m, f + "x_m", "(m)");
             const double y = arg::number(y_m, f + "y_m", "(m)");
             const double force = arg::number_in(force_N, f + "force_N", -1e4, 1e4, "N (the rule of loads[].force_N)");
             const std::string problem = pvdf::probe_footprint_problem(s, {x, y}, s.probe.radius_m);
             if (!problem.empty()) {
               throw pvdf::InputError(f + "(x_m, y_m) = (" + pvdf::format_g(x) + ", " + pvdf::format_g(y) + "): " + problem);
             }
             return pvdf::with_probe_load(s, x, y, force);
           },
           py::arg("x_m"), py::arg("y_m"), py::arg("force_N"),
           "The scene with its loads replaced by one probe press of force_N (N, |force_N| <= 1e4) at (x_m, y_m) (m), "
           "its footprint clear of the rim.")
      .def("__repr__", [](const Scene& s) {
        return "<Scene " + s.source + ": " + std::to_string(s.electrodes.size()) + " electrodes, " +
               std::to_string(s.loads.size()) + " loads>";
      });

  m.def("_load_scene_file", &pvdf::load_scene, py::arg("path"));
  m.def("_parse_scene_text", [](const std::string& text, const std::string& source) {
    return pvdf::parse_scene(pvdf::parse_json_text(text, source), source);
  }, py::arg("text"), py::arg("source"));
  m.def("default_scene", &pvdf::default_scene, "The built-in seed-001 scene (examples/scenes/seed001.json).");
}

}  // namespace pvdf::python
