// Internal to pvdf::fem: ProbeSolver, the fixed-mesh probe solver a SweepEngine owns (and the
// atlas's copies of its mesh, atlas_sweep.cpp). It holds one FilmSolver whose mesh is built once
// without any probe load; one probe is then moved over it, the DOFs, sparsity and symbolic
// factorization kept. Implemented in sweep_engine.cpp (a friend of FilmSolver: it drives the
// solver's assembly, Newton and outputs on that fixed mesh instead of FilmSolver::run()).
#pragma once

#include "film_solver.hpp"

namespace pvdf::fem::detail {

class ProbeSolver {
 public:
  using GoalErrors = FilmSolver::GoalErrors;
  using ClampLayerProbe = FilmSolver::ClampLayerProbe;

  /// The sweep mesh for `sizes` (from `mesh` when given, else the built-in one), graded to the
  /// electrodes of `scene` (whose loads are ignored), and its DOFs, constraints and sparsity.
  /// `keep_bending_pattern`: the bending operator is assembled although `options` leave bending out
  /// (to estimate its effect, estimate_errors; FilmSolver::keep_bending_pattern(false)).
  ProbeSolver(const pvdf::Scene& scene, const Options& options, const SweepMeshSizes& sizes,
              bool keep_bending_pattern, const pvdf::mesh::FilmMesh* mesh = nullptr);

  /// The probe (x, y, F): its load vector on the fixed mesh.
  void set_probe(double x_m, double y_m, double force_N);
  /// The current probe solved into u (warm: from u; see sweep_engine.cpp).
  NewtonOutcome solve(Model model, Vector<double>& u, bool warm, int& newton_iterations, bool& warm_used,
                      bool cold_fallback = true);
  /// What a sweep keeps of the converged state u: charges, mean forces, w under the probe, rim reaction.
  void outputs(const Vector<double>& u, Model model, EngineSolution& out) { solver_.probe_outputs(u, model, out); }
  /// The dual-weighted residual estimates of those outputs (FilmSolver::estimate_goal_errors, the
  /// cheap adjoint).
  GoalErrors estimate_errors(const Vector<double>& u, Model model) { return solver_.estimate_goal_errors(u, model); }

  /// The clamp-layer condition at the current probe, from its converged plain-clamp state u
  /// (FilmSolver::solve_probe_with_clamp_layer); it stays on until reset_clamp_layer().
  ClampLayerProbe solve_with_clamp_layer(Model model, Vector<double>& u, GoalErrors& goal) {
    return solver_.solve_probe_with_clamp_layer(model, u, goal);
  }
  bool clamp_layer_on() const { return solver_.clamp_layer_; }
  void reset_clamp_layer() { solver_.reset_clamp_layer(); }
  /// A cold probe solve's start: no chord step from an earlier probe's tangent, no LDLᵀ-first
  /// countdown left by one (TangentFactorization::forget_history).
  void forget_history() {
    solver_.factorization_.forget_history();
    solver_.chord_first_step_ = false;
  }

  /// Multiplies the in-plane DOFs of u by inplane_factor and its w DOFs by w_factor.
  void scale_state(Vector<double>& u, double inplane_factor, double w_factor) const {
    solver_.scale_state(u, inplane_factor, w_factor);
  }
  /// u (on this mesh) = the interpolant of `other`'s state u_other, both meshes refined from the same
  /// coarse mesh (the sweep mesh and a probe's footprint-refined copy of it).
  void interpolate_state_from(const ProbeSolver& other, const Vector<double>& u_other, Vector<double>& u) const;
  /// Largest size (diameter/√2) of the active cells that reach within `radius_m` of (x, y).
  double largest_cell_near(double x_m, double y_m, double radius_m) const;

  const FilmSolver& film() const { return solver_; }
  std::size_t n_dofs() const { return solver_.n_dofs(); }
  std::size_t n_cells() const { return solver_.n_cells(); }
  int n_factorizations() const { return solver_.n_factorizations(); }
  const Summary& summary() const { return solver_.summary(); }
  /// Time spent integrating probe load vectors (s).
  double load_vector_s() const { return load_vector_s_; }

 private:
  FilmSolver solver_;
  double load_vector_s_ = 0;
};

}  // namespace pvdf::fem::detail
