// Goal-oriented error estimates (docs/fem.md §6): the dual-weighted residual (DWR) method for the
// nonlinear film, for every output J (each electrode's charge, w at each load).
//   adjoint           K(u_h) z_h = J'(u_h)        (the converged tangent, symmetric: K = ∇²Π)
//   discretization    J(u) − J(u_h) ≈ −R⁺(u_h)[z⁺ − z_h]   (z⁺: Q(p+1) adjoint or extrapolated z_h)
//   bending (model)   J(u_b) − J(u_h) ≈ η_layer − z_b · B u_h   with (K + B) z_b = J'   (B without rim terms)
//                     η_layer = [J(u_h + εg) − J(u_h) − z_h·(R(u_h + εg) − R(u_h))] / ε, g the clamp
//                     layer's first-pass rim values (the layer as a moved clamp, docs/fem.md §3.4),
//                     enlarged in magnitude by K·ρ·|η_layer| (what first order leaves out, as η_clamp)
// R⁺ is the residual of the same forms in FE_Q(p+1) on the same mesh (quadrature and penalty of
// degree p, so that R⁺(u_h)[v_h] = R(u_h)[v_h] = 0 for every v_h of the primal space), z⁺ the
// adjoint solved in Q(p+1) on the same mesh or the patch-wise Q(p+1) extrapolation of z_h (see
// estimate_goal_errors), B the C0 interior-penalty bending operator.
#include "electrode_cells.hpp"
#include "film_solver.hpp"

#include "pvdf/core/assert.hpp"
#include "pvdf/core/material.hpp"
#include "pvdf/core/piezo.hpp"

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/grid/grid_tools.h>
#include <deal.II/numerics/vector_tools.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pvdf::fem::detail {

using namespace dealii;

// J'(u) for the charge of electrode k: Q = A/h·(d31 N11 + d32 N22) with N the mean membrane force
// over the electrode's exact outline (outputs.cpp), so with a = d31·T₁ + d32·T₂ (T the rotation to
// material axes, Voigt rows) and λ = Cᵀa, dQ/du_i = A/(h·|Ω_k|) ∫_Ω_k λ·δE(φ_i) dA, δE(φ) for
// component c being (v_c0 φ_x, v_c1 φ_y, v_c0 φ_y + v_c1 φ_x) as in the residual (assembly.cpp).
Vector<double> FilmSolver::charge_derivative(const Vector<double>& u, Model model, std::size_t k) const {
  PVDF_ASSERT(k < scene_.electrodes.size() && u.size() == dof_handler_.n_dofs(),
              "a charge's derivative is asked for an electrode of the scene, at a solution of this space");
  const Eigen::Matrix3d T = pvdf::stress_to_material(draw_angle_);
  const double d31 = scene_.material.d31_C_per_N, d32 = scene_.material.d32_C_per_N;
  double lam[3] = {0, 0, 0};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) lam[i] += membrane_C_.c[j][i] * (d31 * T(0, j) + d32 * T(1, j));

  const FEValuesExtractors::Vector inplane(0);
  const FEValuesExtractors::Scalar w(2);
  std::vector<Tensor<2, dim>> grad_u;
  std::vector<Tensor<1, dim>> grad_w;
  const unsigned int n = fe_->n_dofs_per_cell();
  std::vector<types::global_dof_index> dofs(n);
  Vector<double> cell_g(n), g(dof_handler_.n_dofs());
  double area = 0;
  for (const ElectrodeCell& ec : electrode_cells(k)) {  // the points of the charge itself (outputs.cpp)
    const FEValues<dim>& fe_values = *ec.values;
    grad_u.resize(ec.jxw.size());
    grad_w.resize(ec.jxw.size());
    fe_values[inplane].get_function_gradients(u, grad_u);
    fe_values[w].get_function_gradients(u, grad_w);
    cell_g = 0;
    for (unsigned int q = 0; q < ec.jxw.size(); ++q) {
      double v[3][2];
      for (unsigned int c = 0; c < 2; ++c)
        for (unsigned int b = 0; b < 2; ++b)
          v[c][b] = (c == b ? 1.0 : 0.0) + (model == Model::large_rotation ? grad_u[q][c][b] : 0.0);
      for (unsigned int b = 0; b < 2; ++b) v[2][b] = model == Model::linear ? 0.0 : grad_w[q][b];
      const double jxw = ec.jxw[q];
      area += jxw;
      for (unsigned int i = 0; i < n; ++i) {
        const unsigned int c = fe_->system_to_component_index(i).first;
        const Tensor<1, dim> gr = fe_values.shape_grad(i, q);
        cell_g(i) += (gr[0] * (lam[0] * v[c][0] + lam[2] * v[c][1]) + gr[1] * (lam[1] * v[c][1] + lam[2] * v[c][0])) * jxw;
      }
    }
    ec.cell->get_dof_indices(dofs);
    for (unsigned int i = 0; i < n; ++i) g(dofs[i]) += cell_g(i);
  }
  if (area > 0) g *= scene_.electrodes[k].area_m2() / (thickness_ * area);
  return g;
}

