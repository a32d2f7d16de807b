// Outputs of a converged state (docs/fem.md §6, §7): membrane forces in the global, material and
// polar frames, electrode mean forces by exact-outline quadrature and their charges (the charge
// law of pvdf/core/piezo.hpp), deflections, the rim reaction, the strain energy, sample points.
#include "electrode_cells.hpp"
#include "film_solver.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/material.hpp"
#include "pvdf/core/piezo.hpp"

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/numerics/vector_tools.h>

#include <algorithm>
#include <cmath>

namespace pvdf::fem::detail {

using namespace dealii;

// H = ∇u and g = ∇w at a point (deal.II locates the cell).
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

// S = h·Q̄·E + N0·I at a point, in the global, material (draw angle) and polar (about the first
// load) frames.
MembraneForce FilmSolver::membrane_force(const Kinematics& k, const Point<dim>& x) const {
  const std::array<double, 3> S = membrane_stress(membrane_strain(k, current_model_));  // relaxed if wrinkling
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

// The quadrature of electrode k's integrals (electrode_cells.hpp): every cell whose box meets the
// outline's; a cell wholly inside keeps its Gauss rule (degree p + 2, with the curved mapping), a
// cut cell gets the degree-5 rule of the outline clipped to its straight-sided quadrilateral, the
// points taken back to the unit cell. The cells' chords differ from the Q2 mapping's curved edges by
// the sagitta (~1e-6 of a cell near the electrodes), the whole error of this geometry.
const std::vector<FilmSolver::ElectrodeCell>& FilmSolver::electrode_cells(std::size_t k) const {
  if (electrode_cells_.size() != electrode_polygons_.size()) {
    electrode_cells_.clear();
    electrode_cells_.resize(electrode_polygons_.size());
  }
  std::vector<ElectrodeCell>& out = electrode_cells_[k];
  if (!out.empty()) return out;
  const auto& poly = electrode_polygons_[k];
  const std::array<double, 4> box = polygon_box(poly);
  const QGauss<dim> whole(options_.fe_degree + 2);
  const UpdateFlags flags = update_gradients | update_JxW_values | update_quadrature_points;
  for (const auto& cell : dof_handler_.active_cell_iterators()) {
    if (cell_misses_box(cell, box)) continue;
    std::array<pvdf::Point2, 4> quad;
    const unsigned int order[4] = {0, 1, 3, 2};
    for (int v = 0; v < 4; ++v) quad[v] = {cell->vertex(order[v])[0], cell->vertex(order[v])[1]};
    const std::vector<pvdf::Point2> part = clip_to_convex_quad(poly, quad);
    const double quad_area = std::abs(twice_signed_area({quad.begin(), quad.end()}));
    const double part_area = part.size() < 3 ? 0.0 : std::abs(twice_signed_area(part));
    if (part_area <= 1e-12 * quad_area) continue;
    ElectrodeCell ec;
    ec.cell = cell;
    if (part_area >= (1 - 1e-12) * quad_area) {
      ec.values = std::make_unique<FEValues<dim>>(*mapping_, *fe_, whole, flags);
      ec.values->reinit(cell);
      ec.jxw = ec.values->get_JxW_values();
    } else {
      std::vector<pvdf::Point2> points;
      std::vector<double> weights;
      polygon_quadrature(part, points, weights);
      std::vector<Point<dim>> unit;
      for (std::size_t q = 0; q < points.size(); ++q) {
        try {
          unit.push_back(mapping_->transform_real_to_unit_cell(cell, Point<dim>(points[q][0], points[q][1])));
          ec.jxw.push_back(weights[q]);
        } catch (const Mapping<dim>::ExcTransformationFailed&) {  // outside a strongly curved cell: skip it
        }
      }
      if (unit.empty()) continue;
      ec.values = std::make_unique<FEValues<dim>>(*mapping_, *fe_, Quadrature<dim>(unit, std::vector<double>(unit.size(), 1.0)),
                                                  flags);
      ec.values->reinit(cell);
    }
    out.push_back(std::move(ec));
  }
  return out;
}

// Mean membrane force over electrode k: ∫χ_k N dA / ∫χ_k dA with the exact outline χ_k
// (electrode_cells).
std::array<double, 3> FilmSolver::electrode_mean_force(const Vector<double>& u, Model model, std::size_t k,
                                                       double* integrated_area) const {
  const FEValuesExtractors::Vector inplane(0);
  const FEValuesExtractors::Scalar w(2);
  std::vector<Tensor<2, dim>> grad_u;
  std::vector<Tensor<1, dim>> grad_w;
  std::array<double, 3> sum{0, 0, 0};
  double area = 0;
  for (const ElectrodeCell& ec : electrode_cells(k)) {
    const FEValues<dim>& fe_values = *ec.values;
    grad_u.resize(ec.jxw.size());
    grad_w.resize(ec.jxw.size());
    fe_values[inplane].get_function_gradients(u, grad_u);
    fe_values[w].get_function_gradients(u, grad_w);
    for (unsigned int q = 0; q < ec.jxw.size(); ++q) {
      Kinematics kin;
      for (int a = 0; a < 2; ++a) {
        kin.g[a] = grad_w[q][a];
        for (int b = 0; b < 2; ++b) kin.H[a][b] = grad_u[q][a][b];
      }
      const std::array<double, 3> S = membrane_stress(membrane_strain(kin, model));  // with S0, relaxed if wrinkling
      for (int c = 0; c < 3; ++c) sum[c] += S[c] * ec.jxw[q];
      area += ec.jxw[q];
    }
  }
  if (integrated_area) *integrated_area = area;
  if (area <= 0) return {0, 0, 0};
  std::array<double, 3> mean{sum[0] / area, sum[1] / area, sum[2] / area};
  return mean;
}

// Vertical reaction of the clamped rim (N), from the nodal force balance on the rim.
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

// Membrane (½ S:E without the pretension's share) plus bending energy (J).
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
      const double W = tension_field_ ? membrane_law(E, 0.0, false).W : 0.5 * (S[0] * E[0] + S[1] * E[1] + S[2] * E[2]);
      energy += W * fe_values.JxW(q);
    }
  }
  if (options_.include_bending) energy += 0.5 * bending_raw_.matrix_norm_square(u);
  return energy;
}

