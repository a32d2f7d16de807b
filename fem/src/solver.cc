// The membrane–plate solver: FE_Q(p)^3 for (u_x, u_y, w), membrane by the chosen kinematics,
// Kirchhoff bending by the C0 interior-penalty method (deal.II step-47), Newton–Raphson with
// line search inside an artificial-pretension continuation, output-driven refinement.
// docs/fem.md explains every equation used here.
#include "pvdf/fem/solver.hpp"

#include "sweep_engine.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/material.hpp"

#include <deal.II/base/function.h>
#include <deal.II/base/quadrature_lib.h>
#include <deal.II/base/table.h>
#include <deal.II/base/tensor.h>
#include <deal.II/dofs/dof_handler.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_interface_values.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/fe/fe_system.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping_q.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/grid_refinement.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/grid/manifold_lib.h>
#include <deal.II/grid/tria.h>
#include <deal.II/lac/affine_constraints.h>
#include <deal.II/lac/dynamic_sparsity_pattern.h>
#include <deal.II/lac/precondition.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/solver_gmres.h>
#include <deal.II/lac/sparse_direct.h>
#include <deal.II/lac/sparse_ilu.h>
#include <deal.II/lac/sparse_matrix.h>
#include <deal.II/lac/sparsity_pattern.h>
#include <deal.II/lac/vector.h>
#include <deal.II/numerics/data_out.h>
#include <deal.II/numerics/data_postprocessor.h>
#include <deal.II/numerics/error_estimator.h>
#include <deal.II/numerics/solution_transfer.h>
#include <deal.II/numerics/vector_tools.h>

#include <Eigen/Eigenvalues>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include <algorithm>
#include <chrono>
#include <functional>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>

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

namespace {

using namespace dealii;
constexpr int dim = 2;
constexpr double pi = 3.14159265358979323846;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::string fmt(double x, int precision = 4) {
  std::ostringstream os;
  os.precision(precision);
  os << x;
  return os.str();
}

bool polygon_contains(const std::vector<pvdf::Point2>& v, double x, double y) {
  bool inside = false;
  for (std::size_t i = 0, j = v.size() - 1; i < v.size(); j = i++) {
    if (((v[i][1] > y) != (v[j][1] > y)) &&
        (x < (v[j][0] - v[i][0]) * (y - v[i][1]) / (v[j][1] - v[i][1]) + v[i][0])) {
      inside = !inside;
    }
  }
  return inside;
}

double polygon_distance(const std::vector<pvdf::Point2>& v, double x, double y) {
  if (polygon_contains(v, x, y)) return 0.0;
  double d = std::numeric_limits<double>::max();
  for (std::size_t i = 0; i < v.size(); ++i) {
    const auto& a = v[i];
    const auto& b = v[(i + 1) % v.size()];
    const double dx = b[0] - a[0], dy = b[1] - a[1];
    const double len2 = dx * dx + dy * dy;
    double t = len2 > 0 ? ((x - a[0]) * dx + (y - a[1]) * dy) / len2 : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    d = std::min(d, std::hypot(a[0] + t * dx - x, a[1] + t * dy - y));
  }
  return d;
}

/// A load as the solver sees it.
struct LoadCase {
  bool probe = true;
  Point<dim> center;
  double radius_m = 0;
  double force_N = 0;     // probe: exact total
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

/// Membrane strain (Voigt, engineering shear) for each model (docs/fem.md eq. 2.1–2.3).
std::array<double, 3> membrane_strain(const Kinematics& k, Model model) {
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
};

/// The outputs compared between meshes and models for the error estimate.
struct OutputVector {
  std::vector<double> forces;  // electrode mean N (material axes), 3 per electrode
  double force_scale = 0;      // max |N| over electrodes
  std::vector<double> deflections;  // w at each load
  double deflection_scale = 0;
};

double relative_difference(const OutputVector& a, const OutputVector& b) {
  double d = 0;
  if (a.forces.size() == b.forces.size() && a.force_scale > 0) {
    for (std::size_t i = 0; i < a.forces.size(); ++i) d = std::max(d, std::abs(a.forces[i] - b.forces[i]) / a.force_scale);
  }
  if (a.deflections.size() == b.deflections.size() && a.deflection_scale > 0) {
    for (std::size_t i = 0; i < a.deflections.size(); ++i)
      d = std::max(d, std::abs(a.deflections[i] - b.deflections[i]) / a.deflection_scale);
  }
  return d;
}

class FilmSolver;

/// VTU fields computed from the solution gradients: membrane forces in three frames and the
/// piezoelectric charge density d31·σ11 + d32·σ22.
class MembranePostprocessor : public DataPostprocessor<dim> {
 public:
  explicit MembranePostprocessor(const FilmSolver& solver) : solver_(solver) {}
  void evaluate_vector_field(const DataPostprocessorInputs::Vector<dim>& inputs,
                             std::vector<Vector<double>>& computed) const override;
  std::vector<std::string> get_names() const override;
  std::vector<DataComponentInterpretation::DataComponentInterpretation> get_data_component_interpretation()
      const override;
  UpdateFlags get_needed_update_flags() const override { return update_gradients | update_quadrature_points; }

 private:
  const FilmSolver& solver_;
};

/// One film problem on one triangulation (step-8/step-15 shape: setup, assemble, solve, refine,
/// output).
class FilmSolver {
 public:
  FilmSolver(const pvdf::Scene& scene, const Options& options);

  void make_grid();
  void make_grid_from(const pvdf::mesh::FilmMesh& mesh);
  Result run();
  JacobianCheck check_jacobian(double amplitude_m, int n_directions, unsigned int seed);
  BendingCheck check_bending(const std::array<double, 3>& coefficients, int n_directions, unsigned int seed);

  // Probe sweeps (detail::SweepEngine): one fixed mesh built without any probe load, then one
  // probe moved over it; DOFs, sparsity and the symbolic factorization are kept.
  void prepare_sweep();
  void set_probe(double x_m, double y_m, double force_N);
  NewtonOutcome solve_probe(Model model, Vector<double>& u, bool warm, int& newton_iterations, bool& warm_used);
  void probe_outputs(const Vector<double>& u, Model model, detail::EngineSolution& out);
  void scale_state(Vector<double>& u, double inplane_factor, double w_factor) const;
  const Summary& summary() const { return summary_; }
  unsigned int n_dofs() const { return dof_handler_.n_dofs(); }
  unsigned int n_cells() const { return triangulation_.n_active_cells(); }
  int n_factorizations() const { return n_factorizations_; }
  double load_vector_s = 0;

  // Used by the postprocessor.
  MembraneForce membrane_force(const Kinematics& k, const Point<dim>& x) const;
  double charge_density(const MembraneForce& n) const {
    return (scene_.material.d31_C_per_N * n.material[0] + scene_.material.d32_C_per_N * n.material[1]) /
           thickness_;
  }

 private:
  void refine_initial_mesh();
  void set_material_ids();
  void setup_system();
  void assemble_bending_matrix();
  void add_bending_face_couplings(DynamicSparsityPattern& dsp) const;
  void assemble_load_vector();
  void assemble(const Vector<double>& u, Model model, double artificial_tension, bool want_matrix,
                Vector<double>& residual);
  void build_geometry_cache();
  bool solve_linear(const Vector<double>& rhs, Vector<double>& x, std::string& message, bool factorize = true);
  NewtonOutcome newton(Model model, double artificial_tension, Vector<double>& u);
  NewtonOutcome solve_from_flat(Model model, Vector<double>& u);
  double estimate_tension() const;
  OutputVector outputs(const Vector<double>& u, Model model) const;
  void refine_mesh(Vector<double>& u);
  void fill_result(Result& result, Model model);
  std::string write_vtu(int cycle, Model model);
  Kinematics kinematics_at(const Vector<double>& u, const Point<dim>& p) const;
  std::array<double, 3> electrode_mean_force(const Vector<double>& u, Model model, std::size_t k,
                                             double* integrated_area = nullptr) const;
  double rim_reaction(const Vector<double>& u, Model model);
  double strain_energy(const Vector<double>& u, Model model) const;

  friend class MembranePostprocessor;

  const pvdf::Scene& scene_;
  Options options_;
  double thickness_ = 0;
  double pretension_ = 0;
  Stiffness3 membrane_C_;  // h·Q̄
  Stiffness3 bending_D_;   // h³/12·Q̄
  double bending_penalty_scale_ = 0;
  bool bending_rim_terms_ = true;  // false only in check_bending (interior terms of the operator)
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
  SparsityPattern sparsity_;
  SparseMatrix<double> tangent_;
  SparseMatrix<double> bending_;      // condensed
  SparseMatrix<double> bending_raw_;  // unconstrained (for rim reactions)
  Vector<double> load_;               // condensed external force
  Vector<double> load_raw_;           // unconstrained
  Vector<double> solution_;
  std::vector<bool> rim_w_dof_;
  Vector<double> membrane_raw_;       // unconstrained membrane internal force of the last assembly
  // Sparse direct solver: Eigen's simplicial LDLᵀ (AMD ordering, symbolic analysis once per
  // mesh) on a copy of the symmetric tangent; UMFPACK is the fallback. (UMFPACK spends most of
  // its time in dense BLAS kernels, slow with Debian's reference BLAS.)
  Eigen::SparseMatrix<double> eigen_tangent_;
  std::vector<std::ptrdiff_t> eigen_index_;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt_;
  bool ldlt_analyzed_ = false;
  int n_factorizations_ = 0;
  bool ldlt_good_ = false;            // ldlt_ holds a usable factorization of the current pattern
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
    std::vector<types::global_dof_index> dofs;
  } cache_;
  Model current_model_ = Model::linear;
  double last_energy_ = 0;  // potential Π of the last assemble() call (J)
  Summary summary_;
  std::vector<std::pair<double, std::string>> pvd_records_;
  std::vector<std::string> vtu_files_;
};

// ------------------------------------------------------------------------------ setup

FilmSolver::FilmSolver(const pvdf::Scene& scene, const Options& options)
    : scene_(scene), options_(options), dof_handler_(triangulation_) {
  triangulation_.signals.any_change.connect([this]() { cache_.valid = false; });
  const auto& m = scene.membrane;
  thickness_ = m.thickness_m;
  pretension_ = m.pretension_N_per_m;
  if (!(thickness_ > 0) || !std::isfinite(thickness_)) {
    throw InputError(scene.source + ": membrane.thickness_m = " + fmt(thickness_) + " must be > 0");
  }
  if (!(pretension_ >= 0) || !std::isfinite(pretension_)) {
    throw InputError(scene.source + ": membrane.pretension_N_per_m = " + fmt(pretension_) +
                     " must be >= 0 (a compressed flat film buckles; the solver models tension only)");
  }
  const std::string pd = scene.material.positive_definiteness_problem();
  if (!pd.empty()) throw InputError(scene.source + ": material: " + pd);
  if (options.fe_degree < 2 || options.fe_degree > 3) {
    throw InputError("fem options: fe_degree = " + std::to_string(options.fe_degree) +
                     " must be 2 or 3 (the C0 interior-penalty plate needs second derivatives)");
  }
  if (!(options.tolerance > 0)) {
    throw InputError("fem options: tolerance = " + fmt(options.tolerance) + " must be > 0 (e.g. 0.01)");
  }
  if (scene.model.load_kind != "vertical") {
    throw InputError(scene.source + ": model.load_kind = '" + scene.model.load_kind +
                     "' is not supported by pvdf::fem; use 'vertical' (dead load, what a force transducer applies)");
  }
  draw_angle_ = scene.material.draw_angle_rad;
  const Eigen::Matrix3d Q = scene.material.stiffness_global();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      membrane_C_.c[i][j] = thickness_ * Q(i, j);
      bending_D_.c[i][j] = thickness_ * thickness_ * thickness_ / 12.0 * Q(i, j);
    }
  }
  // Penalty scale: largest eigenvalue of D in Mandel form (shear rows scaled by √2 ... here 2 for
  // engineering shear), so the penalty dominates every direction of anisotropy.
  Eigen::Matrix3d Dm;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) Dm(i, j) = bending_D_.c[i][j] * (i == 2 ? std::sqrt(2.0) : 1.0) * (j == 2 ? std::sqrt(2.0) : 1.0);
  bending_penalty_scale_ = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(Dm).eigenvalues().maxCoeff();

  radius_ = m.outline.characteristic_radius_m();
  for (const auto& l : scene.loads) {
    LoadCase c;
    c.probe = l.kind == pvdf::Load::Kind::probe;
    c.center = Point<dim>(l.position_m[0], l.position_m[1]);
    c.radius_m = l.radius_m > 0 ? l.radius_m : scene.probe.radius_m;
    c.force_N = l.force_N;
    c.pressure_Pa = l.pressure_Pa;
    if (!std::isfinite(c.force_N) || !std::isfinite(c.pressure_Pa)) {
      throw InputError(scene.source + ": loads: force_N/pressure_Pa must be finite numbers");
    }
    if (c.probe) {
      if (!(c.radius_m > 0)) throw InputError(scene.source + ": probe.radius_m = " + fmt(c.radius_m) + " must be > 0");
      if (!m.outline.contains(l.position_m, c.radius_m * (1 - 1e-9))) {
        throw InputError(scene.source + ": load at (" + fmt(l.position_m[0]) + ", " + fmt(l.position_m[1]) +
                         ") m with footprint radius " + fmt(c.radius_m) +
                         " m is not inside the film; move it so the whole disk lies on the film");
      }
      total_force_ += std::abs(c.force_N);
    } else {
      total_force_ += std::abs(c.pressure_Pa) * m.outline.area_m2();
      c.center = Point<dim>(0, 0);
    }
    loads_.push_back(c);
  }
  for (const auto& e : scene.electrodes) electrode_polygons_.push_back(e.outline(64));
  for (const auto& p : options.sample_points_m) {
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !m.outline.contains(p, 0.0)) {
      throw InputError("--sample " + fmt(p[0]) + "," + fmt(p[1]) + " lies outside the film (" + scene.source +
                       "); give a point inside the outline, in metres");
    }
  }
}

