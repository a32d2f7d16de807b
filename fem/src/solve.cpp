// The film solver's method (FilmSolver::run: setup, model, refinement, outputs) and the public
// entry points of pvdf::fem: solve(), the model and status names, options from a scene. docs/fem.md
// explains every equation; the parts are listed in film_solver.hpp (the test checks: checks.cpp).
#include "film_solver.hpp"
#include "pvdf/fem/plausibility.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/resources.hpp"

#include <cmath>
#include <cstdlib>
#include <functional>

namespace pvdf::fem {

// ------------------------------------------------------------------------------ names

Model parse_model(const std::string& text, const std::string& what) {
  if (text == "auto" || text == "automatic") return Model::automatic;
  if (text == "linear") return Model::linear;
  if (text == "von-karman" || text == "von_karman" || text == "vk") return Model::von_karman;
  if (text == "large-rotation" || text == "large_rotation") return Model::large_rotation;
  throw InputError(what + " = '" + text + "' is not a model; use auto, linear, von-karman or large-rotation");
}

std::string model_name(Model model) {
  switch (model) {
    case Model::automatic: return "auto";
    case Model::linear: return "linear";
    case Model::von_karman: return "von-karman";
    case Model::large_rotation: return "large-rotation";
  }
  return "?";
}

std::string status_name(Status status) {
  switch (status) {
    case Status::converged: return "converged";
    case Status::tolerance_not_met: return "tolerance-not-met";
    case Status::no_convergence: return "no-convergence";
    case Status::not_finite: return "not-finite";
    case Status::linear_solver_failed: return "linear-solver-failed";
  }
  return "?";
}

Options options_from_scene(const pvdf::Scene& scene) {
  Options o;
  o.model = parse_model(scene.model.kinematics, scene.source + ": model.kinematics");
  o.tolerance = scene.model.tolerance;
  o.max_refinements = scene.model.max_refinements;
  return o;
}

namespace detail {

// The method, step by step (step-15 shape): the first mesh and the model; then cycles of estimate
// (dual-weighted residual, goal_error.cpp), model switches on the same mesh where the estimate asks
// (bending, the clamp-layer condition), refine and solve, until the estimated output error meets
// the tolerance (adaptivity.cpp); then the outputs. A failure of any Newton solve ends it with
// that status and no fields.
Result FilmSolver::run() {
  const auto t_start = Clock::now();
  reuse_factorization_ = true;  // chord steps while Newton contracts >= 10x per step (see newton())
  narrow_tangent_ = true;       // the tangent without bending's face couplings while bending is left out
  setup_system();
  if (total_force_ == 0) return zero_load_result(t_start);

  // 1. The model (requested, or the `auto` rule's trial solves) on the first mesh.
  Model model = options_.model;
  std::string where;
  NewtonOutcome o = solve_on_first_mesh(model, where);
  if (o.status != Status::converged) return failure_result(o, where, t_start);
  if (!options_.vtu_directory.empty()) vtu_files_.push_back(write_vtu(0, model));

  // 2. Estimate, adapt the model, refine and solve, until the estimated output error is met.
  describe_estimator();
  for (int& cycle = summary_.refinement_cycles;;) {  // cycle: meshes solved after the first
    goal_ = estimate_goal_errors(solution_, model, true);
    const ModelStep step = adapt_model(model, o, where);
    if (step == ModelStep::failed) return failure_result(o, where, t_start);
    if (step == ModelStep::changed) continue;  // solved again on this mesh: estimate again
    if (accurate_enough()) break;
    refine_mesh(solution_, options_.refinement == Refinement::goal ? &goal_.indicators : nullptr);
    o = solve_on_refined_mesh(model, where);
    if (o.status != Status::converged) return failure_result(o, where, t_start);
    ++cycle;
    if (!options_.vtu_directory.empty()) vtu_files_.push_back(write_vtu(cycle, model));
  }

  // 3. Outputs, with their error bars.
  return output_results(model, t_start);
}

// The model: requested (solved from the flat film), or the `auto` rule's trial solves; the
// converged state is solution_.
NewtonOutcome FilmSolver::solve_on_first_mesh(Model& model, std::string& where) {
  Summary& s = summary_;
  Vector<double> u(dof_handler_.n_dofs());
  NewtonOutcome o;
  if (model == Model::automatic) {
    const KinematicsChoice c = choose_kinematics(u);
    o = c.outcome;
    if (o.status != Status::converged) {
      where = c.where;
      return o;
    }
    model = c.model;
    s.model_reason = c.reason;
    kinematics_model_error_ = c.relative_model_error;
  } else {
    s.model_reason = "requested";
    o = solve_from_flat(model, u);
    if (o.status != Status::converged) {
      where = model_name(model) + " solve";
      return o;
    }
  }
  s.model = model;
  solution_ = u;
  return o;
}

// The model's reasons and the final status; the outputs (never NaN: a non-finite output is a
// numerical failure) with their error bars, refused when physically absurd.
Result FilmSolver::output_results(Model model, Clock::time_point t_start) {
  Summary& s = summary_;
  if (!clamp_reason_.empty()) s.model_reason += "; " + clamp_reason_;
  if (!bending_reason_.empty()) s.model_reason += "; " + bending_reason_;
  if (clamp_layer_ && !clamp_share_reason_.empty()) s.model_reason += "; " + clamp_share_reason_;
  set_final_status();
  s.n_dofs = dof_handler_.n_dofs();
  s.n_cells = triangulation_.n_active_cells();
  Result result;
  fill_result(result, model);
  add_error_estimates(result);
  bool finite = std::isfinite(result.max_deflection_m) && std::isfinite(result.rim_reaction_N);
  for (const auto& e : result.electrodes)
    for (double v : e.mean_membrane_force_material_N_per_m) finite = finite && std::isfinite(v);
  if (!finite) {
    NewtonOutcome o;
    o.status = Status::not_finite;
    o.message = "non-finite outputs";
    return failure_result(o, "outputs", t_start);
  }
  result.vtu_files = vtu_files_;
  if (!vtu_files_.empty()) result.vtu_files.push_back(options_.vtu_directory + "/film.pvd");
  s.wall_s = seconds_since(t_start);
  result.summary = s;
  enforce_physical_bounds(scene_, result);  // never "converged" for an absurd answer (checks.cpp)
  return result;
}

// Nothing loads the film: the flat, pretensioned state is the exact solution.
Result FilmSolver::zero_load_result(Clock::time_point t_start) {
  Summary& s = summary_;
  Result result;
  s.status = Status::converged;
  s.model = options_.model == Model::automatic ? Model::linear : options_.model;
  s.model_reason = "no load: the flat state is exact for every model";
  s.message = "zero load";
  s.error_estimator = "exact (no load)";
  s.estimated_relative_error = 0;
  s.n_dofs = dof_handler_.n_dofs();
  s.n_cells = triangulation_.n_active_cells();
  fill_result(result, s.model);
  s.wall_s = seconds_since(t_start);
  result.summary = s;
  return result;
}

// A numerical failure: the status and why, no fields (docs: fields only when usable()).
Result FilmSolver::failure_result(const NewtonOutcome& o, const std::string& where, Clock::time_point t_start) {
  Summary& s = summary_;
  s.status = o.status;
  s.message = where + ": " + o.message;
  s.n_dofs = dof_handler_.n_dofs();
  s.n_cells = triangulation_.n_active_cells();
  s.final_residual_norm = o.residual_norm;
  s.estimated_relative_error = 1.0;
  s.wall_s = seconds_since(t_start);
  Result result;
  result.summary = s;
  return result;
}

// Status from the estimate: converged when it meets the tolerance (or no refinement was asked
// for), tolerance_not_met when the refinement cap stopped it first.
void FilmSolver::set_final_status() {
  Summary& s = summary_;
  const double estimate = s.estimated_relative_error;
  const int max_cycles = options_.adaptive ? options_.max_refinements : 0;
  if (max_cycles == 0) {
    s.status = Status::converged;
    s.message = "Newton converged; no refinement requested, output error not estimated";
  } else if (dof_cap_reached_ && estimate > options_.tolerance) {
    s.status = Status::tolerance_not_met;
    s.message = "Newton converged but the estimated output error " + fmt(estimate) + " > tolerance " +
                fmt(options_.tolerance) + ": refining further would pass max_dofs = " + std::to_string(options_.max_dofs);
  } else if (estimate <= options_.tolerance) {
    s.status = Status::converged;
    s.message = "Newton converged; estimated output error " + fmt(estimate) + " <= tolerance " + fmt(options_.tolerance);
  } else {
    s.status = Status::tolerance_not_met;
    s.message = "Newton converged but the estimated output error " + fmt(estimate) + " > tolerance " +
                fmt(options_.tolerance) + " after " + std::to_string(s.refinement_cycles) + " refinements";
  }
}

// Per-output error bars from the estimates on the final mesh: |discretization| + |model| (the
// kinematics part, relative, scaled by each output).
void FilmSolver::add_error_estimates(Result& result) const {
  auto bar = [this](const std::vector<double>& disc, const std::vector<double>& model, std::size_t j, double value) {
    double e = 0;
    if (j < disc.size() && std::isfinite(disc[j])) e += std::abs(disc[j]);
    else e += std::abs(value);  // not estimated: the whole value
    if (j < model.size() && std::isfinite(model[j])) e += std::abs(model[j]);
    return e + kinematics_model_error_ * std::abs(value);
  };
  auto at = [](const std::vector<double>& v, std::size_t j) { return j < v.size() && std::isfinite(v[j]) ? v[j] : 0.0; };
  std::vector<double> charges;
  for (const auto& e : result.electrodes) charges.push_back(e.charge_C);
  const std::vector<double> clamp_error = clamp_layer_charge_error_C(charges);  // 0 without the condition
  for (std::size_t k = 0; k < result.electrodes.size(); ++k) {
    ElectrodeResult& e = result.electrodes[k];
    e.charge_error_C = clamp_error[k] + bar(goal_.charge_discretization_C, goal_.charge_model_C, k, e.charge_C);
    e.charge_discretization_error_C = at(goal_.charge_discretization_C, k);
    e.charge_model_error_C = at(goal_.charge_model_C, k);
  }
  for (std::size_t l = 0; l < result.loads.size(); ++l) {
    LoadResult& r = result.loads[l];
    r.deflection_error_m = bar(goal_.deflection_discretization_m, goal_.deflection_model_m, l, r.deflection_m);
    r.deflection_discretization_error_m = at(goal_.deflection_discretization_m, l);
    r.deflection_model_error_m = at(goal_.deflection_model_m, l);
  }
}

namespace {

// The `auto` rule's a-priori step decides before the solver is built (bending changes its
// sparsity); the kinematics, if still open, are chosen by run() on the first mesh.
Result run_with_model_choice(const pvdf::Scene& scene, const Options& options,
                             const std::function<void(FilmSolver&)>& make_grid) {
  const double cpu0_s = pvdf::process_cpu_s();
  const ModelChoice choice = choose_model(scene, options);
  Options used = with_clamp_layer_switch(options);  // the PVDF_CLAMP_LAYER bench switch (clamp_layer.cpp)
  used.model = choice.model;
  used.include_bending = choice.include_bending;
  FilmSolver solver(scene, used);
  // `auto` left bending out a priori: the solver keeps its operator so that the adjoint-weighted
  // estimate of its effect decides on every mesh (bending switched on where it matters).
  const bool bending_by_estimate = options.model == Model::automatic && options.include_bending && !choice.include_bending;
  if (bending_by_estimate) solver.keep_bending_pattern(true);
  else if (!used.include_bending && options.estimate_bending_effect) solver.keep_bending_pattern(false);
  make_grid(solver);
  Result r = solver.run();
  const bool decided_a_priori = options.model == Model::automatic && choice.model != Model::automatic;
  std::string& reason = r.summary.model_reason;
  if (decided_a_priori) reason = reason.rfind("requested", 0) == 0 ? choice.reason + reason.substr(9) : choice.reason;
  r.summary.cpu_s = pvdf::process_cpu_s() - cpu0_s;
  return r;
}

}  // namespace

}  // namespace detail

Result solve(const pvdf::Scene& scene, const Options& options) {
  return detail::run_with_model_choice(scene, options, [](detail::FilmSolver& s) { s.make_grid(); });
}

Result solve(const pvdf::Scene& scene, const pvdf::mesh::FilmMesh& mesh, const Options& options) {
  return detail::run_with_model_choice(scene, options, [&mesh](detail::FilmSolver& s) { s.make_grid_from(mesh); });
}

}  // namespace pvdf::fem
