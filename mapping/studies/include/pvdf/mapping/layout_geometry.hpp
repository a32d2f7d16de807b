// Rotated rectangular electrodes as the layout optimizer sees them: corners, the signed distance
// between two rectangles (separating axes), and the clearance of a rectangle from the clamp.
// Pure geometry, no maps; docs/design.md §7 states the constraints these functions check.
#pragma once

#include "pvdf/core/scene.hpp"

#include <array>
#include <vector>

namespace pvdf::mapping {

/// A rectangle of width_m × height_m centred at center_m, its width axis at angle_rad (CCW from x).
struct OrientedRect {
  Point2 center_m{0, 0};
  double width_m = 0.002;
  double height_m = 0.002;
  double angle_rad = 0.0;
};

/// The four corners (m), counter-clockwise.
std::array<Point2, 4> rect_corners(const OrientedRect& rect);

/// Signed distance between two rectangles (m): the Euclidean distance between them when they are
/// apart (> 0), 0 when they touch, and minus the penetration depth (the smallest translation that
/// separates them, by the separating-axis theorem) when they overlap.
double rect_signed_distance_m(const OrientedRect& a, const OrientedRect& b);

/// Smallest signed distance (m, > 0 inside) from the clamp outline of the rectangle: at its
/// corners, which is exact for convex outlines (circle, rectangle, ellipse, convex polygon: the
/// distance to the boundary of a convex region is concave inside it, so its minimum over an edge
/// is at an end), and for a polygon outline also at 16 points along each edge.
double rect_clearance_m(const FilmOutline& outline, const OrientedRect& rect);

/// How far a layout is from meeting the optimizer's constraints (m; 0 = feasible): the sum over
/// pairs of max(0, min_gap_m − signed distance) and over rectangles of
/// max(0, clamp_margin_m − clearance). Continuous, so a search can walk towards feasibility.
double layout_violation_m(const std::vector<OrientedRect>& layout, const FilmOutline& outline, double min_gap_m,
                          double clamp_margin_m);

}  // namespace pvdf::mapping