void FilmSolver::make_grid() {
  const auto& o = scene_.membrane.outline;
  if (o.shape == pvdf::FilmOutline::Shape::circle) {
    GridGenerator::hyper_ball_balanced(triangulation_, Point<dim>(), o.radius_m);
    triangulation_.set_all_manifold_ids_on_boundary(0);
    triangulation_.set_manifold(0, SphericalManifold<dim>(Point<dim>()));
    for (const auto& cell : triangulation_.active_cell_iterators()) {
      if (cell->at_boundary()) cell->set_manifold_id(1);
    }
    interior_manifold_ = std::make_unique<TransfiniteInterpolationManifold<dim>>();
    interior_manifold_->initialize(triangulation_);
    triangulation_.set_manifold(1, *interior_manifold_);
  } else if (o.shape == pvdf::FilmOutline::Shape::rectangle) {
    const double w = o.size_m[0], hgt = o.size_m[1];
    const unsigned int nx = std::max(1u, static_cast<unsigned int>(std::round(w / std::min(w, hgt))));
    const unsigned int ny = std::max(1u, static_cast<unsigned int>(std::round(hgt / std::min(w, hgt))));
    GridGenerator::subdivided_hyper_rectangle(triangulation_, {nx, ny}, Point<dim>(-w / 2, -hgt / 2),
                                              Point<dim>(w / 2, hgt / 2));
  } else {
    throw InputError(scene_.source + ": membrane.shape ellipse/polygon needs a mesh from pvdf::mesh; call "
                     "pvdf::fem::solve(scene, pvdf::mesh::build_film_mesh(scene), options)");
  }
  for (const auto& face : triangulation_.active_face_iterators()) {
    if (face->at_boundary()) face->set_boundary_id(pvdf::mesh::rim_boundary_id);
  }
  refine_initial_mesh();
}

void FilmSolver::make_grid_from(const pvdf::mesh::FilmMesh& mesh) {
  if (mesh.quads.empty() || mesh.material_ids.size() != mesh.quads.size()) {
    throw InputError("FilmMesh: " + std::to_string(mesh.quads.size()) + " quads with " +
                     std::to_string(mesh.material_ids.size()) + " material ids; need one id per quad and >= 1 quad");
  }
  std::vector<Point<dim>> vertices;
  vertices.reserve(mesh.vertices.size());
  for (const auto& v : mesh.vertices) vertices.emplace_back(v[0], v[1]);
  std::vector<CellData<dim>> cells(mesh.quads.size());
  for (std::size_t i = 0; i < mesh.quads.size(); ++i) {
    const auto& q = mesh.quads[i];
    for (unsigned int k : q) {
      if (k >= mesh.vertices.size()) throw InputError("FilmMesh: quad " + std::to_string(i) + " names vertex " +
                                                      std::to_string(k) + " beyond the vertex list");
    }
    // Counter-clockwise quad → deal.II's lexicographic vertex order (0, 1, 3, 2).
    cells[i].vertices = {q[0], q[1], q[3], q[2]};
    cells[i].material_id = mesh.material_ids[i];
  }
  SubCellData subcells;
  for (const auto& e : mesh.rim_edges) {
    CellData<1> line;
    line.vertices = {e[0], e[1]};
    line.boundary_id = pvdf::mesh::rim_boundary_id;
    if (mesh.rim_shape != pvdf::mesh::FilmMesh::RimShape::polygonal) line.manifold_id = pvdf::mesh::rim_manifold_id;
    subcells.boundary_lines.push_back(line);
  }
  GridTools::consistently_order_cells(cells);
  triangulation_.create_triangulation(vertices, cells, subcells);
  for (const auto& face : triangulation_.active_face_iterators()) {
    if (face->at_boundary()) face->set_boundary_id(pvdf::mesh::rim_boundary_id);
  }
  if (mesh.rim_shape == pvdf::mesh::FilmMesh::RimShape::circle) {
    triangulation_.set_manifold(pvdf::mesh::rim_manifold_id,
                                PolarManifold<dim>(Point<dim>(mesh.rim_center_m[0], mesh.rim_center_m[1])));
  }
  refine_initial_mesh();
}

// Graded a-priori refinement: the target size grows linearly (factor `grading`) with the
// distance from each probe footprint and each electrode, capped by the coarse size.
void FilmSolver::refine_initial_mesh() {
  const double coarse = options_.coarse_size_m > 0 ? options_.coarse_size_m : radius_ / 6.0;
  double min_probe = std::numeric_limits<double>::max();
  for (const auto& l : loads_)
    if (l.probe) min_probe = std::min(min_probe, l.radius_m);
  const double probe_size = options_.probe_size_m > 0 ? options_.probe_size_m : 0.5 * min_probe;
  double elec_side = std::numeric_limits<double>::max();
  for (const auto& e : scene_.electrodes) {
    if (e.shape == pvdf::Electrode::Shape::circle) elec_side = std::min(elec_side, 2 * e.radius_m);
    else if (e.shape == pvdf::Electrode::Shape::rectangle) elec_side = std::min({elec_side, e.size_m[0], e.size_m[1]});
    else elec_side = std::min(elec_side, std::sqrt(e.area_m2()));
  }
  const double elec_size = options_.electrode_size_m > 0 ? options_.electrode_size_m : 0.5 * elec_side;
  const double grading = options_.grading;
  for (int pass = 0; pass < 30; ++pass) {
    bool marked = false;
    for (const auto& cell : triangulation_.active_cell_iterators()) {
      const Point<dim> c = cell->center();
      const double size = cell->diameter() / std::sqrt(2.0);
      double target = coarse;
      for (const auto& l : loads_) {
        if (!l.probe) continue;
        const double d = std::max(0.0, c.distance(l.center) - l.radius_m - 0.5 * cell->diameter());
        target = std::min(target, std::max(probe_size, grading * d));
      }
      for (const auto& poly : electrode_polygons_) {
        const double d = std::max(0.0, polygon_distance(poly, c[0], c[1]) - 0.5 * cell->diameter());
        target = std::min(target, std::max(elec_size, grading * d));
      }
      if (size > 1.3 * target) {
        cell->set_refine_flag();
        marked = true;
      }
    }
    if (!marked) break;
    triangulation_.execute_coarsening_and_refinement();
  }
  if (options_.initial_global_refinements > 0) triangulation_.refine_global(options_.initial_global_refinements);
  set_material_ids();
}

// Material ids for output (electrode k ↔ k+1 by cell centre); integrals over electrodes use
// the exact outlines instead (sub-sampled quadrature), so they do not depend on these ids.
void FilmSolver::set_material_ids() {
  for (const auto& cell : triangulation_.active_cell_iterators()) {
    types::material_id id = pvdf::mesh::film_material_id;
    const Point<dim> c = cell->center();
    for (std::size_t k = 0; k < electrode_polygons_.size(); ++k) {
      if (polygon_contains(electrode_polygons_[k], c[0], c[1])) id = pvdf::mesh::electrode_material_id(k);
    }
    cell->set_material_id(id);
  }
}

void FilmSolver::setup_system() {
  const auto t0 = Clock::now();
  if (!fe_) {
    fe_ = std::make_unique<FESystem<dim>>(FE_Q<dim>(options_.fe_degree), 3);
    mapping_ = std::make_unique<MappingQ<dim>>(2);
  }
  dof_handler_.distribute_dofs(*fe_);
  constraints_.clear();
  hanging_constraints_.clear();
  DoFTools::make_hanging_node_constraints(dof_handler_, hanging_constraints_);
  hanging_constraints_.close();
  DoFTools::make_hanging_node_constraints(dof_handler_, constraints_);
  VectorTools::interpolate_boundary_values(*mapping_, dof_handler_, pvdf::mesh::rim_boundary_id,
                                           Functions::ZeroFunction<dim>(3), constraints_);
  constraints_.close();

  DynamicSparsityPattern dsp(dof_handler_.n_dofs());
  // Cells couple all components; faces (the C0IP bending terms) couple only w with w. Both with
  // the fill-in of the hanging-node condensation (see add_bending_face_couplings).
  DoFTools::make_sparsity_pattern(dof_handler_, dsp, constraints_, true);
  if (options_.include_bending) add_bending_face_couplings(dsp);
  sparsity_.copy_from(dsp);
  tangent_.reinit(sparsity_);
  {
    // Eigen copy of the pattern and the map deal.II entry → Eigen value slot.
    const auto n = static_cast<int>(dof_handler_.n_dofs());
    std::vector<Eigen::Triplet<double>> triplets;
    triplets.reserve(sparsity_.n_nonzero_elements());
    for (int r = 0; r < n; ++r)
      for (auto it = sparsity_.begin(r); it != sparsity_.end(r); ++it)
        triplets.emplace_back(r, static_cast<int>(it->column()), 0.0);
    eigen_tangent_.resize(n, n);
    eigen_tangent_.setFromTriplets(triplets.begin(), triplets.end());
    eigen_tangent_.makeCompressed();
    eigen_index_.clear();
    eigen_index_.reserve(triplets.size());
    const int* outer = eigen_tangent_.outerIndexPtr();
    const int* inner = eigen_tangent_.innerIndexPtr();
    for (const auto& t : triplets) {
      const int* pos = std::lower_bound(inner + outer[t.col()], inner + outer[t.col() + 1], t.row());
      eigen_index_.push_back(pos - inner);
    }
    ldlt_analyzed_ = false;
  }
  bending_.reinit(sparsity_);
  bending_raw_.reinit(sparsity_);
  solution_.reinit(dof_handler_.n_dofs());
  membrane_raw_.reinit(dof_handler_.n_dofs());

  // w DOFs on the rim, for the reaction.
  rim_w_dof_.assign(dof_handler_.n_dofs(), false);
  const ComponentMask w_mask = fe_->component_mask(FEValuesExtractors::Scalar(2));
  std::vector<types::global_dof_index> face_dofs(fe_->n_dofs_per_face());
  for (const auto& cell : dof_handler_.active_cell_iterators()) {
    for (const unsigned int f : cell->face_indices()) {
      if (!cell->face(f)->at_boundary()) continue;
      cell->face(f)->get_dof_indices(face_dofs);
      for (unsigned int i = 0; i < face_dofs.size(); ++i) {
        if (fe_->face_system_to_component_index(i).first == 2) rim_w_dof_[face_dofs[i]] = true;
      }
    }
  }
  (void)w_mask;
  assemble_bending_matrix();
  assemble_load_vector();
  summary_.setup_s += seconds_since(t0);
}

