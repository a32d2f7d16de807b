// Internal to pvdf::fem: the film solver (FilmSolver) and the small types its parts share. One
// class, one mesh, implemented in one file per stage of the method (docs/fem.md):
//   setup.cpp        scene checks, the initial mesh, DOFs, constraints, sparsity
//   assembly.cpp     bending operator (C0 interior penalty), load vector, membrane residual/tangent
//   newton.cpp       sparse linear solves, Newton with line search, artificial-pretension continuation
//   model_choice.cpp the `auto` rule (bending negligible? linear / von Kármán / large rotation)
//   adaptivity.cpp   output vector, mesh refinement, the output-error estimate
//   goal_error.cpp   adjoint-weighted residual (DWR) estimates of discretization and bending-model error
//   outputs.cpp      electrode forces and charges, deflections, rim reaction, energy, samples
//   vtu_output.cpp   VTU/PVD files
//   solve.cpp        FilmSolver::run() and the public entry points (pvdf::fem::solve, names)
//   checks.cpp       SolverChecks: tangent by finite differences, bending operator (test checks)
//   sweep_engine.cpp ProbeSolver (probe_solver.hpp): the fixed-mesh probe solver behind ProbeSweep
//   atlas_quadrature.cpp AtlasQuadrature (atlas_quadrature.hpp): an atlas's cell moments on the mesh
//   tension_field.cpp slack films: the relaxed (wrinkling) membrane, its continuation, wrinkled area
// deal.II appears here and in those files only; public headers stay std/Eigen/pvdf.
#pragma once

#include "pvdf/fem/solver.hpp"

#include "sweep_engine.hpp"
#include "tangent_factorization.hpp"
#include "tension_field.hpp"

#include <deal.II/base/point.h>
#include <deal.II/base/tensor.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/fe/fe_system.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/manifold_lib.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/sparsity_pattern.h>
#include <deal.II/lac/vector.h>


#include <array>
#include <chrono>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace pvdf::fem::detail {

// The deal.II names the solver's parts use (a private header: kept to this namespace).
using dealii::AffineConstraints;
using dealii::DoFHandler;
using dealii::DynamicSparsityPattern;
using dealii::FESystem;
using dealii::MappingQ;
using dealii::Point;
using dealii::SparseMatrix;
using dealii::SparsityPattern;
using dealii::TransfiniteInterpolationManifold;
using dealii::Triangulation;
using dealii::Vector;

constexpr int dim = 2;
using Clock = std::chrono::steady_clock;

inline double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

/// A number for a message (default 4 significant digits).
std::string fmt(double x, int precision = 4);

/// Even-odd rule: is (x, y) inside the closed polygon v (vertices in order)?
bool polygon_contains(const std::vector<pvdf::Point2>& v, double x, double y);
/// Distance (m) from (x, y) to the polygon v; 0 inside.
double polygon_distance(const std::vector<pvdf::Point2>& v, double x, double y);

/// A load as the solver sees it.
struct LoadCase {
  bool probe = true;
  Point<dim> center;
  double radius_m = 0;
  double force_N = 0;      // probe: exact total
  double pressure_Pa = 0;  // uniform pressure
};

