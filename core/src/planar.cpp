// Planar geometry for the scene checks: exact predicates are not needed here because every
// check carries a clearance of a fraction of the mesh size.
#include "pvdf/core/planar.hpp"

#include "pvdf/core/assert.hpp"

#include <algorithm>
#include <cmath>

namespace pvdf::planar {

namespace {

double cross(const Point& o, const Point& a, const Point& b) {
  return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
}

double dist(const Point& a, const Point& b) { return std::hypot(a[0] - b[0], a[1] - b[1]); }

bool on_segment(const Point& a, const Point& b, const Point& p) {
  return std::min(a[0], b[0]) <= p[0] && p[0] <= std::max(a[0], b[0]) && std::min(a[1], b[1]) <= p[1] &&
         p[1] <= std::max(a[1], b[1]);
}

/// Distance between a circle's boundary and a segment (0 when the segment crosses it).
double circle_segment_distance(const Point& c, double r, const Point& a, const Point& b) {
  const double near = point_segment_distance(c, a, b);
  const double far = std::max(dist(c, a), dist(c, b));
  if (near >= r) return near - r;  // segment outside the circle
  if (far <= r) return r - far;    // segment inside the circle
  return 0.0;                      // crosses
}

}  // namespace

double signed_area(const std::vector<Point>& v) {
  double a = 0;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const Point& p = v[i];
    const Point& q = v[(i + 1) % v.size()];
    a += p[0] * q[1] - q[0] * p[1];
  }
  return 0.5 * a;
}

double perimeter(const std::vector<Point>& v) {
  double l = 0;
  for (std::size_t i = 0; i < v.size(); ++i) l += dist(v[i], v[(i + 1) % v.size()]);
  return l;
}

double point_segment_distance(const Point& p, const Point& a, const Point& b) {
  const double dx = b[0] - a[0], dy = b[1] - a[1];
  const double len2 = dx * dx + dy * dy;
  double t = len2 > 0 ? ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2 : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return std::hypot(a[0] + t * dx - p[0], a[1] + t * dy - p[1]);
}

bool segments_intersect(const Point& a, const Point& b, const Point& c, const Point& d) {
  const double d1 = cross(c, d, a), d2 = cross(c, d, b), d3 = cross(a, b, c), d4 = cross(a, b, d);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0))) return true;
  if (d1 == 0 && on_segment(c, d, a)) return true;
  if (d2 == 0 && on_segment(c, d, b)) return true;
  if (d3 == 0 && on_segment(a, b, c)) return true;
  if (d4 == 0 && on_segment(a, b, d)) return true;
  return false;
}

double segment_segment_distance(const Point& a, const Point& b, const Point& c, const Point& d) {
  if (segments_intersect(a, b, c, d)) return 0.0;
  return std::min({point_segment_distance(a, c, d), point_segment_distance(b, c, d), point_segment_distance(c, a, b),
                   point_segment_distance(d, a, b)});
}

bool polygon_contains(const std::vector<Point>& v, const Point& p) {
  bool inside = false;
  for (std::size_t i = 0, j = v.size() - 1; i < v.size(); j = i++) {
    if (((v[i][1] > p[1]) != (v[j][1] > p[1])) &&
        (p[0] < (v[j][0] - v[i][0]) * (p[1] - v[i][1]) / (v[j][1] - v[i][1]) + v[i][0])) {
      inside = !inside;
    }
  }
  return inside;
}

std::array<long, 2> first_self_intersection(const std::vector<Point>& v) {
  const std::size_t n = v.size();
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      const bool adjacent = (j == i + 1) || (i == 0 && j == n - 1);
      const Point &a = v[i], &b = v[(i + 1) % n], &c = v[j], &d = v[(j + 1) % n];
      if (adjacent) {
        // Adjacent edges share one vertex; they must not fold back onto each other.
        const Point& shared = (j == i + 1) ? b : a;
        const Point& other_i = (j == i + 1) ? a : b;
        const Point& other_j = (j == i + 1) ? d : c;
        if (cross(shared, other_i, other_j) == 0 &&
            ((other_i[0] - shared[0]) * (other_j[0] - shared[0]) + (other_i[1] - shared[1]) * (other_j[1] - shared[1])) > 0) {
          return {static_cast<long>(i), static_cast<long>(j)};
        }
        continue;
      }
      if (segments_intersect(a, b, c, d)) return {static_cast<long>(i), static_cast<long>(j)};
    }
  }
  return {-1, -1};
}

double boundary_distance(const Region& a, const Region& b) {
  if (a.is_circle && b.is_circle) {
    const double d = dist(a.center, b.center);
    if (d >= a.radius + b.radius) return d - a.radius - b.radius;
    if (d <= std::abs(a.radius - b.radius)) return std::abs(a.radius - b.radius) - d;
    return 0.0;
  }
  if (a.is_circle || b.is_circle) {
    const Region& c = a.is_circle ? a : b;
    const Region& p = a.is_circle ? b : a;
    double best = 1e300;
    for (std::size_t i = 0; i < p.vertices.size(); ++i) {
      best = std::min(best, circle_segment_distance(c.center, c.radius, p.vertices[i],
                                                    p.vertices[(i + 1) % p.vertices.size()]));
    }
    return best;
  }
  double best = 1e300;
  for (std::size_t i = 0; i < a.vertices.size(); ++i) {
    for (std::size_t j = 0; j < b.vertices.size(); ++j) {
      best = std::min(best, segment_segment_distance(a.vertices[i], a.vertices[(i + 1) % a.vertices.size()],
                                                     b.vertices[j], b.vertices[(j + 1) % b.vertices.size()]));
    }
  }
  return best;
}

bool region_contains(const Region& r, const Point& p) {
  if (r.is_circle) return dist(r.center, p) < r.radius;
  return polygon_contains(r.vertices, p);
}

Point boundary_point(const Region& r) {
  if (r.is_circle) return {r.center[0] + r.radius, r.center[1]};
  PVDF_ASSERT(!r.vertices.empty(), "a polygon region must have vertices");
  return r.vertices.front();
}

bool regions_overlap(const Region& a, const Region& b) {
  if (boundary_distance(a, b) <= 0) return true;
  // Disjoint boundaries: either nested or apart.
  return region_contains(a, boundary_point(b)) || region_contains(b, boundary_point(a));
}

double tangency_gap(const Point& c, double radius, const Region& r) {
  if (r.is_circle) {
    const double d = dist(c, r.center);
    return std::min(std::abs(d - (radius + r.radius)), std::abs(d - std::abs(radius - r.radius)));
  }
  double best = 1e300;
  for (std::size_t i = 0; i < r.vertices.size(); ++i) {
    const Point& a = r.vertices[i];
    const Point& b = r.vertices[(i + 1) % r.vertices.size()];
    best = std::min(best, std::abs(point_segment_distance(c, a, b) - radius));
    best = std::min(best, std::abs(dist(c, a) - radius));
  }
  return best;
}

}  // namespace pvdf::planar
