// Python views of the result structs: every field is a property, arrays are numpy arrays (SI
// units, shapes in the docstrings). Only the fields that exist in the C++ structs are shown; a
// new field is one more def_property_readonly here.
#include "bindings.hpp"
#include "results.hpp"

#include "pvdf/mapping/design.hpp"
#include "pvdf/restore/scan_io.hpp"

#include <cmath>
#include <limits>

#ifdef PVDF_PYTHON_WITH_FEM
#include "pvdf/fem/result_json.hpp"
#include "pvdf/fem/solver.hpp"
#endif

namespace pvdf::python {
namespace {

constexpr double nan = std::numeric_limits<double>::quiet_NaN();

/// One column of a batch: f(item) for every item, NaN where `valid(item)` is false.
template <class Item, class F, class V>
py::array_t<double> column(const std::vector<Item>& items, F f, V valid) {
  py::array_t<double> out(py::ssize_t(items.size()));
  double* p = out.mutable_data();
  for (const auto& it : items) *p++ = valid(it) ? double(f(it)) : nan;
  return out;
}

void bind_locations(py::module_& m) {
  using pvdf::mapping::Location;
  const auto has = [](const Location& l) { return l.has_position(); };
  const auto always = [](const Location&) { return true; };
  py::class_<LocationBatch>(m, "Locations", R"doc(Presses located by Locator.locate: one entry per row of charges.

Every attribute is a numpy array of length N (the number of rows). Positions, forces and their
1-sigma values are NaN where ``has_position`` is False (flag outside_map or no_press).
Units: m, N; sigmas from the charge-noise model, (J^T W J)^-1.)doc")
      .def("__len__", [](const LocationBatch& b) { return b.items.size(); })
      .def_property_readonly("x_m", [=](const LocationBatch& b) { return column(b.items, [](const Location& l) { return l.x_m; }, has); }, "x of the press (m), shape (N,)")
      .def_property_readonly("y_m", [=](const LocationBatch& b) { return column(b.items, [](const Location& l) { return l.y_m; }, has); }, "y of the press (m), shape (N,)")
      .def_property_readonly("force_N", [=](const LocationBatch& b) { return column(b.items, [](const Location& l) { return l.force_N; }, has); }, "force (N), shape (N,)")
      .def_property_readonly("sigma_x_m", [=](const LocationBatch& b) { return column(b.items, [](const Location& l) { return l.sigma_x_m; }, has); }, "1-sigma of x (m), shape (N,); 0 where ill_conditioned")
      .def_property_readonly("sigma_y_m", [=](const LocationBatch& b) { return column(b.items, [](const Location& l) { return l.sigma_y_m; }, has); }, "1-sigma of y (m), shape (N,)")
      .def_property_readonly("sigma_F_N", [=](const LocationBatch& b) { return column(b.items, [](const Location& l) { return l.sigma_F_N; }, has); }, "1-sigma of the force (N), shape (N,)")
      .def_property_readonly("map_error_share", [=](const LocationBatch& b) { return column(b.items, [](const Location& l) { return l.map_error_share; }, has); }, "share of the sigmas that is the map's own error, not the charge noise: mean over electrodes of e^2/(sigma^2 + e^2) (0..1), shape (N,)")
      .def_property_readonly("residual", [=](const LocationBatch& b) { return column(b.items, [](const Location& l) { return l.residual; }, always); }, "chi = sqrt(sum((Q_k - q_k)/sigma_k)^2) at the solution (noise units), shape (N,)")
      .def_property_readonly("flags", [](const LocationBatch& b) {
        py::array_t<std::uint32_t> out(py::ssize_t(b.items.size()));
        for (std::size_t i = 0; i < b.items.size(); ++i) out.mutable_data()[i] = b.items[i].flags;
        return out;
      }, "bit mask of pvdfkit.FLAGS per press, uint32 shape (N,)")
      .def_property_readonly("flags_text", [](const LocationBatch& b) {
        std::vector<std::string> out;
        for (const auto& l : b.items) out.push_back(pvdf::mapping::flags_text(l.flags));
        return out;
      }, "'ok' or the flag names joined by '|', list of N str")
      .def_property_readonly("has_position", [](const LocationBatch& b) {
        py::array_t<bool> out(py::ssize_t(b.items.size()));
        for (std::size_t i = 0; i < b.items.size(); ++i) out.mutable_data()[i] = b.items[i].has_position();
        return out;
      }, "False where outside_map or no_press is set, bool shape (N,)")
      .def_property_readonly("n_solutions", [=](const LocationBatch& b) { return column(b.items, [](const Location& l) { return l.n_solutions; }, always).attr("astype")("int32"); }, "distinct positions that fit within noise (> 1: ambiguous), int shape (N,)")
      .def_property_readonly("iterations", [=](const LocationBatch& b) { return column(b.items, [](const Location& l) { return l.iterations; }, always).attr("astype")("int32"); }, "Levenberg-Marquardt iterations of the reported solution, int shape (N,)")
      .def_property_readonly("probability", [=](const LocationBatch& b) { return column(b.items, [](const Location& l) { return l.probability; }, always); }, "posterior probability of the reported (most probable) solution among the n_solutions (docs/lookup.md), shape (N,)")
      .def_property_readonly("alternatives", [](const LocationBatch& b) {
        // (N, max_solutions - 1, 5): every other solution, most probable first:
        // x_m, y_m, force_N, residual, probability; NaN where absent.
        constexpr int n_alt = Location::max_solutions - 1;
        py::array_t<double> out({py::ssize_t(b.items.size()), py::ssize_t(n_alt), py::ssize_t(5)});
        double* p = out.mutable_data();
        for (const auto& l : b.items) {
          for (int a = 0; a < n_alt; ++a) {
            const bool ok = a < l.n_alternatives;
            const auto& alt = l.alternatives[std::size_t(a)];
            *p++ = ok ? alt.x_m : nan;
            *p++ = ok ? alt.y_m : nan;
            *p++ = ok ? alt.force_N : nan;
            *p++ = ok ? alt.residual : nan;
            *p++ = ok ? alt.probability : nan;
          }
        }
        return out;
      }, "the other solutions (flag ambiguous), most probable first, shape (N, 7, 5): [x_m, y_m, force_N, residual, probability], NaN where absent");
}

void bind_design(py::module_& m) {
  using pvdf::mapping::DesignSummary;
  py::class_<DesignSummary>(m, "DesignSummary", R"doc(A layout evaluation (pvdfkit.design).

``summary`` is the same dictionary as ``pvdfkit design --json`` (infinite values as None);
``maps`` holds arrays of shape (ny, nx) over the map's grid ``x_m``, ``y_m`` (m): sigma_pos_m etc.
(m; +inf where the Fisher matrix is singular, NaN where not evaluated), flags as bool arrays, and
``charge_C`` of shape (ny, nx, n_electrodes) (C) at the evaluated force.)doc")
      .def_property_readonly("status", [](const DesignSummary& s) { return pvdf::mapping::design_status_name(s.status); })
      .def_property_readonly("status_reason", [](const DesignSummary& s) { return s.status_reason; })
      .def_property_readonly("figure_of_merit", &DesignSummary::figure_of_merit, "usable fraction of the mapped area (0..1)")
      .def_property_readonly("summary", [](const DesignSummary& s) {
        return py::module_::import("json").attr("loads")(pvdf::mapping::design_summary_json(s).dump());
      })
      .def_property_readonly("x_m", [](const DesignSummary& s) { return to_array(s.maps.x_m); })
      .def_property_readonly("y_m", [](const DesignSummary& s) { return to_array(s.maps.y_m); })
      .def_property_readonly("maps", [](const DesignSummary& s) {
        const auto& d = s.maps;
        const std::vector<py::ssize_t> shape{py::ssize_t(d.y_m.size()), py::ssize_t(d.x_m.size())};
        const auto flags = [&](const std::vector<std::uint8_t>& v) { return to_array(v, shape).attr("astype")("bool"); };
        py::dict out;
        out["sigma_pos_m"] = to_array(d.sigma_pos_m, shape);
        out["sigma_pos_unknown_force_m"] = to_array(d.sigma_pos_unknown_force_m, shape);
        out["sigma_pos_known_force_m"] = to_array(d.sigma_pos_known_force_m, shape);
        out["sigma_major_m"] = to_array(d.sigma_major_m, shape);
        out["sigma_force_rel"] = to_array(d.sigma_force_rel, shape);
        out["ambiguity_distance_m"] = to_array(d.ambiguity_distance_m, shape);
        out["evaluated"] = flags(d.evaluated);
        out["ambiguous"] = flags(d.ambiguous);
        out["dead"] = flags(d.dead);
        out["singular"] = flags(d.singular);
        out["lookup_failed"] = flags(d.lookup_failed);
        const py::ssize_t ne = d.x_m.empty() || d.y_m.empty() ? 0 : py::ssize_t(d.charge_C.size() / (d.x_m.size() * d.y_m.size()));
        out["charge_C"] = to_array(d.charge_C, {shape[0], shape[1], ne});
        return out;
      });
}

void bind_restored(py::module_& m) {
  using pvdf::restore::RestoredForces;
  py::class_<RestoredForces>(m, "RestoredForces", R"doc(Forces restored from a scan (pvdfkit.restore.apply), on the scan grid.

x_m (m), fx_N and fz_N (N per sample), mu (f_x / f_z where f_z > mu_threshold_N, else 0), mu_valid (bool): all shape (n,).)doc")
      .def_property_readonly("x_m", [](const RestoredForces& r) { return to_array(r.x_m); })
      .def_property_readonly("fx_N", [](const RestoredForces& r) { return to_array(r.fx_N); })
      .def_property_readonly("fz_N", [](const RestoredForces& r) { return to_array(r.fz_N); })
      .def_property_readonly("mu", [](const RestoredForces& r) { return to_array(r.mu); })
      .def_property_readonly("mu_valid", [](const RestoredForces& r) { return to_array(r.mu_valid).attr("astype")("bool"); })
      .def_property_readonly("mu_threshold_N", [](const RestoredForces& r) { return r.mu_threshold_N; });
}

#ifdef PVDF_PYTHON_WITH_FEM
void bind_solve_result(py::module_& m) {
  using pvdf::fem::Result;
  using pvdf::fem::SampleResult;
  const auto samples3 = [](const Result& r, auto get) {
    std::vector<std::array<double, 3>> rows;
    for (const auto& s : r.samples) rows.push_back(get(s));
    return to_array(rows);
  };
  py::class_<Result>(m, "SolveResult", R"doc(A film solve (pvdfkit.solve). SI units throughout.

status: 'converged' | 'tolerance-not-met' (both usable, ``ok`` True) | 'no-convergence' |
'not-finite' | 'linear-solver-failed' (no fields; arrays empty). ``estimated_relative_error`` is the
solver's estimate of the outputs' relative error. Electrode arrays follow the scene's electrode
order; sample arrays the ``samples`` passed to solve.)doc")
      .def_property_readonly("status", [](const Result& r) { return pvdf::fem::status_name(r.summary.status); })
      .def_property_readonly("ok", [](const Result& r) { return pvdf::fem::usable(r.summary.status); }, "True when the fields may be used")
      .def_property_readonly("message", [](const Result& r) { return r.summary.message; })
      .def_property_readonly("estimated_relative_error", [](const Result& r) { return r.summary.estimated_relative_error; })
      .def_property_readonly("summary", [](const Result& r) {
        // The solver summary's keys of `pvdfkit solve --json`, taken from its one serializer
        // (pvdf::fem::result_json), plus final_residual_norm, which that JSON does not print.
        const nlohmann::json all = pvdf::fem::result_json(r);
        nlohmann::json d;
        for (const char* key : {"status", "message", "model", "model_reason", "n_dofs", "n_cells", "newton_iterations",
                                "load_steps", "refinement_cycles", "estimated_relative_error",
                                "estimated_discretization_error", "estimated_model_error", "error_estimator", "wall_s",
                                "cpu_s", "time_breakdown_s"})
          d[key] = all.at(key);
        d["final_residual_norm"] = r.summary.final_residual_norm;
        return py::module_::import("json").attr("loads")(d.dump());
      }, "status, message, model, n_dofs, n_cells, iterations, estimates, wall_s, cpu_s and time_breakdown_s {setup, assembly, "
         "linear_solve} (s): the solver summary with the keys of `pvdfkit solve --json`")
      .def("to_dict", [](const Result& r) {
        return py::module_::import("json").attr("loads")(pvdf::fem::result_json(r).dump());
      }, "the object `pvdfkit solve --json` prints, as a dict (without the command's mesh keys; NaN as None)")
      .def_property_readonly("estimated_discretization_error", [](const Result& r) { return r.summary.estimated_discretization_error; },
                             "estimated relative error of the outputs from the mesh")
      .def_property_readonly("estimated_model_error", [](const Result& r) { return r.summary.estimated_model_error; },
                             "estimated relative error of the outputs from the model choice (bending dropped, ...)")
      .def_readonly("wrinkled_area_fraction", &Result::wrinkled_area_fraction, "share of the film that is wrinkled (tension-field membrane)")
      .def_readonly("slack_area_fraction", &Result::slack_area_fraction, "share of the film with no membrane force (tension-field membrane)")
      .def_readonly("max_deflection_m", &Result::max_deflection_m, "max |w| over the film, signed (m)")
      .def_readonly("deflection_at_load_m", &Result::deflection_at_load_m, "w at the first load (m)")
      .def_readonly("rim_reaction_N", &Result::rim_reaction_N, "vertical reaction of the clamped rim (N)")
      .def_readonly("strain_energy_J", &Result::strain_energy_J, "membrane + bending strain energy (J)")
      .def_readonly("vtu_files", &Result::vtu_files)
      .def_property_readonly("electrode_names", [](const Result& r) {
        std::vector<std::string> n;
        for (const auto& e : r.electrodes) n.push_back(e.name);
        return n;
      })
      .def_property_readonly("charge_C", [](const Result& r) {
        std::vector<double> q;
        for (const auto& e : r.electrodes) q.push_back(e.charge_C);
        return to_array(q);
      }, "charge of each electrode (C), shape (n_electrodes,)")
      .def_property_readonly("charge_error_C", [](const Result& r) {
        std::vector<double> q;
        for (const auto& e : r.electrodes) q.push_back(e.charge_error_C);
        return to_array(q);
      }, "estimated absolute error of each electrode's charge (C), shape (n_electrodes,)")
      .def_property_readonly("electrode_area_m2", [](const Result& r) {
        std::vector<double> a;
        for (const auto& e : r.electrodes) a.push_back(e.area_m2);
        return to_array(a);
      }, "nominal electrode areas (m^2), shape (n_electrodes,)")
      .def_property_readonly("mean_membrane_force_material_N_per_m", [](const Result& r) {
        std::vector<std::array<double, 3>> rows;
        for (const auto& e : r.electrodes) rows.push_back(e.mean_membrane_force_material_N_per_m);
        return to_array(rows);
      }, "mean [N11, N22, N12] over each electrode, material axes (N/m), shape (n_electrodes, 3)")
      .def_property_readonly("mean_membrane_force_global_N_per_m", [](const Result& r) {
        std::vector<std::array<double, 3>> rows;
        for (const auto& e : r.electrodes) rows.push_back(e.mean_membrane_force_global_N_per_m);
        return to_array(rows);
      }, "mean [Nxx, Nyy, Nxy] over each electrode (N/m), shape (n_electrodes, 3)")
      .def_property_readonly("load_position_m", [](const Result& r) {
        std::vector<std::array<double, 2>> rows;
        for (const auto& l : r.loads) rows.push_back({l.x_m, l.y_m});
        return to_array(rows);
      }, "load positions (m), shape (n_loads, 2)")
      .def_property_readonly("load_force_N", [](const Result& r) {
        std::vector<double> v;
        for (const auto& l : r.loads) v.push_back(l.force_N);
        return to_array(v);
      }, "total vertical force of each load (N), shape (n_loads,)")
      .def_property_readonly("load_deflection_m", [](const Result& r) {
        std::vector<double> v;
        for (const auto& l : r.loads) v.push_back(l.deflection_m);
        return to_array(v);
      }, "w at each load position (m), shape (n_loads,)")
      .def_property_readonly("sample_position_m", [](const Result& r) {
        std::vector<std::array<double, 2>> rows;
        for (const auto& s : r.samples) rows.push_back({s.x_m, s.y_m});
        return to_array(rows);
      }, "sample points (m), shape (n_samples, 2)")
      .def_property_readonly("displacement_m", [=](const Result& r) {
        return samples3(r, [](const SampleResult& s) { return std::array<double, 3>{s.ux_m, s.uy_m, s.w_m}; });
      }, "[ux, uy, w] at the sample points (m), shape (n_samples, 3)")
      .def_property_readonly("deflection_m", [](const Result& r) {
        std::vector<double> v;
        for (const auto& s : r.samples) v.push_back(s.w_m);
        return to_array(v);
      }, "w at the sample points (m), shape (n_samples,)")
      .def_property_readonly("membrane_force_global_N_per_m", [=](const Result& r) {
        return samples3(r, [](const SampleResult& s) { return s.membrane_force.global; });
      }, "[Nxx, Nyy, Nxy] at the sample points (N/m), shape (n_samples, 3)")
      .def_property_readonly("membrane_force_material_N_per_m", [=](const Result& r) {
        return samples3(r, [](const SampleResult& s) { return s.membrane_force.material; });
      }, "[N11, N22, N12] at the sample points, 1 = draw direction (N/m), shape (n_samples, 3)")
      .def_property_readonly("membrane_force_polar_N_per_m", [=](const Result& r) {
        return samples3(r, [](const SampleResult& s) { return s.membrane_force.polar; });
      }, "[Nr, Ntheta, Nrtheta] about the first load (N/m), shape (n_samples, 3)")
      .def_property_readonly("charge_density_C_per_m2", [](const Result& r) {
        std::vector<double> v;
        for (const auto& s : r.samples) v.push_back(s.charge_density_C_per_m2);
        return to_array(v);
      }, "d31 sigma11 + d32 sigma22 at the sample points (C/m^2), shape (n_samples,)")
      .def("__repr__", [](const Result& r) {
        return "<SolveResult " + pvdf::fem::status_name(r.summary.status) + ", " + std::to_string(r.summary.n_dofs) +
               " DOFs, estimated relative error " + std::to_string(r.summary.estimated_relative_error) + ">";
      });
}

void bind_sweep_batch(py::module_& m) {
  using pvdf::fem::ProbeSolution;
  const auto ok = [](const ProbeSolution& s) { return pvdf::fem::usable(s.status); };
  const auto always = [](const ProbeSolution&) { return true; };
  py::class_<SweepBatch>(m, "ProbeSolutions", R"doc(N probe solves (ProbeSweep.solve). Arrays of length N; NaN where ``ok`` is False.)doc")
      .def("__len__", [](const SweepBatch& b) { return b.items.size(); })
      .def_property_readonly("ok", [](const SweepBatch& b) {
        py::array_t<bool> out(py::ssize_t(b.items.size()));
        for (std::size_t i = 0; i < b.items.size(); ++i) out.mutable_data()[i] = pvdf::fem::usable(b.items[i].status);
        return out;
      })
      .def_property_readonly("status", [](const SweepBatch& b) {
        std::vector<std::string> v;
        for (const auto& s : b.items) v.push_back(pvdf::fem::status_name(s.status));
        return v;
      })
      .def_property_readonly("message", [](const SweepBatch& b) {
        std::vector<std::string> v;
        for (const auto& s : b.items) v.push_back(s.message);
        return v;
      })
      .def_property_readonly("x_m", [=](const SweepBatch& b) { return column(b.items, [](const ProbeSolution& s) { return s.x_m; }, always); })
      .def_property_readonly("y_m", [=](const SweepBatch& b) { return column(b.items, [](const ProbeSolution& s) { return s.y_m; }, always); })
      .def_property_readonly("force_N", [=](const SweepBatch& b) { return column(b.items, [](const ProbeSolution& s) { return s.force_N; }, always); })
      .def_property_readonly("deflection_at_load_m", [=](const SweepBatch& b) { return column(b.items, [](const ProbeSolution& s) { return s.deflection_at_load_m; }, ok); }, "w at the probe centre (m), shape (N,)")
      .def_property_readonly("rim_reaction_N", [=](const SweepBatch& b) { return column(b.items, [](const ProbeSolution& s) { return s.rim_reaction_N; }, ok); })
      .def_property_readonly("charge_C", [](const SweepBatch& b) {
        py::array_t<double> out({py::ssize_t(b.items.size()), py::ssize_t(b.n_electrodes)});
        double* p = out.mutable_data();
        for (const auto& s : b.items) {
          for (std::size_t k = 0; k < b.n_electrodes; ++k) {
            *p++ = pvdf::fem::usable(s.status) && k < s.charge_C.size() ? s.charge_C[k] : nan;
          }
        }
        return out;
      }, "electrode charges (C), shape (N, n_electrodes)");
}
#endif

}  // namespace

void bind_results(py::module_& m) {
  bind_locations(m);
  bind_design(m);
  bind_restored(m);
#ifdef PVDF_PYTHON_WITH_FEM
  bind_solve_result(m);
  bind_sweep_batch(m);
#endif
}

}  // namespace pvdf::python