/// Plane-stress stiffness in Voigt [xx, yy, xy] (engineering shear) as a small fixed array.
struct Stiffness3 {
  double c[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  std::array<double, 3> apply(const std::array<double, 3>& e) const {
    return {c[0][0] * e[0] + c[0][1] * e[1] + c[0][2] * e[2], c[1][0] * e[0] + c[1][1] * e[1] + c[1][2] * e[2],
            c[2][0] * e[0] + c[2][1] * e[1] + c[2][2] * e[2]};
  }
};

/// Mid-surface kinematics at one point: H = ∇u (in-plane, H[a][b] = ∂u_a/∂x_b), g = ∇w.
struct Kinematics {
  double H[2][2] = {{0, 0}, {0, 0}};
  double g[2] = {0, 0};
};

/// Membrane strain (Voigt, engineering shear) for each model (docs/fem.md eq. 2.1–2.3):
/// linear sym H; von Kármán + ½ g⊗g; large rotation + ½ HᵀH as well.
inline std::array<double, 3> membrane_strain(const Kinematics& k, Model model) {
  std::array<double, 3> e{k.H[0][0], k.H[1][1], k.H[0][1] + k.H[1][0]};
  if (model == Model::linear) return e;
  e[0] += 0.5 * k.g[0] * k.g[0];
  e[1] += 0.5 * k.g[1] * k.g[1];
  e[2] += k.g[0] * k.g[1];
  if (model == Model::large_rotation) {
    e[0] += 0.5 * (k.H[0][0] * k.H[0][0] + k.H[1][0] * k.H[1][0]);
    e[1] += 0.5 * (k.H[0][1] * k.H[0][1] + k.H[1][1] * k.H[1][1]);
    e[2] += k.H[0][0] * k.H[0][1] + k.H[1][0] * k.H[1][1];
  }
  return e;
}

/// Where the solver stands after a Newton solve.
struct NewtonOutcome {
  Status status = Status::converged;
  int iterations = 0;
  double residual_norm = 0;
  std::string message;
  bool stagnated = false;  ///< no_convergence by the stagnation limit (Options::stagnation_iterations)
};

/// The outputs compared between meshes and models for the error estimate.
struct OutputVector {
  std::vector<double> forces;       // electrode mean N (material axes), 3 per electrode
  double force_scale = 0;           // max |N| over electrodes
  std::vector<double> deflections;  // w at each load
  double deflection_scale = 0;
};

/// max over outputs of |a − b| / scale(a), forces and deflections each on their own scale.
double relative_difference(const OutputVector& a, const OutputVector& b);

/// Wrinkled and slack share of the film (tension_field.cpp), and each cell's MembraneState.
struct WrinkleMap {
  double wrinkled_area_fraction = 0, slack_area_fraction = 0;
  std::vector<float> cell_state;
};

/// One film problem on one triangulation, in the shape of deal.II's step-15: setup, then cycles of
/// solve, estimate, refine, then the outputs (run(), solve.cpp). Each group of members below is
/// implemented in the file named in its comment. Three narrow friends use its parts on a fixed
/// mesh: ProbeSolver (probe_solver.hpp, one probe moved over the mesh of a sweep), AtlasQuadrature
/// (atlas_quadrature.hpp, the charge-density moments of an atlas) and SolverChecks (checks.cpp, the
/// test checks of the tangent and of the bending operator); MembranePostprocessor writes its VTU.
class FilmSolver {
 public:
  // setup.cpp
  FilmSolver(const pvdf::Scene& scene, const Options& options);
  void make_grid();
  void make_grid_from(const pvdf::mesh::FilmMesh& mesh);
  /// Assemble the bending operator and its sparsity even when the model leaves bending out (call
  /// before the first setup_system()): needed to estimate what bending would change.
  /// `switchable`: the adaptive loop switches bending on when its estimated effect is too large
  /// (`auto`); otherwise the effect is only reported.
  void keep_bending_pattern(bool switchable) {
    bending_pattern_ = true;
    bending_switchable_ = switchable;
  }

  // solve.cpp: the method, step by step (setup; cycles of solve, estimate, refine; outputs).
  Result run();

  // model_choice.cpp: the trial half of the `auto` rule on the current (first) mesh.
  struct KinematicsChoice {
    NewtonOutcome outcome;  // failure of a trial solve (status not converged) ends the solve
    std::string where;      // which trial failed
    Model model = Model::linear;
    std::string reason;
    double relative_model_error = 0;  // what the chosen kinematics leave out, relative (0: most general)
  };
  KinematicsChoice choose_kinematics_on_first_mesh();

