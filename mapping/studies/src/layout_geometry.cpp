// Rectangle geometry of the layout optimizer (layout_geometry.hpp).
#include "pvdf/mapping/layout_geometry.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace pvdf::mapping {

std::array<Point2, 4> rect_corners(const OrientedRect& r) {
  const double c = std::cos(r.angle_rad), s = std::sin(r.angle_rad);
  const double hw = 0.5 * r.width_m, hh = 0.5 * r.height_m;
  const double local[4][2] = {{-hw, -hh}, {hw, -hh}, {hw, hh}, {-hw, hh}};
  std::array<Point2, 4> corners;
  for (int k = 0; k < 4; ++k) {
    corners[k] = {r.center_m[0] + c * local[k][0] - s * local[k][1], r.center_m[1] + s * local[k][0] + c * local[k][1]};
  }
  return corners;
}

namespace {

double point_segment_distance_m(const Point2& p, const Point2& a, const Point2& b) {
  const double ex = b[0] - a[0], ey = b[1] - a[1];
  const double len2 = ex * ex + ey * ey;
  double t = len2 > 0 ? ((p[0] - a[0]) * ex + (p[1] - a[1]) * ey) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return std::hypot(p[0] - a[0] - t * ex, p[1] - a[1] - t * ey);
}

/// Projections of the corners on axis (nx, ny): [min, max].
std::array<double, 2> project(const std::array<Point2, 4>& corners, double nx, double ny) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& p : corners) {
    const double d = p[0] * nx + p[1] * ny;
    lo = std::min(lo, d);
    hi = std::max(hi, d);
  }
  return {lo, hi};
}

}  // namespace

double rect_signed_distance_m(const OrientedRect& a, const OrientedRect& b) {
  const auto ca = rect_corners(a), cb = rect_corners(b);
  // Separating-axis theorem for two convex polygons: they are disjoint iff their projections on
  // some edge normal are disjoint. The largest axis gap is ≤ 0 for overlapping rectangles and is
  // then minus the penetration depth (the smallest overlap over the candidate axes).
  double largest_gap = -std::numeric_limits<double>::infinity();
  for (const double angle : {a.angle_rad, b.angle_rad}) {
    for (int k = 0; k < 2; ++k) {
      const double nx = k == 0 ? std::cos(angle) : -std::sin(angle);
      const double ny = k == 0 ? std::sin(angle) : std::cos(angle);
      const auto pa = project(ca, nx, ny), pb = project(cb, nx, ny);
      largest_gap = std::max(largest_gap, std::max(pb[0] - pa[1], pa[0] - pb[1]));
    }
  }
  if (largest_gap <= 0) return largest_gap;
  // Apart: the distance between two disjoint convex polygons is attained between a vertex of one
  // and an edge of the other.
  double d = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 4; ++k) {
    for (int e = 0; e < 4; ++e) {
      d = std::min(d, point_segment_distance_m(ca[k], cb[e], cb[(e + 1) % 4]));
      d = std::min(d, point_segment_distance_m(cb[k], ca[e], ca[(e + 1) % 4]));
    }
  }
  return d;
}

double rect_clearance_m(const FilmOutline& outline, const OrientedRect& rect) {
  const auto corners = rect_corners(rect);
  double clearance = std::numeric_limits<double>::infinity();
  const int samples = outline.shape == FilmOutline::Shape::polygon ? 16 : 1;
  for (int e = 0; e < 4; ++e) {
    const Point2& p = corners[e];
    const Point2& q = corners[(e + 1) % 4];
    for (int s = 0; s < samples; ++s) {
      const double t = double(s) / samples;
      clearance = std::min(clearance, outline.inside_distance_m({p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])}));
    }
  }
  return clearance;
}

double layout_violation_m(const std::vector<OrientedRect>& layout, const FilmOutline& outline, double min_gap_m,
                          double clamp_margin_m) {
  double violation = 0;
  for (std::size_t i = 0; i < layout.size(); ++i) {
    violation += std::max(0.0, clamp_margin_m - rect_clearance_m(outline, layout[i]));
    for (std::size_t j = i + 1; j < layout.size(); ++j) {
      violation += std::max(0.0, min_gap_m - rect_signed_distance_m(layout[i], layout[j]));
    }
  }
  return violation;
}

}  // namespace pvdf::mapping
