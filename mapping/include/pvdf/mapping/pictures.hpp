// Pictures of charge maps: isocharge contour maps per electrode (seed 001 Figs 6, 8), a charge
// triple's isocharge contours with their intersection, and VTK image data for ParaView.
#pragma once

#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/map.hpp"

#include <string>

namespace pvdf::mapping {

/// Isocharge contours of electrode `electrode` for presses of `force_N` over the map: filled
/// field and labelled contour lines in pC, axes in mm, electrodes marked. PNG, written atomically.
void write_isocharge_png(const Locator& locator, const ChargeMap& map, std::size_t electrode, double force_N,
                         const std::string& path);

/// For measured charges q: each electrode's isocharge contour Q_k(x, y, F) = q_k at the located
/// force, on one figure, with the located position (and an ambiguous alternative) marked —
/// the picture of seed 001 Fig. 6. PNG, written atomically.
void write_intersection_png(const Locator& locator, const ChargeMap& map, const double* charges_C,
                            const Location& result, const std::string& path);

/// Legacy VTK STRUCTURED_POINTS of the map: one scalar field `charge_<name>_pC_F<i>` per
/// electrode and force level (NaN outside the mask / failed points), plus `mask`; coordinates in m.
void write_charge_vtk(const ChargeMap& map, const std::string& path);

}  // namespace pvdf::mapping
