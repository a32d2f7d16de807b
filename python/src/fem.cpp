// The FEM side: one solve of a scene, many probe solves on one prepared mesh, and map generation.
// The GIL is released while C++ works; numerical failure is a status (or NumericalError on request).
#include "arguments.hpp"
#include "bindings.hpp"
#include "results.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/scene_geometry.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/fem/probe_sweep.hpp"
#include "pvdf/fem/solver.hpp"
#include "pvdf/mapping/generate.hpp"
#include "pvdf/mapping/map_report.hpp"

#include <malloc.h>

#include <cmath>
#include <algorithm>
#include <cstdio>
#include <optional>

namespace pvdf::python {

/// The rule of the scene key model.tolerance, as `pvdfkit solve/map --tolerance` apply it.
std::optional<double> tolerance_arg(py::object value, const std::string& what) {
  return arg::optional_number_in(value, what, 1e-8, 0.5, "(the rule of the scene key model.tolerance), e.g. 0.01");
}

/// Force levels (N) as `pvdfkit map --forces-N` takes them: each in (0, 1e4], resolved by the
/// film (not lost to rounding), and distinct (two levels within 1e-6 are one level twice).
std::vector<double> force_levels(py::object value, const std::string& what, const pvdf::Scene& scene) {
  const std::vector<double> forces = arg::vector(value, what, {false, true, "give force levels in N, e.g. [0.5, 1.0, 2.0]"});
  std::size_t index = 0;
  const std::string problem = pvdf::force_levels_problem(forces, index);  // the rule of map --forces-N
  if (!problem.empty()) {
    throw pvdf::InputError(what + (index < forces.size() ? "[" + std::to_string(index) + "] = " : ": ") + problem);
  }
  for (std::size_t i = 0; i < forces.size(); ++i) {
    const std::string unresolved = pvdf::force_resolution_problem(scene, forces[i]);
    if (!unresolved.empty()) throw pvdf::InputError(what + "[" + std::to_string(i) + "] = " + pvdf::format_g(forces[i]) + ": " + unresolved);
  }
  return forces;
}

namespace {

/// `loads`: probe presses replacing the scene's, each checked with the rules of loads[] (as
/// `pvdfkit solve --load` does): |force_N| <= 1e4, the footprint clear of the rim.
std::vector<pvdf::Load> load_rows(py::object value, const pvdf::Scene& scene) {
  const DoubleArray a = arg::rows(value, "solve: loads", 3, "(x_m, y_m, force_N)",
                                  {false, true, "give one row [x_m, y_m, force_N] per press, or leave loads out for the scene's"});
  std::vector<pvdf::Load> loads;
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    const double* r = a.data() + 3 * i;
    const std::string at = "solve: loads[" + std::to_string(i) + "] = [" + pvdf::format_g(r[0]) + ", " +
                           pvdf::format_g(r[1]) + ", " + pvdf::format_g(r[2]) + "]";
    if (!(std::abs(r[2]) <= 1e4)) {
      throw pvdf::InputError(at + ": force " + pvdf::format_g(r[2]) + " N must lie in [-1e4, 1e4] N (the rule of loads[].force_N)");
    }
    if (r[2] == 0) {
      throw pvdf::InputError(at + ": a force of 0 N loads nothing (the answer would be the flat film); give the press's "
                                  "force or leave the row out");
    }
    const std::string unresolved = pvdf::force_resolution_problem(scene, std::abs(r[2]));
    if (!unresolved.empty()) throw pvdf::InputError(at + ": " + unresolved);
    const std::string problem = pvdf::probe_footprint_problem(scene, {r[0], r[1]}, scene.probe.radius_m);
    if (!problem.empty()) throw pvdf::InputError(at + ": " + problem);
    pvdf::Load l;
    l.kind = pvdf::Load::Kind::probe;
    l.position_m = {r[0], r[1]};
    l.force_N = r[2];
    loads.push_back(l);
  }
  return loads;
}

pvdf::fem::Result solve(py::object scene_arg, py::object loads, py::object samples, py::object model, py::object tolerance,
                        py::object max_refinements, py::object vtu_dir, py::object check_arg) {
  pvdf::Scene scene = arg::scene(scene_arg, "solve: scene");
  if (!loads.is_none()) scene.loads = load_rows(loads, scene);
  pvdf::fem::Options options = pvdf::fem::options_from_scene(scene);
  if (!model.is_none()) options.model = pvdf::fem::parse_model(arg::text(model, "solve: model"), "solve: model");
  if (const auto t = tolerance_arg(tolerance, "solve: tolerance")) options.tolerance = *t;
  if (!max_refinements.is_none()) {
    options.max_refinements = int(arg::integer_in(max_refinements, "solve: max_refinements", 0, 20,
                                                  "(the rule of the scene key model.max_refinements)"));
  }
  if (!samples.is_none()) {
    const auto points = arg::points(samples, "solve: samples", {true, true, "give points [x_m, y_m] inside the film"});
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (!scene.membrane.outline.contains(points[i])) {
        throw pvdf::InputError("solve: samples[" + std::to_string(i) + "] = [" + pvdf::format_g(points[i][0]) + ", " +
                               pvdf::format_g(points[i][1]) + "] lies outside the film; give a point inside the clamped outline (m)");
      }
    }
    options.sample_points_m = points;
  }
  options.vtu_directory = vtu_dir.is_none() ? std::string() : arg::output_folder(vtu_dir, "solve: vtu_dir");
  const bool check = arg::flag(check_arg, "solve: check");
  pvdf::fem::Result r;
  {
    py::gil_scoped_release release;
    r = pvdf::fem::solve(scene, options);
    // The solve's meshes, matrices and factors (GBs near the clamp) go back to the system now: glibc
    // keeps freed memory otherwise, and a Python loop of solves held its largest solve's RSS.
    malloc_trim(0);
  }
  if (check && !pvdf::fem::usable(r.summary.status)) {
    throw pvdf::NumericalError(scene.source + ": the film solve did not converge (" +
                               pvdf::fem::status_name(r.summary.status) + "): " + r.summary.message);
  }
  return r;
}

