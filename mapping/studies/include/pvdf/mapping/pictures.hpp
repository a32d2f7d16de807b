// Pictures of charge maps: isocharge contour maps per electrode (seed 001 Figs 6, 8), a charge
// triple's isocharge contours with their intersection, and VTK image data for ParaView. The
// figures are PNG, SVG or PDF, chosen by the extension of `path` (pvdf::plot).
#pragma once

#include "pvdf/mapping/analysis.hpp"
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/map.hpp"

#include <string>
#include <vector>

namespace pvdf::mapping {

/// The force level a picture of the map shows: `requested_N` when > 0, else the map's level
/// nearest 1 N in ratio (|ln F| smallest; seed 001 pressed with 1 N; the first of a tie).
double picture_force_N(const ChargeMap& map, double requested_N);

/// Isocharge contours of electrode `electrode` for presses of `force_N` over the map: filled
/// field and labelled contour lines in pC, axes in mm, electrodes marked. PNG, written atomically.
/// `half_width_m` > 0 zooms on the square [−w, w]² around the film centre (seed 001 Fig. 6
/// shows the electrode triangle); 0 draws the whole map.
void write_isocharge_png(const Locator& locator, const ChargeMap& map, std::size_t electrode, double force_N,
                         const std::string& path, double half_width_m = 0.0);

/// Every electrode's labelled isocharge contours on one figure, one colour per electrode (seed
/// 001 Fig. 8), over [−w, w]² (w = half_width_m; 0 = whole map). PNG, written atomically.
void write_isocharge_overlay_png(const Locator& locator, const ChargeMap& map, double force_N, const std::string& path,
                                 double half_width_m = 0.0);

/// For measured charges q: each electrode's isocharge contour Q_k(x, y, F) = q_k at the located
/// force, on one figure, with the located position (and an ambiguous alternative) marked —
/// the picture of seed 001 Fig. 6. PNG, written atomically.
void write_intersection_png(const Locator& locator, const ChargeMap& map, const double* charges_C,
                            const Location& result, const std::string& path);

/// Legacy VTK STRUCTURED_POINTS (binary, big-endian; opens in ParaView and vtkStructuredPointsReader) of
/// the map: one scalar field per electrode and force level, named by charge_vtk_field_name (charges
/// in C, NaN outside the mask / failed points), plus `mask`; coordinates in m.
void write_charge_vtk(const ChargeMap& map, const std::string& path);
/// The charges.vtk field of an electrode at a force level: `charge_<electrode>_C_at_<F>N`, F in N
/// by value (%.6g), e.g. `charge_A_C_at_1N`, `charge_B_C_at_0.5N`.
std::string charge_vtk_field_name(const std::string& electrode, double force_N);

/// Charge against distance (seed 001 Fig. 7): for electrode `electrode`, the sampled Q(d) of the
/// rays at the angles `beta_deg` (markers) and their eq. 6 fits (lines), log-log axes in mm and
/// pC. With `measured` (may be null), measured presses whose bearing from the electrode lies
/// within ±angle_tolerance_deg of a drawn ray are added as filled markers (Fig. 12). Rays that
/// were not fitted are drawn without a line. PNG, written atomically.
void write_rays_png(const RayAnalysis& analysis, const ChargeMap& map, std::size_t electrode,
                    const std::vector<double>& beta_deg, const std::vector<MeasuredPress>* measured,
                    double angle_tolerance_deg, const std::string& path);

/// Map against a CSV of presses (seed 001 Fig. 12): left, the CSV's charge against the map's per
/// electrode (pC) with the identity and ±18 % lines; right, the % difference of every compared
/// value against the press number. `csv_name` (e.g. the file name) labels the CSV's axis; the
/// plot never calls the values "measured", since the CSV may hold synthetic or map values.
void write_comparison_png(const Comparison& comparison, const std::string& path, const std::string& csv_name = "");

}  // namespace pvdf::mapping
