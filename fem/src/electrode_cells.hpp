// The cell filter of the electrode integrals (the charge in outputs.cpp, its derivative in
// goal_error.cpp): one rule, so that both see the same cells.
#pragma once

#include "pvdf/core/scene.hpp"

#include <algorithm>
#include <array>
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

}  // namespace pvdf::fem::detail
