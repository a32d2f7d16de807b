// Planar geometry shared by the scene reader (core) and the geometric checks (mesh): points,
// segments, polygons and circles, with distances between outlines. Lengths in the caller's unit.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

namespace pvdf::planar {

using Point = std::array<double, 2>;

/// A closed region bounded by a simple polygon or a circle.
struct Region {
  bool is_circle = false;
  Point center{0, 0};        ///< circle
  double radius = 0;         ///< circle
  std::vector<Point> vertices;  ///< polygon, either orientation
};

double signed_area(const std::vector<Point>& polygon);
double perimeter(const std::vector<Point>& polygon);
/// Distance from p to the segment [a, b].
double point_segment_distance(const Point& p, const Point& a, const Point& b);
/// True when segments [a, b] and [c, d] share a point (touching counts).
bool segments_intersect(const Point& a, const Point& b, const Point& c, const Point& d);
/// Distance between segments (0 when they intersect).
double segment_segment_distance(const Point& a, const Point& b, const Point& c, const Point& d);
/// Even-odd point-in-polygon test (boundary points may go either way).
bool polygon_contains(const std::vector<Point>& polygon, const Point& p);
/// Index pair (i, j) of the first two non-adjacent edges that intersect, or {-1, -1}.
std::array<long, 2> first_self_intersection(const std::vector<Point>& polygon);

/// Smallest distance between the boundaries of two regions (0 when they cross or touch).
double boundary_distance(const Region& a, const Region& b);
/// True when p lies inside the region (boundary excluded up to round-off).
bool region_contains(const Region& r, const Point& p);
/// A point on the boundary of the region (its first vertex, or the circle's east point).
Point boundary_point(const Region& r);
/// Regions overlap (share interior area) or touch.
bool regions_overlap(const Region& a, const Region& b);

/// How close a circle (centre c, radius r) comes to being tangent to the outline of `r`:
/// the smallest | distance(c, outline feature) - radius | over the edges, vertices (polygon) or
/// the circle itself. Small values mean slivers if both outlines become mesh edges.
double tangency_gap(const Point& c, double radius, const Region& r);

}  // namespace pvdf::planar
