// Setup of a film problem (docs/fem.md §1, §4): the scene's thickness, pretension, material and
// loads checked and turned into stiffnesses; the initial mesh (deal.II grid or a pvdf::mesh
// FilmMesh) graded to the probes and electrodes; DOFs, the clamped-rim and hanging-node
// constraints, the sparsity pattern (with the C0IP face couplings), handed to the factorization.
#include "film_solver.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/material.hpp"

#include <deal.II/base/function.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_q.h>
#include <deal.II/grid/grid_generator.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/numerics/vector_tools.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace pvdf::fem::detail {

using namespace dealii;

std::string fmt(double x, int precision) {
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

FilmSolver::FilmSolver(const pvdf::Scene& scene, const Options& options)
    : scene_(scene), options_(options), dof_handler_(triangulation_) {
  triangulation_.signals.any_change.connect([this]() { cache_.valid = false; });
  const auto& m = scene.membrane;
  thickness_ = m.thickness_m;
  pretension_ = m.pretension_N_per_m;
  if (!(thickness_ > 0) || !std::isfinite(thickness_)) {
    throw InputError(scene.source + ": membrane.thickness_m = " + fmt(thickness_) + " must be > 0");
  }
  if (!std::isfinite(pretension_)) {
    throw InputError(scene.source + ": membrane.pretension_N_per_m = " + fmt(pretension_) + " must be finite");
  }
  const bool slack = pretension_ < 0 || m.slack_strain > 0;
  if ((slack || m.tension_field) && options.model == Model::linear) {
    throw InputError(scene.source + ": a slack or wrinkling film (membrane.pretension_N_per_m < 0, slack_strain or "
                     "tension_field) needs a nonlinear model; use model.kinematics auto, von-karman or large-rotation");
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
  setup_natural_state();  // tension_field.cpp
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
      throw InputError("sample point (x, y) = (" + fmt(p[0]) + ", " + fmt(p[1]) + ") m lies outside the film (" +
                       scene.source + "); give a point inside the outline, in metres");
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
  if (options_.grade_given_mesh) {
    refine_initial_mesh();
  } else {
    if (options_.initial_global_refinements > 0) triangulation_.refine_global(options_.initial_global_refinements);
    set_material_ids();
  }
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
  // Bending kept from the start (requested, or `auto` a priori): the full plate, rim graded. The
  // clamp-layer condition replaces the grading where `auto` switches bending on by its estimate
  // (adaptivity.cpp, clamp_layer.cpp).
  if (options_.include_bending) grade_toward_rim(nullptr);
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
  electrode_cells_.clear();  // every change of the mesh passes here before its next output
  clamp_shift_.clear();      // rim values of the clamp-layer condition belong to the old DOFs
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
  // Clamped rim: u = 0 and w = 0 (the clamp-layer condition sets other rim values in u itself,
  // clamp_layer.cpp; Newton increments keep them).
  VectorTools::interpolate_boundary_values(*mapping_, dof_handler_, pvdf::mesh::rim_boundary_id,
                                           Functions::ZeroFunction<dim>(3), constraints_);
  constraints_.close();

  k_plus_b_.clear();  // on the old sparsity_ (goal_error.cpp makes it again when it is needed)
  k_plus_b_factorization_.reset();
  if (residual_only_ && !options_.include_bending && !bending_pattern_) {
    // The enriched space of a film without bending assembles residuals only and has no operator:
    // no pattern at all (its Q(p+1) pattern was a tenth of a map node's time, round 23).
    bending_.clear();
    sparsity_.reinit(0, 0, 0);
  } else {
    DynamicSparsityPattern dsp(dof_handler_.n_dofs());
    // Cells couple all components; faces (the C0IP bending terms) couple only w with w. Both with
    // the fill-in of the hanging-node condensation (see add_bending_face_couplings).
    DoFTools::make_sparsity_pattern(dof_handler_, dsp, constraints_, true);
    const bool narrow = narrow_tangent_ && !residual_only_ && !options_.include_bending && bending_pattern_;
    if (narrow) membrane_sparsity_.copy_from(dsp);  // before the face couplings (film_solver.hpp)
    if (options_.include_bending || bending_pattern_) add_bending_face_couplings(dsp);
    sparsity_.copy_from(dsp);
    if (!residual_only_) {  // the enriched space (goal_error.cpp) assembles residuals only
      const SparsityPattern& pattern = narrow ? membrane_sparsity_ : sparsity_;
      tangent_.reinit(pattern);
      factorization_.set_pattern(pattern);
      tangent_narrow_ = narrow;
    }
    bending_.reinit(sparsity_);
  }
  // The unconstrained copy serves the rim reaction and the potential of the line search, neither of
  // which the enriched space (form_degree_ > 0, goal_error.cpp) computes: there it is left empty
  // (on the Q3 space of a direct solve near the clamp it was 0.2 GB, heaptrack).
  if (form_degree_ == 0) bending_raw_.reinit(sparsity_);
  else bending_raw_.clear();
  solution_.reinit(dof_handler_.n_dofs());
  membrane_raw_.reinit(dof_handler_.n_dofs());

  mark_rim_w_dofs();
  assemble_bending_matrix();
  assemble_load_vector();
  summary_.setup_s += seconds_since(t0);
}

void FilmSolver::widen_tangent() {
  if (!tangent_narrow_) return;
  tangent_.reinit(sparsity_);
  factorization_.set_pattern(sparsity_);
  tangent_narrow_ = false;
}

// w DOFs on the rim: the clamped rim's vertical reaction is summed over them (outputs.cpp).
void FilmSolver::mark_rim_w_dofs() {
  rim_w_dof_.assign(dof_handler_.n_dofs(), false);
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

}  // namespace pvdf::fem::detail
