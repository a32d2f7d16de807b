// The solver's checks (SolverChecks, behind pvdf::fem::check_jacobian and check_bending; docs/fem.md
// §3, §8): the assembled tangent against central differences of the residual, and the C0IP bending
// operator against its energy; and the physical bounds every answer must meet before it is called
// converged (plausibility.hpp).
#include "film_solver.hpp"
#include "pvdf/fem/plausibility.hpp"

#include "pvdf/core/io.hpp"

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>

namespace pvdf::fem::detail {

using namespace dealii;

// The checks the tests run on a solver's parts, kept out of FilmSolver (a friend of it): each sets
// the solver up on its mesh and compares one of its operators with what it must equal.
class SolverChecks {
 public:
  static JacobianCheck jacobian(FilmSolver& s, double amplitude_m, int n_directions, unsigned int seed);
  static BendingCheck bending(FilmSolver& s, const std::array<double, 3>& coefficients, int n_directions,
                              unsigned int seed);
};

// The bending operator (docs/fem.md §8). (1) Condensation: for a random admissible v (constrained
// entries distributed from their masters), the condensed operator must give K_c v̄ = Cᵀ K v, the
// gradient of the energy ½ vᵀKv the line search uses. (2) Energy: w = c0 x² + c1 xy + c2 y² is represented
// exactly by Q2 on straight-sided cells and is C¹, so every jump term vanishes and ½ wᵀKw over the
// interior terms (cells + interior faces, without the rim's one-sided terms) must equal
// ½ κ·Dκ × area with the constant κ = [2c0, 2c2, 2c1], on any mesh, hanging nodes or not.
BendingCheck SolverChecks::bending(FilmSolver& s, const std::array<double, 3>& coefficients, int n_directions,
                                   unsigned int seed) {
  s.setup_system();
  BendingCheck out;
  out.n_dofs = s.dof_handler_.n_dofs();
  out.n_hanging_node_constraints = s.hanging_constraints_.n_constraints();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  Vector<double> v(s.dof_handler_.n_dofs()), condensed(v.size()), projected(v.size());
  for (int d = 0; d < n_directions; ++d) {
    for (auto& x : v) x = uni(rng);
    s.constraints_.distribute(v);
    s.bending_.vmult(condensed, v);
    s.constraints_.set_zero(condensed);
    s.bending_raw_.vmult(projected, v);
    s.constraints_.condense(projected);
    s.constraints_.set_zero(projected);
    const double scale = projected.l2_norm();
    condensed -= projected;
    out.condensation_mismatch = std::max(out.condensation_mismatch, condensed.l2_norm() / scale);
  }

  s.bending_rim_terms_ = false;
  s.assemble_bending_matrix();
  s.bending_rim_terms_ = true;
  std::map<types::global_dof_index, Point<dim>> support;
  DoFTools::map_dofs_to_support_points(*s.mapping_, s.dof_handler_, support);
  Vector<double> w(s.dof_handler_.n_dofs());
  std::vector<types::global_dof_index> dofs(s.fe_->n_dofs_per_cell());
  for (const auto& cell : s.dof_handler_.active_cell_iterators()) {
    cell->get_dof_indices(dofs);
    for (unsigned int i = 0; i < dofs.size(); ++i) {
      if (s.fe_->system_to_component_index(i).first != 2) continue;
      const Point<dim>& x = support.at(dofs[i]);
      w(dofs[i]) = coefficients[0] * x[0] * x[0] + coefficients[1] * x[0] * x[1] + coefficients[2] * x[1] * x[1];
    }
  }
  out.energy_J = 0.5 * s.bending_raw_.matrix_norm_square(w);
  const QGauss<dim> quadrature(s.options_.fe_degree + 1);
  FEValues<dim> fe_values(*s.mapping_, *s.fe_, quadrature, update_JxW_values);
  for (const auto& cell : s.dof_handler_.active_cell_iterators()) {
    fe_values.reinit(cell);
    for (unsigned int q = 0; q < quadrature.size(); ++q) out.mesh_area_m2 += fe_values.JxW(q);
  }
  s.assemble_bending_matrix();  // back to the operator with the rim terms
  return out;
}


// The tangent (docs/fem.md §3): on a random smooth state, K·v against the central difference
// (r(u + εv) − r(u − εv))/2ε along random admissible directions v.
JacobianCheck SolverChecks::jacobian(FilmSolver& s, double amplitude_m, int n_directions, unsigned int seed) {
  s.setup_system();
  s.tangent_regularization_ = 0;  // the exact relaxed tangent of a wrinkling film
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  // A smooth state: a few low-order modes of (u_x, u_y, w) interpolated.
  const double a = s.radius_;
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
  Vector<double> u(s.dof_handler_.n_dofs());
  std::map<types::global_dof_index, Point<dim>> support;
  DoFTools::map_dofs_to_support_points(*s.mapping_, s.dof_handler_, support);
  for (const auto& cell : s.dof_handler_.active_cell_iterators()) {
    std::vector<types::global_dof_index> dofs(s.fe_->n_dofs_per_cell());
    cell->get_dof_indices(dofs);
    for (unsigned int i = 0; i < dofs.size(); ++i) {
      u(dofs[i]) = field(support.at(dofs[i]), s.fe_->system_to_component_index(i).first);
    }
  }
  s.constraints_.distribute(u);
  JacobianCheck out;
  out.n_dofs = u.size();
  const Model model = s.options_.model == Model::automatic ? Model::large_rotation : s.options_.model;
  Vector<double> r(u.size()), rp(u.size()), rm(u.size()), Kv(u.size()), v(u.size()), up(u.size());
  s.assemble(u, model, 0.0, true, r);
  SparseMatrix<double> K(s.tangent_.get_sparsity_pattern());
  K.copy_from(s.tangent_);
  for (int d = 0; d < n_directions; ++d) {
    for (auto& x : v) x = uni(rng);
    s.constraints_.distribute(v);  // homogeneous: Dirichlet entries 0, hanging entries from their masters
    K.vmult(Kv, v);
    s.constraints_.set_zero(Kv);
    const double eps = 1e-6 * std::max(u.linfty_norm(), 1e-12) / std::max(v.linfty_norm(), 1e-300);
    up = u;
    up.add(eps, v);
    s.assemble(up, model, 0.0, false, rp);
    up = u;
    up.add(-eps, v);
    s.assemble(up, model, 0.0, false, rm);
    rp -= rm;
    rp /= 2 * eps;
    rp -= Kv;
    out.max_relative_difference = std::max(out.max_relative_difference, rp.linfty_norm() / Kv.linfty_norm());
  }
  return out;
}

}  // namespace pvdf::fem::detail

