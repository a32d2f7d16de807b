// The probe solver behind ProbeSweep (docs/bench-fem.md, "ProbeSweep"; docs/map-generation.md §6):
// one sweep mesh graded to the electrodes and built without any probe. Each probe is solved on a
// copy of it refined around that probe's footprint (or, without a footprint size, on the sweep mesh
// itself, whose DOFs, sparsity and symbolic factorization are then kept), warm-started from a
// neighbour's state stored on the sweep mesh and scaled by the pure-membrane laws across forces
// (pvdf/core/membrane_scaling.hpp).
#include "pvdf/core/constants.hpp"
#include "probe_solver.hpp"

#include "pvdf/core/membrane_scaling.hpp"

#include <deal.II/numerics/vector_tools.h>

#include <algorithm>
#include <cmath>

namespace pvdf::fem::detail {

using namespace dealii;

// The sweep mesh is graded to the electrodes only (the scene copy given to this solver carries
// no loads), capped everywhere by the coarse size, which is therefore the size under any probe.
// A given mesh (map --mesh) is the starting mesh of that grading.
ProbeSolver::ProbeSolver(const pvdf::Scene& scene, const Options& options, const SweepMeshSizes& sizes,
                         bool keep_bending_pattern, const pvdf::mesh::FilmMesh* mesh)
    : solver_(scene, options) {
  FilmSolver& s = solver_;
  if (keep_bending_pattern) s.keep_bending_pattern(false);
  // Newton's tangent without bending's face couplings while bending is left out, as solve's (round
  // 23: a quarter of the Cholesky's flops; the bending estimate's K + B has its own, wide, pattern).
  s.narrow_tangent_ = true;
  s.keep_k_plus_b_ = true;
  if (mesh) s.make_grid_from(*mesh);
  else s.make_grid();
  if (sizes.rim_size_m > 0) {
    s.refine_toward_rim(sizes.rim_size_m, sizes.rim_grading, sizes.rim_angle_rad, sizes.rim_half_angle_rad, nullptr);
    s.set_material_ids();
  }
  s.setup_system();
}

// A new probe position or force changes only the load vector: it is re-integrated on the fixed
// mesh (cut cells sub-sampled, then scaled so the total vertical force is exactly F).
void ProbeSolver::set_probe(double x_m, double y_m, double force_N) {
  FilmSolver& s = solver_;
  const auto t0 = Clock::now();
  LoadCase c;
  c.probe = true;
  c.center = Point<dim>(x_m, y_m);
  c.radius_m = s.scene_.probe.radius_m;
  c.force_N = force_N;
  s.loads_ = {c};
  s.total_force_ = std::abs(force_N);
  s.assemble_load_vector();
  load_vector_s_ += seconds_since(t0);
}

// Warm: Newton from the given state (no continuation: a neighbour's state is already tensioned);
// if that fails (unless cold_fallback is false: then the failure is returned, u as given), or when
// cold, the artificial-pretension continuation from the flat film.
NewtonOutcome ProbeSolver::solve(Model model, Vector<double>& u, bool warm, int& newton_iterations, bool& warm_used,
                                 bool cold_fallback) {
  FilmSolver& s = solver_;
  const int before = s.summary_.newton_iterations;
  warm_used = false;
  s.reuse_factorization_ = true;
  if (warm) {
    // The warm state is a neighbour's converged one: its last factorized tangent is a good chord.
    s.chord_first_step_ = true;
    const int cap = s.options_.max_newton_iterations;
    s.options_.max_newton_iterations = cold_fallback ? std::min(cap, 25) : cap;
    Vector<double> start = u;
    NewtonOutcome o = s.newton(model, 0.0, u);
    s.options_.max_newton_iterations = cap;
    s.summary_.newton_iterations += o.iterations;
    if (o.status == Status::converged) {
      newton_iterations = s.summary_.newton_iterations - before;
      warm_used = true;
      return o;
    }
    u = start;
    if (!cold_fallback) {
      newton_iterations = s.summary_.newton_iterations - before;
      o.iterations = newton_iterations;
      return o;
    }
  }
  NewtonOutcome o = s.solve_from_flat(model, u);
  newton_iterations = s.summary_.newton_iterations - before;
  o.iterations = newton_iterations;
  return o;
}

// Multiplies the in-plane DOFs by inplane_factor and the w DOFs by w_factor (each DOF once); also
// the slack film's cone predictor (tension_field.cpp).
void FilmSolver::scale_state(Vector<double>& u, double inplane_factor, double w_factor) const {
  std::vector<bool> done(u.size(), false);
  std::vector<types::global_dof_index> dofs(fe_->n_dofs_per_cell());
  for (const auto& cell : dof_handler_.active_cell_iterators()) {
    cell->get_dof_indices(dofs);
    for (unsigned int i = 0; i < dofs.size(); ++i) {
      if (done[dofs[i]]) continue;
      done[dofs[i]] = true;
      u(dofs[i]) *= fe_->system_to_component_index(i).first == 2 ? w_factor : inplane_factor;
    }
  }
}

// u = the interpolant of other's u_other: cell by cell through the common coarse mesh (where this
// mesh is finer, by interpolation of other's cell; where coarser, of its children), then the
// hanging nodes and the clamped rim made consistent.
void ProbeSolver::interpolate_state_from(const ProbeSolver& other, const Vector<double>& u_other,
                                         Vector<double>& u) const {
  const FilmSolver& s = solver_;
  u.reinit(s.dof_handler_.n_dofs());
  VectorTools::interpolate_to_different_mesh(other.solver_.dof_handler_, u_other, s.dof_handler_, s.constraints_, u);
}

double ProbeSolver::largest_cell_near(double x_m, double y_m, double radius_m) const {
  const Point<dim> p(x_m, y_m);
  double largest = 0;
  for (const auto& cell : solver_.triangulation_.active_cell_iterators()) {
    const double half = 0.5 * cell->diameter();
    if (cell->center().distance(p) - half > radius_m) continue;
    largest = std::max(largest, cell->diameter() / std::sqrt(2.0));
  }
  return largest;
}

struct SweepEngine::Impl {
  pvdf::Scene scene;  // outlives the solver, which keeps a reference
  Options options;
  Model model = Model::large_rotation;
  std::unique_ptr<ProbeSolver> solver;  // the sweep mesh: every state lives on it
  EngineTiming timing;
  bool estimate_errors = false;
  bool include_bending = false;
  SweepMeshSizes sizes;
  const pvdf::mesh::FilmMesh* mesh = nullptr;
  // With sizes.probe_size_m > 0: the last probe's footprint-refined mesh (kept while the probe
  // stays at that position, e.g. across force levels) and its scene (with that probe as its load).
  pvdf::Scene probe_scene;
  std::unique_ptr<ProbeSolver> probe_solver;
  double probe_x = 0, probe_y = 0;
  Summary retired;  // time and iterations of the probe meshes already dropped
  int retired_factorizations = 0;
  double retired_load_s = 0;
  double probe_dofs_sum = 0;
  int probe_meshes = 0;
  // The last converged probe (for solve_clamp_layer): its solver (the sweep's or the probe's own)
  // and its state on that solver's mesh.
  ProbeSolver* last_solver = nullptr;
  Vector<double> last_u;
  void retire_probe_solver();
  ProbeSolver& probe_solver_at(double x_m, double y_m, double force_N);
};

void SweepEngine::Impl::retire_probe_solver() {
  if (!probe_solver) return;
  const Summary& s = probe_solver->summary();
  retired.assembly_s += s.assembly_s;
  retired.linear_solve_s += s.linear_solve_s;
  retired.newton_iterations += s.newton_iterations;
  retired_factorizations += probe_solver->n_factorizations();
  retired_load_s += probe_solver->load_vector_s();
  probe_solver.reset();
}

// The sweep mesh refined around this probe's footprint: the same construction as the sweep mesh
// (same coarse mesh, electrode and rim grading) with the probe as the scene's load, so the graded
// a-priori refinement (setup.cpp) also brings the cells under the footprint to sizes.probe_size_m.
ProbeSolver& SweepEngine::Impl::probe_solver_at(double x_m, double y_m, double force_N) {
  if (probe_solver && probe_x == x_m && probe_y == y_m) return *probe_solver;
  const auto t0 = Clock::now();
  retire_probe_solver();
  probe_scene = scene;
  pvdf::Load load;
  load.position_m = {x_m, y_m};
  load.force_N = force_N;
  probe_scene.loads = {load};
  Options o = options;
  o.probe_size_m = sizes.probe_size_m;
  probe_solver = std::make_unique<ProbeSolver>(probe_scene, o, sizes, estimate_errors && !include_bending, mesh);
  probe_x = x_m;
  probe_y = y_m;
  probe_dofs_sum += probe_solver->n_dofs();
  ++probe_meshes;
  timing.probe_mesh_s += seconds_since(t0);
  return *probe_solver;
}

Options engine_solver_options(const Options& options, Model model, bool include_bending, const SweepMeshSizes& sizes) {
  Options o = options;
  o.model = model;
  o.include_bending = include_bending;
  o.adaptive = false;
  o.grade_rim_for_bending = false;  // the rim model grades its own arc (sizes.rim_size_m)
  o.coarse_size_m = sizes.region_size_m;
  o.probe_size_m = sizes.region_size_m;
  o.electrode_size_m = sizes.electrode_size_m;
  o.grading = sizes.grading;
  o.initial_global_refinements = sizes.global_refinements;
  o.sample_points_m.clear();
  o.vtu_directory.clear();
  return o;
}

SweepEngine::SweepEngine(const pvdf::Scene& scene, const Options& options, Model model, bool include_bending,
                         const SweepMeshSizes& sizes, bool estimate_errors, const pvdf::mesh::FilmMesh* mesh)
    : impl_(std::make_unique<Impl>()) {
  impl_->estimate_errors = estimate_errors;
  impl_->include_bending = include_bending;
  impl_->sizes = sizes;
  impl_->mesh = mesh;
  impl_->scene = scene;
  impl_->scene.loads.clear();
  impl_->model = model;
  const Options o = engine_solver_options(options, model, include_bending, sizes);
  impl_->options = o;
  impl_->solver = std::make_unique<ProbeSolver>(impl_->scene, o, sizes, estimate_errors && !include_bending, mesh);
}

SweepEngine::~SweepEngine() = default;

std::size_t SweepEngine::n_dofs() const { return impl_->solver->n_dofs(); }
std::size_t SweepEngine::n_cells() const { return impl_->solver->n_cells(); }

EngineTiming SweepEngine::timing() const {
  EngineTiming t = impl_->timing;
  Summary s = impl_->solver->summary();
  int factorizations = impl_->solver->n_factorizations() + impl_->retired_factorizations;
  double load_s = impl_->solver->load_vector_s() + impl_->retired_load_s;
  s.assembly_s += impl_->retired.assembly_s;
  s.linear_solve_s += impl_->retired.linear_solve_s;
  s.newton_iterations += impl_->retired.newton_iterations;
  if (impl_->probe_solver) {
    const Summary& p = impl_->probe_solver->summary();
    s.assembly_s += p.assembly_s;
    s.linear_solve_s += p.linear_solve_s;
    s.newton_iterations += p.newton_iterations;
    factorizations += impl_->probe_solver->n_factorizations();
    load_s += impl_->probe_solver->load_vector_s();
  }
  t.assembly_s = s.assembly_s;
  t.linear_solve_s = s.linear_solve_s;
  t.load_vector_s = load_s;
  t.newton_iterations = s.newton_iterations;
  t.factorizations = factorizations;
  t.probe_mesh_dofs = impl_->probe_meshes > 0 ? impl_->probe_dofs_sum / impl_->probe_meshes : 0.0;
  return t;
}

EngineSolution SweepEngine::solve(double x_m, double y_m, double force_N, std::vector<double>& state, bool warm,
                                  double state_force_N, bool cold_fallback) {
  ProbeSolver& sweep = *impl_->solver;
  // Where the sweep mesh already resolves the footprint (near the electrodes, or the rim model's
  // graded cells near the clamp), the probe is solved on it directly.
  const double probe_size = impl_->sizes.probe_size_m;
  const bool refine_probe =
      probe_size > 0 && sweep.largest_cell_near(x_m, y_m, impl_->scene.probe.radius_m) > 1.3 * probe_size;
  impl_->last_solver = nullptr;
  ProbeSolver& fs = refine_probe ? impl_->probe_solver_at(x_m, y_m, force_N) : sweep;
  if (fs.clamp_layer_on()) fs.reset_clamp_layer();  // left on by solve_clamp_layer at the last probe
  EngineSolution out;
  const int factorizations_before = fs.n_factorizations();
  fs.set_probe(x_m, y_m, force_N);
  Vector<double> u(fs.n_dofs());
  const bool use_warm = warm && state.size() == sweep.n_dofs();
  if (use_warm) {
    Vector<double> s(sweep.n_dofs());
    std::copy(state.begin(), state.end(), s.begin());
    // Pure-membrane scaling (w ∝ F^(1/3), strains and in-plane displacements ∝ F^(2/3)): exact for
    // von Kármán without bending or pretension, a close start otherwise.
    if (state_force_N > 0 && state_force_N != force_N) {
      const double ratio = force_N / state_force_N;
      sweep.scale_state(s, pvdf::membrane_charge_factor(ratio), pvdf::membrane_deflection_factor(ratio));
    }
    if (refine_probe) {
      const auto t0 = Clock::now();
      fs.interpolate_state_from(sweep, s, u);
      impl_->timing.probe_mesh_s += seconds_since(t0);
    } else {
      u = s;
    }
  }
  NewtonOutcome o = fs.solve(impl_->model, u, use_warm, out.newton_iterations, out.warm_started, cold_fallback);
  out.status = o.status;
  out.message = o.message;
  out.factorizations = fs.n_factorizations() - factorizations_before;
  if (o.status != Status::converged) return out;
  const auto t0 = Clock::now();
  fs.outputs(u, impl_->model, out);
  if (impl_->estimate_errors) {
    const auto t_estimate = Clock::now();
    const ProbeSolver::GoalErrors ge = fs.estimate_errors(u, impl_->model);
    impl_->timing.estimate_s += seconds_since(t_estimate);
    out.errors_estimated = true;
    out.charge_error_discretization_C = ge.charge_discretization_C;
    out.charge_error_model_C = ge.charge_model_C;
    out.deflection_error_discretization_m = ge.deflection_discretization_m.empty() ? 0.0 : ge.deflection_discretization_m[0];
    out.deflection_error_model_m = ge.deflection_model_m.empty() ? 0.0 : ge.deflection_model_m[0];
  }
  impl_->timing.outputs_s += seconds_since(t0);
  bool finite = std::isfinite(out.deflection_at_load_m) && std::isfinite(out.rim_reaction_N);
  for (double q : out.charge_C) finite = finite && std::isfinite(q);
  if (!finite) {
    out.status = Status::not_finite;
    out.message = "non-finite outputs";
    return out;
  }
  impl_->last_solver = &fs;
  impl_->last_u = u;
  if (refine_probe) {
    const auto t1 = Clock::now();
    Vector<double> s;
    sweep.interpolate_state_from(fs, u, s);
    state.assign(s.begin(), s.end());
    impl_->timing.probe_mesh_s += seconds_since(t1);
  } else {
    state.assign(u.begin(), u.end());
  }
  return out;
}

// The clamp's bending layer as a boundary condition at the last probe (clamp_layer.cpp): on the
// probe's own mesh, from its converged plain-clamp state, so near the clamp the probe costs a few
// lagged Newton solves on the cheap model's mesh instead of a bending solve on a rim-graded one.
// The condition stays on in that solver until its next probe (solve() resets it).
void SweepEngine::forget_history() {
  impl_->solver->forget_history();
  if (impl_->probe_solver) impl_->probe_solver->forget_history();  // kept: it serves its position again
  impl_->last_solver = nullptr;
}

EngineSolution SweepEngine::solve_clamp_layer() {
  Impl& im = *impl_;
  EngineSolution out;
  out.message = "the clamp-layer condition is not wanted here";
  if (!im.last_solver || !im.estimate_errors || im.include_bending) return out;
  ProbeSolver& fs = *im.last_solver;
  im.last_solver = nullptr;
  Vector<double> u = im.last_u;
  const int factorizations_before = fs.n_factorizations();
  ProbeSolver::GoalErrors ge;
  // (its time, estimates included, is counted by the sweep as clamp_layer_s)
  const ProbeSolver::ClampLayerProbe c = fs.solve_with_clamp_layer(im.model, u, ge);
  out.newton_iterations = c.newton_iterations;
  out.factorizations = fs.n_factorizations() - factorizations_before;
  out.clamp_layer = c.wanted;
  if (!c.wanted) return out;
  out.status = c.outcome.status;
  out.message = c.outcome.message;
  out.warm_started = true;
  out.clamp_layer_bending = c.bending;
  out.clamp_layer_passes = c.passes;
  out.clamp_layer_width_m = c.width_m;
  if (c.outcome.status != Status::converged) return out;
  fs.outputs(u, im.model, out);
  out.errors_estimated = true;
  out.charge_error_discretization_C = ge.charge_discretization_C;
  out.charge_error_model_C = ge.charge_model_C;
  out.deflection_error_discretization_m = ge.deflection_discretization_m.empty() ? 0.0 : ge.deflection_discretization_m[0];
  out.deflection_error_model_m = ge.deflection_model_m.empty() ? 0.0 : ge.deflection_model_m[0];
  out.clamp_layer_settled = c.settled;
  out.clamp_layer_relative_error = c.estimate;
  out.charge_error_clamp_layer_C = c.charge_error_C;
  bool finite = std::isfinite(out.deflection_at_load_m) && std::isfinite(out.rim_reaction_N) &&
                std::isfinite(out.clamp_layer_relative_error);
  for (double q : out.charge_C) finite = finite && std::isfinite(q);
  if (!finite) {
    out.status = Status::not_finite;
    out.message = "non-finite outputs with the clamp-layer condition";
  }
  return out;
}

}  // namespace pvdf::fem::detail
