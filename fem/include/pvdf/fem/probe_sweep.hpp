// Many single-probe solves on one scene (charge maps, design sweeps): the setup (mesh, model
// choice, DOF numbering, sparsity, symbolic factorization) is done once; each probe solve
// warm-starts Newton from a neighbouring solution. Public types are std/pvdf only.
#pragma once

#include "pvdf/core/scene.hpp"
#include "pvdf/fem/solver.hpp"

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace pvdf::fem {

/// Settings of a probe sweep (public members with defaults).
struct SweepOptions {
  /// Model, tolerance and Newton settings. The mesh is chosen once at setup so that the
  /// electrode charges meet `solver.tolerance` for any served probe position.
  Options solver;
  /// Probe centres closer than this to the rim are not served (m); 0 = the probe radius.
  double rim_margin_m = 0.0;
  /// Force levels the sweep will be asked for (N); the setup chooses model and mesh for the
  /// largest and checks them at the smallest. Empty = the scene's first load force (or 1 N).
  std::vector<double> forces_N;
  /// Probe positions (film centre, on the first electrode, beside the last one, far) at which the
  /// setup evaluates the sweep's own error estimate to size the mesh (0..4; 0 = the first mesh is
  /// kept unchecked; every probe solve still carries its estimate).
  int n_setup_checks = 4;
  /// Sweep-mesh sizes (m) and grading; 0 = chosen from the tolerance (docs/bench-fem.md,
  /// "ProbeSweep"). The setup check still measures the error of whatever mesh results.
  double region_size_m = 0;
  double electrode_size_m = 0;
  double grading = 0;
  /// Cell size under the probe's footprint (m): each probe is solved on the sweep mesh refined
  /// around its own footprint to this size (graded away from it), so that a footprint smaller than
  /// the sweep's cells is resolved (docs/map-generation.md §6). 0 = the footprint's diameter, scaled
  /// with the tolerance like the other sizes; < 0 = no per-probe refinement (every probe on the one
  /// fixed mesh, as before; the charges then carry the footprint's discretization error, which the
  /// estimate does not see). Slack and wrinkling films get no per-probe refinement unless a
  /// size is given here (their warm starts must carry the film's cone from press to press).
  double probe_size_m = 0;
  /// Where a probe is solved again near the clamp, when the cheap model drops bending: `by_estimate`
  /// = where the cheap model's estimated model error exceeds its share of the tolerance, `never`,
  /// `always`. Such a probe first gets the clamp-layer condition on its own mesh (docs/fem.md §3.4;
  /// solver.clamp_layer_condition, PVDF_CLAMP_LAYER=rim-graded turns it off); the rim model
  /// (bending kept, mesh graded toward the clamped rim) solves it where the condition's estimate
  /// exceeds its share of the tolerance, its Newton fails or its lagged passes do not settle.
  enum class RimModel { by_estimate, never, always };
  RimModel rim_model = RimModel::by_estimate;
  /// Rim-graded mesh: cell size at the clamp (m) and growth with the distance from it; 0 = chosen
  /// from the bending boundary layer sqrt(D/N) (docs/map-generation.md §9).
  double rim_size_m = 0;
  double rim_grading = 0;
  /// Grade the sweep mesh itself toward the whole clamped rim down to this size (m), with
  /// `rim_grading` (0 = 0.5); 0 = not (the default). For a sweep that keeps bending at every probe
  /// (the charge-density atlas, docs/atlas.md §3), which then needs no rim model.
  double sweep_rim_size_m = 0;
  /// The rim mesh is graded along one arc of the rim only: the rim is cut into this many equal
  /// sectors (seen from the film centre) and a probe uses the mesh graded along its own sector and
  /// the two neighbours, built when first needed (1 = one mesh graded along the whole rim).
  int rim_sectors = 16;
  /// Per-probe adjoint-weighted error estimates (docs/fem.md §6): one or two extra factorizations
  /// per probe. Off (e.g. a fit that solves the same presses many times): probes carry no estimate
  /// (NaN) and no rim model is used; the setup still sizes the mesh with them and reports its estimate.
  bool estimate_errors = true;
  /// Called on the constructing thread after each setup check solve with the checks done and those
  /// planned for the present mesh (n_setup_checks; the setup may halve the mesh and check again), so
  /// that a caller can show a setup of minutes with an ETA (MapOptions::time_left). Null = none.
  std::function<void(std::size_t done, std::size_t planned)> on_setup_check;
  /// Start the sweep mesh from this mesh (e.g. read_msh of `pvdfkit mesh`'s file) instead of the
  /// built-in one: it is refined to the sizes above (never coarsened). Null = built-in mesh.
  std::shared_ptr<const pvdf::mesh::FilmMesh> mesh;
};

/// What the setup decided, for reports and map provenance.
struct SweepSetup {
  Model model = Model::linear;          ///< kinematics used for every probe solve
  std::string model_reason;             ///< why
  bool include_bending = true;          ///< whether bending stiffness is in the model
  std::size_t n_dofs = 0;
  std::size_t n_cells = 0;
  /// Largest per-probe estimate (ProbeSolution::estimated_relative_error) at the setup's check
  /// positions; every probe solve carries its own.
  double estimated_relative_error = 1;
  /// Its discretization part, largest at the check positions: what sizes the sweep mesh (≤ half
  /// the tolerance unless the halvings ran out). The model part is not reduced by the mesh: a probe
  /// whose model part exceeds half the tolerance goes on to the clamp-layer condition or the rim
  /// model, so estimated_relative_error (the cheap model's) may exceed the tolerance.
  double estimated_discretization_error = 1;
  std::string error_estimator;          ///< how the per-probe estimates are obtained
  double estimated_deflection_relative_error = 1;  ///< the same for deflection_at_load_m
  /// The rim model (bending kept, rim-graded mesh), built when the cheap model drops bending.
  bool rim_model_available = false;
  std::size_t rim_n_dofs = 0;           ///< of the first rim mesh built (0 = none yet)
  double rim_size_m = 0;                ///< cell size at the clamp of the rim mesh (m)
  /// Near-clamp probes try the clamp-layer condition before the rim model (Options::clamp_layer_condition
  /// after the PVDF_CLAMP_LAYER switch).
  bool clamp_layer_condition = false;
  double region_size_m = 0;             ///< largest cell size of the sweep mesh (also under any probe)
  double electrode_size_m = 0;          ///< cell size on the electrodes
  double probe_size_m = 0;              ///< cell size under each probe's footprint (0 = not refined there)
  double setup_s = 0;                   ///< wall time of the setup
};

/// Opaque solver state (nodal unknowns) for warm starts. Valid only for the ProbeSweep that
/// produced it; empty = start from the flat film.
struct SweepState {
  std::vector<double> dofs;
  double force_N = 0;                   ///< force it was converged under (warm starts across forces scale it)
  double x_m = 0, y_m = 0;              ///< probe centre it was converged for (m)
  /// Used as a warm start: the sweep first forgets what its earlier solves left in the solvers
  /// (chord tangents, factorization countdowns), as it does before a cold solve, so that the result
  /// depends only on this state and the press (the atlas's rows warm-started from a column chain,
  /// docs/atlas.md §3). Maps never set it.
  bool fresh_history = false;
  /// The rim model's last converged state in the same chain (empty = none) and where/under what force.
  std::vector<double> rim_dofs;
  double rim_force_N = 0, rim_x_m = 0, rim_y_m = 0;
  int rim_sector = -1;
};

/// Which model and mesh solved a probe (stored per map node as uint8).
enum class SweepModel : unsigned char {
  cheap = 0,  ///< the setup's model (SweepSetup::model, bending per SweepSetup::include_bending), sweep mesh
  rim = 1,    ///< the setup's kinematics with bending, on the mesh graded toward the clamped rim
  direct = 2, ///< a direct adaptive solve at this press alone (map generation, not the sweep)
  /// The cheap model's mesh and kinematics with the clamp's bending layer as a boundary condition
  /// (docs/fem.md §3.4; bending kept with it where its remaining effect exceeded tolerance/2).
  clamp_layer = 3
};

/// One probe solve.
struct ProbeSolution {
  Status status = Status::no_convergence;
  std::string message;                  ///< one line: diagnostic when not usable
  double x_m = 0, y_m = 0, force_N = 0;
  double deflection_at_load_m = 0;      ///< w at the probe centre (m)
  double rim_reaction_N = 0;            ///< vertical rim reaction (= force_N at equilibrium)
  /// Charge of every electrode, scene order (C): ∫ (d31 σ11 + d32 σ22) dA, σ = N/h.
  std::vector<double> charge_C;
  /// Mean membrane force over each electrode in material axes [N11, N22, N12] (N/m).
  std::vector<std::array<double, 3>> mean_membrane_force_material_N_per_m;
  /// Estimated absolute error of each charge (C), scene order: discretization + model parts (the
  /// adjoint-weighted residual estimates of the solver, docs/fem.md), each part taken by magnitude.
  std::vector<double> charge_error_C;
  std::vector<double> charge_error_discretization_C;
  std::vector<double> charge_error_model_C;
  /// The clamp-layer condition's share (model clamp_layer; empty otherwise), C, by electrode.
  std::vector<double> charge_error_clamp_layer_C;
  /// max_k charge_error_C[k] / max_k |charge_C[k]|: the relative charge error of this probe.
  double estimated_relative_error = 1;
  double deflection_error_m = 0;        ///< estimated |error| of deflection_at_load_m (m)
  SweepModel model_used = SweepModel::cheap;
  /// When the rim model solved it: the cheap model's own estimated relative model error that sent it
  /// there; NaN when the cheap model did not converge at all (taut films then take the rim model).
  double cheap_model_relative_error = 0;
  /// Model clamp_layer: the condition's own estimate K·ρ·|ΔQ| relative to the largest charge (in
  /// estimated_relative_error too); otherwise 0.
  double clamp_layer_relative_error = 0;
  int newton_iterations = 0;
  bool warm_started = false;            ///< Newton started from the given state (not from flat)
  double wall_s = 0;
};

/// Where the time of the probe solves went (s), accumulated since construction (setup checks included).
struct SweepTiming {
  double assembly_s = 0;      ///< residual + tangent assembly
  double linear_solve_s = 0;  ///< factorizations, back substitutions, preconditioned iterations
  double load_vector_s = 0;   ///< probe load re-integration
  double outputs_s = 0;       ///< electrode charges, deflection, rim reaction
  int newton_iterations = 0;
  int factorizations = 0;
  int rim_solves = 0;         ///< probes solved (also) by the rim model
  double rim_s = 0;           ///< wall time of the rim-model solves
  int clamp_layer_solves = 0; ///< probes solved (also) with the clamp-layer condition, kept or not
  double clamp_layer_s = 0;   ///< wall time of those solves (their estimates included)
  double estimate_s = 0;      ///< wall time of the error estimates
  double probe_mesh_s = 0;    ///< building each probe's footprint-refined mesh and moving states to and from it
  double probe_mesh_dofs = 0; ///< mean DOFs of the footprint-refined probe meshes (0 = none)
};

/// A reusable single-probe solver for one scene. Not thread-safe: use one instance per thread
/// (instances are independent). The scene's own loads are ignored; the probe radius is the
/// scene's `probe.radius_m`.
class ProbeSweep {
 public:
  /// Chooses model and mesh and prepares the linear algebra. Throws pvdf::InputError on bad
  /// input (e.g. a film outline the solver cannot mesh).
  explicit ProbeSweep(const pvdf::Scene& scene, const SweepOptions& options = {});
  ~ProbeSweep();
  ProbeSweep(const ProbeSweep&) = delete;
  ProbeSweep& operator=(const ProbeSweep&) = delete;

  const SweepSetup& setup() const;
  /// Cost breakdown of the solves so far (for benchmarks).
  SweepTiming timing() const;

  /// Solves a vertical probe force `force_N` (N, > 0) centred at (`x_m`, `y_m`) (m).
  /// @param[in]  warm_start  state of a neighbouring solve (nullptr or empty = from flat)
  /// @param[out] state_out   receives the converged state when usable(status) (may be nullptr)
  /// A position outside the served region gives an InputError; a numerical failure is a status.
  ProbeSolution solve(double x_m, double y_m, double force_N, const SweepState* warm_start = nullptr,
                      SweepState* state_out = nullptr);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pvdf::fem
