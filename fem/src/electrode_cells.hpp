// The geometry of the electrode integrals (the charge in outputs.cpp, its derivative in
// goal_error.cpp): one cell filter and one quadrature, so that both see the same points. A cell cut
// by the electrode outline is integrated over the exact intersection of the outline with the cell
// (its straight-sided quadrilateral), not by sampling an indicator: the sampled indicator left an
// output-quadrature error of 2–4e-4 of the charge that no mesh refinement removed (docs/fem.md §6.1).
#pragma once

#include "pvdf/core/scene.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace pvdf::fem::detail {

/// The bounding box {xmin, xmax, ymin, ymax} of polygon v (computed once per integral).
inline std::array<double, 4> polygon_box(const std::vector<pvdf::Point2>& v) {
  std::array<double, 4> b{1e300, -1e300, 1e300, -1e300};
  for (const auto& p : v) {
    b[0] = std::min(b[0], p[0]);
    b[1] = std::max(b[1], p[0]);
    b[2] = std::min(b[2], p[1]);
    b[3] = std::max(b[3], p[1]);
  }
  return b;
}

/// Whether the cell's bounding box misses `box` (from polygon_box), so that the cell holds none of
/// the polygon.
template <class CellIterator>
bool cell_misses_box(const CellIterator& cell, const std::array<double, 4>& box) {
  const auto c = cell->bounding_box().get_boundary_points();
  return c.first[0] > box[1] || c.second[0] < box[0] || c.first[1] > box[3] || c.second[1] < box[2];
}

/// Twice the signed area of polygon v (positive counter-clockwise).
inline double twice_signed_area(const std::vector<pvdf::Point2>& v) {
  double a = 0;
  for (std::size_t i = 0, j = v.size() - 1; i < v.size(); j = i++) a += v[j][0] * v[i][1] - v[i][0] * v[j][1];
  return a;
}

/// The part of the simple polygon `poly` inside the convex quadrilateral `quad` (vertices in order,
/// either orientation): Sutherland–Hodgman, clipping `poly` by each edge of `quad` in turn. For a
/// non-convex `poly` the result may hold zero-area bridges along the quadrilateral's edges, which
/// add nothing to an integral over it.
inline std::vector<pvdf::Point2> clip_to_convex_quad(const std::vector<pvdf::Point2>& poly,
                                                     const std::array<pvdf::Point2, 4>& quad) {
  const double orientation = twice_signed_area({quad.begin(), quad.end()}) > 0 ? 1.0 : -1.0;
  std::vector<pvdf::Point2> out = poly, in;
  for (int e = 0; e < 4 && !out.empty(); ++e) {
    const pvdf::Point2 a = quad[e], b = quad[(e + 1) % 4];
    auto side = [&](const pvdf::Point2& p) {
      return orientation * ((b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]));
    };
    in.swap(out);
    out.clear();
    for (std::size_t i = 0; i < in.size(); ++i) {
      const pvdf::Point2 p = in[i], q = in[(i + 1) % in.size()];
      const double sp = side(p), sq = side(q);
      if (sp >= 0) out.push_back(p);
      if ((sp >= 0) != (sq >= 0)) {
        const double t = sp / (sp - sq);
        out.push_back({p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])});
      }
    }
  }
  return out;
}

/// A quadrature of polygon v: its fan of triangles from v[0], each with the 7-point degree-5 rule
/// (Radon), weights signed by the triangle's orientation and taken positive for a counter-clockwise
/// v; exact for polynomials of degree 5 over any simple polygon. Points lie in v's convex hull.
inline void polygon_quadrature(const std::vector<pvdf::Point2>& v, std::vector<pvdf::Point2>& points,
                               std::vector<double>& weights) {
  const double r = std::sqrt(15.0);
  const double a1 = (6 - r) / 21, a2 = (6 + r) / 21, w1 = (155 - r) / 1200, w2 = (155 + r) / 1200;
  const double bary[7][3] = {{1.0 / 3, 1.0 / 3, 1.0 / 3}, {a1, a1, 1 - 2 * a1}, {a1, 1 - 2 * a1, a1},
                             {1 - 2 * a1, a1, a1},        {a2, a2, 1 - 2 * a2}, {a2, 1 - 2 * a2, a2},
                             {1 - 2 * a2, a2, a2}};
  const double bw[7] = {9.0 / 40, w1, w1, w1, w2, w2, w2};
  const double sign = twice_signed_area(v) >= 0 ? 1.0 : -1.0;
  for (std::size_t i = 1; i + 1 < v.size(); ++i) {
    const pvdf::Point2 &p0 = v[0], &p1 = v[i], &p2 = v[i + 1];
    const double area = 0.5 * ((p1[0] - p0[0]) * (p2[1] - p0[1]) - (p2[0] - p0[0]) * (p1[1] - p0[1]));
    if (area == 0) continue;
    for (int q = 0; q < 7; ++q) {
      points.push_back({bary[q][0] * p0[0] + bary[q][1] * p1[0] + bary[q][2] * p2[0],
                        bary[q][0] * p0[1] + bary[q][1] * p1[1] + bary[q][2] * p2[1]});
      weights.push_back(sign * area * bw[q]);
    }
  }
}

}  // namespace pvdf::fem::detail