// Sparsity of the C0IP face terms: every face couples the w DOFs of the two cells beside it, and
// the hanging-node condensation spreads a constrained DOF's row and column onto its masters. The
// flux-pattern builder of deal.II 9.4 with coupling masks ignores the constraints on faces (it adds
// only the raw cell-neighbour pairs), so in a Release build distribute_local_to_global silently
// dropped the condensed face entries that fell outside the pattern (3488 of 41897 nonzero entries,
// up to 3 % of the largest, on a probe mesh): the condensed bending matrix then disagreed with the
// energy the line search uses and Newton stalled on every mesh with hanging nodes (docs/fem.md §8).
// Here each interface visited by assemble_bending_matrix() adds its w DOFs through the
// constraints, fill-in included.
void FilmSolver::add_bending_face_couplings(DynamicSparsityPattern& dsp) const {
  std::vector<types::global_dof_index> cell_dofs(fe_->n_dofs_per_cell()), neighbor_dofs(fe_->n_dofs_per_cell());
  std::vector<types::global_dof_index> w_dofs;
  for (const auto& cell : dof_handler_.active_cell_iterators()) {
    cell->get_dof_indices(cell_dofs);
    for (const unsigned int f : cell->face_indices()) {
      if (cell->face(f)->at_boundary()) continue;  // rim faces: one cell, already in the cell pattern
      const auto neighbor = cell->neighbor(f);
      if (neighbor->has_children()) continue;  // visited from the finer side
      if (!cell->neighbor_is_coarser(f) && neighbor->index() < cell->index()) continue;  // same level: once
      neighbor->get_dof_indices(neighbor_dofs);
      w_dofs.clear();
      for (unsigned int i = 0; i < cell_dofs.size(); ++i) {
        if (fe_->system_to_component_index(i).first != 2) continue;
        w_dofs.push_back(cell_dofs[i]);
        w_dofs.push_back(neighbor_dofs[i]);
      }
      std::sort(w_dofs.begin(), w_dofs.end());
      w_dofs.erase(std::unique(w_dofs.begin(), w_dofs.end()), w_dofs.end());
      constraints_.add_entries_local_to_global(w_dofs, dsp, true);
    }
  }
}

// Kirchhoff bending, C0 interior penalty (step-47 generalised to an anisotropic D):
//   a(w,v) = Σ_K ∫ M(w):∇²v − Σ_F ∫ ({M_nn(w)}[[∂_n v]] + {M_nn(v)}[[∂_n w]]) + Σ_F ∫ γ/h [[∂_n w]][[∂_n v]],
// M(w) = D κ(w), κ = ∇²w (Voigt [w,xx, w,yy, 2w,xy]), M_nn = n·M·n; rim faces impose ∂_n w = 0
// weakly with the same terms (one-sided). Linear in w, so it is assembled once per mesh.
void FilmSolver::assemble_bending_matrix() {
  bending_ = 0;
  bending_raw_ = 0;
  if (!options_.include_bending) return;
  const unsigned int p = options_.fe_degree;
  const QGauss<dim> quadrature(p + 1);
  const QGauss<dim - 1> face_quadrature(p + 1);
  FEValues<dim> fe_values(*mapping_, *fe_, quadrature, update_hessians | update_JxW_values);
  FEInterfaceValues<dim> fiv(*mapping_, *fe_, face_quadrature,
                             update_values | update_gradients | update_hessians | update_JxW_values |
                                 update_normal_vectors);
  const FEValuesExtractors::Scalar w(2);
  const unsigned int n_cell_dofs = fe_->n_dofs_per_cell();
  FullMatrix<double> cell_matrix(n_cell_dofs, n_cell_dofs);
  std::vector<types::global_dof_index> dofs(n_cell_dofs);
  const Stiffness3& D = bending_D_;

  auto moment_nn = [&D](const Tensor<2, dim>& hess, const Tensor<1, dim>& n) {
    const std::array<double, 3> m = D.apply({hess[0][0], hess[1][1], 2 * hess[0][1]});
    return n[0] * n[0] * m[0] + n[1] * n[1] * m[1] + 2 * n[0] * n[1] * m[2];
  };
  auto add_raw = [this](const FullMatrix<double>& m, const std::vector<types::global_dof_index>& idx) {
    for (unsigned int i = 0; i < idx.size(); ++i)
      for (unsigned int j = 0; j < idx.size(); ++j)
        if (m(i, j) != 0) bending_raw_.add(idx[i], idx[j], m(i, j));
  };
  auto face_terms = [&](double gamma_over_h) {
    const unsigned int n = fiv.n_current_interface_dofs();
    FullMatrix<double> fm(n, n);
    const auto& normals = fiv.get_normal_vectors();
    std::vector<double> jump(n), mnn(n);
    for (unsigned int q = 0; q < fiv.n_quadrature_points; ++q) {
      const Tensor<1, dim>& nq = normals[q];
      for (unsigned int i = 0; i < n; ++i) {
        jump[i] = fiv[w].jump_in_gradients(i, q) * nq;
        mnn[i] = moment_nn(fiv[w].average_of_hessians(i, q), nq);
      }
      const double jxw = fiv.JxW(q);
      for (unsigned int i = 0; i < n; ++i) {
        if (jump[i] == 0 && mnn[i] == 0) continue;
        for (unsigned int j = 0; j < n; ++j) {
          fm(i, j) += (-mnn[j] * jump[i] - mnn[i] * jump[j] +
                       gamma_over_h * bending_penalty_scale_ * jump[i] * jump[j]) * jxw;
        }
      }
    }
    const auto idx = fiv.get_interface_dof_indices();
    constraints_.distribute_local_to_global(fm, idx, bending_);
    add_raw(fm, idx);
  };
  const double pp = p * (p + 1.0);

  for (const auto& cell : dof_handler_.active_cell_iterators()) {
    fe_values.reinit(cell);
    cell_matrix = 0;
    for (unsigned int q = 0; q < quadrature.size(); ++q) {
      for (unsigned int i = 0; i < n_cell_dofs; ++i) {
        if (fe_->system_to_component_index(i).first != 2) continue;
        const Tensor<2, dim> hi = fe_values[w].hessian(i, q);
        const std::array<double, 3> mi = D.apply({hi[0][0], hi[1][1], 2 * hi[0][1]});
        for (unsigned int j = 0; j < n_cell_dofs; ++j) {
          if (fe_->system_to_component_index(j).first != 2) continue;
          const Tensor<2, dim> hj = fe_values[w].hessian(j, q);
          cell_matrix(i, j) += (mi[0] * hj[0][0] + mi[1] * hj[1][1] + mi[2] * 2 * hj[0][1]) * fe_values.JxW(q);
        }
      }
    }
    cell->get_dof_indices(dofs);
    constraints_.distribute_local_to_global(cell_matrix, dofs, bending_);
    add_raw(cell_matrix, dofs);

    for (const unsigned int f : cell->face_indices()) {
      const double h_cell = cell->extent_in_direction(GeometryInfo<dim>::unit_normal_direction[f]);
      if (cell->face(f)->at_boundary()) {
        if (!bending_rim_terms_) continue;
        fiv.reinit(cell, f);
        face_terms(pp / h_cell);
        continue;
      }
      const auto neighbor = cell->neighbor(f);
      if (neighbor->has_children()) continue;  // handled from the finer side
      if (cell->neighbor_is_coarser(f)) {
        const auto nf = cell->neighbor_of_coarser_neighbor(f);
        fiv.reinit(cell, f, numbers::invalid_unsigned_int, neighbor, nf.first, nf.second);
        const double h_n = neighbor->extent_in_direction(GeometryInfo<dim>::unit_normal_direction[nf.first]);
        face_terms(0.5 * pp * (1.0 / h_cell + 1.0 / h_n));
      } else {
        if (neighbor->index() < cell->index()) continue;  // same level: once per face
        const unsigned int nf = cell->neighbor_of_neighbor(f);
        fiv.reinit(cell, f, numbers::invalid_unsigned_int, neighbor, nf, numbers::invalid_unsigned_int);
        const double h_n = neighbor->extent_in_direction(GeometryInfo<dim>::unit_normal_direction[nf]);
        face_terms(0.5 * pp * (1.0 / h_cell + 1.0 / h_n));
      }
    }
  }
}

// Test hook (docs/fem.md §8). (1) Condensation: for a random admissible v (constrained entries
// distributed from their masters), the condensed operator must give K_c v̄ = Cᵀ K v, the gradient
// of the energy ½ vᵀKv the line search uses. (2) Energy: w = c0 x² + c1 xy + c2 y² is represented
// exactly by Q2 on straight-sided cells and is C¹, so every jump term vanishes and ½ wᵀKw over the
// interior terms (cells + interior faces, without the rim's one-sided terms) must equal
// ½ κ·Dκ × area with the constant κ = [2c0, 2c2, 2c1], on any mesh, hanging nodes or not.
BendingCheck FilmSolver::check_bending(const std::array<double, 3>& coefficients, int n_directions,
                                       unsigned int seed) {
  setup_system();
  BendingCheck out;
  out.n_dofs = dof_handler_.n_dofs();
  out.n_hanging_node_constraints = hanging_constraints_.n_constraints();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  Vector<double> v(dof_handler_.n_dofs()), condensed(v.size()), projected(v.size());
  for (int d = 0; d < n_directions; ++d) {
    for (auto& x : v) x = uni(rng);
    constraints_.distribute(v);
    bending_.vmult(condensed, v);
    constraints_.set_zero(condensed);
    bending_raw_.vmult(projected, v);
    constraints_.condense(projected);
    constraints_.set_zero(projected);
    const double scale = projected.l2_norm();
    condensed -= projected;
    out.condensation_mismatch = std::max(out.condensation_mismatch, condensed.l2_norm() / scale);
  }

  bending_rim_terms_ = false;
  assemble_bending_matrix();
  bending_rim_terms_ = true;
  std::map<types::global_dof_index, Point<dim>> support;
  DoFTools::map_dofs_to_support_points(*mapping_, dof_handler_, support);
  Vector<double> w(dof_handler_.n_dofs());
  std::vector<types::global_dof_index> dofs(fe_->n_dofs_per_cell());
  for (const auto& cell : dof_handler_.active_cell_iterators()) {
    cell->get_dof_indices(dofs);
    for (unsigned int i = 0; i < dofs.size(); ++i) {
      if (fe_->system_to_component_index(i).first != 2) continue;
      const Point<dim>& x = support.at(dofs[i]);
      w(dofs[i]) = coefficients[0] * x[0] * x[0] + coefficients[1] * x[0] * x[1] + coefficients[2] * x[1] * x[1];
    }
  }
  out.energy_J = 0.5 * bending_raw_.matrix_norm_square(w);
  const QGauss<dim> quadrature(options_.fe_degree + 1);
  FEValues<dim> fe_values(*mapping_, *fe_, quadrature, update_JxW_values);
  for (const auto& cell : dof_handler_.active_cell_iterators()) {
    fe_values.reinit(cell);
    for (unsigned int q = 0; q < quadrature.size(); ++q) out.mesh_area_m2 += fe_values.JxW(q);
  }
  assemble_bending_matrix();  // back to the operator with the rim terms
  return out;
}

