// Smooth interpolation of a Grid between its nodes: Keys' cubic convolution (a = −1/2, the
// Catmull–Rom kernel) in x and y. It passes through the nodes, has a continuous gradient and
// reproduces quadratics exactly, so contours traced on a refined grid are smooth curves instead
// of chords of the coarse cells. Where a NaN node is in the 4 × 4 stencil the cell falls back to
// bilinear; where one of the cell's corners is NaN it has no value (contours) or, for fields,
// the finite corners are averaged where they hold at least half the bilinear weight, which puts
// the field's edge smoothly halfway between valid and missing nodes instead of a staircase.
#include "interpolate.hpp"

#include "pvdf/core/assert.hpp"
#include "pvdf/core/error.hpp"

#include <algorithm>

namespace pvdf::plot {

namespace detail {
namespace {

/// Keys' cubic convolution weights for the nodes at offsets −1, 0, 1, 2 of a point at t ∈ [0, 1].
std::array<double, 4> keys_weights(double t) {
  const double t2 = t * t, t3 = t2 * t;
  return {(-t3 + 2 * t2 - t) / 2, (3 * t3 - 5 * t2 + 2) / 2, (-3 * t3 + 4 * t2 + t) / 2, (t3 - t2) / 2};
}

/// Node value with one ghost node on each side, extrapolated quadratically (linearly on a
/// two-node axis) so that the kernel keeps its quadratic precision at the grid's edges.
double node_x(const Grid& g, long i, std::size_t j) {
  const long n = static_cast<long>(g.nx);
  if (i >= 0 && i < n) return g.at(static_cast<std::size_t>(i), j);
  const bool low = i < 0;
  auto v = [&](long k) { return g.at(static_cast<std::size_t>(low ? k : n - 1 - k), j); };
  return n >= 3 ? 3 * v(0) - 3 * v(1) + v(2) : 2 * v(0) - v(1);
}

double node(const Grid& g, long i, long j) {
  const long n = static_cast<long>(g.ny);
  if (j >= 0 && j < n) return node_x(g, i, static_cast<std::size_t>(j));
  const bool low = j < 0;
  auto v = [&](long k) { return node_x(g, i, static_cast<std::size_t>(low ? k : n - 1 - k)); };
  return n >= 3 ? 3 * v(0) - 3 * v(1) + v(2) : 2 * v(0) - v(1);
}

/// Value in cell (i0, j0) at local coordinates (u, v) ∈ [0, 1]²; NaN if a corner is NaN.
double in_cell(const Grid& g, std::size_t i0, std::size_t j0, double u, double v) {
  const double f00 = g.at(i0, j0), f10 = g.at(i0 + 1, j0), f01 = g.at(i0, j0 + 1), f11 = g.at(i0 + 1, j0 + 1);
  if (!finite(f00) || !finite(f10) || !finite(f01) || !finite(f11)) return kNaN;
  const auto wx = keys_weights(u), wy = keys_weights(v);
  double sum = 0;
  for (int b = 0; b < 4; ++b) {
    double row = 0;
    for (int a = 0; a < 4; ++a) {
      const double f = node(g, static_cast<long>(i0) + a - 1, static_cast<long>(j0) + b - 1);
      if (!finite(f)) return (1 - v) * ((1 - u) * f00 + u * f10) + v * ((1 - u) * f01 + u * f11);
      row += wx[static_cast<std::size_t>(a)] * f;
    }
    sum += wy[static_cast<std::size_t>(b)] * row;
  }
  return sum;
}

/// The cell holding fractional node position `a` along an axis of n nodes, and the local coordinate.
void locate(double a, std::size_t n, std::size_t& i0, double& u) {
  PVDF_ASSERT(n >= 2, "an axis with a cell has at least 2 nodes");
  i0 = std::min(static_cast<std::size_t>(std::max(a, 0.0)), n - 2);
  u = std::clamp(a - static_cast<double>(i0), 0.0, 1.0);
}

/// The cell (i0, j0) and local coordinates (u, v) of fractional node position (a, b); false when
/// the grid has no cell or the position lies outside it.
bool find_cell(const Grid& g, double a, double b, std::size_t& i0, std::size_t& j0, double& u, double& v) {
  if (g.nx < 2 || g.ny < 2) return false;
  if (!(a >= -1e-9 && a <= static_cast<double>(g.nx - 1) + 1e-9 && b >= -1e-9 && b <= static_cast<double>(g.ny - 1) + 1e-9))
    return false;
  locate(a, g.nx, i0, u);
  locate(b, g.ny, j0, v);
  return true;
}

}  // namespace

double interpolate(const Grid& g, double a, double b) {
  std::size_t i0 = 0, j0 = 0;
  double u = 0, v = 0;
  if (!find_cell(g, a, b, i0, j0, u, v)) return kNaN;
  double f = in_cell(g, i0, j0, u, v);
  // On a cell edge the neighbouring cell holds the same value: try it when this cell has a hole.
  if (!finite(f) && u == 0 && i0 > 0) f = in_cell(g, i0 - 1, j0, 1, v);
  if (!finite(f) && v == 0 && j0 > 0) f = in_cell(g, i0, j0 - 1, u, 1);
  if (!finite(f) && u == 0 && v == 0 && i0 > 0 && j0 > 0) f = in_cell(g, i0 - 1, j0 - 1, 1, 1);
  return f;
}

double interpolate_field(const Grid& g, double a, double b) {
  const double f = interpolate(g, a, b);
  if (finite(f)) return f;
  std::size_t i0 = 0, j0 = 0;
  double u = 0, v = 0;
  if (!find_cell(g, a, b, i0, j0, u, v)) return kNaN;
  const double w[4] = {(1 - u) * (1 - v), u * (1 - v), (1 - u) * v, u * v};
  const double fk[4] = {g.at(i0, j0), g.at(i0 + 1, j0), g.at(i0, j0 + 1), g.at(i0 + 1, j0 + 1)};
  double weight = 0, sum = 0;
  for (int k = 0; k < 4; ++k) {
    if (!finite(fk[k])) continue;
    weight += w[k];
    sum += w[k] * fk[k];
  }
  return weight >= 0.5 ? sum / weight : kNaN;
}

}  // namespace detail

Grid refine_grid(const Grid& grid, int factor) {
  detail::check_grid(grid, "refine_grid");
  if (factor < 1 || factor > 64) {
    throw InputError("plot refine_grid: factor " + std::to_string(factor) + " must be between 1 and 64");
  }
  if (factor == 1 || grid.nx < 2 || grid.ny < 2) return grid;
  Grid out;
  out.x0 = grid.x0, out.x1 = grid.x1, out.y0 = grid.y0, out.y1 = grid.y1;
  out.nx = (grid.nx - 1) * static_cast<std::size_t>(factor) + 1;
  out.ny = (grid.ny - 1) * static_cast<std::size_t>(factor) + 1;
  out.values.resize(out.nx * out.ny);
  for (std::size_t j = 0; j < out.ny; ++j)
    for (std::size_t i = 0; i < out.nx; ++i)
      out.values[j * out.nx + i] =
          detail::interpolate(grid, static_cast<double>(i) / factor, static_cast<double>(j) / factor);
  return out;
}

}  // namespace pvdf::plot
