// The atlas quadrature on a solver's mesh (AtlasQuadrature, atlas_quadrature.hpp; docs/atlas.md §3)
// and the charge-density moments of the atlas cells at a state: the electrode integrals' cut-cell
// construction (outputs.cpp) with the atlas squares as the outlines.
#include "atlas_quadrature.hpp"

#include "electrode_cells.hpp"

#include "pvdf/core/material.hpp"
#include "pvdf/core/piezo.hpp"

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/fe/fe_values.h>

#include <algorithm>
#include <cmath>

namespace pvdf::fem::detail {

using namespace dealii;

// Every FE cell is cut by the atlas squares its box meets; a cell wholly inside one square keeps its
// Gauss rule (degree p + 2, curved mapping), a cut cell gets the degree-5 rule of each piece (its
// straight-sided quadrilateral clipped to the square, electrode_cells.hpp), the points taken back
// to the unit cell: the construction of FilmSolver::electrode_cells (outputs.cpp) with the atlas
// squares as the outlines. Built once per mesh; each press then costs one gradient evaluation per
// point.
AtlasQuadrature::AtlasQuadrature(const FilmSolver& solver, const AtlasGrid& grid, std::vector<double>& geometry)
    : solver_(solver) {
  const FilmSolver& s = solver_;
  n_cells_ = grid.nx * grid.ny;
  geometry.assign(n_cells_ * 6, 0.0);
  const QGauss<dim> whole(s.options_.fe_degree + 2);
  const UpdateFlags flags = update_gradients | update_JxW_values | update_quadrature_points;
  const double a = grid.cell_m;
  for (const auto& cell : s.dof_handler_.active_cell_iterators()) {
    std::array<pvdf::Point2, 4> quad;
    const unsigned int order[4] = {0, 1, 3, 2};
    for (int v = 0; v < 4; ++v) quad[v] = {cell->vertex(order[v])[0], cell->vertex(order[v])[1]};
    const std::vector<pvdf::Point2> cell_poly(quad.begin(), quad.end());
    const std::array<double, 4> box = polygon_box(cell_poly);
    const double quad_area = std::abs(twice_signed_area(cell_poly));
    const long i_lo = std::max(0L, long(std::floor((box[0] - grid.x0_m) / a)));
    const long i_hi = std::min(long(grid.nx) - 1, long(std::floor((box[1] - grid.x0_m) / a)));
    const long j_lo = std::max(0L, long(std::floor((box[2] - grid.y0_m) / a)));
    const long j_hi = std::min(long(grid.ny) - 1, long(std::floor((box[3] - grid.y0_m) / a)));
    CellPoints acp;
    acp.cell = cell;
    std::vector<Point<dim>> unit;
    for (long j = j_lo; j <= j_hi; ++j) {
      for (long i = i_lo; i <= i_hi; ++i) {
        const std::array<pvdf::Point2, 4> square = grid.square(std::size_t(i), std::size_t(j));
        const std::vector<pvdf::Point2> part = clip_to_convex_quad(cell_poly, square);
        const double part_area = part.size() < 3 ? 0.0 : std::abs(twice_signed_area(part));
        if (part_area <= 1e-12 * quad_area) continue;
        const std::size_t index = std::size_t(j) * grid.nx + std::size_t(i);
        const auto centre = grid.centre_m(std::size_t(i), std::size_t(j));
        std::vector<pvdf::Point2> points;
        std::vector<double> weights;
        if (part_area >= (1 - 1e-12) * quad_area) {  // the whole cell in this square: its Gauss rule
          FEValues<dim> gauss(*s.mapping_, *s.fe_, whole, update_JxW_values | update_quadrature_points);
          gauss.reinit(cell);
          for (unsigned int q = 0; q < whole.size(); ++q) {
            unit.push_back(whole.point(q));
            const Point<dim> x = gauss.quadrature_point(q);
            acp.jxw.push_back(gauss.JxW(q));
            acp.dx.push_back(x[0] - centre[0]);
            acp.dy.push_back(x[1] - centre[1]);
            acp.atlas_cell.push_back(index);
          }
          continue;
        }
        polygon_quadrature(part, points, weights);
        for (std::size_t q = 0; q < points.size(); ++q) {
          try {
            unit.push_back(s.mapping_->transform_real_to_unit_cell(cell, Point<dim>(points[q][0], points[q][1])));
          } catch (const Mapping<dim>::ExcTransformationFailed&) {  // outside a strongly curved cell: skip it
            continue;
          }
          acp.jxw.push_back(weights[q]);
          acp.dx.push_back(points[q][0] - centre[0]);
          acp.dy.push_back(points[q][1] - centre[1]);
          acp.atlas_cell.push_back(index);
        }
      }
    }
    if (unit.empty()) continue;
    acp.values = std::make_unique<FEValues<dim>>(
        *s.mapping_, *s.fe_, Quadrature<dim>(unit, std::vector<double>(unit.size(), 1.0)), flags);
    acp.values->reinit(cell);
    for (std::size_t q = 0; q < acp.jxw.size(); ++q) {
      double* g = &geometry[acp.atlas_cell[q] * 6];
      const double w = acp.jxw[q], dx = acp.dx[q], dy = acp.dy[q];
      g[0] += w;
      g[1] += w * dx;
      g[2] += w * dy;
      g[3] += w * dx * dx;
      g[4] += w * dx * dy;
      g[5] += w * dy * dy;
    }
    points_.push_back(std::move(acp));
  }
}

// The moments of q over each atlas cell at state u, by the quadrature of the constructor; q is the
// point form of the charge law (charge_density, pvdf::piezo_charge_density_C_per_m2).
void AtlasQuadrature::moments(const Vector<double>& u, Model model, std::vector<double>& moments) const {
  const FilmSolver& s = solver_;
  moments.assign(n_cells_ * 3, 0.0);
  const FEValuesExtractors::Vector inplane(0);
  const FEValuesExtractors::Scalar w(2);
  std::vector<Tensor<2, dim>> grad_u;
  std::vector<Tensor<1, dim>> grad_w;
  const Eigen::Matrix3d to_material = pvdf::stress_to_material(s.draw_angle_);
  for (const CellPoints& acp : points_) {
    grad_u.resize(acp.jxw.size());
    grad_w.resize(acp.jxw.size());
    (*acp.values)[inplane].get_function_gradients(u, grad_u);
    (*acp.values)[w].get_function_gradients(u, grad_w);
    for (std::size_t q = 0; q < acp.jxw.size(); ++q) {
      Kinematics kin;
      for (int a = 0; a < 2; ++a) {
        kin.g[a] = grad_w[q][a];
        for (int b = 0; b < 2; ++b) kin.H[a][b] = grad_u[q][a][b];
      }
      const std::array<double, 3> S = s.membrane_stress(membrane_strain(kin, model));  // as electrode_mean_force
      const Eigen::Vector3d m = to_material * Eigen::Vector3d(S[0], S[1], S[2]);
      const double density = pvdf::piezo_charge_density_C_per_m2(m[0], m[1], s.thickness_, s.scene_.material.d31_C_per_N,
                                                                 s.scene_.material.d32_C_per_N);
      double* out = &moments[acp.atlas_cell[q] * 3];
      const double qw = density * acp.jxw[q];
      out[0] += qw;
      out[1] += qw * acp.dx[q];
      out[2] += qw * acp.dy[q];
    }
  }
}

}  // namespace pvdf::fem::detail
