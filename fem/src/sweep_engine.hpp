// Internal to pvdf::fem, free of deal.II: what ProbeSweep (probe_sweep.cpp) uses from the solver —
// the `auto` model rule (model_choice.cpp) and the fixed-mesh probe solver (sweep_engine.cpp).
// The solver's own parts share film_solver.hpp, which includes this header.
#pragma once

#include "pvdf/core/scene.hpp"
#include "pvdf/fem/probe_sweep.hpp"
#include "pvdf/fem/solver.hpp"

#include "clamp_layer.hpp"  // the condition's share of the tolerance and its bench switch

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace pvdf::fem::detail {

/// A-priori sizes of the one mesh a sweep uses for every probe position (m).
struct SweepMeshSizes {
  double region_size_m = 0;     ///< largest cell size anywhere (also under every probe)
  double electrode_size_m = 0;  ///< cell size on the electrodes
  /// Cell size under the probe's footprint (0 = none): each probe is then solved on the sweep mesh
  /// refined around its footprint (sizes <= max(probe_size_m, grading x distance)); states stay on
  /// the sweep mesh, interpolated to and from each probe's mesh.
  double probe_size_m = 0;
  double grading = 1.0;         ///< away from the electrodes: size <= grading x distance
  int global_refinements = 0;   ///< uniform refinements after the grading
  /// Grading toward the clamped rim (0 = none): cells within the arc are refined until their size
  /// is <= max(rim_size_m, rim_grading x distance to the rim), so the bending boundary layer
  /// sqrt(D/N) at the clamp is resolved. The arc is the part of the rim seen from the film centre
  /// within rim_half_angle_rad of the direction rim_angle_rad (>= pi: the whole rim).
  double rim_size_m = 0;
  double rim_grading = 1.0;
  double rim_angle_rad = 0;
  double rim_half_angle_rad = 4.0;
};

/// The solver options of a sweep engine's mesh: `options` with the engine's model and bending, no
/// adaptivity and no rim grading of its own, and the mesh sizes of `sizes`. Every ProbeSolver that
/// must number its DOFs as an engine does (the engine itself, the atlas's copies of its mesh) is
/// built from these.
Options engine_solver_options(const Options& options, Model model, bool include_bending, const SweepMeshSizes& sizes);

/// Outcome of one probe solve on the sweep mesh.
struct EngineSolution {
  Status status = Status::no_convergence;
  std::string message;
  int newton_iterations = 0;
  int factorizations = 0;
  bool warm_started = false;
  double deflection_at_load_m = 0;
  double rim_reaction_N = 0;
  std::vector<double> charge_C;
  std::vector<std::array<double, 3>> mean_membrane_force_material_N_per_m;

  /// Goal-oriented (adjoint-weighted residual) error estimates of this probe's outputs, filled
  /// when the engine was built with estimate_errors (docs/fem.md §6). Each is a signed estimate of
  /// (exact − computed) for that output, in its unit; take |·| for an error bar.
  bool errors_estimated = false;
  /// Discretization error of each electrode's charge on the engine's mesh (C), per electrode.
  std::vector<double> charge_error_discretization_C;
  /// What the bending term would change in each charge when the engine runs without bending (C);
  /// zeros when the engine keeps bending (the richest model it has).
  std::vector<double> charge_error_model_C;
  double deflection_error_discretization_m = 0;  ///< of deflection_at_load_m (m)
  double deflection_error_model_m = 0;           ///< bending's effect on deflection_at_load_m (m); 0 with bending

  /// SweepEngine::solve_clamp_layer only (docs/fem.md §3.4). `clamp_layer`: the condition was tried
  /// (false: not wanted here, e.g. the layer is thinner than tolerance/10 of the radius, or
  /// Options::clamp_layer_condition is off; nothing else is filled). Its estimate of what it leaves
  /// out: relative to the largest charge (1 = its lagged values did not settle) and each
  /// electrode's share (C, by magnitude, to be added to the discretization and model parts).
  bool clamp_layer = false;
  bool clamp_layer_settled = false;
  bool clamp_layer_bending = false;  ///< bending kept with it (its remaining effect exceeded tolerance/2)
  double clamp_layer_relative_error = 0;
  std::vector<double> charge_error_clamp_layer_C;
  double clamp_layer_width_m = 0;    ///< largest l_b along the rim (m)
  int clamp_layer_passes = 0;
};

/// Accumulated cost of the probe solves: the public pvdf::fem::SweepTiming.
using EngineTiming = SweepTiming;

class SweepEngine {
 public:
  /// Builds the mesh (graded to the electrodes, nowhere coarser than sizes.region_size_m; from `mesh`
  /// when given, else the built-in one), the
  /// DOFs, constraints and sparsity for `model` (with/without bending). The scene's loads are ignored.
  /// With `estimate_errors`, every converged solve() also fills the EngineSolution error fields:
  /// one extra factorization of the converged tangent (two without bending: the bending model error
  /// uses the tangent with bending), one back substitution per output, and one residual evaluation
  /// in the Q(p+1) space of the same mesh.
  SweepEngine(const pvdf::Scene& scene, const Options& options, Model model, bool include_bending,
              const SweepMeshSizes& sizes, bool estimate_errors = false,
              const pvdf::mesh::FilmMesh* mesh = nullptr);
  ~SweepEngine();
  SweepEngine(const SweepEngine&) = delete;
  SweepEngine& operator=(const SweepEngine&) = delete;

  std::size_t n_dofs() const;
  std::size_t n_cells() const;
  EngineTiming timing() const;

  /// One vertical probe (x, y, F). `state` (size n_dofs) is the starting guess when `warm`;
  /// if it was converged under another force `state_force_N` (> 0), it is first scaled by the
  /// pure-membrane law (w by (F/F0)^(1/3), in-plane displacements by (F/F0)^(2/3)). On a usable
  /// outcome `state` receives the converged state (else it is left as given). A failed warm start
  /// falls back to the continuation from the flat film unless `cold_fallback` is false.
  EngineSolution solve(double x_m, double y_m, double force_N, std::vector<double>& state, bool warm,
                       double state_force_N = 0, bool cold_fallback = true);

  /// Forgets what earlier solves left in the solvers (ProbeSolver::forget_history, the
  /// footprint-refined probe mesh's too): the next solve depends only on its own inputs.
  void forget_history();

  /// The last probe solve() converged (same position and force, same mesh) again with the clamp's
  /// bending layer as a boundary condition (docs/fem.md §3.4), from its converged state; the
  /// warm-start state solve() returned is not touched. Needs an engine built with estimate_errors
  /// and without bending. With the condition not wanted, `clamp_layer` is false and the status
  /// no_convergence; a usable outcome carries solve()'s estimates (the model part: bending's
  /// remaining effect with the rim terms dropped) and the condition's own.
  EngineSolution solve_clamp_layer();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Width of the bending boundary layer at the clamped rim, sqrt(D/N), with N the larger of the
/// pretension and the rim membrane force of the point-loaded membrane under force_N
/// (model_choice.cpp): the rim cell size that resolves it.
double rim_boundary_layer_m(const pvdf::Scene& scene, double force_N);

/// What the `auto` rule decided.
struct ModelChoice {
  /// Kinematics; `automatic` = still open: chosen by trial solves on the solve's first mesh
  /// (FilmSolver::run's first step, only when no force range is given).
  Model model = Model::automatic;
  bool include_bending = true;
  std::string reason;  ///< why (empty while the kinematics are open)
};

/// Probe forces a sweep serves (N), for the `auto` rule.
struct ForceRange {
  double smallest_N = 0;
  double largest_N = 0;
};

/// The `auto` rule (docs/fem.md §2), the one place it is decided, for pvdf::fem::solve and
/// ProbeSweep. A requested model is returned as is. Otherwise:
///  1. a priori: bending is negligible for the loads (boundary layer sqrt(D/N) against the probe
///     radius) -> large-rotation membrane without bending;
///  2. on the first mesh, by trial solves: linear plate if its w_max/h <= 0.5·sqrt(tolerance), else
///     von Kármán if it agrees with large rotation within tolerance/4, else large rotation.
/// Without `sweep`, step 1 uses the scene's loads and step 2 is left to the solve (model stays
/// `automatic`). With `sweep` (a centred probe), bending is judged at the smallest force (its
/// layer is widest there), step 2 runs now at the largest force, and a film whose bending is
/// negligible at the largest force only keeps bending with large-rotation kinematics.
ModelChoice choose_model(const pvdf::Scene& scene, const Options& options, const ForceRange* sweep = nullptr);

/// The bending part of `auto` decided by the dual-weighted residual estimate of bending's effect
/// (goal_error.cpp): bending may be left out when that relative effect on every output is at most
/// half the tolerance (the other half is the discretization's). `reason` quotes the numbers.
bool bending_may_be_left_out(double relative_bending_effect, double tolerance, std::string& reason);

}  // namespace pvdf::fem::detail
