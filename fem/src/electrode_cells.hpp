// The cell filter of the electrode integrals (the charge in outputs.cpp, its derivative in
// goal_error.cpp): one rule, so that both see the same cells.
#pragma once

#include "pvdf/core/scene.hpp"

#include <algorithm>
#include <vector>

namespace pvdf::fem::detail {

/// Whether the cell's bounding box misses the bounding box of polygon v, so that the cell holds
/// none of v.
template <class CellIterator>
bool cell_misses_polygon(const CellIterator& cell, const std::vector<pvdf::Point2>& v) {
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (const auto& p : v) {
    xmin = std::min(xmin, p[0]);
    xmax = std::max(xmax, p[0]);
    ymin = std::min(ymin, p[1]);
    ymax = std::max(ymax, p[1]);
  }
  const auto box = cell->bounding_box().get_boundary_points();
  return box.first[0] > xmax || box.second[0] < xmin || box.first[1] > ymax || box.second[1] < ymin;
}

}  // namespace pvdf::fem::detail