  // goal_error.cpp: dual-weighted residual estimates for the outputs (every electrode's charge,
  // w at every load). Each estimate is signed, (exact − computed).
  struct GoalErrors {
    std::vector<double> charge_C, deflection_m;                         // the outputs themselves
    std::vector<double> charge_discretization_C, deflection_discretization_m;
    std::vector<double> charge_model_C, deflection_model_m;             // bending's effect (zeros if kept)
    bool model_estimated = false;
    double relative_discretization = 0;  // max over outputs of |estimate| / output scale
    double relative_model = 0;
    Vector<float> indicators;            // per active cell: Σ_outputs |η_K| / output scale
  };
  // clamp_layer.cpp: one probe of a sweep with the clamp-layer condition (docs/fem.md §3.4).
  struct ClampLayerProbe {
    bool wanted = false;   // tried: the layer matters (clamp_layer_wanted) and bending can be switched
    NewtonOutcome outcome;
    bool settled = false;  // the lagged passes settled
    bool bending = false;  // bending switched on with it (its remaining effect > tolerance/2, as in solve)
    double estimate = 0;   // clamp_layer_estimate(), relative to the largest charge
    std::vector<double> charge_error_C;  // its share of each electrode's error bar (C)
    double width_m = 0;
    int passes = 0, newton_iterations = 0;
  };

  const Summary& summary() const { return summary_; }
  unsigned int n_dofs() const { return dof_handler_.n_dofs(); }
  unsigned int n_cells() const { return triangulation_.n_active_cells(); }
  int n_factorizations() const { return factorization_.n_factorizations(); }

 private:
  friend class ProbeSolver;
  friend class AtlasQuadrature;
  friend class SolverChecks;
  friend class MembranePostprocessor;

  // solve.cpp: the first and last steps of run().
  /// The model (requested, or the `auto` rule's trial solves) solved on the first mesh into solution_.
  NewtonOutcome solve_on_first_mesh(Model& model, std::string& where);
  /// The model's reasons, the final status, the outputs and their error bars.
  Result output_results(Model model, Clock::time_point t_start);

  // adaptivity.cpp: the steps of run()'s cycle.
  /// The error estimator's description in the summary.
  void describe_estimator();
  enum class ModelStep { kept, changed, failed };
  /// After an estimate (goal_): bending or the clamp-layer condition switched on, or the reference
  /// path taken, where the estimates ask; `changed`: solved again on this mesh (estimate again),
  /// `failed`: that solve failed (`o`, `where`).
  ModelStep adapt_model(Model model, NewtonOutcome& o, std::string& where);
  /// The summary's estimates from goal_; true when they meet the tolerance or refinement must stop
  /// (the cycle cap, the DOF cap).
  bool accurate_enough();
  /// After refine_mesh: Newton from the transferred state, the fallbacks after it.
  NewtonOutcome solve_on_refined_mesh(Model model, std::string& where);

  // model_choice.cpp
  KinematicsChoice choose_kinematics(Vector<double>& u);

  // sweep_engine.cpp: in-plane DOFs times inplane_factor, w DOFs times w_factor (each DOF once).
  void scale_state(Vector<double>& u, double inplane_factor, double w_factor) const;
  // outputs.cpp: what a probe sweep keeps (ProbeSolver::outputs).
  void probe_outputs(const Vector<double>& u, Model model, EngineSolution& out);

  /// Estimates at the converged state u of `model`. The bending-model part is computed when the
  /// solver runs without bending but kept the bending pattern (keep_bending_pattern()).
  /// `higher_order_adjoint`: the adjoint weights from a Q(p+1) solve on the same mesh (one more
  /// factorization, reliable on coarse meshes) instead of the patch-wise extrapolation of the Q(p)
  /// adjoint (cheap; what the probe sweep uses).
  GoalErrors estimate_goal_errors(const Vector<double>& u, Model model, bool higher_order_adjoint = false);
  /// From the converged plain-clamp, bending-free state u of the current probe: the condition on,
  /// solved, estimated (into `goal`); bending on with it when its remaining effect asks. The
  /// condition stays on until reset_clamp_layer(); on failure u is as given.
  ClampLayerProbe solve_probe_with_clamp_layer(Model model, Vector<double>& u, GoalErrors& goal);
  /// Back to the plain clamp without bending (DOFs unchanged), for the next probe.
  void reset_clamp_layer();
  /// Switch the bending term of the residual on (the pattern must hold it).
  void enable_bending() { options_.include_bending = true; }