/// Values of a scalar-or-1-D argument, repeated to length n (n = 0: its own length).
std::vector<double> broadcast(py::object a, std::size_t n, const std::string& what) {
  std::vector<double> v = arg::vector(a, "ProbeSweep.solve: " + what);
  if (v.size() == 1 && n > 1) v.assign(n, v[0]);
  if (n != 0 && v.size() != n) {
    throw pvdf::InputError("ProbeSweep.solve: " + what + " has " + std::to_string(v.size()) + " values for " +
                           std::to_string(n) + " presses; give one value or one per press");
  }
  return v;
}

std::size_t length(py::object a, const std::string& what) { return arg::vector(a, "ProbeSweep.solve: " + what).size(); }

SweepBatch sweep_solve(pvdf::fem::ProbeSweep& sweep, std::size_t n_electrodes, py::object x, py::object y, py::object f,
                       py::object warm_start_arg) {
  const std::size_t n = std::max({length(x, "x_m"), length(y, "y_m"), length(f, "force_N")});
  const auto xs = broadcast(x, n, "x_m"), ys = broadcast(y, n, "y_m"), fs = broadcast(f, n, "force_N");
  for (std::size_t i = 0; i < n; ++i) {
    if (!(fs[i] > 0 && fs[i] <= 1e4)) {
      throw pvdf::InputError("ProbeSweep.solve: force_N[" + std::to_string(i) + "] = " + pvdf::format_g(fs[i]) +
                             " must lie in (0, 1e4] N (a press pushes the film; the rule of loads[].force_N)");
    }
  }
  const bool warm_start = arg::flag(warm_start_arg, "ProbeSweep.solve: warm_start");
  SweepBatch batch;
  batch.n_electrodes = n_electrodes;
  py::gil_scoped_release release;
  pvdf::fem::SweepState state, next;
  for (std::size_t i = 0; i < n; ++i) {
    const bool warm = warm_start && !state.dofs.empty();
    batch.items.push_back(sweep.solve(xs[i], ys[i], fs[i], warm ? &state : nullptr, &next));
    if (pvdf::fem::usable(batch.items.back().status)) std::swap(state, next);
  }
  return batch;
}

/// The report with the keys of `pvdfkit map --json` (the command's output path and mesh aside),
/// plus setup_s, which the command does not print.
py::dict report_dict(const pvdf::mapping::MapReport& r, const pvdf::mapping::ChargeMap& map) {
  py::dict d = py::module_::import("json").attr("loads")(pvdf::mapping::map_report_json(r, map).dump());
  d["setup_s"] = r.setup_s;
  return d;
}