// J'(u) for w(x): the w shape functions of the cell holding x, evaluated there.
Vector<double> FilmSolver::deflection_derivative(const Point<dim>& x) const {
  Vector<double> g(dof_handler_.n_dofs());
  const auto found = GridTools::find_active_cell_around_point(*mapping_, dof_handler_, x);
  const Point<dim> xi = GeometryInfo<dim>::project_to_unit_cell(found.second);
  std::vector<types::global_dof_index> dofs(fe_->n_dofs_per_cell());
  found.first->get_dof_indices(dofs);
  for (unsigned int i = 0; i < dofs.size(); ++i)
    if (fe_->system_to_component_index(i).first == 2) g(dofs[i]) += fe_->shape_value(i, xi);
  return g;
}

// The enriched space: FE_Q(p+1) on this very triangulation (same cells, same mapping), built once
// per mesh (and again when bending is switched on). Only residuals are assembled there.
void FilmSolver::prepare_enriched(bool with_tangent) {
  if (enriched_ && enriched_->dof_handler_.get_triangulation().n_active_cells() == triangulation_.n_active_cells() &&
      enriched_->options_.include_bending == options_.include_bending && enriched_->clamp_layer_ == clamp_layer_ &&
      (!with_tangent || !enriched_->residual_only_))
    return;
  Options o = options_;
  o.adaptive = false;
  o.sample_points_m.clear();
  o.vtu_directory.clear();
  enriched_ = std::make_unique<FilmSolver>(scene_, o);  // fe_degree p passes the constructor's check
  FilmSolver& e = *enriched_;
  e.dof_handler_.reinit(triangulation_);  // this mesh itself (refine_mesh drops enriched_ before refining)
  e.loads_ = loads_;
  e.total_force_ = total_force_;
  e.options_.fe_degree = options_.fe_degree + 1;
  e.form_degree_ = options_.fe_degree;
  e.residual_only_ = !with_tangent;
  e.clamp_layer_ = clamp_layer_;  // the same rim condition (clamp_layer.cpp)
  e.bending_rim_terms_ = bending_rim_terms_;
  e.setup_system();
}