  // outputs.cpp (also used by the VTU postprocessor)
  MembraneForce membrane_force(const Kinematics& k, const Point<dim>& x) const;
  double charge_density(const MembraneForce& n) const;

  // setup.cpp
  void refine_initial_mesh();
  // adaptivity.cpp: with bending, cells toward the clamped rim down to its boundary layer (once);
  // u, when given, is carried over to the new mesh.
  void grade_toward_rim(Vector<double>* u, Model model = Model::von_karman);
  /// A point of the rim and the width of the clamp's bending layer there (m).
  struct RimLayerPoint {
    double x_m = 0, y_m = 0, width_m = 0;
  };
  /// `widths`, when given: no cell is made smaller than the layer at the nearest of those points
  /// (the size is max(size_m, that width, grading x distance)).
  bool refine_toward_rim(double size_m, double grading, double angle_rad, double half_angle_rad, Vector<double>* u,
                         const std::vector<RimLayerPoint>* widths = nullptr);
  void set_material_ids();
  void setup_system();
  /// tangent_ (and factorization_) on sparsity_, with bending's face couplings (no-op when it is already).
  void widen_tangent();
  void mark_rim_w_dofs();
  void add_bending_face_couplings(DynamicSparsityPattern& dsp) const;

  // clamp_layer.cpp: the clamp's bending layer as a boundary condition (docs/fem.md §3.4).
  /// Is the layer wide enough to matter (l_b/a > tolerance/10) and the model one that has it?
  bool clamp_layer_wanted() const;
  /// Switch the condition on or off (rim bending terms dropped when on); DOFs unchanged, u kept.
  void set_clamp_layer(bool on, Vector<double>& u);
  /// The rim values of the condition from the converged state u (w from the rim's reaction, the
  /// in-plane shift) and the estimate's ratio.
  void update_clamp_layer(const Vector<double>& u, Model model);
  /// The rim's Dirichlet values of the condition, hanging nodes after them.
  void apply_clamp_shift(Vector<double>& u) const;
  /// From a converged plain-clamp state u: u with the condition's first-pass rim values (the layer's
  /// first-order effect, for the bending-left-out estimate, goal_error.cpp) and the factor of its
  /// own estimate (what first order leaves out / the change); the condition's own state (held
  /// values, N_nn, ratio) is left as it was. False where the rim carries no tension.
  bool clamp_layer_first_pass(const Vector<double>& u, Model model, Vector<double>& shifted, double& remainder_factor);
  /// Lagged: solve, update the rim values, until the outputs stop changing.
  NewtonOutcome solve_with_clamp_layer(Model model, Vector<double>& u);
  /// From a converged plain-clamp state u: the condition switched on and solved (bending-free
  /// first, for the size of the correction; then with bending again if the model has it).
  NewtonOutcome switch_to_clamp_layer(Model model, Vector<double>& u);
  /// Its estimated remaining error, relative (largest charge change × clamp_ratio_).
  double clamp_layer_estimate() const;
  /// The reference path instead of the condition: plain clamp, bending kept, rim graded (adaptivity.cpp).
  NewtonOutcome leave_clamp_layer_for_graded_rim(Model model);
  /// The layer's width l_b = sqrt(D_nn/N_nn) at the rim's face quadrature points of state u (N_nn
  /// the membrane's normal force there; at most `cap_m`, and `cap_m` where the rim is not in tension).
  std::vector<RimLayerPoint> rim_layer_widths(const Vector<double>& u, Model model, double cap_m) const;
  /// Its share of each electrode's error bar (C), for charges charge_C.
  std::vector<double> clamp_layer_charge_error_C(const std::vector<double>& charge_C) const;

