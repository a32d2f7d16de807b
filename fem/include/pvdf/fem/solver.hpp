// Anisotropic, geometrically nonlinear membrane–plate solver for a clamped PVDF film (deal.II
// inside, std/Eigen/pvdf types outside): solve(scene, options) -> Result{Summary, fields}.
#pragma once

#include "pvdf/core/scene.hpp"
#include "pvdf/mesh/film_mesh.hpp"

#include <Eigen/Core>

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace pvdf::fem {

/// Kinematics of the mid-surface (docs/fem.md §2).
enum class Model {
  automatic,      ///< pick the cheapest of the three below whose output error stays within the tolerance
  linear,         ///< linear plate + linear membrane (uncoupled except through pretension)
  von_karman,     ///< E = sym∇u + ½∇w⊗∇w (moderate rotations) + Kirchhoff bending
  large_rotation  ///< E = ½(FᵀF − I) + ½∇w⊗∇w (full Green–Lagrange mid-surface strain) + bending
};

/// "auto" | "linear" | "von-karman" | "large-rotation" → Model; throws pvdf::InputError naming `what`.
Model parse_model(const std::string& text, const std::string& what);
/// Model → the same names.
std::string model_name(Model model);

/// Outcome of a solve. The stopping rules are stated per value.
enum class Status {
  converged,          ///< every Newton solve met ‖r‖ ≤ rtol·‖f‖ + atol AND ‖Δu‖ ≤ increment_tol·‖u‖ (or hit the
                      ///< round-off floor: ‖Δu‖ ≤ 1e-11‖u‖ with ‖r‖ ≤ 1e-6‖f‖), and the
                      ///< estimated output error ≤ tolerance (or no refinement was requested)
  tolerance_not_met,  ///< the Newton solves converged but the refinement cap was reached with the estimated
                      ///< output error still above the tolerance; the fields are usable, the error is reported
  no_convergence,     ///< Newton did not converge within max_newton_iterations even after the smallest
                      ///< continuation step (max_cutbacks halvings); no fields are returned
  not_finite,         ///< a NaN/Inf appeared in the residual or the update; no fields are returned
  linear_solver_failed  ///< the sparse factorization or iterative solve failed (singular tangent)
};
/// Status → "converged", "tolerance-not-met", "no-convergence", "not-finite", "linear-solver-failed".
std::string status_name(Status status);
/// True for the statuses whose fields may be used (converged, tolerance_not_met).
inline bool usable(Status status) { return status == Status::converged || status == Status::tolerance_not_met; }

/// Which cells an adaptive cycle refines (docs/fem.md §6).
enum class Refinement {
  goal,  ///< the cell shares of the adjoint-weighted residual estimates of the outputs (default)
  kelly  ///< Kelly's gradient-jump indicators of (u_x, u_y) and w (kept for comparison)
};

/// Solver settings (public members with defaults, DOLFINx style).
struct Options {
  Model model = Model::automatic;       ///< kinematics; automatic = choose (Summary::model_reason says why)
  double tolerance = 0.01;              ///< requested relative error of the outputs (electrode forces, deflection)
  int max_refinements = 4;              ///< cap on adaptive refinement cycles after the first mesh
  int fe_degree = 2;                    ///< polynomial degree of FE_Q for u_x, u_y, w (2 or 3)
  bool include_bending = true;          ///< false: pure membrane (for oracle tests; singular flat tangent)
  /// Initial mesh: target cell size far from loads and electrodes (m); 0 = radius/6.
  double coarse_size_m = 0.0;
  /// Target cell size under a probe footprint (m); 0 = probe radius / 2.
  double probe_size_m = 0.0;
  /// Target cell size on electrodes (m); 0 = smallest electrode side / 2.
  double electrode_size_m = 0.0;
  /// With bending: refine toward the clamped rim until the cells there are no larger than its
  /// bending boundary layer sqrt(D/N) (growing by half the distance from the rim), on the first
  /// mesh or when `auto` switches bending on (docs/fem.md §6). The goal-oriented loop cannot find
  /// that layer from a coarse rim (its estimate is blind there).
  bool grade_rim_for_bending = true;
  /// The clamp's bending layer as a boundary condition (docs/fem.md §3.4): where `auto` would switch
  /// bending on near the clamp, the rim's w is not clamped but held at w = l_b ∂w/∂n
  /// (l_b = sqrt(D_nn/N_nn); rim Dirichlet values lagged between Newton solves, slope from the rim
  /// reaction) and the rim's bending terms are dropped, so the rim is not graded to l_b. The rim is
  /// graded (grade_rim_for_bending) only when the condition's own error estimate exceeds its share
  /// of the tolerance (¾·tolerance minus the other model errors) or its passes do not settle.
  /// false = the rim-graded reference path.
  bool clamp_layer_condition = true;
  /// With the clamp-layer condition: also shift the rim's in-plane displacement inward by
  /// ¾ l_b (∂w/∂n)² (the stretch the layer does not take, docs/fem.md §3.4).
  bool clamp_layer_inplane_shift = true;
  /// Initial-mesh grading: away from probes and electrodes the cell size is at most
  /// grading × distance (smaller = finer far field).
  double grading = 0.8;
  /// Extra uniform refinements of the initial mesh (for convergence studies).
  int initial_global_refinements = 0;
  /// FilmMesh solves: grade the given mesh to the probes and electrodes (refining only) before the
  /// first solve. false = the first solve is on the given mesh exactly as it is (`pvdfkit solve
  /// --mesh`); the output-driven refinement (`adaptive`) follows either way.
  bool grade_given_mesh = true;
  bool adaptive = true;                 ///< refine until the output error estimate meets `tolerance`
  Refinement refinement = Refinement::goal;  ///< indicators of the adaptive cycles
  /// Work cap of the adaptive loop: no refinement that would take the DOFs past this (the solve
  /// then ends tolerance_not_met with its estimate).
  std::size_t max_dofs = 400000;
  /// Without bending (include_bending = false): still estimate what bending would change
  /// (Summary::estimated_model_error, *_model_error_* of the results) without switching it on.
  bool estimate_bending_effect = false;

  /// Tension-field membrane: residual stiffness ε of the relaxed law (docs/fem.md §3.3). 0 = the exact
  /// relaxed law (wrinkled or slack points carry no stiffness across the wrinkles; the Newton tangent
  /// alone is regularized). ε > 0: the energy (1 − ε)·W_relaxed + ε·½e·C·e (unchanged where taut), its
  /// exact tangent, and for slack films the pretension-stepping continuation; strongly slack films
  /// converge with ε = 1e-3 and bending kept. Its effect on the answers is of order ε·|N0|.
  double tension_field_residual_stiffness = 0.0;

  // Newton–Raphson.
  int max_newton_iterations = 40;       ///< per continuation stage
  double residual_rtol = 1e-9;          ///< ‖r‖ ≤ rtol·‖f_ext‖ + atol
  double residual_atol = 1e-14;         ///< (N)
  double increment_tol = 1e-8;          ///< ‖Δu‖ ≤ increment_tol·‖u‖
  int max_cutbacks = 12;                ///< halvings of a failed continuation step before giving up
  /// Stagnation limit (issue 30): a Newton solve stops with no_convergence when the smallest ‖r‖ of
  /// its last `stagnation_iterations` iterations is not below `stagnation_factor` × the smallest
  /// ‖r‖ before them (0 = no limit); a continuation gives up after `max_stagnated_stages` such stops.
  int stagnation_iterations = 8;
  double stagnation_factor = 0.5;
  int max_stagnated_stages = 2;
  bool iterative_solver = false;        ///< GMRES + ILU instead of the sparse direct solver (big meshes)
  /// Use the dense-enough direct solver below this many DOFs even if iterative_solver is set.
  unsigned int direct_solver_max_dofs = 400000;
  bool verbose = false;                 ///< print Newton progress to stdout

  /// Extra evaluation points (m) whose fields are returned in Result::samples.
  std::vector<std::array<double, 2>> sample_points_m;
  /// Write VTU files (one per refinement cycle) and a PVD series here when non-empty.
  std::string vtu_directory;
};

/// What happened (Ceres-style Summary).
struct Summary {
  Status status = Status::no_convergence;
  std::string message;                  ///< one line: why the status (diagnostic when not usable)
  Model model = Model::linear;          ///< the kinematics actually used
  std::string model_reason;             ///< why that model (for automatic: the measured criterion)
  std::size_t n_dofs = 0;               ///< on the final mesh
  std::size_t n_cells = 0;              ///< on the final mesh
  int newton_iterations = 0;            ///< total over all stages, models and meshes
  int load_steps = 0;                   ///< continuation stages (artificial-pretension steps) in total
  int refinement_cycles = 0;            ///< meshes solved after the first
  double final_residual_norm = 0;       ///< ‖r‖ of the last Newton solve (N)
  /// Of the outputs (docs/fem.md §6): estimated_discretization_error + estimated_model_error;
  /// NaN-free, 1 if unknown.
  double estimated_relative_error = 0;
  /// Adjoint-weighted residual estimate of the discretization error: max over the outputs (each
  /// electrode charge, w at each load) of |estimate| / (largest |charge| or |w| of its kind).
  double estimated_discretization_error = 0;
  /// Same normalisation, for what the model leaves out: bending (adjoint-weighted bending residual
  /// when `auto` left it out) plus the kinematics difference measured by the `auto` trial solves.
  double estimated_model_error = 0;
  /// How the clamp's bending layer was treated: "none" (bending-free model, layer ignored, or no
  /// layer), "boundary-condition" (w = l_b ∂w/∂n at the rim, docs/fem.md §3.4) or "rim-graded".
  std::string clamp_layer = "none";
  /// With the boundary condition: its estimated remaining error (same normalisation as
  /// estimated_model_error, and included there), the size of the correction it made (relative, the
  /// largest output change against the plain clamp on the mesh where it was switched on), the
  /// largest l_b along the rim (m) and the outer (lagged-N_nn) passes of the last solve.
  double estimated_clamp_layer_error = 0;
  double clamp_layer_correction = 0;
  double clamp_layer_width_m = 0;
  int clamp_layer_passes = 0;
  std::string error_estimator;          ///< how the estimates were obtained
  double wall_s = 0;                    ///< total
  /// CPU seconds (user + system, all threads) of the whole solve: model choice, mesh, Newton,
  /// estimates and outputs (process CPU time, so other work of the process in the same interval
  /// counts too; 0 when the system does not say).
  double cpu_s = 0;
  double assembly_s = 0;                ///< residual + tangent assembly
  double linear_solve_s = 0;            ///< factorization + back substitution
  double setup_s = 0;                   ///< mesh, DOFs, sparsity, bending matrix
};

/// Membrane force resultants (N/m) — 2nd Piola–Kirchhoff stress × thickness, in undeformed axes.
struct MembraneForce {
  std::array<double, 3> global{0, 0, 0};    ///< [Nxx, Nyy, Nxy]
  std::array<double, 3> material{0, 0, 0};  ///< [N11, N22, N12], 1 = draw direction
  std::array<double, 3> polar{0, 0, 0};     ///< [Nr, Nθ, Nrθ] about the first load position
};

struct ElectrodeResult {
  std::string name;
  double area_m2 = 0;                       ///< nominal area of the electrode outline
  std::array<double, 3> mean_membrane_force_material_N_per_m{0, 0, 0};  ///< ∫N dA / area, material axes
  std::array<double, 3> mean_membrane_force_global_N_per_m{0, 0, 0};
  /// Charge ∫ (d31 σ11 + d32 σ22) dA with σ = N/h the through-thickness mean stress (C), sign by d31.
  double charge_C = 0;
  /// Estimated absolute error of charge_C (C): |discretization estimate| + |model estimate|.
  double charge_error_C = 0;
  double charge_discretization_error_C = 0;  ///< signed estimate of (exact − computed) on this mesh (C)
  double charge_model_error_C = 0;           ///< signed estimate of what bending left out would change (C)
};

struct SampleResult {
  double x_m = 0, y_m = 0;
  double ux_m = 0, uy_m = 0, w_m = 0;       ///< displacement (m)
  MembraneForce membrane_force;             ///< N/m
  double charge_density_C_per_m2 = 0;       ///< d31 σ11 + d32 σ22 (σ = N/h)
};

struct LoadResult {
  double x_m = 0, y_m = 0;
  double force_N = 0;                       ///< total vertical force applied (probe: exact; pressure: p·area)
  double deflection_m = 0;                  ///< w at the load position (pressure: at the film centre)
  double deflection_error_m = 0;            ///< estimated absolute error of deflection_m (as charge_error_C)
  double deflection_discretization_error_m = 0;  ///< signed, as ElectrodeResult's
  double deflection_model_error_m = 0;           ///< signed, as ElectrodeResult's
};

/// Fields for the caller; empty unless usable(summary.status).
struct Result {
  Summary summary;
  double max_deflection_m = 0;              ///< max |w| over the film (signed value of that extremum)
  double deflection_at_load_m = 0;          ///< w at the first load position
  double rim_reaction_N = 0;                ///< total vertical reaction of the clamped rim (= Σ F at equilibrium)
  double strain_energy_J = 0;               ///< membrane + bending (without pretension work)
  /// Share of the film's area that is wrinkled (uniaxial tension) and slack (no membrane force); both 0
  /// unless the tension-field membrane is in use (slack films, membrane.tension_field).
  double wrinkled_area_fraction = 0, slack_area_fraction = 0;
  std::vector<LoadResult> loads;
  std::vector<ElectrodeResult> electrodes;
  std::vector<SampleResult> samples;
  std::vector<std::string> vtu_files;       ///< written VTU files (and the PVD last)
};

/// Solves the scene's loads (all applied at once) with the scene's membrane, material,
/// electrodes and probe. Meshes circles and rectangles itself (deal.II grid, refined around
/// probes and electrodes); other outlines need the FilmMesh overload. Bad input throws
/// pvdf::InputError; numerical failure is a Summary status (never NaN fields).
Result solve(const pvdf::Scene& scene, const Options& options = {});

/// Same on a mesh from pvdf::mesh (quads, material ids, rim edges, rim manifold).
Result solve(const pvdf::Scene& scene, const pvdf::mesh::FilmMesh& mesh, const Options& options = {});

/// Options from a scene's model section (kinematics, tolerance, max_refinements).
Options options_from_scene(const pvdf::Scene& scene);

/// Solver internals exposed for tests (finite-difference check of the tangent).
struct JacobianCheck {
  double max_relative_difference = 0;  ///< max |K·v − (r(u+εv) − r(u−εv))/2ε| / max|K·v|
  std::size_t n_dofs = 0;
};
/// Builds the scene's initial mesh, sets a random smooth state (u, w scaled by `amplitude_m`),
/// and compares the assembled tangent against central differences of the residual along
/// `n_directions` random directions.
JacobianCheck check_jacobian(const pvdf::Scene& scene, const Options& options, double amplitude_m,
                             int n_directions = 3, unsigned int seed = 1);

/// Solver internals exposed for tests: the C0 interior-penalty bending operator K on the scene's
/// initial mesh (docs/fem.md §8).
struct BendingCheck {
  /// ½ wᵀKw for w = c0 x² + c1 xy + c2 y² interpolated (x, y in m), K restricted to its interior
  /// terms (cells and interior faces; the rim's one-sided terms left out) (J).
  double energy_J = 0;
  double mesh_area_m2 = 0;              ///< Σ JxW over the mesh with the solver's mapping
  /// max over random admissible v of |K_c v − Cᵀ K v| / |Cᵀ K v|: the condensed operator (Newton
  /// tangent, residual) against the gradient of the unconstrained energy (line search).
  double condensation_mismatch = 0;
  std::size_t n_hanging_node_constraints = 0;
  std::size_t n_dofs = 0;
};
/// Builds the scene's initial mesh and checks the bending operator (see BendingCheck).
BendingCheck check_bending(const pvdf::Scene& scene, const Options& options, const std::array<double, 3>& coefficients,
                           int n_directions = 3, unsigned int seed = 1);

}  // namespace pvdf::fem