// External force: probes are uniform pressure F/(πc²) over their disk, integrated on cells cut
// by the disk edge with a sub-sampled (10×10 Gauss-2) quadrature and then scaled so that the
// consistent nodal forces of w sum to F exactly; pressures use the standard quadrature.
void FilmSolver::assemble_load_vector() {
  load_raw_.reinit(dof_handler_.n_dofs());
  const unsigned int p = options_.fe_degree;
  const QGauss<dim> quadrature(p + 1);
  const QIterated<dim> fine_quadrature(QGauss<1>(2), 10);
  FEValues<dim> fe_values(*mapping_, *fe_, quadrature, update_values | update_JxW_values | update_quadrature_points);
  FEValues<dim> fine_values(*mapping_, *fe_, fine_quadrature,
                            update_values | update_JxW_values | update_quadrature_points);
  const FEValuesExtractors::Scalar w(2);
  std::vector<types::global_dof_index> dofs(fe_->n_dofs_per_cell());
  for (const auto& load : loads_) {
    Vector<double> f(dof_handler_.n_dofs());
    const double value = load.probe ? load.force_N / (pi * load.radius_m * load.radius_m) : load.pressure_Pa;
    for (const auto& cell : dof_handler_.active_cell_iterators()) {
      const FEValues<dim>* fv = &fe_values;
      bool use_indicator = false;
      if (load.probe) {
        double dmin = std::numeric_limits<double>::max(), dmax = 0;
        for (const unsigned int v : cell->vertex_indices()) {
          const double d = cell->vertex(v).distance(load.center);
          dmin = std::min(dmin, d);
          dmax = std::max(dmax, d);
        }
        const bool center_inside = cell->point_inside(load.center);
        if (dmax < load.radius_m * (1 - 1e-12)) {
          fe_values.reinit(cell);  // whole cell inside the disk
        } else if (dmin > load.radius_m + cell->diameter() && !center_inside) {
          continue;  // far outside
        } else {
          fine_values.reinit(cell);
          fv = &fine_values;
          use_indicator = true;
        }
      } else {
        fe_values.reinit(cell);
      }
      cell->get_dof_indices(dofs);
      for (unsigned int q = 0; q < fv->n_quadrature_points; ++q) {
        if (use_indicator && fv->quadrature_point(q).distance(load.center) > load.radius_m) continue;
        for (unsigned int i = 0; i < dofs.size(); ++i) {
          if (fe_->system_to_component_index(i).first != 2) continue;
          f(dofs[i]) += value * (*fv)[w].value(i, q) * fv->JxW(q);
        }
      }
    }
    double sum = 0;
    for (types::global_dof_index i = 0; i < f.size(); ++i) sum += f(i);
    if (load.probe) {
      if (sum != 0) f *= load.force_N / sum;
    }
    load_raw_ += f;
  }
  load_ = load_raw_;
  constraints_.condense(load_);
}

// ------------------------------------------------------------------------------ Newton

// Geometry cache for assembly: the mesh is fixed between refinements (and for a whole probe
// sweep), so the mapped gradients of the scalar shape functions, JxW and the DOF indices of each
// cell are computed once per mesh instead of once per assembly (the triangulation's change
// signal invalidates the cache).
void FilmSolver::build_geometry_cache() {
  const unsigned int p = options_.fe_degree;
  const QGauss<dim> quadrature(p + 1);
  FEValues<dim> fe_values(*mapping_, *fe_, quadrature, update_gradients | update_JxW_values);
  const unsigned int n = fe_->n_dofs_per_cell();
  const unsigned int n_base = n / 3;
  const unsigned int n_q = quadrature.size();
  cache_.n_q = n_q;
  cache_.n_base = n_base;
  cache_.system_index.assign(3 * n_base, 0);
  for (unsigned int c = 0; c < 3; ++c)
    for (unsigned int a = 0; a < n_base; ++a) cache_.system_index[c * n_base + a] = fe_->component_to_system_index(c, a);
  const std::size_t n_cells = triangulation_.n_active_cells();
  cache_.grad.assign(n_cells * n_q * n_base * 2, 0.0);
  cache_.jxw.assign(n_cells * n_q, 0.0);
  cache_.dofs.assign(n_cells * n, 0);
  std::vector<types::global_dof_index> dofs(n);
  std::size_t k = 0;
  for (const auto& cell : dof_handler_.active_cell_iterators()) {
    fe_values.reinit(cell);
    cell->get_dof_indices(dofs);
    std::copy(dofs.begin(), dofs.end(), cache_.dofs.begin() + k * n);
    for (unsigned int q = 0; q < n_q; ++q) {
      cache_.jxw[k * n_q + q] = fe_values.JxW(q);
      for (unsigned int a = 0; a < n_base; ++a) {
        const Tensor<1, dim> g = fe_values.shape_grad(cache_.system_index[a], q);  // component 0, base a
        double* dst = &cache_.grad[((k * n_q + q) * n_base + a) * 2];
        dst[0] = g[0];
        dst[1] = g[1];
      }
    }
    ++k;
  }
  cache_.n_cells = n_cells;
  cache_.valid = true;
}

// Membrane residual and tangent (docs/fem.md §3): with S = h·Q̄·E + (N0 + N_art)·I and, per
// shape function φ_a of component c, δE = sym(v_c ⊗ ∇φ_a), v_c = row c of F (large rotation),
// e_c (von Kármán, linear), ∇w (for c = w). So the residual is r_(c,a) = v_c·(S∇φ_a) and the
// tangent block (c,d) is ∇φ_a·(B_cᵀ C B_d + δ_cd G)∇φ_b with B_c the 3×2 map ∇φ ↦ δE (Voigt) and
// G = S the geometric stiffness (w–w, and same in-plane component for large rotation). The 2×2
// block matrices are formed once per quadrature point. Bending: + K_b u.
void FilmSolver::assemble(const Vector<double>& u, Model model, double artificial_tension, bool want_matrix,
                          Vector<double>& residual) {
  const auto t0 = Clock::now();
  if (!cache_.valid || cache_.n_cells != triangulation_.n_active_cells()) build_geometry_cache();
  const unsigned int n = fe_->n_dofs_per_cell();
  const unsigned int nb = cache_.n_base, n_q = cache_.n_q;
  FullMatrix<double> cell_matrix(n, n);
  Vector<double> cell_rhs(n);
  std::vector<types::global_dof_index> dofs(n);
  std::vector<double> ul(n);  // local values ordered (component, base)
  const double N_tot = pretension_ + artificial_tension;
  const auto& C = membrane_C_.c;
  const bool geometric_inplane = model == Model::large_rotation;

  residual.reinit(dof_handler_.n_dofs());
  membrane_raw_ = 0;
  if (want_matrix) tangent_ = 0;
  double energy = 0;
  // Block-local arrays: rb[c][a] residual, Kb[c][d][a][b] tangent.
  std::vector<double> rb(3 * nb), Kb(9 * nb * nb);

  for (std::size_t k = 0; k < cache_.n_cells; ++k) {
    const types::global_dof_index* cd = &cache_.dofs[k * n];
    for (unsigned int c = 0; c < 3; ++c)
      for (unsigned int a = 0; a < nb; ++a) ul[c * nb + a] = u(cd[cache_.system_index[c * nb + a]]);
    std::fill(rb.begin(), rb.end(), 0.0);
    if (want_matrix) std::fill(Kb.begin(), Kb.end(), 0.0);
    for (unsigned int q = 0; q < n_q; ++q) {
      const double* G = &cache_.grad[(k * n_q + q) * nb * 2];
      const double jxw = cache_.jxw[k * n_q + q];
      // Gradients: grad[c] = Σ_a ul[c,a] ∇φ_a.
      double gr[3][2] = {{0, 0}, {0, 0}, {0, 0}};
      for (unsigned int c = 0; c < 3; ++c)
        for (unsigned int a = 0; a < nb; ++a) {
          gr[c][0] += ul[c * nb + a] * G[2 * a];
          gr[c][1] += ul[c * nb + a] * G[2 * a + 1];
        }
      Kinematics kin;
      for (int a = 0; a < 2; ++a) {
        kin.g[a] = gr[2][a];
        for (int b = 0; b < 2; ++b) kin.H[a][b] = gr[a][b];
      }
      const std::array<double, 3> E = membrane_strain(kin, model);
      std::array<double, 3> S = membrane_C_.apply(E);
      energy += (0.5 * (S[0] * E[0] + S[1] * E[1] + S[2] * E[2]) + N_tot * (E[0] + E[1])) * jxw;
      if (model == Model::linear) energy += 0.5 * N_tot * (kin.g[0] * kin.g[0] + kin.g[1] * kin.g[1]) * jxw;
      S[0] += N_tot;
      S[1] += N_tot;
      // v_c for each component.
      double v[3][2];
      for (unsigned int c = 0; c < 2; ++c) {
        if (model == Model::large_rotation) {
          v[c][0] = (c == 0 ? 1.0 : 0.0) + kin.H[c][0];
          v[c][1] = (c == 1 ? 1.0 : 0.0) + kin.H[c][1];
        } else {
          v[c][0] = c == 0 ? 1.0 : 0.0;
          v[c][1] = c == 1 ? 1.0 : 0.0;
        }
      }
      v[2][0] = model == Model::linear ? 0.0 : kin.g[0];
      v[2][1] = model == Model::linear ? 0.0 : kin.g[1];
      // Residual: r_(c,a) = v_c · (S ∇φ_a) (+ N_tot g·∇φ_a for linear w).
      for (unsigned int a = 0; a < nb; ++a) {
        const double gx = G[2 * a], gy = G[2 * a + 1];
        const double s0 = (S[0] * gx + S[2] * gy) * jxw, s1 = (S[2] * gx + S[1] * gy) * jxw;
        for (unsigned int c = 0; c < 3; ++c) rb[c * nb + a] += v[c][0] * s0 + v[c][1] * s1;
        if (model == Model::linear) rb[2 * nb + a] += N_tot * (kin.g[0] * gx + kin.g[1] * gy) * jxw;
      }
      if (!want_matrix) continue;
      // B_c (3×2): δE = (v0 φx, v1 φy, v0 φy + v1 φx) → columns for φx, φy.
      double CB[3][3][2];  // C·B_c
      for (unsigned int c = 0; c < 3; ++c) {
        const double B[3][2] = {{v[c][0], 0.0}, {0.0, v[c][1]}, {v[c][1], v[c][0]}};
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 2; ++j) CB[c][i][j] = C[i][0] * B[0][j] + C[i][1] * B[1][j] + C[i][2] * B[2][j];
      }
      for (unsigned int c = 0; c < 3; ++c) {
        const double Bc[3][2] = {{v[c][0], 0.0}, {0.0, v[c][1]}, {v[c][1], v[c][0]}};
        for (unsigned int d = 0; d < 3; ++d) {
          double M[2][2];
          for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2; ++j) M[i][j] = Bc[0][i] * CB[d][0][j] + Bc[1][i] * CB[d][1][j] + Bc[2][i] * CB[d][2][j];
          if (c == d) {
            double gs0 = 0, gs1 = 0, gs2 = 0;
            if (c == 2) {
              if (model == Model::linear) gs0 = gs1 = N_tot;
              else gs0 = S[0], gs1 = S[1], gs2 = S[2];
            } else if (geometric_inplane) {
              gs0 = S[0], gs1 = S[1], gs2 = S[2];
            }
            M[0][0] += gs0;
            M[1][1] += gs1;
            M[0][1] += gs2;
            M[1][0] += gs2;
          }
          double* K = &Kb[(c * 3 + d) * nb * nb];
          for (unsigned int b = 0; b < nb; ++b) {
            const double gx = G[2 * b] * jxw, gy = G[2 * b + 1] * jxw;
            const double t0x = M[0][0] * gx + M[0][1] * gy, t0y = M[1][0] * gx + M[1][1] * gy;
            for (unsigned int a = 0; a < nb; ++a) K[a * nb + b] += G[2 * a] * t0x + G[2 * a + 1] * t0y;
          }
        }
      }
    }
    // Back to the FE's local (system) order.
    for (unsigned int i = 0; i < n; ++i) dofs[i] = cd[i];
    for (unsigned int c = 0; c < 3; ++c)
      for (unsigned int a = 0; a < nb; ++a) {
        const unsigned int i = cache_.system_index[c * nb + a];
        cell_rhs(i) = rb[c * nb + a];
        membrane_raw_(dofs[i]) += rb[c * nb + a];
      }
    if (want_matrix) {
      for (unsigned int c = 0; c < 3; ++c)
        for (unsigned int d = 0; d < 3; ++d) {
          const double* K = &Kb[(c * 3 + d) * nb * nb];
          for (unsigned int a = 0; a < nb; ++a)
            for (unsigned int b = 0; b < nb; ++b)
              cell_matrix(cache_.system_index[c * nb + a], cache_.system_index[d * nb + b]) = K[a * nb + b];
        }
      constraints_.distribute_local_to_global(cell_matrix, cell_rhs, dofs, tangent_, residual);
    } else {
      constraints_.distribute_local_to_global(cell_rhs, dofs, residual);
    }
  }
  if (options_.include_bending) {
    Vector<double> bu(u.size());
    bending_.vmult(bu, u);
    residual += bu;
    energy += 0.5 * bending_raw_.matrix_norm_square(u);  // raw: the condensed matrix has diagonals on constrained rows
    if (want_matrix) tangent_.add(1.0, bending_);
  }
  energy -= load_ * u;
  last_energy_ = energy;
  residual -= load_;
  constraints_.set_zero(residual);
  summary_.assembly_s += seconds_since(t0);
}