  // assembly.cpp
  /// bending_ (and bending_raw_ when `with_raw`) of the current rim terms (bending_rim_terms_); with
  /// `rim_only` ≠ 0, the rim terms alone × rim_only added to bending_ (assembly.cpp).
  void assemble_bending_matrix(bool with_raw = true, double rim_only = 0);
  void assemble_load_vector();
  void build_geometry_cache();
  void assemble(const Vector<double>& u, Model model, double artificial_tension, bool want_matrix,
                Vector<double>& residual);

  // newton.cpp
  /// x = A⁻¹ rhs for A = `matrix` factorized by `factorization` (default: tangent_ by factorization_).
  bool solve_linear(const Vector<double>& rhs, Vector<double>& x, std::string& message, bool factorize = true,
                    const SparseMatrix<double>* matrix = nullptr, TangentFactorization* factorization = nullptr);
  /// `stage_rtol` > 0: a stepping-stone solve (an intermediate continuation stage), stopped as
  /// soon as ‖r‖ ≤ stage_rtol·‖f‖ with no increment test.
  NewtonOutcome newton(Model model, double artificial_tension, Vector<double>& u, double stage_rtol = 0);
  struct LineSearch {
    double alpha = 1.0;        // accepted step length
    double residual_norm = 0;  // ‖r‖ at u + alpha·du (max() = every trial non-finite)
    double last_alpha = -1;    // the last trial assembled (r_trial and last_energy_ belong to it)
  };
  LineSearch line_search(Model model, double artificial_tension, const Vector<double>& u, const Vector<double>& du,
                         double slope, double energy0, double r_norm, Vector<double>& trial, Vector<double>& r_trial);
  double estimate_tension() const;
  /// From the flat film (with the clamp-layer condition on: its lagged passes after it).
  NewtonOutcome solve_from_flat(Model model, Vector<double>& u);
  /// The artificial-pretension continuation from the flat film.
  NewtonOutcome solve_by_continuation(Model model, Vector<double>& u);

  // adaptivity.cpp
  OutputVector outputs(const Vector<double>& u, Model model) const;
  void refine_mesh(Vector<double>& u, const Vector<float>* goal_indicators = nullptr);

  // goal_error.cpp
  Vector<double> charge_derivative(const Vector<double>& u, Model model, std::size_t k) const;
  Vector<double> deflection_derivative(const Point<dim>& x) const;
  void prepare_enriched(bool with_tangent = false);
  unsigned int form_degree() const { return form_degree_ > 0 ? form_degree_ : options_.fe_degree; }

  // outputs.cpp
  /// One cell of an electrode integral: FE values at points of the cell's part inside the outline
  /// (the cell's Gauss rule when the cell lies wholly inside) and their weights (m²).
  struct ElectrodeCell {
    DoFHandler<dim>::active_cell_iterator cell;
    std::unique_ptr<dealii::FEValues<dim>> values;  // reinit'ed on its cell
    std::vector<double> jxw;
  };
  /// The cells and points of electrode k's integral on this mesh (built on first use, dropped
  /// when the mesh or the DOFs change).
  const std::vector<ElectrodeCell>& electrode_cells(std::size_t k) const;
  void fill_result(Result& result, Model model);
  Kinematics kinematics_at(const Vector<double>& u, const Point<dim>& p) const;
  std::array<double, 3> electrode_mean_force(const Vector<double>& u, Model model, std::size_t k,
                                             double* integrated_area = nullptr) const;
  double electrode_charge(std::size_t k, const std::array<double, 3>& mean_force_material) const;
  double rim_reaction(const Vector<double>& u, Model model);
  double strain_energy(const Vector<double>& u, Model model) const;
  double deflection_extremum(const Vector<double>& u) const;

  // vtu_output.cpp
  std::string write_vtu(int cycle, Model model);

  // solve.cpp
  Result zero_load_result(Clock::time_point t_start);
  Result failure_result(const NewtonOutcome& o, const std::string& where, Clock::time_point t_start);
  void set_final_status();
  void add_error_estimates(Result& result) const;