// The largest |w| over the nodal values (signed value of that extremum; the first one met on a
// tie). Nodal values of Q2/Q3 are a close bound of the field's extremum for these smooth w.
double FilmSolver::deflection_extremum(const Vector<double>& u) const {
  double wmax = 0;
  for (const auto& cell : dof_handler_.active_cell_iterators()) {
    std::vector<types::global_dof_index> dofs(fe_->n_dofs_per_cell());
    cell->get_dof_indices(dofs);
    for (unsigned int i = 0; i < dofs.size(); ++i) {
      if (fe_->system_to_component_index(i).first == 2 && std::abs(u(dofs[i])) > std::abs(wmax)) wmax = u(dofs[i]);
    }
  }
  return wmax;
}

// Charge of electrode k from its mean membrane force in material axes: the charge law
// Q = A·(d31·N11 + d32·N22)/h (pvdf/core/piezo.hpp) with the electrode's nominal area A.
double FilmSolver::electrode_charge(std::size_t k, const std::array<double, 3>& mean_force_material) const {
  return pvdf::piezo_charge_C(scene_.electrodes[k].area_m2(), mean_force_material[0], mean_force_material[1],
                              thickness_, scene_.material.d31_C_per_N, scene_.material.d32_C_per_N);
}

// The point form of the same law, (d31·N11 + d32·N22)/h (C/m²), for samples and the VTU field.
double FilmSolver::charge_density(const MembraneForce& n) const {
  return pvdf::piezo_charge_density_C_per_m2(n.material[0], n.material[1], thickness_, scene_.material.d31_C_per_N,
                                             scene_.material.d32_C_per_N);
}

// Every field of Result from the converged solution_.
void FilmSolver::fill_result(Result& result, Model model) {
  current_model_ = model;
  const Vector<double>& u = solution_;
  result.max_deflection_m = deflection_extremum(u);
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
    er.charge_C = electrode_charge(k, er.mean_membrane_force_material_N_per_m);
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
      throw InputError("sample point (x, y) = (" + fmt(p[0]) + ", " + fmt(p[1]) +
                       ") m could not be located in the mesh (too close to the rim?); move it inside the film");
    }
    s.ux_m = value[0];
    s.uy_m = value[1];
    s.w_m = value[2];
    s.charge_density_C_per_m2 = charge_density(s.membrane_force);
    result.samples.push_back(s);
  }
  result.rim_reaction_N = rim_reaction(u, model);
  result.strain_energy_J = strain_energy(u, model);
  const WrinkleMap wm = wrinkle_map(u, model);
  result.wrinkled_area_fraction = wm.wrinkled_area_fraction;
  result.slack_area_fraction = wm.slack_area_fraction;
}

// The outputs a probe sweep keeps: electrode charges and mean forces, w under the probe, the
// rim reaction (equilibrium check).
void FilmSolver::probe_outputs(const Vector<double>& u, Model model, EngineSolution& out) {
  current_model_ = model;
  out.charge_C.clear();
  out.mean_membrane_force_material_N_per_m.clear();
  for (std::size_t k = 0; k < scene_.electrodes.size(); ++k) {
    const auto g = electrode_mean_force(u, model, k);
    const Eigen::Vector3d m = pvdf::stress_to_material(draw_angle_) * Eigen::Vector3d(g[0], g[1], g[2]);
    out.mean_membrane_force_material_N_per_m.push_back({m[0], m[1], m[2]});
    out.charge_C.push_back(electrode_charge(k, out.mean_membrane_force_material_N_per_m.back()));
  }
  Vector<double> value(3);
  VectorTools::point_value(*mapping_, dof_handler_, u, loads_.front().center, value);
  out.deflection_at_load_m = value[2];
  out.rim_reaction_N = rim_reaction(u, model);
}

}  // namespace pvdf::fem::detail