/// Largest map (positions x force levels) `pvdfkit map` starts (app/src/cmd_map.cpp).
constexpr double max_map_points = 2e6;

/// generate_map's options, each argument checked as `pvdfkit map` checks its flag.
pvdf::mapping::MapOptions map_options(const pvdf::Scene& scene, py::object spacing_m, py::object forces_N,
                                      py::object region_m, py::object rim_margin_m, py::object model, py::object tolerance,
                                      py::object n_setup_checks, py::object threads, py::object use_symmetry,
                                      py::object use_force_scaling, py::object noise_C, py::object description,
                                      py::object checkpoint_path) {
  const std::string f = "generate_map: ";
  pvdf::mapping::MapOptions o;
  o.spacing_m = arg::number_in(spacing_m, f + "spacing_m", 1e-5, 0.1, "m");
  o.forces_N = force_levels(forces_N, f + "forces_N", scene);
  double area_m2 = scene.membrane.outline.area_m2();
  if (!region_m.is_none()) {
    const auto r = arg::vector(region_m, f + "region_m", {false, true, "give (xmin, xmax, ymin, ymax) in m"});
    if (r.size() != 4) {
      throw pvdf::InputError(f + "region_m has " + std::to_string(r.size()) + " values; give (xmin, xmax, ymin, ymax) in m");
    }
    if (!(r[0] < r[1] && r[2] < r[3])) {
      throw pvdf::InputError(f + "region_m = (" + pvdf::format_g(r[0]) + ", " + pvdf::format_g(r[1]) + ", " +
                             pvdf::format_g(r[2]) + ", " + pvdf::format_g(r[3]) + ") needs xmin < xmax and ymin < ymax (m)");
    }
    // As `pvdfkit map --region`: a region far beyond the film maps nothing and its node count
    // would overflow.
    const double half_size_m = scene.membrane.outline.characteristic_radius_m();
    for (const double v : r) {
      if (std::abs(v) > 2 * half_size_m) {
        throw pvdf::InputError(f + "region_m: " + pvdf::format_g(v) + " m lies beyond the film (half-size " +
                               pvdf::format_g(half_size_m) + " m); give the region in m, within the film");
      }
    }
    o.region_m = std::array<double, 4>{r[0], r[1], r[2], r[3]};
    area_m2 = std::min(area_m2, (r[1] - r[0]) * (r[3] - r[2]));
  }
  const double n_positions = area_m2 / (o.spacing_m * o.spacing_m);
  if (n_positions * double(o.forces_N.size()) > max_map_points) {
    throw pvdf::InputError(f + "spacing_m = " + pvdf::format_g(o.spacing_m) + ": the map would hold about " +
                           pvdf::format_g(n_positions) + " positions x " + std::to_string(o.forces_N.size()) +
                           " force levels, more than the limit " + pvdf::format_g(max_map_points) +
                           " points; use a larger spacing_m or a smaller region_m (m)");
  }
  o.rim_margin_m = arg::number_in(rim_margin_m, f + "rim_margin_m", 0, 1, "m");
  if (o.rim_margin_m != 0 && o.rim_margin_m < 2 * scene.probe.radius_m) {
    throw pvdf::InputError(f + "rim_margin_m = " + pvdf::format_g(o.rim_margin_m) + " must be 0 (default) or >= " +
                           pvdf::format_g(2 * scene.probe.radius_m) +
                           " m, two probe radii: a footprint must stay one probe radius clear of the rim (docs/scene.md)");
  }
  o.model = arg::text(model, f + "model");
  if (!o.model.empty()) pvdf::fem::parse_model(o.model, f + "model");
  o.tolerance = tolerance_arg(tolerance, f + "tolerance").value_or(0.0);  // 0: the scene's model.tolerance
  o.n_setup_checks = int(arg::integer_in(n_setup_checks, f + "n_setup_checks", 0, 3, "(as pvdfkit map --setup-checks)"));
  o.threads = int(arg::integer_in(threads, f + "threads", 0, 1024, "(0 = all cores)"));
  o.use_symmetry = arg::flag(use_symmetry, f + "use_symmetry");
  o.use_force_scaling = arg::flag(use_force_scaling, f + "use_force_scaling");
  if (!noise_C.is_none()) {
    o.noise_C = arg::vector(noise_C, f + "noise_C", {true, true, "give one 1-sigma noise in C per electrode"});
    if (!o.noise_C.empty() && o.noise_C.size() != scene.electrodes.size()) {
      throw pvdf::InputError(f + "noise_C has " + std::to_string(o.noise_C.size()) + " values for " +
                             std::to_string(scene.electrodes.size()) + " electrodes; give one 1-sigma noise in C per electrode");
    }
    for (std::size_t k = 0; k < o.noise_C.size(); ++k) {
      if (!(o.noise_C[k] > 0 && o.noise_C[k] < 1e-6)) {
        throw pvdf::InputError(f + "noise_C[" + std::to_string(k) + "] = " + pvdf::format_g(o.noise_C[k]) +
                               " must lie in (0, 1e-6) C (a 1-sigma charge noise)");
      }
    }
  }
  o.description = arg::text(description, f + "description");
  if (!checkpoint_path.is_none() && !(py::isinstance<py::str>(checkpoint_path) && checkpoint_path.cast<std::string>().empty())) {
    o.checkpoint_path = arg::output_file(checkpoint_path, f + "checkpoint_path");
  }
  return o;
}

}  // namespace