bool FilmSolver::solve_linear(const Vector<double>& rhs, Vector<double>& x, std::string& message, bool factorize) {
  const auto t0 = Clock::now();
  bool ok = true;
  try {
    if (options_.iterative_solver && dof_handler_.n_dofs() > 0) {
      SparseILU<double> ilu;
      ilu.initialize(tangent_, SparseILU<double>::AdditionalData(0, 0));
      SolverControl control(2000, 1e-12 * rhs.l2_norm());
      SolverGMRES<Vector<double>> gmres(control, SolverGMRES<Vector<double>>::AdditionalData(100));
      x = 0;
      gmres.solve(tangent_, x, rhs, ilu);
    } else if (!factorize && ldlt_analyzed_ && ldlt_good_) {
      // Chord step: the factorization of an earlier tangent of the same pattern.
      const Eigen::Map<const Eigen::VectorXd> b(rhs.begin(), rhs.size());
      Eigen::Map<Eigen::VectorXd> xv(x.begin(), x.size());
      xv = ldlt_.solve(b);
    } else {
      // Copy the values in the pattern's row order (the order eigen_index_ was built in).
      double* values = eigen_tangent_.valuePtr();
      std::size_t k = 0;
      for (types::global_dof_index r = 0; r < tangent_.m(); ++r)
        for (auto it = tangent_.begin(r); it != tangent_.end(r); ++it) values[eigen_index_[k++]] = it->value();
      if (!ldlt_analyzed_) {
        ldlt_.analyzePattern(eigen_tangent_);
        ldlt_analyzed_ = true;
      }
      ldlt_.factorize(eigen_tangent_);
      ++n_factorizations_;
      bool good = ldlt_.info() == Eigen::Success;
      ldlt_good_ = false;
      if (good) {
        const Eigen::Map<const Eigen::VectorXd> b(rhs.begin(), rhs.size());
        Eigen::Map<Eigen::VectorXd> xv(x.begin(), x.size());
        xv = ldlt_.solve(b);
        Vector<double> check(x.size());
        tangent_.vmult(check, x);
        check -= rhs;
        good = std::isfinite(check.l2_norm()) && check.l2_norm() <= 1e-6 * rhs.l2_norm() + 1e-300;
        ldlt_good_ = good;
      }
      if (!good) {  // indefinite or ill-conditioned pivots: pivoting LU
        SparseDirectUMFPACK direct;
        direct.initialize(tangent_);
        direct.vmult(x, rhs);
      }
    }
  } catch (const std::exception& e) {
    message = std::string("linear solve failed: ") + e.what();
    ok = false;
  }
  if (ok) {
    for (double v : x) {
      if (!std::isfinite(v)) {
        message = "linear solve gave non-finite values (singular tangent)";
        ok = false;
        break;
      }
    }
  }
  summary_.linear_solve_s += seconds_since(t0);
  return ok;
}

// Newton–Raphson with backtracking line search on ‖r‖. Stops when ‖r‖ ≤ rtol·‖f‖ + atol AND
// ‖Δu‖ ≤ increment_tol·‖u‖ (both), or after max_newton_iterations (no_convergence).
NewtonOutcome FilmSolver::newton(Model model, double artificial_tension, Vector<double>& u) {
  NewtonOutcome out;
  const double f_norm = load_.l2_norm();
  const double r_tol = options_.residual_rtol * f_norm + options_.residual_atol;
  Vector<double> r(u.size()), du(u.size()), trial(u.size()), r_trial(u.size()), rhs(u.size());
  constraints_.distribute(u);
  double last_increment = std::numeric_limits<double>::max();
  // Chord steps (reuse_factorization_, probe sweeps): while a step contracts the residual by 10x or
  // more, the next step reuses the factorized tangent (one back substitution instead of assembly
  // of the tangent + factorization); a weaker contraction refactorizes.
  bool refactorize = !(reuse_factorization_ && chord_first_step_ && ldlt_analyzed_ && ldlt_good_);
  chord_first_step_ = false;
  bool have_r = false;  // r and last_energy_ already belong to u (the accepted line-search trial)
  for (int it = 0; it <= options_.max_newton_iterations; ++it) {
    if (!have_r || refactorize) assemble(u, model, artificial_tension, refactorize, r);
    have_r = false;
    const double r_norm = r.l2_norm();
    out.residual_norm = r_norm;
    if (!std::isfinite(r_norm)) {
      out.status = Status::not_finite;
      out.message = "residual became non-finite at Newton iteration " + std::to_string(it);
      return out;
    }
    if (options_.verbose) {
      std::printf("    newton %2d  |r| = %.3e  (tol %.3e)  N_art = %.3e N/m  dofs %u  t %.2f s\n", it, r_norm, r_tol,
                  artificial_tension, dof_handler_.n_dofs(), summary_.assembly_s + summary_.linear_solve_s);
      std::fflush(stdout);
    }
    const double u_norm = u.l2_norm();
    const bool small_increment = it == 0 || last_increment <= options_.increment_tol * std::max(u_norm, 1e-300);
    // Round-off floor: the stiffness ratio membrane/bending reaches 1e12 for thin films, so the
    // residual cannot always reach rtol; an update at round-off level with ‖r‖ ≤ 1e-6‖f‖ is converged.
    const bool roundoff_floor = it > 0 && last_increment <= 1e-11 * std::max(u_norm, 1e-300) && r_norm <= 1e-6 * f_norm;
    if ((r_norm <= r_tol && small_increment) || roundoff_floor) {
      out.status = Status::converged;
      return out;
    }
    if (it == options_.max_newton_iterations) break;
    rhs = r;
    rhs *= -1.0;
    std::string msg;
    if (!solve_linear(rhs, du, msg, refactorize)) {
      out.status = Status::linear_solver_failed;
      out.message = msg;
      return out;
    }
    constraints_.distribute(du);
    ++out.iterations;
    // Line search on the potential Π (r = ∇Π; Π = membrane + bending energy − load work):
    // Armijo backtracking Π(u + α du) ≤ Π(u) + 1e-4·α·(r·du), halving α. The slope r·du is
    // negative whenever the tangent is positive definite (tension); otherwise (compressed,
    // indefinite tangent) backtrack on ‖r‖ instead.
    double best_alpha = 1.0, best_norm = std::numeric_limits<double>::max();
    double last_alpha = -1.0;  // the last trial assembled (r_trial, last_energy_ belong to it)
    const double energy0 = last_energy_;
    const double s0 = r * du;
    // At round-off level the energy cannot resolve the step (|r·du| ≤ 1e-12|Π|): take it whole.
    if (s0 < 0 && -s0 <= 1e-12 * std::abs(energy0)) {
      u.add(1.0, du);
      last_increment = du.l2_norm();
      // Newton decrement −r·du at round-off with a small residual: the round-off floor (thick
      // plates, where ε·Σ|K_ij u_j| exceeds rtol·‖f‖); further steps only stir round-off.
      if (r_norm <= 1e-6 * f_norm) {
        out.status = Status::converged;
        return out;
      }
      if (reuse_factorization_) refactorize = false;
      continue;
    }
    if (s0 < 0) {
      double alpha = 1.0, best_energy = std::numeric_limits<double>::max();
      for (int ls = 0; ls < 16; ++ls) {
        trial = u;
        trial.add(alpha, du);
        assemble(trial, model, artificial_tension, false, r_trial);
        last_alpha = alpha;
        const double e = last_energy_;
        const double tn = r_trial.l2_norm();
        if (std::isfinite(e) && std::isfinite(tn) && e < best_energy) {
          best_energy = e;
          best_alpha = alpha;
          best_norm = tn;
        }
        if (std::isfinite(e) && e <= energy0 + 1e-4 * alpha * s0) break;
        alpha *= 0.5;
      }
    }
    if (s0 >= 0 || !(best_norm < std::numeric_limits<double>::max())) {
      best_norm = std::numeric_limits<double>::max();
      double alpha = 1.0;
      for (int ls = 0; ls < 12; ++ls) {
        trial = u;
        trial.add(alpha, du);
        assemble(trial, model, artificial_tension, false, r_trial);
        last_alpha = alpha;
        const double tn = r_trial.l2_norm();
        if (std::isfinite(tn) && tn < best_norm) {
          best_norm = tn;
          best_alpha = alpha;
        }
        if (std::isfinite(tn) && tn <= (1 - 1e-4 * alpha) * r_norm) break;
        alpha *= 0.5;
      }
    }
    if (!(best_norm < std::numeric_limits<double>::max())) {
      out.status = Status::not_finite;
      out.message = "every line-search trial gave a non-finite residual";
      return out;
    }
    u.add(best_alpha, du);
    last_increment = best_alpha * du.l2_norm();
    if (reuse_factorization_ && !options_.iterative_solver) {
      refactorize = !(best_alpha == 1.0 && best_norm <= 0.1 * r_norm);
      if (last_alpha == best_alpha) {
        r.swap(r_trial);
        have_r = true;
      }
    }
    if (options_.verbose) {
      std::printf("      step alpha = %.3g, |du| = %.3e, slope r.du = %.3e\n", best_alpha, du.l2_norm(), s0);
    }
  }
  out.status = Status::no_convergence;
  out.message = "Newton did not converge in " + std::to_string(options_.max_newton_iterations) +
                " iterations (|r| = " + fmt(out.residual_norm) + " N, tolerance " + fmt(r_tol) + " N)";
  return out;
}

// A tension scale for the continuation: Hencky-type membrane estimate
// N* = 2·E·h·(F/(E·h·a))^(2/3): a few times the membrane forces of a clamped membrane carrying F,
// so that the first (tensioned, linear) step undershoots the deflection rather than overshoots it.
double FilmSolver::estimate_tension() const {
  const double E = std::sqrt(membrane_C_.c[0][0] * membrane_C_.c[1][1]);  // h·E-like (N/m)
  return 2.0 * E * std::pow(total_force_ / (E * radius_), 2.0 / 3.0);
}

// From the flat, stress-free state the membrane tangent has no transverse stiffness (only the
// tiny bending one). By design the solver starts with an artificial isotropic pretension N*
// of the size of the expected membrane forces (its first Newton step is the linear
// tensioned-membrane solution −N*Δw = p, the cone-like w of the membrane scaling), then lowers
// it geometrically to zero, each stage a Newton solve from the last; a failed stage is retried
// with a smaller reduction (cutback).
NewtonOutcome FilmSolver::solve_from_flat(Model model, Vector<double>& u) {
  NewtonOutcome total;
  u = 0;
  if (model == Model::linear || pretension_ >= estimate_tension()) {
    auto o = newton(model, 0.0, u);
    ++summary_.load_steps;
    summary_.newton_iterations += o.iterations;
    return o;
  }
  const double n_star = estimate_tension();
  std::vector<double> targets;
  // N* → 0.1 N* → 0.01 N* → 0 (docs/fem.md §5); measured on the seed-001 sweep mesh: 11
  // factorizations from flat instead of 16 with steps of 0.3, same result (cutbacks guard it).
  for (double t = n_star; t > 0.005 * n_star; t *= 0.1) targets.push_back(t);
  targets.push_back(0.0);
  double last_converged = -1;
  Vector<double> u_saved = u;
  int cutbacks = 0;
  std::size_t k = 0;
  while (k < targets.size()) {
    const double target = targets[k];
    auto o = newton(model, target, u);
    ++summary_.load_steps;
    summary_.newton_iterations += o.iterations;
    total.residual_norm = o.residual_norm;
    if (o.status == Status::converged) {
      last_converged = target;
      u_saved = u;
      ++k;
      continue;
    }
    if (++cutbacks > options_.max_cutbacks) {
      total.status = o.status;
      total.message = o.message + "; gave up after " + std::to_string(options_.max_cutbacks) +
                      " continuation cutbacks at artificial pretension " + fmt(target) + " N/m";
      return total;
    }
    u = u_saved;
    if (last_converged < 0) {
      // Even the first stage failed: start with a larger tension.
      targets.insert(targets.begin() + static_cast<long>(k), 10 * target);
    } else {
      const double mid = target > 0 ? std::sqrt(last_converged * target) : 0.3 * last_converged;
      targets.insert(targets.begin() + static_cast<long>(k), mid);
    }
  }
  total.status = Status::converged;
  return total;
}

