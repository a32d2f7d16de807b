// Geometric consistency of a scene — the film's size range, electrodes inside the film and
// disjoint, probe sizes a mesh can resolve, probe footprints clear of the rim. Checked once, by
// the scene reader, for every command; pvdf::mesh adds the rules that depend on mesh sizes.
#pragma once

#include "pvdf/core/planar.hpp"
#include "pvdf/core/scene.hpp"

#include <cstddef>
#include <string>
#include <vector>

namespace pvdf {

/// The documented physical range of a scene (docs/scene.md, "Geometry").
namespace scene_limits {
/// Film size: circle radius, half the longer rectangle side, larger semi-axis, or farthest
/// polygon vertex from the origin (FilmOutline::characteristic_radius_m).
inline constexpr double film_radius_min_m = 1e-3;
inline constexpr double film_radius_max_m = 10.0;
/// Largest ratio of that size to the inscribed radius (a 1:100 strip at most).
inline constexpr double film_aspect_max = 100.0;
/// Smallest probe radius, electrode size and mesh size as a fraction of the film size: below
/// it, a mesh fine enough to resolve the feature cannot span the film.
inline constexpr double feature_ratio_min = 1e-3;
/// Largest probe radius as a fraction of the inscribed radius.
inline constexpr double probe_radius_max_ratio = 0.25;
/// Smallest estimated deflection of a press as a fraction of the film size: below it the
/// deflection is a few thousand ulps of the coordinates (rounding), and a solve "converges" to
/// zero (docs/scene.md "Physical bounds").
inline constexpr double deflection_ratio_min = 1e-12;
}  // namespace scene_limits

/// The film outline as a planar region (the ellipse as a fine polygon, 1024 vertices).
planar::Region film_region(const FilmOutline& outline);
/// An electrode as a planar region (circles exact, rectangles and polygons by their vertices).
planar::Region electrode_region(const Electrode& electrode);
/// Smallest size of an electrode (m): the shorter rectangle side, the diameter, or 4·area/perimeter.
double electrode_feature_size_m(const Electrode& electrode);

/// Where an electrode sits relative to the film: inside with a clearance, crossing, or outside.
struct RimRelation {
  enum class Kind { inside, crossing, outside } kind = Kind::inside;
  double clearance_m = 0;  ///< smallest distance from the electrode outline to the rim (inside only)
};
RimRelation rim_relation(const FilmOutline& outline, const Electrode& electrode);

/// Why a probe of `radius_m` pressed at `center_m` cannot be solved on `scene`'s film, or "":
/// its centre must lie inside and its footprint must stay one probe radius clear of the rim
/// (the margin charge maps keep: the clamped edge beside a footprint is what a mesh resolves).
std::string probe_footprint_problem(const Scene& scene, const Point2& center_m, double radius_m);

/// Lower estimate of the deflection (m) under a press of `force_N` at the film's centre: plate
/// bending (w = F·a²/(16πD)), pre-tension (w = F·ln(a/r_p)/(2πN0), N0 > 0) and membrane
/// stretching (w = a·(F/(E·h·a))^(1/3)) as springs in parallel, with a the inscribed radius and
/// E the larger modulus (the stiffest reading of the film). Within a factor of about 3 of the
/// solver's answer; used only to refuse forces whose deflection would be lost to rounding.
double estimated_deflection_m(const Scene& scene, double force_N);

/// Why a press of `force_N` on `scene`'s film would deflect it by less than deflection_ratio_min
/// of the film size (lost to rounding), with the smallest force that would not; or "".
std::string force_resolution_problem(const Scene& scene, double force_N);

/// Why `forces_N` cannot be a map's force levels, or "" — the one rule of `map --forces-N`, the
/// design's levels and Python's generate_map/ProbeSweep: each level in [1e-9, 1e4] N (the rule of
/// loads[].force_N; then `index` is the offending level's and the text starts with its value) and
/// no two within a relative 1e-6 (one level twice; `index` = forces_N.size()).
std::string force_levels_problem(const std::vector<double>& forces_N, std::size_t& index);

/// Throws InputError (naming the scene file and the key) when the scene breaks a rule above.
void check_scene_geometry(const Scene& scene);

}  // namespace pvdf