void bind_fem(py::module_& m) {
  m.def("_solve", &solve, py::arg("scene"), py::arg("loads") = py::none(), py::arg("samples") = py::none(),
        py::arg("model") = py::none(), py::arg("tolerance") = py::none(), py::arg("max_refinements") = py::none(),
        py::arg("vtu_dir") = py::none(), py::arg("check") = true);

  using pvdf::fem::ProbeSweep;
  struct Sweep {
    std::unique_ptr<ProbeSweep> sweep;
    std::size_t n_electrodes = 0;
  };
  py::class_<Sweep>(m, "ProbeSweep", R"doc(Many probe presses on one scene, solved on one prepared mesh.

The setup (model choice, mesh, factorization pattern; seconds) is done once so that the
electrode charges meet ``tolerance`` anywhere on the film (checked against direct solves at
``n_setup_checks`` positions, default 3 as ``pvdfkit map --setup-checks``:
``setup['estimated_relative_error']``); each press then costs a warm-started Newton solve. The
scene's own loads are ignored; the probe radius is the scene's.)doc")
      .def(py::init([](py::object scene_arg, py::object tolerance, py::object model, py::object forces_N,
                       py::object n_setup_checks, py::object rim_margin_m) {
             const std::string f = "ProbeSweep: ";
             const pvdf::Scene scene = arg::scene(scene_arg, f + "scene");
             pvdf::fem::SweepOptions o;
             o.solver = pvdf::fem::options_from_scene(scene);
             if (const auto t = tolerance_arg(tolerance, f + "tolerance")) o.solver.tolerance = *t;
             if (!model.is_none()) {
               const std::string name = arg::text(model, f + "model");
               if (!name.empty()) o.solver.model = pvdf::fem::parse_model(name, f + "model");
             }
             // 0..4 positions are what the sweep can check; 3 is `pvdfkit map`'s default.
             o.n_setup_checks = int(arg::integer_in(n_setup_checks, f + "n_setup_checks", 0, 4,
                                                    "(positions checked at setup; pvdfkit map uses 3)"));
             if (!forces_N.is_none()) {
               const auto levels = arg::vector(forces_N, f + "forces_N", {true, true, "give force levels in N, e.g. [0.5, 1.0]"});
               if (levels.empty()) {
                 throw pvdf::InputError(f + "forces_N = [] names no force level; give levels in N, e.g. [0.5, 1.0], "
                                            "or leave forces_N out for the default");
               }
               o.forces_N = force_levels(forces_N, f + "forces_N", scene);
             }
             o.rim_margin_m = arg::number_in(rim_margin_m, f + "rim_margin_m", 0, 1, "m (0 = the probe radius)");
             Sweep s;
             s.n_electrodes = scene.electrodes.size();
             py::gil_scoped_release release;
             s.sweep = std::make_unique<ProbeSweep>(scene, o);
             return s;
           }),
           py::arg("scene"), py::arg("tolerance") = py::none(), py::arg("model") = py::none(), py::arg("forces_N") = py::none(),
           py::arg("n_setup_checks") = 3, py::arg("rim_margin_m") = 0.0,
           "scene: Scene, dict or path; tolerance: requested relative charge error in [1e-8, 0.5] (default: the scene's); "
           "model: auto | linear | von-karman | large-rotation (default: the scene's); forces_N: the force levels to be "
           "served (N, each in (0, 1e4]); n_setup_checks: 0..4 (default 3, as pvdfkit map); rim_margin_m: presses closer "
           "to the rim are refused (m, in [0, 1]).")
      .def_property_readonly("setup", [](const Sweep& s) {
        const auto& u = s.sweep->setup();
        py::dict d;
        d["model"] = pvdf::fem::model_name(u.model);
        d["model_reason"] = u.model_reason;
        d["n_dofs"] = u.n_dofs;
        d["n_cells"] = u.n_cells;
        d["estimated_relative_error"] = u.estimated_relative_error;
        d["error_estimator"] = u.error_estimator;
        d["estimated_deflection_relative_error"] = u.estimated_deflection_relative_error;
        d["setup_s"] = u.setup_s;
        return d;
      }, "what the setup chose: model, n_dofs, n_cells, estimated_relative_error (of the charges), setup_s (s)")
      .def("solve", [](Sweep& s, py::object x_m, py::object y_m, py::object force_N, py::object warm_start) {
             return sweep_solve(*s.sweep, s.n_electrodes, x_m, y_m, force_N, warm_start);
           },
           py::arg("x_m"), py::arg("y_m"), py::arg("force_N") = 1.0, py::arg("warm_start") = true,
           "Solves N presses (x_m, y_m in m, force_N in N: arrays of length N or scalars, finite, force in (0, 1e4]), "
           "each warm-started from the previous one when warm_start. A press outside the served region raises "
           "InputError; a numerical failure is a status (ok False, NaN values). Returns ProbeSolutions.");

  m.def("generate_map", [](py::object scene_arg, py::object spacing_m, py::object forces_N, py::object region_m,
                           py::object rim_margin_m, py::object model, py::object tolerance, py::object n_setup_checks,
                           py::object threads, py::object use_symmetry, py::object use_force_scaling, py::object noise_C,
                           py::object description, py::object checkpoint_path) {
          const pvdf::Scene scene = arg::scene(scene_arg, "generate_map: scene");
          const pvdf::mapping::MapOptions o =
              map_options(scene, spacing_m, forces_N, region_m, rim_margin_m, model, tolerance, n_setup_checks, threads,
                          use_symmetry, use_force_scaling, noise_C, description, checkpoint_path);
          pvdf::mapping::MapReport report;
          pvdf::mapping::ChargeMap map;
          {
            py::gil_scoped_release release;
            map = pvdf::mapping::generate_map(scene, o, &report);
          }
          return py::make_tuple(map, report_dict(report, map));
        },
        py::arg("scene"), py::arg("spacing_m") = 0.002, py::arg("forces_N") = std::vector<double>{1.0},
        py::arg("region_m") = py::none(), py::arg("rim_margin_m") = 0.0, py::arg("model") = "auto",
        py::arg("tolerance") = py::none(), py::arg("n_setup_checks") = 3, py::arg("threads") = 0, py::arg("use_symmetry") = true,
        py::arg("use_force_scaling") = true, py::arg("noise_C") = py::none(), py::arg("description") = "",
        py::arg("checkpoint_path") = py::none(),
        R"doc(Charge map of a scene by the FEM (what ``pvdfkit map`` does, with its defaults and checks). Returns
(ChargeMap, report dict with the keys of ``pvdfkit map --json``, plus setup_s).

spacing_m: grid step (m, in [1e-5, 0.1]); forces_N: force levels (N, each in (0, 1e4]); region_m:
(xmin, xmax, ymin, ymax) (m), default the film's bounding box; rim_margin_m: positions closer to the
rim are masked (m, 0 = twice the probe radius); tolerance: requested relative charge error in
[1e-8, 0.5] (default: the scene's model.tolerance); n_setup_checks: 0..3 (default 3); threads: 0 =
all cores; noise_C: one 1-sigma noise per electrode (C, in (0, 1e-6)). Failed points have status
not_converged (never a guess).)doc");
}

}  // namespace pvdf::python