// ------------------------------------------------------------------------------ outputs

Kinematics FilmSolver::kinematics_at(const Vector<double>& u, const Point<dim>& p) const {
  std::vector<Tensor<1, dim>> grads(3);
  VectorTools::point_gradient(*mapping_, dof_handler_, u, p, grads);
  Kinematics k;
  for (int a = 0; a < 2; ++a) {
    for (int b = 0; b < 2; ++b) k.H[a][b] = grads[a][b];
    k.g[a] = grads[2][a];
  }
  return k;
}

MembraneForce FilmSolver::membrane_force(const Kinematics& k, const Point<dim>& x) const {
  const std::array<double, 3> E = membrane_strain(k, current_model_);
  std::array<double, 3> S = membrane_C_.apply(E);
  S[0] += pretension_;
  S[1] += pretension_;
  MembraneForce n;
  n.global = S;
  const Eigen::Vector3d s(S[0], S[1], S[2]);
  const Eigen::Vector3d m = pvdf::stress_to_material(draw_angle_) * s;
  n.material = {m[0], m[1], m[2]};
  const Point<dim> c = loads_.empty() ? Point<dim>() : loads_.front().center;
  const double phi = std::atan2(x[1] - c[1], x[0] - c[0]);
  const Eigen::Vector3d pr = pvdf::stress_to_material(phi) * s;
  n.polar = {pr[0], pr[1], pr[2]};
  return n;
}

// Mean membrane force over electrode k: ∫χ_k N dA / ∫χ_k dA with the exact outline χ_k, by a
// sub-sampled (8×8 Gauss-2) quadrature on every cell near the electrode.
std::array<double, 3> FilmSolver::electrode_mean_force(const Vector<double>& u, Model model, std::size_t k,
                                                       double* integrated_area) const {
  const auto& poly = electrode_polygons_[k];
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (const auto& v : poly) {
    xmin = std::min(xmin, v[0]);
    xmax = std::max(xmax, v[0]);
    ymin = std::min(ymin, v[1]);
    ymax = std::max(ymax, v[1]);
  }
  const QIterated<dim> quadrature(QGauss<1>(2), 8);
  FEValues<dim> fe_values(*mapping_, *fe_, quadrature, update_gradients | update_JxW_values | update_quadrature_points);
  const FEValuesExtractors::Vector inplane(0);
  const FEValuesExtractors::Scalar w(2);
  std::vector<Tensor<2, dim>> grad_u(quadrature.size());
  std::vector<Tensor<1, dim>> grad_w(quadrature.size());
  std::array<double, 3> sum{0, 0, 0};
  double area = 0;
  for (const auto& cell : dof_handler_.active_cell_iterators()) {
    const auto box = cell->bounding_box();
    if (box.get_boundary_points().first[0] > xmax || box.get_boundary_points().second[0] < xmin ||
        box.get_boundary_points().first[1] > ymax || box.get_boundary_points().second[1] < ymin)
      continue;
    fe_values.reinit(cell);
    fe_values[inplane].get_function_gradients(u, grad_u);
    fe_values[w].get_function_gradients(u, grad_w);
    for (unsigned int q = 0; q < quadrature.size(); ++q) {
      const Point<dim>& x = fe_values.quadrature_point(q);
      if (!polygon_contains(poly, x[0], x[1])) continue;
      Kinematics kin;
      for (int a = 0; a < 2; ++a) {
        kin.g[a] = grad_w[q][a];
        for (int b = 0; b < 2; ++b) kin.H[a][b] = grad_u[q][a][b];
      }
      const std::array<double, 3> S = membrane_C_.apply(membrane_strain(kin, model));
      for (int c = 0; c < 3; ++c) sum[c] += S[c] * fe_values.JxW(q);
      area += fe_values.JxW(q);
    }
  }
  if (integrated_area) *integrated_area = area;
  if (area <= 0) return {0, 0, 0};
  std::array<double, 3> mean{sum[0] / area + pretension_, sum[1] / area + pretension_, sum[2] / area};
  return mean;
}

OutputVector FilmSolver::outputs(const Vector<double>& u, Model model) const {
  OutputVector o;
  for (std::size_t k = 0; k < electrode_polygons_.size(); ++k) {
    const auto g = electrode_mean_force(u, model, k);
    const Eigen::Vector3d m = pvdf::stress_to_material(draw_angle_) * Eigen::Vector3d(g[0], g[1], g[2]);
    for (int c = 0; c < 3; ++c) {
      o.forces.push_back(m[c]);
      o.force_scale = std::max(o.force_scale, std::abs(m[c]));
    }
  }
  for (const auto& l : loads_) {
    std::vector<Tensor<1, dim>> dummy;
    Vector<double> value(3);
    VectorTools::point_value(*mapping_, dof_handler_, u, l.center, value);
    o.deflections.push_back(value[2]);
    o.deflection_scale = std::max(o.deflection_scale, std::abs(value[2]));
  }
  return o;
}

double FilmSolver::rim_reaction(const Vector<double>& u, Model model) {
  Vector<double> r;
  assemble(u, model, 0.0, false, r);
  Vector<double> internal = membrane_raw_;
  if (options_.include_bending) {
    Vector<double> bu(u.size());
    bending_raw_.vmult(bu, u);
    internal += bu;
  }
  // Force transmitted to the rim = Σ over rim w-DOFs of (internal − external) nodal forces,
  // after moving the forces of hanging DOFs onto their masters (some masters lie on the rim).
  internal -= load_raw_;
  hanging_constraints_.condense(internal);
  double reaction = 0;
  for (types::global_dof_index i = 0; i < u.size(); ++i) {
    if (rim_w_dof_[i] && !hanging_constraints_.is_constrained(i)) reaction += internal(i);
  }
  return -reaction;
}

double FilmSolver::strain_energy(const Vector<double>& u, Model model) const {
  const QGauss<dim> quadrature(options_.fe_degree + 1);
  FEValues<dim> fe_values(*mapping_, *fe_, quadrature, update_gradients | update_JxW_values);
  const FEValuesExtractors::Vector inplane(0);
  const FEValuesExtractors::Scalar w(2);
  std::vector<Tensor<2, dim>> grad_u(quadrature.size());
  std::vector<Tensor<1, dim>> grad_w(quadrature.size());
  double energy = 0;
  for (const auto& cell : dof_handler_.active_cell_iterators()) {
    fe_values.reinit(cell);
    fe_values[inplane].get_function_gradients(u, grad_u);
    fe_values[w].get_function_gradients(u, grad_w);
    for (unsigned int q = 0; q < quadrature.size(); ++q) {
      Kinematics k;
      for (int a = 0; a < 2; ++a) {
        k.g[a] = grad_w[q][a];
        for (int b = 0; b < 2; ++b) k.H[a][b] = grad_u[q][a][b];
      }
      const auto E = membrane_strain(k, model);
      const auto S = membrane_C_.apply(E);
      energy += 0.5 * (S[0] * E[0] + S[1] * E[1] + S[2] * E[2]) * fe_values.JxW(q);
    }
  }
  if (options_.include_bending) energy += 0.5 * bending_raw_.matrix_norm_square(u);
  return energy;
}

void MembranePostprocessor::evaluate_vector_field(const DataPostprocessorInputs::Vector<dim>& inputs,
                                                  std::vector<Vector<double>>& computed) const {
  for (unsigned int q = 0; q < inputs.solution_gradients.size(); ++q) {
    Kinematics k;
    for (int a = 0; a < 2; ++a) {
      k.g[a] = inputs.solution_gradients[q][2][a];
      for (int b = 0; b < 2; ++b) k.H[a][b] = inputs.solution_gradients[q][a][b];
    }
    const MembraneForce n = solver_.membrane_force(k, inputs.evaluation_points[q]);
    for (int c = 0; c < 3; ++c) {
      computed[q](c) = n.global[c];
      computed[q](3 + c) = n.material[c];
      computed[q](6 + c) = n.polar[c];
    }
    computed[q](9) = solver_.charge_density(n);
  }
}

std::vector<std::string> MembranePostprocessor::get_names() const {
  // Scalars, one per component: deal.II groups "vector" components in blocks of spacedim (2 here),
  // which would merge 3-component Voigt triples across fields.
  return {"N_global_xx_N_per_m", "N_global_yy_N_per_m", "N_global_xy_N_per_m",
          "N_material_11_N_per_m", "N_material_22_N_per_m", "N_material_12_N_per_m",
          "N_polar_rr_N_per_m", "N_polar_tt_N_per_m", "N_polar_rt_N_per_m",
          "charge_density_C_per_m2"};
}

std::vector<DataComponentInterpretation::DataComponentInterpretation>
MembranePostprocessor::get_data_component_interpretation() const {
  return std::vector<DataComponentInterpretation::DataComponentInterpretation>(
      10, DataComponentInterpretation::component_is_scalar);
}

std::string FilmSolver::write_vtu(int cycle, Model model) {
  current_model_ = model;
  pvdf::make_directories(options_.vtu_directory);
  DataOut<dim> data_out;
  data_out.attach_dof_handler(dof_handler_);
  // In-plane displacement as a 2-vector (ParaView pads it to 3-D), deflection w as a scalar.
  const std::vector<std::string> names = {"displacement_inplane_m", "displacement_inplane_m", "w_m"};
  const std::vector<DataComponentInterpretation::DataComponentInterpretation> interp = {
      DataComponentInterpretation::component_is_part_of_vector,
      DataComponentInterpretation::component_is_part_of_vector, DataComponentInterpretation::component_is_scalar};
  data_out.add_data_vector(solution_, names, DataOut<dim>::type_dof_data, interp);
  MembranePostprocessor post(*this);
  data_out.add_data_vector(solution_, post);
  Vector<float> electrode_id(triangulation_.n_active_cells());
  for (const auto& cell : triangulation_.active_cell_iterators()) {
    electrode_id(cell->active_cell_index()) =
        cell->material_id() == pvdf::mesh::film_material_id ? -1.0f : static_cast<float>(cell->material_id() - 1);
  }
  data_out.add_data_vector(electrode_id, "electrode_id", DataOut<dim>::type_cell_data);
  data_out.build_patches(*mapping_, options_.fe_degree, DataOut<dim>::curved_inner_cells);
  const std::string name = "film_cycle" + std::to_string(cycle) + ".vtu";
  const std::string path = options_.vtu_directory + "/" + name;
  pvdf::write_file_atomically(path, [&](std::ostream& os) { data_out.write_vtu(os); });
  pvd_records_.emplace_back(static_cast<double>(cycle), name);
  const std::string pvd = options_.vtu_directory + "/film.pvd";
  pvdf::write_file_atomically(pvd, [&](std::ostream& os) { DataOutBase::write_pvd_record(os, pvd_records_); });
  return path;
}

