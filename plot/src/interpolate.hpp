// Internal: the smooth interpolant of a Grid (interpolate.cpp) that fields and contours share.
#pragma once

#include "detail.hpp"

namespace pvdf::plot::detail {

/// The grid's value at fractional node position (a, b) (a = 0 … nx − 1 along x, b along y):
/// bicubic (Keys' cubic convolution) where the 4 × 4 stencil is finite, bilinear where it is not,
/// NaN where a corner of the cell is NaN or (a, b) is outside the grid.
double interpolate(const Grid& g, double a, double b);
/// As interpolate(), but next to NaN nodes the finite corners are averaged with their bilinear
/// weights where those hold at least half the weight: a field's edge runs smoothly halfway
/// between valid and missing nodes (what the nearest node would cover, without the staircase).
double interpolate_field(const Grid& g, double a, double b);

}  // namespace pvdf::plot::detail
