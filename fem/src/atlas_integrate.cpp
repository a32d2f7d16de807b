// An electrode read from the atlas (pvdf/fem/atlas.hpp, docs/atlas.md §4): the outline clipped to
// each atlas square (electrode_cells.hpp, the clip the FE charge integrals use), the exact area and
// first moments of each piece, and the cell's linear reconstruction of q from its three moments.
// No deal.II here.
#include "pvdf/fem/atlas.hpp"

#include "electrode_cells.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>

namespace pvdf::fem {

namespace {

// Area and first moments ∫dx, ∫dy of polygon v about (xc, yc), for a positive orientation (the
// shoelace formulas; zero-area bridges of a clipped non-convex outline add nothing).
std::array<double, 3> area_moments(const std::vector<pvdf::Point2>& v, double xc, double yc) {
  double a = 0, mx = 0, my = 0;
  for (std::size_t k = 0; k < v.size(); ++k) {
    const double x0 = v[k][0] - xc, y0 = v[k][1] - yc;
    const double x1 = v[(k + 1) % v.size()][0] - xc, y1 = v[(k + 1) % v.size()][1] - yc;
    const double c = x0 * y1 - x1 * y0;
    a += c;
    mx += (x0 + x1) * c;
    my += (y0 + y1) * c;
  }
  const double sign = a >= 0 ? 1.0 : -1.0;
  return {sign * a / 2, sign * mx / 6, sign * my / 6};
}

}  // namespace

// Linear reconstruction q ≈ c0 + c1·dx + c2·dy with the cell's moments matched over the film
// within the cell: G c = m with G the Gram matrix of {1, dx, dy} there (a square cell wholly in the
// film: G = diag(a², a⁴/12, a⁴/12)). The electrode's share is p·c = (G⁻¹p)·m, p = (|P|, ∫_P dx, ∫_P dy).
AtlasElectrode atlas_electrode(const AtlasGrid& grid, const std::vector<double>& geometry,
                               const std::vector<pvdf::Point2>& outline_m) {
  AtlasElectrode out;
  if (outline_m.size() < 3 || grid.nx == 0 || grid.ny == 0) return out;
  const std::array<double, 4> box = detail::polygon_box(outline_m);
  const double a = grid.cell_m, cell_area = a * a;
  const long i_lo = std::max(0L, long(std::floor((box[0] - grid.x0_m) / a)));
  const long i_hi = std::min(long(grid.nx) - 1, long(std::floor((box[1] - grid.x0_m) / a)));
  const long j_lo = std::max(0L, long(std::floor((box[2] - grid.y0_m) / a)));
  const long j_hi = std::min(long(grid.ny) - 1, long(std::floor((box[3] - grid.y0_m) / a)));
  for (long j = j_lo; j <= j_hi; ++j) {
    for (long i = i_lo; i <= i_hi; ++i) {
      const std::size_t index = std::size_t(j) * grid.nx + std::size_t(i);
      const std::vector<pvdf::Point2> part = detail::clip_to_convex_quad(outline_m, grid.square(std::size_t(i), std::size_t(j)));
      if (part.size() < 3) continue;
      const auto c = grid.centre_m(std::size_t(i), std::size_t(j));
      const std::array<double, 3> p = area_moments(part, c[0], c[1]);
      if (p[0] <= 1e-12 * cell_area) continue;
      const double* g = &geometry[index * 6];
      const double film = g[0];
      out.area_m2 += p[0];
      if (!(film > 1e-9 * cell_area)) continue;  // no film here: no charge
      std::array<double, 3> w{0, 0, 0};
      const double r = std::min(1.0, p[0] / film);
      const bool whole = p[0] >= (1 - 1e-9) * film;
      if (whole) {
        w = {1, 0, 0};
      } else {
        Eigen::Matrix3d G;
        G << g[0], g[1], g[2], g[1], g[3], g[4], g[2], g[4], g[5];
        const Eigen::LDLT<Eigen::Matrix3d> ldlt(G);
        // A sliver of film (a rim cell) whose Gram matrix is near singular (det against the product of
        // its diagonal, Hadamard's bound): the constant reconstruction.
        const bool solvable = ldlt.info() == Eigen::Success && G.determinant() > 1e-8 * g[0] * g[3] * g[5];
        if (solvable) {
          const Eigen::Vector3d x = ldlt.solve(Eigen::Vector3d(p[0], p[1], p[2]));
          w = {x[0], x[1], x[2]};
        } else {
          w = {r, 0, 0};
        }
      }
      out.cell.push_back(index);
      out.weight.push_back(w);
      out.constant_weight.push_back(r);
      out.partial.push_back(whole ? 0 : 1);
    }
  }
  return out;
}

void integrate_atlas_electrode(const AtlasElectrode& electrode, const double* moments, double& charge_C,
                               double& integration_error_C) {
  double q = 0, err = 0;
  for (std::size_t k = 0; k < electrode.cell.size(); ++k) {
    const double* m = moments + electrode.cell[k] * 3;
    const auto& w = electrode.weight[k];
    const double linear = w[0] * m[0] + w[1] * m[1] + w[2] * m[2];
    q += linear;
    if (electrode.partial[k]) err += std::abs(linear - electrode.constant_weight[k] * m[0]);
  }
  charge_C = q;
  integration_error_C = err;
}

}  // namespace pvdf::fem