void FilmSolver::refine_mesh(Vector<double>& u) {
  const unsigned int p = options_.fe_degree;
  Vector<float> est_u(triangulation_.n_active_cells()), est_w(triangulation_.n_active_cells());
  const ComponentMask mask_u = fe_->component_mask(FEValuesExtractors::Vector(0));
  const ComponentMask mask_w = fe_->component_mask(FEValuesExtractors::Scalar(2));
  KellyErrorEstimator<dim>::estimate(*mapping_, dof_handler_, QGauss<dim - 1>(p + 1), {}, u, est_u, mask_u);
  KellyErrorEstimator<dim>::estimate(*mapping_, dof_handler_, QGauss<dim - 1>(p + 1), {}, u, est_w, mask_w);
  const double nu = est_u.l2_norm(), nw = est_w.l2_norm();
  Vector<float> indicator(triangulation_.n_active_cells());
  for (unsigned int i = 0; i < indicator.size(); ++i) {
    indicator(i) = static_cast<float>((nu > 0 ? est_u(i) / nu : 0.0) + (nw > 0 ? est_w(i) / nw : 0.0));
  }
  GridRefinement::refine_and_coarsen_fixed_number(triangulation_, indicator, 0.3, 0.0);
  SolutionTransfer<dim, Vector<double>> transfer(dof_handler_);
  triangulation_.prepare_coarsening_and_refinement();
  transfer.prepare_for_coarsening_and_refinement(u);
  triangulation_.execute_coarsening_and_refinement();
  set_material_ids();
  setup_system();
  Vector<double> u_new(dof_handler_.n_dofs());
  transfer.interpolate(u, u_new);
  constraints_.distribute(u_new);
  u = u_new;
}

void FilmSolver::fill_result(Result& result, Model model) {
  current_model_ = model;
  const Vector<double>& u = solution_;
  double wmax = 0;
  for (const auto& cell : dof_handler_.active_cell_iterators()) {
    std::vector<types::global_dof_index> dofs(fe_->n_dofs_per_cell());
    cell->get_dof_indices(dofs);
    for (unsigned int i = 0; i < dofs.size(); ++i) {
      if (fe_->system_to_component_index(i).first == 2 && std::abs(u(dofs[i])) > std::abs(wmax)) wmax = u(dofs[i]);
    }
  }
  result.max_deflection_m = wmax;
  for (const auto& l : loads_) {
    LoadResult lr;
    lr.x_m = l.center[0];
    lr.y_m = l.center[1];
    lr.force_N = l.probe ? l.force_N : l.pressure_Pa * scene_.membrane.outline.area_m2();
    Vector<double> value(3);
    VectorTools::point_value(*mapping_, dof_handler_, u, l.center, value);
    lr.deflection_m = value[2];
    result.loads.push_back(lr);
  }
  result.deflection_at_load_m = result.loads.empty() ? 0.0 : result.loads.front().deflection_m;
  for (std::size_t k = 0; k < scene_.electrodes.size(); ++k) {
    ElectrodeResult er;
    er.name = scene_.electrodes[k].name;
    er.area_m2 = scene_.electrodes[k].area_m2();
    er.mean_membrane_force_global_N_per_m = electrode_mean_force(u, model, k);
    const auto& g = er.mean_membrane_force_global_N_per_m;
    const Eigen::Vector3d m = pvdf::stress_to_material(draw_angle_) * Eigen::Vector3d(g[0], g[1], g[2]);
    er.mean_membrane_force_material_N_per_m = {m[0], m[1], m[2]};
    er.charge_C = er.area_m2 * (scene_.material.d31_C_per_N * m[0] + scene_.material.d32_C_per_N * m[1]) / thickness_;
    result.electrodes.push_back(er);
  }
  for (const auto& p : options_.sample_points_m) {
    SampleResult s;
    s.x_m = p[0];
    s.y_m = p[1];
    const Point<dim> x(p[0], p[1]);
    Vector<double> value(3);
    try {
      VectorTools::point_value(*mapping_, dof_handler_, u, x, value);
      const Kinematics k = kinematics_at(u, x);
      s.membrane_force = membrane_force(k, x);
    } catch (const std::exception&) {
      throw InputError("--sample " + fmt(p[0]) + "," + fmt(p[1]) +
                       " could not be located in the mesh (too close to the rim?); move it inside the film");
    }
    s.ux_m = value[0];
    s.uy_m = value[1];
    s.w_m = value[2];
    s.charge_density_C_per_m2 = charge_density(s.membrane_force);
    result.samples.push_back(s);
  }
  result.rim_reaction_N = rim_reaction(u, model);
  result.strain_energy_J = strain_energy(u, model);
}

// ------------------------------------------------------------------------------ run

Result FilmSolver::run() {
  const auto t_start = Clock::now();
  Result result;
  reuse_factorization_ = true;  // chord steps while Newton contracts >= 10x per step (see newton())
  setup_system();
  Summary& s = summary_;
  auto finish_failure = [&](const NewtonOutcome& o, const std::string& where) {
    s.status = o.status;
    s.message = where + ": " + o.message;
    s.n_dofs = dof_handler_.n_dofs();
    s.n_cells = triangulation_.n_active_cells();
    s.final_residual_norm = o.residual_norm;
    s.estimated_relative_error = 1.0;
    s.wall_s = seconds_since(t_start);
    result = Result{};
    result.summary = s;
    return result;
  };

  if (total_force_ == 0) {
    // Nothing loads the film: the flat, pretensioned state is the exact solution.
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

  // 1. The model.
  Model model = options_.model;
  Vector<double> u(dof_handler_.n_dofs());
  if (model == Model::automatic) {
    NewtonOutcome o = solve_from_flat(Model::linear, u);
    if (o.status != Status::converged) return finish_failure(o, "linear trial solve");
    double wmax = 0;
    for (const auto& cell : dof_handler_.active_cell_iterators()) {
      std::vector<types::global_dof_index> dofs(fe_->n_dofs_per_cell());
      cell->get_dof_indices(dofs);
      for (unsigned int i = 0; i < dofs.size(); ++i)
        if (fe_->system_to_component_index(i).first == 2) wmax = std::max(wmax, std::abs(u(dofs[i])));
    }
    const double ratio = wmax / thickness_;
    const double limit = std::sqrt(options_.tolerance) * 0.5;
    if (ratio <= limit && pretension_ * 0 == 0 && options_.include_bending) {
      model = Model::linear;
      s.model_reason = "linear plate deflection w_max/h = " + fmt(ratio) + " <= 0.5*sqrt(tolerance) = " + fmt(limit) +
                       " (membrane coupling changes the outputs by ~(w/h)^2)";
    } else {
      NewtonOutcome ovk = solve_from_flat(Model::von_karman, u);
      if (ovk.status != Status::converged) return finish_failure(ovk, "von Karman solve");
      const OutputVector q_vk = outputs(u, Model::von_karman);
      Vector<double> u_lr = u;
      NewtonOutcome olr = newton(Model::large_rotation, 0.0, u_lr);
      ++s.load_steps;
      s.newton_iterations += olr.iterations;
      if (olr.status != Status::converged) {
        olr = solve_from_flat(Model::large_rotation, u_lr);
        if (olr.status != Status::converged) return finish_failure(olr, "large-rotation solve");
      }
      const OutputVector q_lr = outputs(u_lr, Model::large_rotation);
      const double d = relative_difference(q_lr, q_vk);
      if (d <= 0.25 * options_.tolerance) {
        model = Model::von_karman;
        s.model_reason = "linear w_max/h = " + fmt(ratio) + " too large; von Karman and large-rotation outputs differ by " +
                         fmt(d) + " <= tolerance/4 on the first mesh";
      } else {
        model = Model::large_rotation;
        u = u_lr;
        s.model_reason = "linear w_max/h = " + fmt(ratio) + " too large; von Karman differs from large-rotation by " +
                         fmt(d) + " > tolerance/4 on the first mesh";
      }
    }
  } else {
    s.model_reason = "requested";
    NewtonOutcome o = solve_from_flat(model, u);
    if (o.status != Status::converged) return finish_failure(o, model_name(model) + " solve");
  }
  s.model = model;
  solution_ = u;
  if (!options_.vtu_directory.empty()) vtu_files_.push_back(write_vtu(0, model));

  // 2. Output-driven refinement: re-solve on refined meshes from the transferred solution until
  // the change of the outputs (extrapolated with the observed contraction) meets the tolerance.
  std::vector<OutputVector> history{outputs(solution_, model)};
  std::vector<double> diffs;
  double estimate = 1.0;
  s.error_estimator = "not estimated (adaptivity off or refinement cap 0)";
  const int max_cycles = options_.adaptive ? options_.max_refinements : 0;
  for (int cycle = 1; cycle <= max_cycles; ++cycle) {
    if (dof_handler_.n_dofs() > 600000) break;
    refine_mesh(solution_);
    NewtonOutcome o = newton(model, 0.0, solution_);
    ++s.load_steps;
    s.newton_iterations += o.iterations;
    if (o.status != Status::converged) {
      o = solve_from_flat(model, solution_);
      if (o.status != Status::converged) return finish_failure(o, "refinement cycle " + std::to_string(cycle));
    }
    ++s.refinement_cycles;
    if (!options_.vtu_directory.empty()) vtu_files_.push_back(write_vtu(cycle, model));
    history.push_back(outputs(solution_, model));
    diffs.push_back(relative_difference(history.back(), history[history.size() - 2]));
    const double d = diffs.back();
    if (diffs.size() >= 2 && diffs[diffs.size() - 2] > 0) {
      const double rho = d / diffs[diffs.size() - 2];
      if (rho < 0.9) {
        // Never below the last change itself: the Richardson tail alone was 4.2x optimistic
        // against Timoshenko's plate (test [adaptivity]).
        estimate = std::max(d, d * std::max(rho, 0.1) / (1 - std::max(rho, 0.1)));
        s.error_estimator = "Richardson: last change x rho/(1-rho), observed contraction rho = " + fmt(rho, 3);
      } else {
        estimate = d;
        s.error_estimator = "last change between meshes (no contraction observed yet, rho = " + fmt(rho, 3) + ")";
      }
    } else {
      estimate = d;
      s.error_estimator = "change between the last two meshes";
    }
    if (options_.verbose) std::printf("  cycle %d: %u dofs, output change %.3e, estimate %.3e\n", cycle, dof_handler_.n_dofs(), d, estimate);
    if (estimate <= options_.tolerance) break;
  }
  s.estimated_relative_error = estimate;
  if (max_cycles == 0) {
    s.status = Status::converged;
    s.message = "Newton converged; no refinement requested, output error not estimated";
  } else if (estimate <= options_.tolerance) {
    s.status = Status::converged;
    s.message = "Newton converged; estimated output error " + fmt(estimate) + " <= tolerance " + fmt(options_.tolerance);
  } else {
    s.status = Status::tolerance_not_met;
    s.message = "Newton converged but the estimated output error " + fmt(estimate) + " > tolerance " +
                fmt(options_.tolerance) + " after " + std::to_string(s.refinement_cycles) + " refinements";
  }
  s.n_dofs = dof_handler_.n_dofs();
  s.n_cells = triangulation_.n_active_cells();
  fill_result(result, model);
  // Never return NaN: a non-finite output is a numerical failure.
  bool finite = std::isfinite(result.max_deflection_m) && std::isfinite(result.rim_reaction_N);
  for (const auto& e : result.electrodes)
    for (double v : e.mean_membrane_force_material_N_per_m) finite = finite && std::isfinite(v);
  if (!finite) {
    NewtonOutcome o;
    o.status = Status::not_finite;
    o.message = "non-finite outputs";
    return finish_failure(o, "outputs");
  }
  result.vtu_files = vtu_files_;
  if (!vtu_files_.empty()) result.vtu_files.push_back(options_.vtu_directory + "/film.pvd");
  s.wall_s = seconds_since(t_start);
  result.summary = s;
  return result;
}

// ------------------------------------------------------------------------------ probe sweeps

// The sweep mesh is graded to the electrodes only (the scene copy given to this solver carries
// no loads), capped everywhere by the coarse size, which is therefore the size under any probe.
void FilmSolver::prepare_sweep() {
  make_grid();
  setup_system();
}

// A new probe position or force changes only the load vector: it is re-integrated on the fixed
// mesh (cut cells sub-sampled, then scaled so the total vertical force is exactly F).
void FilmSolver::set_probe(double x_m, double y_m, double force_N) {
  const auto t0 = Clock::now();
  LoadCase c;
  c.probe = true;
  c.center = Point<dim>(x_m, y_m);
  c.radius_m = scene_.probe.radius_m;
  c.force_N = force_N;
  loads_ = {c};
  total_force_ = std::abs(force_N);
  assemble_load_vector();
  load_vector_s += seconds_since(t0);
}

// Warm: Newton from the given state (no continuation: a neighbour's state is already tensioned);
// if that fails, or when cold, the artificial-pretension continuation from the flat film.
NewtonOutcome FilmSolver::solve_probe(Model model, Vector<double>& u, bool warm, int& newton_iterations,
                                      bool& warm_used) {
  const int before = summary_.newton_iterations;
  warm_used = false;
  reuse_factorization_ = true;
  if (warm) {
    // The warm state is a neighbour's converged one: its last factorized tangent is a good chord.
    chord_first_step_ = true;
    const int cap = options_.max_newton_iterations;
    options_.max_newton_iterations = std::min(cap, 25);
    Vector<double> start = u;
    NewtonOutcome o = newton(model, 0.0, u);
    options_.max_newton_iterations = cap;
    summary_.newton_iterations += o.iterations;
    if (o.status == Status::converged) {
      newton_iterations = summary_.newton_iterations - before;
      warm_used = true;
      return o;
    }
    u = start;
  }
  NewtonOutcome o = solve_from_flat(model, u);
  newton_iterations = summary_.newton_iterations - before;
  o.iterations = newton_iterations;
  return o;
}

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

void FilmSolver::probe_outputs(const Vector<double>& u, Model model, detail::EngineSolution& out) {
  current_model_ = model;
  out.charge_C.clear();
  out.mean_membrane_force_material_N_per_m.clear();
  for (std::size_t k = 0; k < scene_.electrodes.size(); ++k) {
    const auto g = electrode_mean_force(u, model, k);
    const Eigen::Vector3d m = pvdf::stress_to_material(draw_angle_) * Eigen::Vector3d(g[0], g[1], g[2]);
    out.mean_membrane_force_material_N_per_m.push_back({m[0], m[1], m[2]});
    out.charge_C.push_back(scene_.electrodes[k].area_m2() *
                           (scene_.material.d31_C_per_N * m[0] + scene_.material.d32_C_per_N * m[1]) / thickness_);
  }
  Vector<double> value(3);
  VectorTools::point_value(*mapping_, dof_handler_, u, loads_.front().center, value);
  out.deflection_at_load_m = value[2];
  out.rim_reaction_N = rim_reaction(u, model);
}

JacobianCheck FilmSolver::check_jacobian(double amplitude_m, int n_directions, unsigned int seed) {
  setup_system();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  // A smooth state: a few low-order modes of (u_x, u_y, w) interpolated.
  const double a = radius_;
  const double c1 = uni(rng), c2 = uni(rng), c3 = uni(rng), c4 = uni(rng);
  const double amp = amplitude_m;
  const double inplane_amp = 0.05 * amp;
  auto field = [&](const Point<dim>& p, unsigned int comp) {
    const double x = p[0] / a, y = p[1] / a, r2 = x * x + y * y;
    const double bubble = std::max(0.0, 1 - r2);
    if (comp == 0) return inplane_amp * bubble * (c1 + c2 * y);
    if (comp == 1) return inplane_amp * bubble * (c3 * x + c4);
    return amp * bubble * bubble * (1 + 0.3 * c1 * x + 0.2 * c2 * y * x);
  };
  Vector<double> u(dof_handler_.n_dofs());
  std::map<types::global_dof_index, Point<dim>> support;
  DoFTools::map_dofs_to_support_points(*mapping_, dof_handler_, support);
  for (const auto& cell : dof_handler_.active_cell_iterators()) {
    std::vector<types::global_dof_index> dofs(fe_->n_dofs_per_cell());
    cell->get_dof_indices(dofs);
    for (unsigned int i = 0; i < dofs.size(); ++i) {
      u(dofs[i]) = field(support.at(dofs[i]), fe_->system_to_component_index(i).first);
    }
  }
  constraints_.distribute(u);
  JacobianCheck out;
  out.n_dofs = u.size();
  const Model model = options_.model == Model::automatic ? Model::large_rotation : options_.model;
  Vector<double> r(u.size()), rp(u.size()), rm(u.size()), Kv(u.size()), v(u.size()), up(u.size());
  assemble(u, model, 0.0, true, r);
  SparseMatrix<double> K(sparsity_);
  K.copy_from(tangent_);
  for (int d = 0; d < n_directions; ++d) {
    for (auto& x : v) x = uni(rng);
    constraints_.distribute(v);  // homogeneous: Dirichlet entries 0, hanging entries from their masters
    K.vmult(Kv, v);
    constraints_.set_zero(Kv);
    const double eps = 1e-6 * std::max(u.linfty_norm(), 1e-12) / std::max(v.linfty_norm(), 1e-300);
    up = u;
    up.add(eps, v);
    assemble(up, model, 0.0, false, rp);
    up = u;
    up.add(-eps, v);
    assemble(up, model, 0.0, false, rm);
    rp -= rm;
    rp /= 2 * eps;
    rp -= Kv;
    out.max_relative_difference = std::max(out.max_relative_difference, rp.linfty_norm() / Kv.linfty_norm());
  }
  return out;
}

}  // namespace

