// Assembly (docs/fem.md §3, §4, §8): the Kirchhoff bending operator by the C0 interior-penalty
// method (once per mesh), the probe and pressure load vector, and the membrane residual and
// tangent of the chosen kinematics (every Newton step), with a per-mesh geometry cache.
#include "film_solver.hpp"

#include "pvdf/core/assert.hpp"
#include "pvdf/core/constants.hpp"

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_interface_values.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/lac/full_matrix.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pvdf::fem::detail {

using namespace dealii;

// Kirchhoff bending, C0 interior penalty (step-47 generalised to an anisotropic D):
//   a(w,v) = Σ_K ∫ M(w):∇²v − Σ_F ∫ ({M_nn(w)}[[∂_n v]] + {M_nn(v)}[[∂_n w]]) + Σ_F ∫ γ/h [[∂_n w]][[∂_n v]],
// M(w) = D κ(w), κ = ∇²w (Voigt [w,xx, w,yy, 2w,xy]), M_nn = n·M·n; rim faces impose ∂_n w = 0
// weakly with the same terms (one-sided). Linear in w, so it is assembled once per mesh.
// The local matrices hold the w DOFs only (a third of a cell's DOFs, the only ones the operator
// couples): the constraints then resolve 9x fewer local entries (round 22, docs/bench-fem.md:
// resolve_matrix_row was most of this function, 0.06 s per call on seed 001's first mesh). The
// entries are the same numbers added in the same order; only the diagonal deal.II puts on a
// constrained row differs (none on an in-plane row), a row the condensed system decouples.
// `with_raw` false: the condensed operator only (bending_raw_ left as it was).
// `rim_only` ≠ 0: only the rim faces' terms, × rim_only, added to bending_ as it is (−1: the operator
// without its rim terms, for the estimate of goal_error.cpp, at the cost of the rim cells alone
// rather than of a whole assembly; the constrained rows' diagonals grow, which they may).
void FilmSolver::assemble_bending_matrix(bool with_raw, double rim_only) {
  const bool raw = with_raw && rim_only == 0 && !bending_raw_.empty();  // empty in the enriched space (setup_system)
  if (bending_.empty()) return;  // an enriched space without bending has no operator (setup_system)
  if (rim_only == 0) bending_ = 0;
  if (raw) bending_raw_ = 0;
  if (!options_.include_bending && !bending_pattern_) return;
  const unsigned int p = form_degree();  // the primal degree, also in the enriched space (consistent forms)
  const QGauss<dim> quadrature(p + 1);
  const QGauss<dim - 1> face_quadrature(p + 1);
  FEValues<dim> fe_values(*mapping_, *fe_, quadrature, update_hessians | update_JxW_values);
  FEInterfaceValues<dim> fiv(*mapping_, *fe_, face_quadrature,
                             update_values | update_gradients | update_hessians | update_JxW_values |
                                 update_normal_vectors);
  const FEValuesExtractors::Scalar w(2);
  const unsigned int n_cell_dofs = fe_->n_dofs_per_cell();
  std::vector<unsigned int> w_local;  // the cell's w DOFs (local indices, in order)
  for (unsigned int i = 0; i < n_cell_dofs; ++i)
    if (fe_->system_to_component_index(i).first == 2) w_local.push_back(i);
  const unsigned int n_w = w_local.size();
  FullMatrix<double> cell_matrix(n_w, n_w);
  std::vector<types::global_dof_index> dofs(n_cell_dofs), w_dofs(n_w);
  std::vector<Tensor<2, dim>> hess(n_w);
  const Stiffness3& D = bending_D_;

  auto moment_nn = [&D](const Tensor<2, dim>& hess, const Tensor<1, dim>& n) {
    const std::array<double, 3> m = D.apply({hess[0][0], hess[1][1], 2 * hess[0][1]});
    return n[0] * n[0] * m[0] + n[1] * n[1] * m[1] + 2 * n[0] * n[1] * m[2];
  };
  std::vector<double> raw_row;
  std::vector<types::global_dof_index> raw_cols;
  auto add_raw = [&](const FullMatrix<double>& m, const std::vector<types::global_dof_index>& idx) {
    if (!raw) return;
    for (unsigned int i = 0; i < idx.size(); ++i) {
      raw_cols.clear();
      raw_row.clear();
      for (unsigned int j = 0; j < idx.size(); ++j)
        if (m(i, j) != 0) {
          raw_cols.push_back(idx[j]);
          raw_row.push_back(m(i, j));
        }
      if (!raw_cols.empty()) bending_raw_.add(idx[i], raw_cols.size(), raw_cols.data(), raw_row.data(), false, false);
    }
  };
  std::vector<unsigned int> w_face;  // the interface's w DOFs (interface indices, in order)
  std::vector<types::global_dof_index> w_face_dofs;
  std::vector<double> jump, mnn;
  FullMatrix<double> fm;
  auto face_terms = [&](double gamma_over_h) {
    const unsigned int n = fiv.n_current_interface_dofs();
    const auto idx = fiv.get_interface_dof_indices();
    w_face.clear();
    w_face_dofs.clear();
    for (unsigned int i = 0; i < n; ++i) {
      const auto local = fiv.interface_dof_to_dof_indices(i);
      const unsigned int l = local[0] != numbers::invalid_unsigned_int ? local[0] : local[1];
      if (fe_->system_to_component_index(l).first != 2) continue;
      w_face.push_back(i);
      w_face_dofs.push_back(idx[i]);
    }
    const unsigned int m = w_face.size();
    fm.reinit(m, m);
    jump.resize(m);
    mnn.resize(m);
    const auto& normals = fiv.get_normal_vectors();
    for (unsigned int q = 0; q < fiv.n_quadrature_points; ++q) {
      const Tensor<1, dim>& nq = normals[q];
      for (unsigned int i = 0; i < m; ++i) {
        jump[i] = fiv[w].jump_in_gradients(w_face[i], q) * nq;
        mnn[i] = moment_nn(fiv[w].average_of_hessians(w_face[i], q), nq);
      }
      const double jxw = fiv.JxW(q);
      for (unsigned int i = 0; i < m; ++i) {
        if (jump[i] == 0 && mnn[i] == 0) continue;
        for (unsigned int j = 0; j < m; ++j) {
          fm(i, j) += (-mnn[j] * jump[i] - mnn[i] * jump[j] +
                       gamma_over_h * bending_penalty_scale_ * jump[i] * jump[j]) * jxw;
        }
      }
    }
    if (rim_only != 0) fm *= rim_only;
    constraints_.distribute_local_to_global(fm, w_face_dofs, bending_);
    add_raw(fm, w_face_dofs);
  };
  const double pp = p * (p + 1.0);

  for (const auto& cell : dof_handler_.active_cell_iterators()) {
    if (rim_only != 0) {
      if (!cell->at_boundary()) continue;
      for (const unsigned int f : cell->face_indices()) {
        if (!cell->face(f)->at_boundary()) continue;
        fiv.reinit(cell, f);
        face_terms(pp / cell->extent_in_direction(GeometryInfo<dim>::unit_normal_direction[f]));
      }
      continue;
    }
    fe_values.reinit(cell);
    cell_matrix = 0;
    for (unsigned int q = 0; q < quadrature.size(); ++q) {
      for (unsigned int j = 0; j < n_w; ++j) hess[j] = fe_values[w].hessian(w_local[j], q);
      for (unsigned int i = 0; i < n_w; ++i) {
        const Tensor<2, dim>& hi = hess[i];
        const std::array<double, 3> mi = D.apply({hi[0][0], hi[1][1], 2 * hi[0][1]});
        for (unsigned int j = 0; j < n_w; ++j) {
          const Tensor<2, dim>& hj = hess[j];
          cell_matrix(i, j) += (mi[0] * hj[0][0] + mi[1] * hj[1][1] + mi[2] * 2 * hj[0][1]) * fe_values.JxW(q);
        }
      }
    }
    cell->get_dof_indices(dofs);
    for (unsigned int i = 0; i < n_w; ++i) w_dofs[i] = dofs[w_local[i]];
    constraints_.distribute_local_to_global(cell_matrix, w_dofs, bending_);
    add_raw(cell_matrix, w_dofs);

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

// External force: probes are uniform pressure F/(πc²) over their disk, integrated on cells cut
// by the disk edge with a sub-sampled (10×10 Gauss-2) quadrature and then scaled so that the
// consistent nodal forces of w sum to F exactly; pressures use the standard quadrature.
void FilmSolver::assemble_load_vector() {
  load_raw_.reinit(dof_handler_.n_dofs());
  const unsigned int p = form_degree();  // the primal degree, also in the enriched space (consistent forms)
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
    PVDF_ASSERT(std::isfinite(sum), "the nodal forces of a load must be finite");
    if (load.probe) {
      if (sum != 0) f *= load.force_N / sum;
    }
    load_raw_ += f;
  }
  load_ = load_raw_;
  constraints_.condense(load_);
}

// Geometry cache for assembly: the mesh is fixed between refinements (and for a whole probe
// sweep), so the mapped gradients of the scalar shape functions, JxW and the DOF indices of each
// cell are computed once per mesh instead of once per assembly (the triangulation's change
// signal invalidates the cache).
void FilmSolver::build_geometry_cache() {
  const unsigned int p = form_degree();  // the primal degree, also in the enriched space (consistent forms)
  const QGauss<dim> quadrature(p + 1);
  FEValues<dim> fe_values(*mapping_, *fe_, quadrature, update_gradients | update_JxW_values);
  const unsigned int n = fe_->n_dofs_per_cell();
  const unsigned int n_base = n / 3;
  PVDF_ASSERT(n == 3 * n_base, "the element has three components (u_x, u_y, w) of the same base");
  const unsigned int n_q = quadrature.size();
  cache_.n_q = n_q;
  cache_.n_base = n_base;
  cache_.system_index.assign(3 * n_base, 0);
  for (unsigned int c = 0; c < 3; ++c)
    for (unsigned int a = 0; a < n_base; ++a) cache_.system_index[c * n_base + a] = fe_->component_to_system_index(c, a);
  const std::size_t n_cells = dof_handler_.get_triangulation().n_active_cells();  // (the enriched space shares the mesh)
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
  PVDF_ASSERT(k == n_cells, "the geometry cache must hold every active cell once");
  cache_.n_cells = n_cells;
  cache_.valid = true;
}

namespace {

// The membrane at one quadrature point: the 2nd Piola–Kirchhoff resultant S = h·Q̄·E + N_tot·I
// (docs/fem.md eq. 3.1) and, per component c, the vector v_c with δE = sym(v_c ⊗ ∇φ) for a shape
// function φ of component c: row c of F = I + H (large rotation) or e_c (von Kármán, linear) for
// u_x, u_y; ∇w for w (0 in the linear model, whose w couples only through N_tot).
struct MembranePoint {
  std::array<double, 3> S{0, 0, 0};
  double v[3][2] = {{0, 0}, {0, 0}, {0, 0}};
  Kinematics kin;
};

// Kinematics from the nodal gradients gr[c] = Σ_a u_(c,a) ∇φ_a, the stress resultant, and the
// point's share of the potential Π: ½ S:E + N_tot tr E (+ ½ N_tot |∇w|² in the linear model,
// where the pretension's work on w is not in E).
MembranePoint membrane_point(const double gr[3][2], Model model, const Stiffness3& C, double N_tot, double jxw,
                             double& energy) {
  MembranePoint p;
  Kinematics& kin = p.kin;
  for (int a = 0; a < 2; ++a) {
    kin.g[a] = gr[2][a];
    for (int b = 0; b < 2; ++b) kin.H[a][b] = gr[a][b];
  }
  const std::array<double, 3> E = membrane_strain(kin, model);
  std::array<double, 3> S = C.apply(E);
  energy += (0.5 * (S[0] * E[0] + S[1] * E[1] + S[2] * E[2]) + N_tot * (E[0] + E[1])) * jxw;
  if (model == Model::linear) energy += 0.5 * N_tot * (kin.g[0] * kin.g[0] + kin.g[1] * kin.g[1]) * jxw;
  S[0] += N_tot;
  S[1] += N_tot;
  p.S = S;
  for (unsigned int c = 0; c < 2; ++c) {
    if (model == Model::large_rotation) {
      p.v[c][0] = (c == 0 ? 1.0 : 0.0) + kin.H[c][0];
      p.v[c][1] = (c == 1 ? 1.0 : 0.0) + kin.H[c][1];
    } else {
      p.v[c][0] = c == 0 ? 1.0 : 0.0;
      p.v[c][1] = c == 1 ? 1.0 : 0.0;
    }
  }
  p.v[2][0] = model == Model::linear ? 0.0 : kin.g[0];
  p.v[2][1] = model == Model::linear ? 0.0 : kin.g[1];
  return p;
}

// Residual r_(c,a) = v_c · (S ∇φ_a) (+ N_tot ∇w·∇φ_a for w in the linear model), added to
// rb[c·nb + a]. G holds the nb shape gradients of this point (x, y interleaved).
void add_point_residual(const MembranePoint& p, const double* G, unsigned int nb, double jxw, Model model,
                        double N_tot, double* rb) {
  const auto& S = p.S;
  for (unsigned int a = 0; a < nb; ++a) {
    const double gx = G[2 * a], gy = G[2 * a + 1];
    const double s0 = (S[0] * gx + S[2] * gy) * jxw, s1 = (S[2] * gx + S[1] * gy) * jxw;
    for (unsigned int c = 0; c < 3; ++c) rb[c * nb + a] += p.v[c][0] * s0 + p.v[c][1] * s1;
    if (model == Model::linear) rb[2 * nb + a] += N_tot * (p.kin.g[0] * gx + p.kin.g[1] * gy) * jxw;
  }
}

// Tangent block (c, d): ∇φ_a·(B_cᵀ C B_d + δ_cd G)∇φ_b, with B_c the 3×2 map ∇φ ↦ δE (Voigt)
// and the geometric stiffness G = S (w–w; also u–u of the same component for large rotation;
// N_tot·I for w in the linear model). The 2×2 block matrices are formed once per point and
// added to Kb[(c·3 + d)·nb² + a·nb + b].
void add_point_tangent(const MembranePoint& p, const double* G, unsigned int nb, double jxw, Model model,
                       double N_tot, const Stiffness3& stiffness, double* Kb) {
  const auto& C = stiffness.c;
  const auto& S = p.S;
  const auto& v = p.v;
  const bool geometric_inplane = model == Model::large_rotation;
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

}  // namespace

// Membrane residual and tangent (docs/fem.md §3), total Lagrangian: per cell and quadrature
// point, membrane_point() → add_point_residual() (+ add_point_tangent()), then the cell blocks
// go back to the FE's local order and through the constraints. Bending adds K_b u and K_b; the
// external force is subtracted. Also leaves the potential Π(u) in last_energy_ (line search)
// and the unconstrained membrane force in membrane_raw_ (rim reaction).
void FilmSolver::assemble(const Vector<double>& u, Model model, double artificial_tension, bool want_matrix,
                          Vector<double>& residual) {
  const auto t0 = Clock::now();
  if (!cache_.valid || cache_.n_cells != dof_handler_.get_triangulation().n_active_cells()) build_geometry_cache();
  const unsigned int n = fe_->n_dofs_per_cell();
  const unsigned int nb = cache_.n_base, n_q = cache_.n_q;
  FullMatrix<double> cell_matrix(n, n);
  Vector<double> cell_rhs(n);
  std::vector<types::global_dof_index> dofs(n);
  std::vector<double> ul(n);  // local values ordered (component, base)
  const double N_tot = pretension_ + artificial_tension;
  PVDF_ASSERT(u.size() == dof_handler_.n_dofs(), "the displacement must have one value per DOF of this space");
  PVDF_ASSERT(cache_.dofs.size() == cache_.n_cells * n && cache_.system_index.size() == 3 * std::size_t(nb),
              "the geometry cache must belong to this element and mesh");

  residual.reinit(dof_handler_.n_dofs());
  membrane_raw_ = 0;
  if (want_matrix && options_.include_bending) widen_tangent();  // K + bending needs its face couplings
  if (want_matrix) tangent_ = 0;
  double energy = 0;
  // Block-local arrays: rb[c][a] residual, Kb[c][d][a][b] tangent.
  std::vector<double> rb(3 * nb), Kb(9 * nb * nb);
  Stiffness3 relaxed_C;

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
      MembranePoint point = membrane_point(gr, model, membrane_C_, N_tot, jxw, energy);
      const Stiffness3* tangent_C = &membrane_C_;
      if (tension_field_) {  // wrinkling: relaxed stress, tangent and energy (tension_field.cpp)
        energy += relax_membrane_point(point.kin, model, artificial_tension, want_matrix, point.S, relaxed_C) * jxw;
        tangent_C = &relaxed_C;
      }
      add_point_residual(point, G, nb, jxw, model, N_tot, rb.data());
      if (want_matrix) add_point_tangent(point, G, nb, jxw, model, N_tot, *tangent_C, Kb.data());
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
    // raw: the condensed matrix has diagonals on constrained rows (absent in the enriched space,
    // whose potential is never used)
    if (!bending_raw_.empty()) energy += 0.5 * bending_raw_.matrix_norm_square(u);
    if (want_matrix) tangent_.add(1.0, bending_);
  }
  energy -= load_ * u;
  last_energy_ = energy;
  residual -= load_;
  constraints_.set_zero(residual);
  summary_.assembly_s += seconds_since(t0);
}

}  // namespace pvdf::fem::detail