  // tension_field.cpp
  void setup_natural_state();
  RelaxedMembrane membrane_law(const std::array<double, 3>& E, double artificial_tension, bool want_tangent) const;
  std::array<double, 3> membrane_stress(const std::array<double, 3>& E) const;
  double relax_membrane_point(const Kinematics& k, Model model, double artificial_tension, bool want_tangent,
                              std::array<double, 3>& S, Stiffness3& D) const;
  NewtonOutcome solve_slack_from_flat(Model model, Vector<double>& u);
  NewtonOutcome solve_slack_by_pretension(Model model, Vector<double>& u);
  double slack_cone_slope(double natural_strain) const;
  double tension_field_regularization() const;
  WrinkleMap wrinkle_map(const Vector<double>& u, Model model) const;

  const pvdf::Scene& scene_;
  Options options_;
  double thickness_ = 0;
  double pretension_ = 0;
  // Natural state and wrinkling (tension_field.cpp): S0 (trial stress of the flat film), C⁻¹S0, C⁻¹(1,1,0).
  bool tension_field_ = false;
  std::array<double, 3> initial_stress_{0, 0, 0}, compliance_initial_stress_{0, 0, 0}, unit_compliance_{0, 0, 0};
  double tangent_regularization_ = tension_field_tangent_regularization;  // 0 in check_jacobian
  double residual_stiffness_ = 0;
  // Set while newton() assembles the convexified tangent of the residual-stiffness law (newton.cpp):
  // the geometric stiffness then takes only the tensile part of each point's membrane force.
  bool convexified_tangent_ = false;
  double load_factor_ = 1;  // the slack continuation's force factor on load_
  mutable double regularization_force_ = -1, regularization_eta_ = 0;
  Stiffness3 membrane_C_;  // h·Q̄
  Stiffness3 bending_D_;   // h³/12·Q̄
  double bending_penalty_scale_ = 0;
  bool bending_rim_terms_ = true;  // false: interior terms only (SolverChecks::bending, the clamp-layer condition)
  double draw_angle_ = 0;
  double radius_ = 0;  // characteristic film radius
  std::vector<LoadCase> loads_;
  std::vector<std::vector<pvdf::Point2>> electrode_polygons_;
  double total_force_ = 0;

  Triangulation<dim> triangulation_;
  std::unique_ptr<TransfiniteInterpolationManifold<dim>> interior_manifold_;
  std::unique_ptr<MappingQ<dim>> mapping_;
  std::unique_ptr<FESystem<dim>> fe_;
  DoFHandler<dim> dof_handler_;
  AffineConstraints<double> constraints_;
  AffineConstraints<double> hanging_constraints_;  // hanging nodes only (for the rim reaction)
  SparsityPattern sparsity_;  // every coupling of the operators (bending's face terms when its pattern is kept)
  // The tangent's own pattern while bending is left out (narrow_tangent_, set by run()): the cell
  // couplings only. The C0IP face couplings of w more than quadruple the Cholesky's flops on seed
  // 001's first mesh (78 -> 327 Mflop, lnz 0.70 -> 1.45 M); only the bending estimate's K + B needs
  // them (goal_error.cpp), and assemble() widens the tangent as soon as bending is on.
  SparsityPattern membrane_sparsity_;
  bool narrow_tangent_ = false;   // run(): a tangent without bending may use membrane_sparsity_
  bool tangent_narrow_ = false;   // tangent_ and factorization_ are on membrane_sparsity_
  SparseMatrix<double> tangent_;
  SparseMatrix<double> bending_;      // condensed
  SparseMatrix<double> bending_raw_;  // unconstrained (for rim reactions)
  Vector<double> load_;               // condensed external force
  Vector<double> load_raw_;           // unconstrained
  Vector<double> solution_;
  std::vector<bool> rim_w_dof_;
  Vector<double> membrane_raw_;       // unconstrained membrane internal force of the last assembly
  // Sparse direct solver (tangent_factorization.hpp): symbolic analysis once per pattern,
  // CHOLMOD supernodal LLᵀ, simplicial LDLᵀ where indefinite; UMFPACK is the caller's fallback.
  TangentFactorization factorization_;
  // The bending estimate's K + B while the tangent is narrow (goal_error.cpp): on sparsity_, with its
  // factorization; kept across estimates on the same mesh (its symbolic analysis made once) where
  // keep_k_plus_b_ (probe sweeps: every force level of a position on its mesh), else released after
  // each estimate (solve: one estimate per mesh; it held 28 MB of seed 001's 360 MB near the clamp).
  SparseMatrix<double> k_plus_b_;
  std::unique_ptr<TangentFactorization> k_plus_b_factorization_;
  bool keep_k_plus_b_ = false;
  // Chord steps (probe sweeps): keep the last factorized tangent while Newton contracts fast.
  bool reuse_factorization_ = false;
  bool chord_first_step_ = false;     // the first step of the next newton() may use the old factorization

