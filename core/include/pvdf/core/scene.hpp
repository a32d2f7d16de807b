// Scene files: one JSON file describes a sensor — film, material, electrodes, probe, loads,
// mesh and model options. Keys carry SI units in their names; docs/scene.md is the reference.
#pragma once

#include "pvdf/core/material.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace pvdf {

using Point2 = std::array<double, 2>;

/// Outline of the clamped film (the frame's hole).
struct FilmOutline {
  enum class Shape { circle, rectangle, ellipse, polygon };
  Shape shape = Shape::circle;
  double radius_m = 0.045;               ///< circle
  std::array<double, 2> size_m{0, 0};    ///< rectangle [width, height], centred at the origin
  std::array<double, 2> semi_axes_m{0, 0};  ///< ellipse [a along x, b along y], centred at the origin
  std::vector<Point2> vertices_m;        ///< polygon, counter-clockwise or clockwise
  /// Area of the outline (m²).
  double area_m2() const;
  /// Perimeter (m); the ellipse uses Ramanujan's second approximation (rel. error < 1e-9 for b/a > 0.5).
  double perimeter_m() const;
  /// Radius of the largest circle about the origin that fits inside (m).
  double inscribed_radius_m() const;
  /// Half the largest extent (m), used for default mesh sizes.
  double characteristic_radius_m() const;
  /// Bounding box {xmin, xmax, ymin, ymax} (m).
  std::array<double, 4> bounding_box_m() const;
  /// True when p lies strictly inside, at least `margin_m` from the outline.
  bool contains(const Point2& p, double margin_m = 0.0) const;
  /// Signed distance from p to the outline: positive inside (m).
  double inside_distance_m(const Point2& p) const;
};

struct Membrane {
  FilmOutline outline;
  double thickness_m = 25e-6;            ///< film thickness
  double pretension_N_per_m = 0.0;       ///< uniform isotropic in-plane pre-tension; < 0: slack film (docs/scene.md)
  double slack_strain = 0.0;             ///< stress-free film (1 + s) times the hole in every direction (slack)
  bool tension_field = false;            ///< wrinkling (relaxed) membrane; always on for slack films
};

/// One electrode pair (top and bottom electrode overlap): the sensing area.
struct Electrode {
  enum class Shape { rectangle, circle, polygon };
  std::string name;
  Shape shape = Shape::rectangle;
  Point2 center_m{0, 0};                 ///< rectangle and circle
  std::array<double, 2> size_m{0.002, 0.002};  ///< rectangle [width along its own x, height]
  double angle_rad = 0.0;                ///< rectangle rotation (CCW)
  double radius_m = 0.001;               ///< circle
  std::vector<Point2> vertices_m;        ///< polygon (simple, either orientation)
  /// Outline as a polygon (circles sampled with `n_circle` points).
  std::vector<Point2> outline(int n_circle = 64) const;
  /// Nominal area (exact for circles: πr²).
  double area_m2() const;
  /// Centroid of the area (m).
  Point2 centroid_m() const;
};

struct Probe {
  double radius_m = 0.001;               ///< radius of the disk over which a probe load is spread
};

/// A load: a probe press (uniform pressure on a disk, total vertical force exact), or a uniform
/// pressure over the whole film.
struct Load {
  enum class Kind { probe, pressure };
  Kind kind = Kind::probe;
  Point2 position_m{0, 0};
  double force_N = 1.0;                  ///< probe: total vertical force (positive pushes +z)
  double radius_m = 0.0;                 ///< probe: footprint radius; 0 = scene probe radius
  double pressure_Pa = 0.0;              ///< pressure: uniform over the film
};

/// Mesh options (consumed by pvdf::mesh). Zero means "derive a default from the geometry".
struct MeshOptions {
  double size_min_m = 0.0;               ///< finest element size (near electrodes, probes)
  double size_max_m = 0.0;               ///< coarsest element size (far field)
  double growth = 1.3;                   ///< size growth rate away from fine features
  int order = 1;                         ///< geometric order of boundary elements (1 or 2)
  bool embed_probes = true;              ///< make probe footprints mesh edges
  double min_scaled_jacobian = 0.2;      ///< refuse meshes whose worst element is below this
};

/// Model options (consumed by pvdf::fem).
struct ModelOptions {
  std::string kinematics = "auto";       ///< auto | linear | von-karman | large-rotation
  double tolerance = 0.01;               ///< requested relative error of the outputs
  std::string load_kind = "vertical";    ///< vertical (dead load) | follower (pressure normal to the deformed film)
  int max_refinements = 6;               ///< cap on adaptive refinement cycles
};

/// A whole sensor scene.
struct Scene {
  std::string source = "<built-in>";     ///< file the scene came from (for messages)
  Membrane membrane;
  Material material;
  std::vector<Electrode> electrodes;
  Probe probe;
  std::vector<Load> loads;
  MeshOptions mesh;
  ModelOptions model;
  std::vector<std::string> warnings;     ///< non-fatal remarks (e.g. reciprocity), printed by the app
  nlohmann::json original;               ///< the scene as read, for copying into output files
};

/// Reads and validates a scene file. Throws InputError naming file, key path, value, rule, fix.
Scene load_scene(const std::string& path);
/// Same, from parsed JSON; `source` names the input in messages.
Scene parse_scene(const nlohmann::json& json, const std::string& source);
/// The built-in default scene: the seed-001 membrane sensor (see examples/scenes/seed001.json).
Scene default_scene();
/// The built-in default scene as JSON text.
const char* default_scene_json();
/// The scene with its loads replaced by one probe of force_N at (x_m, y_m) (the scene's probe
/// radius): what a probe sweep or a map solves at each position.
Scene with_probe_load(const Scene& scene, double x_m, double y_m, double force_N);
/// Serializes a scene back to JSON (all keys, defaults filled in).
nlohmann::json scene_to_json(const Scene& scene);

/// Relative tolerance above which a tabulated nu21 that differs from nu12·E2/E1 draws a warning.
inline constexpr double reciprocity_warn_tolerance = 0.005;
/// Relative difference above which it is rejected as a likely typo.
inline constexpr double reciprocity_reject_tolerance = 0.2;

}  // namespace pvdf
