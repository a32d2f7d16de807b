// The FEM side: one solve of a scene, many probe solves on one prepared mesh, and map generation.
// The GIL is released while C++ works; numerical failure is a status (or NumericalError on request).
#include "bindings.hpp"
#include "results.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/fem/probe_sweep.hpp"
#include "pvdf/fem/solver.hpp"
#include "pvdf/mapping/generate.hpp"

#include <cmath>
#include <optional>

namespace pvdf::python {
namespace {

void check_tolerance(double tolerance, const std::string& what) {
  if (!(tolerance > 0 && tolerance < 1)) {
    throw pvdf::InputError(what + " = " + std::to_string(tolerance) + " must be in (0, 1), e.g. 0.01");
  }
}

pvdf::fem::Result solve(const pvdf::Scene& scene_in, const std::optional<DoubleArray>& loads,
                        const std::optional<DoubleArray>& samples, const std::optional<std::string>& model,
                        std::optional<double> tolerance, std::optional<int> max_refinements, const std::string& vtu_dir,
                        bool check) {
  pvdf::Scene scene = scene_in;
  if (loads) {
    const DoubleArray& a = *loads;
    const bool one = a.ndim() == 1 && a.shape(0) == 3;
    if (!one && !(a.ndim() == 2 && a.shape(1) == 3)) {
      throw pvdf::InputError("solve: loads has shape " + shape_text(a) + "; expected n x 3 rows of (x_m, y_m, force_N)");
    }
    scene.loads.clear();
    for (py::ssize_t i = 0; i < a.size() / 3; ++i) {
      pvdf::Load l;
      l.kind = pvdf::Load::Kind::probe;
      l.position_m = {a.data()[3 * i], a.data()[3 * i + 1]};
      l.force_N = a.data()[3 * i + 2];
      scene.loads.push_back(l);
    }
  }
  pvdf::fem::Options options = pvdf::fem::options_from_scene(scene);
  if (model) options.model = pvdf::fem::parse_model(*model, "solve: model");
  if (tolerance) {
    check_tolerance(*tolerance, "solve: tolerance");
    options.tolerance = *tolerance;
  }
  if (max_refinements) {
    if (*max_refinements < 0) throw pvdf::InputError("solve: max_refinements = " + std::to_string(*max_refinements) + " must be >= 0");
    options.max_refinements = *max_refinements;
  }
  if (samples) options.sample_points_m = to_points(*samples, "solve: samples");
  options.vtu_directory = vtu_dir;
  pvdf::fem::Result r;
  {
    py::gil_scoped_release release;
    r = pvdf::fem::solve(scene, options);
  }
  if (check && !pvdf::fem::usable(r.summary.status)) {
    throw pvdf::NumericalError(scene.source + ": the film solve did not converge (" +
                               pvdf::fem::status_name(r.summary.status) + "): " + r.summary.message);
  }
  return r;
}

/// Values of a scalar-or-1-D argument, repeated to length n (n = 0: its own length).
std::vector<double> broadcast(const DoubleArray& a, std::size_t n, const std::string& what) {
  std::vector<double> v = to_vector(a, what);
  if (v.size() == 1 && n > 1) v.assign(n, v[0]);
  if (n != 0 && v.size() != n) {
    throw pvdf::InputError("ProbeSweep.solve: " + what + " has " + std::to_string(v.size()) + " values for " +
                           std::to_string(n) + " presses; give one value or one per press");
  }
  return v;
}

SweepBatch sweep_solve(pvdf::fem::ProbeSweep& sweep, std::size_t n_electrodes, const DoubleArray& x,
                       const DoubleArray& y, const DoubleArray& f, bool warm_start) {
  const std::size_t n = std::max({std::size_t(x.size()), std::size_t(y.size()), std::size_t(f.size())});
  const auto xs = broadcast(x, n, "x_m"), ys = broadcast(y, n, "y_m"), fs = broadcast(f, n, "force_N");
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

py::dict report_dict(const pvdf::mapping::MapReport& r) {
  py::dict d;
  d["n_positions"] = r.n_positions;
  d["n_points"] = r.n_points;
  d["n_solved"] = r.n_solved;
  d["n_scaled"] = r.n_scaled;
  d["n_mirrored"] = r.n_mirrored;
  d["n_resumed"] = r.n_resumed;
  d["n_failed"] = r.n_failed;
  d["n_scaling_checks"] = r.n_scaling_checks;
  d["n_scaling_checks_failed"] = r.n_scaling_checks_failed;
  d["max_scaling_check_error"] = r.max_scaling_check_error;
  d["symmetry_reason"] = r.symmetry_reason;
  d["model"] = r.model;
  d["model_reason"] = r.model_reason;
  d["estimated_relative_error"] = r.estimated_relative_error;
  d["n_dofs"] = r.n_dofs;
  d["threads"] = r.threads;
  d["setup_s"] = r.setup_s;
  d["wall_s"] = r.wall_s;
  d["per_position_s"] = r.per_position_s;
  d["first_failure"] = r.first_failure;
  return d;
}

}  // namespace

void bind_fem(py::module_& m) {
  m.def("_solve", &solve, py::arg("scene"), py::arg("loads") = py::none(), py::arg("samples") = py::none(),
        py::arg("model") = py::none(), py::arg("tolerance") = py::none(), py::arg("max_refinements") = py::none(),
        py::arg("vtu_dir") = "", py::arg("check") = true);

  using pvdf::fem::ProbeSweep;
  struct Sweep {
    std::unique_ptr<ProbeSweep> sweep;
    std::size_t n_electrodes = 0;
  };
  py::class_<Sweep>(m, "ProbeSweep", R"doc(Many probe presses on one scene, solved on one prepared mesh.

The setup (model choice, mesh, factorization pattern; seconds) is done once so that the
electrode charges meet ``tolerance`` anywhere on the film (checked against direct solves at
``n_setup_checks`` positions: ``setup['estimated_relative_error']``); each press then costs a
warm-started Newton solve. The scene's own loads are ignored; the probe radius is the scene's.)doc")
      .def(py::init([](const pvdf::Scene& scene, std::optional<double> tolerance, const std::string& model,
                       const std::vector<double>& forces_N, int n_setup_checks, double rim_margin_m) {
             pvdf::fem::SweepOptions o;
             o.solver = pvdf::fem::options_from_scene(scene);
             if (tolerance) {
               check_tolerance(*tolerance, "ProbeSweep: tolerance");
               o.solver.tolerance = *tolerance;
             }
             if (!model.empty()) o.solver.model = pvdf::fem::parse_model(model, "ProbeSweep: model");
             if (n_setup_checks < 0 || n_setup_checks > 4) {
               throw pvdf::InputError("ProbeSweep: n_setup_checks = " + std::to_string(n_setup_checks) + " must be in 0..4");
             }
             o.n_setup_checks = n_setup_checks;
             o.forces_N = forces_N;
             o.rim_margin_m = rim_margin_m;
             Sweep s;
             s.n_electrodes = scene.electrodes.size();
             py::gil_scoped_release release;
             s.sweep = std::make_unique<ProbeSweep>(scene, o);
             return s;
           }),
           py::arg("scene"), py::arg("tolerance") = py::none(), py::arg("model") = "", py::arg("forces_N") = std::vector<double>{},
           py::arg("n_setup_checks") = 4, py::arg("rim_margin_m") = 0.0,
           "tolerance: requested relative charge error (default: the scene's); model: auto | linear | von-karman | "
           "large-rotation; forces_N: the force levels to be served (N); rim_margin_m: presses closer to the rim are refused (m).")
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
      .def("solve", [](Sweep& s, const DoubleArray& x_m, const DoubleArray& y_m, const DoubleArray& force_N, bool warm_start) {
             return sweep_solve(*s.sweep, s.n_electrodes, x_m, y_m, force_N, warm_start);
           },
           py::arg("x_m"), py::arg("y_m"), py::arg("force_N") = 1.0, py::arg("warm_start") = true,
           "Solves N presses (x_m, y_m in m, force_N in N: arrays of length N or scalars), each warm-started from the "
           "previous one when warm_start. A press outside the served region raises InputError; a numerical failure is "
           "a status (ok False, NaN values). Returns ProbeSolutions.");

  m.def("generate_map", [](const pvdf::Scene& scene, double spacing_m, const std::vector<double>& forces_N,
                           std::optional<std::array<double, 4>> region_m, double rim_margin_m, const std::string& model,
                           double tolerance, int n_setup_checks, int threads, bool use_symmetry, bool use_force_scaling,
                           const std::vector<double>& noise_C, const std::string& description, const std::string& checkpoint_path) {
          pvdf::mapping::MapOptions o;
          o.spacing_m = spacing_m;
          o.forces_N = forces_N;
          o.region_m = region_m;
          o.rim_margin_m = rim_margin_m;
          o.model = model;
          o.tolerance = tolerance;
          o.n_setup_checks = n_setup_checks;
          o.threads = threads;
          o.use_symmetry = use_symmetry;
          o.use_force_scaling = use_force_scaling;
          o.noise_C = noise_C;
          o.description = description;
          o.checkpoint_path = checkpoint_path;
          pvdf::mapping::MapReport report;
          pvdf::mapping::ChargeMap map;
          {
            py::gil_scoped_release release;
            map = pvdf::mapping::generate_map(scene, o, &report);
          }
          return py::make_tuple(map, report_dict(report));
        },
        py::arg("scene"), py::arg("spacing_m") = 0.002, py::arg("forces_N") = std::vector<double>{1.0},
        py::arg("region_m") = py::none(), py::arg("rim_margin_m") = 0.0, py::arg("model") = "auto",
        py::arg("tolerance") = 0.01, py::arg("n_setup_checks") = 3, py::arg("threads") = 0, py::arg("use_symmetry") = true,
        py::arg("use_force_scaling") = true, py::arg("noise_C") = std::vector<double>{}, py::arg("description") = "",
        py::arg("checkpoint_path") = "",
        R"doc(Charge map of a scene by the FEM (what ``pvdfkit map`` does). Returns (ChargeMap, report dict).

spacing_m: grid step (m); forces_N: force levels (N); region_m: (xmin, xmax, ymin, ymax) (m), default
the film's bounding box; rim_margin_m: positions closer to the rim are masked (m, 0 = twice the probe
radius); tolerance: requested relative charge error; threads: 0 = all cores. Failed points have
status not_converged (never a guess).)doc");
}

}  // namespace pvdf::python