namespace pvdf::fem {

JacobianCheck check_jacobian(const pvdf::Scene& scene, const Options& options, double amplitude_m, int n_directions,
                             unsigned int seed) {
  detail::FilmSolver solver(scene, options);
  solver.make_grid();
  return detail::SolverChecks::jacobian(solver, amplitude_m, n_directions, seed);
}

BendingCheck check_bending(const pvdf::Scene& scene, const Options& options, const std::array<double, 3>& coefficients,
                           int n_directions, unsigned int seed) {
  detail::FilmSolver solver(scene, options);
  solver.make_grid();
  return detail::SolverChecks::bending(solver, coefficients, n_directions, seed);
}

// The bounds of plausibility.hpp. The applied force is what the rim must carry at equilibrium
// (vertical loads; a follower pressure's vertical share is smaller but not zero, so only a
// reaction below a millionth of it is refused).
std::string physical_bound_violation(const pvdf::Scene& scene, const Result& result) {
  if (!usable(result.summary.status)) return "";
  const double size_m = scene.membrane.outline.characteristic_radius_m();
  if (!(std::abs(result.max_deflection_m) <= size_m)) {
    return "physical bound broken: the largest deflection " + pvdf::format_g(result.max_deflection_m) +
           " m exceeds the film's size " + pvdf::format_g(size_m) +
           " m (a strain far beyond any film); check the moduli and the loads in the scene";
  }
  double applied_N = 0;
  for (const auto& l : scene.loads) {
    applied_N += l.kind == pvdf::Load::Kind::probe ? l.force_N : l.pressure_Pa * scene.membrane.outline.area_m2();
  }
  if (applied_N != 0 && !(std::abs(result.rim_reaction_N) > 1e-6 * std::abs(applied_N))) {
    return "physical bound broken: the rim carries " + pvdf::format_g(result.rim_reaction_N) + " N of the applied " +
           pvdf::format_g(applied_N) + " N (a loaded film with no reaction); the load is lost to rounding";
  }
  return "";
}

bool enforce_physical_bounds(const pvdf::Scene& scene, Result& result) {
  const std::string why = physical_bound_violation(scene, result);
  if (why.empty()) return false;
  Result refused;
  refused.summary = result.summary;
  refused.summary.status = Status::no_convergence;
  refused.summary.message = result.summary.message + "; " + why;
  result = std::move(refused);
  return true;
}

}  // namespace pvdf::fem