  // Per-mesh assembly cache (build_geometry_cache): scalar shape gradients [cell][q][base][2],
  // JxW [cell][q], DOF indices [cell][i]; system_index[c·n_base + a] = local index of (component c, base a).
  struct GeometryCache {
    bool valid = false;
    std::size_t n_cells = 0;
    unsigned int n_q = 0, n_base = 0;
    std::vector<unsigned int> system_index;
    std::vector<double> grad, jxw;
    std::vector<dealii::types::global_dof_index> dofs;
  } cache_;
  Model current_model_ = Model::linear;
  double last_energy_ = 0;  // potential Π of the last assemble() call (J)
  Summary summary_;
  std::vector<std::pair<double, std::string>> pvd_records_;
  std::vector<std::string> vtu_files_;
  // goal_error.cpp: the same mesh with FE_Q(p+1) (residual and adjoint reconstruction there).
  std::unique_ptr<FilmSolver> enriched_;
  bool rim_graded_ = false;      // grade_toward_rim() done
  bool bending_pattern_ = false;  // bending operator assembled although the model leaves it out
  bool bending_switchable_ = false;
  unsigned int form_degree_ = 0;  // > 0: quadrature and penalty of this degree (the enriched space)
  bool residual_only_ = false;    // no tangent storage (the enriched space)
  GoalErrors goal_;               // the estimates on the final mesh (run())
  std::string bending_reason_;    // the bending part of `auto` decided by its estimate
  double kinematics_model_error_ = 0;  // relative, from the `auto` trial solves
  bool dof_cap_reached_ = false;
  // clamp_layer.cpp
  bool clamp_layer_ = false;
  std::vector<std::pair<dealii::types::global_dof_index, double>> clamp_shift_;  // rim values of u (m)
  double clamp_ratio_ = 0;          // weighted l_b |∂_nn w| / |∂_n w| along the rim (the estimate's factor)
  double clamp_l_over_h_ = 0;       // largest l_b / (rim cell size)
  // Rim N_nn per w DOF, face-averaged (∮ N_nn φ_i ds / ∮ φ_i ds), taken at the first pass of
  // solve_with_clamp_layer and held over its passes (docs/fem.md §3.4: a lagged N_nn fed back).
  std::map<dealii::types::global_dof_index, double> clamp_N_;
  bool clamp_settled_ = false;      // the lagged rim values settled (solve_with_clamp_layer)
  bool clamp_failed_ = false;       // the condition's Newton failed once: the reference path
  std::vector<double> clamp_correction_C_;  // per electrode: Q(condition) − Q(plain clamp), where switched on
  double clamp_correction_ = 0;     // the same, largest relative to the largest |charge| (and w at the loads)
  std::vector<double> electrode_charges(const Vector<double>& u, Model model) const;
  std::string clamp_reason_;        // for model_reason
  std::string clamp_share_reason_;  // the last estimate against its share (model_reason)
  // outputs.cpp: electrode_cells() per electrode; declared last, so destroyed before the mapping,
  // the finite element and the DoF handler its FEValues refer to.
  mutable std::vector<std::vector<ElectrodeCell>> electrode_cells_;
};

}  // namespace pvdf::fem::detail