namespace {

// Model only what the scene needs: is the bending stiffness negligible for the outputs?
// Bending acts in boundary layers of width l_b = sqrt(D/N) at the probe edge and the rim
// (D = E h^3/12, N the membrane force). With the pure-membrane scaling N ~ E h (F/(E h a))^(2/3)
// the layer relative to the probe radius c is eta = l_b / c. Against the independent
// axisymmetric oracle (tests/fem/oracles) the seed-001 film (eta = 0.095) changes its centre
// deflection by 0.18 % and its electrode forces by less when bending is added: the effect is
// ~eta/50. Bending is neglected when that estimate is below tolerance/4. Returns the reason
// (empty when bending must be kept).
std::string bending_negligible(const pvdf::Scene& scene, const Options& options) {
  if (options.model != Model::automatic || !options.include_bending) return {};
  double force_N = 0, radius_m = 1e300;
  for (const auto& l : scene.loads) {
    if (l.kind == pvdf::Load::Kind::probe) {
      force_N += std::abs(l.force_N);
      radius_m = std::min(radius_m, l.radius_m > 0 ? l.radius_m : scene.probe.radius_m);
    } else {
      force_N += std::abs(l.pressure_Pa) * scene.membrane.outline.area_m2();
      radius_m = std::min(radius_m, scene.membrane.outline.inscribed_radius_m());
    }
  }
  if (!(force_N > 0) || !(radius_m < 1e300)) return {};
  const auto& m = scene.material;
  const double E = std::min(m.E1_Pa, m.E2_Pa), h = scene.membrane.thickness_m;
  const double a = scene.membrane.outline.characteristic_radius_m();
  const double D = std::max(m.E1_Pa, m.E2_Pa) * h * h * h / 12.0;
  const double N = E * h * std::cbrt(std::pow(force_N / (E * h * a), 2.0)) + scene.membrane.pretension_N_per_m;
  const double eta = std::sqrt(D / N) / radius_m;
  const double effect = eta / 50.0;
  if (effect > 0.25 * options.tolerance) return {};
  return "bending neglected: boundary layer sqrt(D/N)/c = " + fmt(eta) + ", estimated effect " + fmt(effect) +
         " <= tolerance/4 = " + fmt(0.25 * options.tolerance) + ": large-rotation membrane without bending (docs/fem.md)";
}

Result run_with_model_choice(const pvdf::Scene& scene, const Options& options,
                             const std::function<void(FilmSolver&)>& make_grid) {
  const std::string reason = bending_negligible(scene, options);
  Options used = options;
  if (!reason.empty()) {
    used.include_bending = false;
    used.model = Model::large_rotation;
  }
  FilmSolver solver(scene, used);
  make_grid(solver);
  Result r = solver.run();
  if (!reason.empty()) {
    r.summary.model_reason = reason;
  }
  return r;
}

}  // namespace

// ------------------------------------------------------------------------------ sweep engine

namespace detail {

std::string bending_negligible_reason(const pvdf::Scene& scene, const Options& options) {
  return bending_negligible(scene, options);
}

struct SweepEngine::Impl {
  pvdf::Scene scene;  // outlives the solver, which keeps a reference
  Options options;
  Model model = Model::large_rotation;
  std::unique_ptr<FilmSolver> solver;
  EngineTiming timing;
};

SweepEngine::SweepEngine(const pvdf::Scene& scene, const Options& options, Model model, bool include_bending,
                         const SweepMeshSizes& sizes)
    : impl_(std::make_unique<Impl>()) {
  impl_->scene = scene;
  impl_->scene.loads.clear();
  impl_->model = model;
  Options o = options;
  o.model = model;
  o.include_bending = include_bending;
  o.adaptive = false;
  o.coarse_size_m = sizes.region_size_m;
  o.probe_size_m = sizes.region_size_m;
  o.electrode_size_m = sizes.electrode_size_m;
  o.grading = sizes.grading;
  o.initial_global_refinements = sizes.global_refinements;
  o.sample_points_m.clear();
  o.vtu_directory.clear();
  impl_->options = o;
  impl_->solver = std::make_unique<FilmSolver>(impl_->scene, o);
  impl_->solver->prepare_sweep();
}

SweepEngine::~SweepEngine() = default;

std::size_t SweepEngine::n_dofs() const { return impl_->solver->n_dofs(); }
std::size_t SweepEngine::n_cells() const { return impl_->solver->n_cells(); }

EngineTiming SweepEngine::timing() const {
  EngineTiming t = impl_->timing;
  const Summary& s = impl_->solver->summary();
  t.assembly_s = s.assembly_s;
  t.linear_solve_s = s.linear_solve_s;
  t.load_vector_s = impl_->solver->load_vector_s;
  t.newton_iterations = s.newton_iterations;
  t.factorizations = impl_->solver->n_factorizations();
  return t;
}

EngineSolution SweepEngine::solve(double x_m, double y_m, double force_N, std::vector<double>& state, bool warm,
                                  double state_force_N) {
  FilmSolver& fs = *impl_->solver;
  EngineSolution out;
  const int factorizations_before = fs.n_factorizations();
  fs.set_probe(x_m, y_m, force_N);
  Vector<double> u(fs.n_dofs());
  const bool use_warm = warm && state.size() == u.size();
  if (use_warm) {
    std::copy(state.begin(), state.end(), u.begin());
    // Pure-membrane scaling (w ∝ F^(1/3), strains and in-plane displacements ∝ F^(2/3)): exact for
    // von Kármán without bending or pretension, a close start otherwise.
    if (state_force_N > 0 && state_force_N != force_N) {
      const double ratio = force_N / state_force_N;
      fs.scale_state(u, std::cbrt(ratio * ratio), std::cbrt(ratio));
    }
  }
  NewtonOutcome o = fs.solve_probe(impl_->model, u, use_warm, out.newton_iterations, out.warm_started);
  out.status = o.status;
  out.message = o.message;
  out.factorizations = fs.n_factorizations() - factorizations_before;
  if (o.status != Status::converged) return out;
  const auto t0 = Clock::now();
  fs.probe_outputs(u, impl_->model, out);
  impl_->timing.outputs_s += seconds_since(t0);
  bool finite = std::isfinite(out.deflection_at_load_m) && std::isfinite(out.rim_reaction_N);
  for (double q : out.charge_C) finite = finite && std::isfinite(q);
  if (!finite) {
    out.status = Status::not_finite;
    out.message = "non-finite outputs";
    return out;
  }
  state.assign(u.begin(), u.end());
  return out;
}

}  // namespace detail

Result solve(const pvdf::Scene& scene, const Options& options) {
  return run_with_model_choice(scene, options, [](FilmSolver& s) { s.make_grid(); });
}

Result solve(const pvdf::Scene& scene, const pvdf::mesh::FilmMesh& mesh, const Options& options) {
  return run_with_model_choice(scene, options, [&mesh](FilmSolver& s) { s.make_grid_from(mesh); });
}

JacobianCheck check_jacobian(const pvdf::Scene& scene, const Options& options, double amplitude_m, int n_directions,
                             unsigned int seed) {
  FilmSolver solver(scene, options);
  solver.make_grid();
  return solver.check_jacobian(amplitude_m, n_directions, seed);
}

BendingCheck check_bending(const pvdf::Scene& scene, const Options& options, const std::array<double, 3>& coefficients,
                           int n_directions, unsigned int seed) {
  FilmSolver solver(scene, options);
  solver.make_grid();
  return solver.check_bending(coefficients, n_directions, seed);
}

}  // namespace pvdf::fem