namespace {

// Adds |Σ_(i∈K) c_i / m_i| · factor to indicator[K] for every active cell K, where c_i = r_i ψ_i is
// the contribution of DOF i to r·ψ and m_i the number of cells sharing it (so that the signed cell
// sums add up to r·ψ exactly).
void add_cell_shares(const DoFHandler<2>& dofh, const Vector<double>& r, const Vector<double>& psi, double factor,
                     const std::vector<unsigned int>& multiplicity, Vector<float>& indicator) {
  PVDF_ASSERT(r.size() == dofh.n_dofs() && psi.size() == dofh.n_dofs() && multiplicity.size() == dofh.n_dofs(),
              "the residual, the weights and the DOF multiplicities must have one value per DOF");
  PVDF_ASSERT(indicator.size() == dofh.get_triangulation().n_active_cells(), "one error indicator per active cell");
  std::vector<types::global_dof_index> dofs(dofh.get_fe().n_dofs_per_cell());
  for (const auto& cell : dofh.active_cell_iterators()) {
    cell->get_dof_indices(dofs);
    double sum = 0;
    for (const auto i : dofs) sum += r(i) * psi(i) / multiplicity[i];
    indicator(cell->active_cell_index()) += static_cast<float>(std::abs(sum) * factor);
  }
}

std::vector<unsigned int> cell_multiplicity(const DoFHandler<2>& dofh) {
  std::vector<unsigned int> m(dofh.n_dofs(), 0);
  std::vector<types::global_dof_index> dofs(dofh.get_fe().n_dofs_per_cell());
  for (const auto& cell : dofh.active_cell_iterators()) {
    cell->get_dof_indices(dofs);
    for (const auto i : dofs) ++m[i];
  }
  return m;
}

double relative_max(const std::vector<double>& est, const std::vector<double>& scale) {
  double r = 0;
  for (std::size_t j = 0; j < est.size(); ++j) r = std::max(r, std::abs(est[j]) / scale[j]);
  return std::isfinite(r) ? r : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

// All estimates at the converged u (see the file comment). Cost: one factorization of K(u) (the
// factorization left behind, which a probe sweep's next chord step reuses), one more of K + B for
// the bending part, one back substitution per output and adjoint, one residual in Q(p+1); with
// `higher_order_adjoint` (solve's loop) one factorization of the Q(p+1) tangent for the charges.
FilmSolver::GoalErrors FilmSolver::estimate_goal_errors(const Vector<double>& u, Model model,
                                                        bool higher_order_adjoint) {
  GoalErrors ge;
  const std::size_t ne = electrode_polygons_.size(), nl = loads_.size(), n_out = ne + nl;
  PVDF_ASSERT(ne == scene_.electrodes.size() && u.size() == dof_handler_.n_dofs(),
              "one electrode outline per electrode of the scene; the solution has one value per DOF");
  std::vector<Vector<double>> dJ;
  double q_scale = 0, w_scale = 0;
  current_model_ = model;
  auto deflections = [&](const Vector<double>& v) {  // w at every load's centre
    std::vector<double> w;
    Vector<double> value(3);
    for (const auto& l : loads_) {
      VectorTools::point_value(*mapping_, dof_handler_, v, l.center, value);
      w.push_back(value[2]);
    }
    return w;
  };
  ge.charge_C = electrode_charges(u, model);
  for (std::size_t k = 0; k < ne; ++k) {
    q_scale = std::max(q_scale, std::abs(ge.charge_C[k]));
    dJ.push_back(charge_derivative(u, model, k));
  }
  ge.deflection_m = deflections(u);
  for (std::size_t l = 0; l < nl; ++l) {
    w_scale = std::max(w_scale, std::abs(ge.deflection_m[l]));
    dJ.push_back(deflection_derivative(loads_[l].center));
  }
  PVDF_ASSERT(dJ.size() == n_out, "one output derivative per charge and per load's deflection");
  std::vector<double> scale(n_out);
  for (std::size_t j = 0; j < n_out; ++j) scale[j] = std::max(j < ne ? q_scale : w_scale, 1e-300);
  for (auto& g : dJ) constraints_.condense(g);
  ge.indicators.reinit(triangulation_.n_active_cells());
  const auto multiplicity = cell_multiplicity(dof_handler_);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<double> model_est(n_out, 0.0), disc_est(n_out, nan);
  Vector<double> r(u.size()), z(u.size());
  std::string message;

  // 1. Bending left out, in two parts (docs/fem.md §6.1).
  //  (a) The clamp's layer, to first order in l_b: g the clamp-layer condition's first-pass rim
  //      values from u (clamp_layer.cpp), the membrane's linear response to them
  //      [J(u + εg) − J(u) − z·R(u + εg)] / ε, z the adjoint of K (step 2). A derivative, not one
  //      Newton step from u + g: g moves a rim cell's strain by as much as the strain itself (δ/h of
  //      the in-plane shift, the w values over one cell), and that step overshot the layer's effect
  //      3–7× on the oracle films of test_fem_clamp_layer. ε = 1e-3 (1e-2 gives the same to 0.5 %).
  //      The C0IP operator's rim terms (∂_n w = 0 by a penalty) see this layer only on rim cells of
  //      about l_b, which a membrane mesh does not have: with them alone the estimate was 0.40–0.49
  //      of the truth on seed 001 and on the oracle's 50 µm film (docs/fem.md §6.1).
  //      Plus, in magnitude, what first order leaves out, as the condition estimates it for itself
  //      (K·ρ × the change, §3.4): with the first order alone test_atlas_vs_maps failed its bound
  //      (|atlas − direct| ≤ both stated errors) by 0.1 % and 1.2 % at nodes 2.5 mm from the clamp.
  //  (b) Bending inside the film: one Newton step of the model with bending from u, B without its
  //      rim terms where (a) stands for the layer.
  const bool bending_left_out = !options_.include_bending && bending_pattern_;
  Vector<double> layer_residual;             // (R(u + εg) − R(u)) / ε
  std::vector<double> layer_jump(n_out, 0);  // (J(u + εg) − J(u)) / ε
  bool layer = false;
  double remainder_factor = 0;  // the layer's higher-order part / its first-order effect (clamp_layer.cpp)
  constexpr double eps = 1e-3;
  if (bending_left_out && !clamp_layer_ && !tension_field_ && total_force_ > 0) {
    Vector<double> us;
    layer = clamp_layer_first_pass(u, model, us, remainder_factor);
    if (layer) {
      us -= u;
      us *= eps;
      us += u;
      assemble(us, model, 0.0, false, layer_residual);
      layer_residual /= eps;  // R(u)/ε off below, once R(u) is assembled: u is converged, not exact
      constraints_.set_zero(layer_residual);
      const std::vector<double> qs = electrode_charges(us, model), ws = deflections(us);
      for (std::size_t k = 0; k < ne; ++k) layer_jump[k] = (qs[k] - ge.charge_C[k]) / eps;
      for (std::size_t l = 0; l < nl; ++l) layer_jump[ne + l] = (ws[l] - ge.deflection_m[l]) / eps;
    }
  }
  // The operator without its rim terms replaces bending_ for (b) and is then put back: its nonzero
  // values are kept here (a ninth of the pattern: w with w), not assembled again (round 22: that
  // assembly and bending_raw_'s were 0.1 s of seed 001's 1.0 CPU-s centre solve).
  std::vector<std::pair<std::size_t, double>> kept_bending;
  if (bending_left_out) {
    if (layer) {
      std::size_t k = 0;
      for (auto it = bending_.begin(); it != bending_.end(); ++it, ++k)
        if (it->value() != 0) kept_bending.emplace_back(k, it->value());
      bending_rim_terms_ = false;
      assemble_bending_matrix(false, -1.0);  // the rim terms off; bending_raw_ keeps them
    }
    assemble(u, model, 0.0, true, r);
    // K + B on the pattern with bending's face couplings: tangent_ itself when it has them, else
    // k_plus_b_, a copy of bending_ with K added (the same sums, B + K = K + B), with its own
    // factorization (its symbolic analysis made once per mesh), so that K's stays for step 2 and
    // for a sweep's next chord step.
    if (tangent_narrow_) {
      if (k_plus_b_.empty() || !k_plus_b_factorization_) {
        k_plus_b_.reinit(sparsity_);
        k_plus_b_factorization_ = std::make_unique<TangentFactorization>();
        k_plus_b_factorization_->set_pattern(sparsity_);
      }
      k_plus_b_.copy_from(bending_);
      std::vector<types::global_dof_index> cols;
      std::vector<double> vals;
      for (types::global_dof_index row = 0; row < tangent_.m(); ++row) {
        cols.clear();
        vals.clear();
        for (auto it = tangent_.begin(row); it != tangent_.end(row); ++it) {
          cols.push_back(it->column());
          vals.push_back(it->value());
        }
        k_plus_b_.add(row, cols.size(), cols.data(), vals.data(), false, false);
      }
    } else {
      tangent_.add(1.0, bending_);
    }
    const SparseMatrix<double>& k_plus_b = tangent_narrow_ ? k_plus_b_ : tangent_;
    TangentFactorization& k_plus_b_factorization = tangent_narrow_ ? *k_plus_b_factorization_ : factorization_;
    Vector<double> bu(u.size());
    bending_.vmult(bu, u);
    constraints_.set_zero(bu);
    for (std::size_t j = 0; j < n_out; ++j) {
      if (!solve_linear(dJ[j], z, message, j == 0, &k_plus_b, &k_plus_b_factorization)) {
        model_est[j] = nan;
        continue;
      }
      constraints_.distribute(z);
      model_est[j] = -(bu * z);
      add_cell_shares(dof_handler_, bu, z, 1.0 / scale[j], multiplicity, ge.indicators);
    }
    if (!tangent_narrow_) tangent_.add(-1.0, bending_);  // K again, without a second assembly
    if (!keep_k_plus_b_) {
      k_plus_b_.clear();
      k_plus_b_factorization_.reset();
    }
    if (layer) {
      bending_rim_terms_ = true;
      std::size_t k = 0, next = 0;
      for (auto it = bending_.begin(); it != bending_.end(); ++it, ++k) {
        const bool kept = next < kept_bending.size() && kept_bending[next].first == k;
        it->value() = kept ? kept_bending[next++].second : 0.0;
      }
    }
    ge.model_estimated = true;
  } else {
    assemble(u, model, 0.0, true, r);
  }
  if (layer) layer_residual.add(-1.0 / eps, r);

  // 2. Discretization: adjoint with the model's own tangent, weights from the Q(p+1) extrapolation
  // of z_h, or the adjoint solved in Q(p+1) itself on the same mesh (the higher-order dual of deal.II's
  // step-14; about (p+1)^2/p^2 the DOFs of the primal problem, one more factorization): for the
  // charges when `higher_order_adjoint`, and for every output on a mesh with unrefined cells (a Gmsh
  // file as read), which has no patches to extrapolate on. Measured against the oracle (docs/fem.md
  // §6.1): where cells are larger than the electrode, the extrapolated Q(p) adjoint of a charge
  // misses its source and the estimate took the wrong sign (effectivity −0.4 … 3.4), the Q(p+1)
  // adjoint gives 0.8 … 1.15; for w at a probe's centre the extrapolation did better (0.6 … 0.8,
  // against 3.0 at 2e-4 true error with the Q(p+1) adjoint, whose point source is singular).
  // The same z also weighs the layer's residual (1a).
  bool patches = true;
  for (const auto& cell : triangulation_.active_cell_iterators()) patches = patches && cell->level() > 0;
  auto solved_in_richer_space = [&](std::size_t j) { return !patches || (higher_order_adjoint && j < ne); };
  bool any_richer = false;
  for (std::size_t j = 0; j < n_out; ++j) any_richer = any_richer || solved_in_richer_space(j);
  prepare_enriched(any_richer);
  FilmSolver& e = *enriched_;
  e.loads_ = loads_;
  e.total_force_ = total_force_;
  e.current_model_ = model;
  e.assemble_load_vector();
  Vector<double> ue(e.n_dofs()), re(e.n_dofs()), zplus(e.n_dofs()), zi(e.n_dofs());
  // Hanging nodes only: u's rim values (0, or the clamp-layer condition's) are kept exactly.
  FETools::interpolate(dof_handler_, u, e.dof_handler_, e.hanging_constraints_, ue);
  e.assemble(ue, model, 0.0, any_richer, re);
  const auto e_multiplicity = cell_multiplicity(e.dof_handler_);
  bool richer_factorized = false;
  for (std::size_t j = 0; j < n_out; ++j) {
    if (!solve_linear(dJ[j], z, message, j == 0)) {
      if (layer) model_est[j] = nan;
      continue;
    }
    constraints_.distribute(z);
    if (layer) {
      // The first-order effect and, in magnitude, what first order leaves out (the condition's own
      // estimate of it: §3.4's η_clamp, the same factor times the change).
      const double first = layer_jump[j] - (layer_residual * z);
      model_est[j] += first;
      model_est[j] += std::copysign(remainder_factor * std::abs(first), model_est[j]);
    }
    if (!solved_in_richer_space(j)) {
      FETools::extrapolate(dof_handler_, z, e.dof_handler_, e.constraints_, zplus);
    } else {
      Vector<double> dJe = j < ne ? e.charge_derivative(ue, model, j) : e.deflection_derivative(loads_[j - ne].center);
      e.constraints_.condense(dJe);
      const bool ok = e.solve_linear(dJe, zplus, message, !richer_factorized);
      richer_factorized = richer_factorized || ok;
      if (!ok) continue;
      e.constraints_.distribute(zplus);
    }
    FETools::interpolate(dof_handler_, z, e.dof_handler_, e.constraints_, zi);
    zplus -= zi;
    disc_est[j] = -(re * zplus);
    add_cell_shares(e.dof_handler_, re, zplus, 1.0 / scale[j], e_multiplicity, ge.indicators);
  }
  ge.charge_discretization_C.assign(disc_est.begin(), disc_est.begin() + static_cast<long>(ne));
  ge.deflection_discretization_m.assign(disc_est.begin() + static_cast<long>(ne), disc_est.end());
  ge.charge_model_C.assign(model_est.begin(), model_est.begin() + static_cast<long>(ne));
  ge.deflection_model_m.assign(model_est.begin() + static_cast<long>(ne), model_est.end());
  ge.relative_discretization = relative_max(disc_est, scale);
  ge.relative_model = relative_max(model_est, scale);
  return ge;
}

}  // namespace pvdf::fem::detail
