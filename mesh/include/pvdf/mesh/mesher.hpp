// Meshing a sensor scene with Gmsh: geometric validation of the scene (electrodes inside the
// film, apart, not too small; probe footprints inside), size-graded all-quad meshes, quality report.
#pragma once

#include "pvdf/core/scene.hpp"
#include "pvdf/mesh/film_mesh.hpp"

#include <array>
#include <cstddef>
#include <string>
#include <vector>

namespace pvdf::mesh {

/// What the mesher produced, and how good it is.
struct MeshReport {
  std::size_t n_cells = 0;            ///< number of quadrilaterals
  std::size_t n_vertices = 0;         ///< number of vertices
  double size_min_m = 0;              ///< shortest quad edge in the mesh (m)
  double size_max_m = 0;              ///< longest quad edge in the mesh (m)
  double min_scaled_jacobian = 0;     ///< worst corner scaled Jacobian over all quads (1 = square, <= 0 = inverted)
  double max_aspect_ratio = 0;        ///< worst longest/shortest edge ratio of a quad
  double wall_s = 0;                  ///< wall time of geometry + meshing + extraction (s)
  double target_size_min_m = 0;       ///< fine size requested from Gmsh (scene or default) (m)
  double target_size_max_m = 0;       ///< coarse size requested from Gmsh (scene or default) (m)
  std::size_t n_probes_embedded = 0;  ///< probe footprints whose circles are mesh edges
  std::vector<std::string> notes;     ///< remarks, e.g. a footprint left out because it would make slivers
  std::string algorithm;              ///< Gmsh configuration that made the mesh (2-D algorithm + recombination)
  std::size_t n_attempts = 0;         ///< configurations tried (the first all-quad one above the threshold wins)
};

/// Physical-group tags in .msh files: tag = deal.II id (film_mesh.hpp) + msh_tag_offset, because
/// Gmsh reserves tag 0. Surfaces: "film" = 1, electrode k (its name) = k + 2; curves: "rim" = 1,
/// embedded probe footprint j ("probe_<j>") = msh_probe_tag_base + j.
inline constexpr int msh_tag_offset = 1;
inline constexpr int msh_probe_tag_base = 101;

/// Range of MeshParameters::size_factor (`pvdfkit mesh --size-factor`).
inline constexpr double size_factor_min = 0.01;
inline constexpr double size_factor_max = 100.0;
/// Largest mesh pvdf::mesh makes: a request estimated above it is refused before Gmsh runs
/// (exit 2), instead of exhausting memory (2e6 quadrilaterals take ~1 GB in Gmsh).
inline constexpr double max_cells = 2e6;

/// Extra knobs beyond the scene's mesh section.
struct MeshParameters {
  /// Multiplies both target sizes (size_min, size_max): 0.5 gives roughly 4× the cells. For
  /// refinement studies. Must lie in [size_factor_min, size_factor_max].
  double size_factor = 1.0;
  /// Print Gmsh's own log to stdout.
  bool verbose = false;
};

/// Fine and coarse target sizes (m) for a scene: the scene's mesh.size_min_m / size_max_m
/// where given (> 0), otherwise derived from the geometry:
///   size_min = min(probe radius / 2, smallest electrode side (or radius) / 4),
///   size_max = characteristic film radius / 8 (never below size_min).
std::array<double, 2> target_sizes_m(const pvdf::Scene& scene);

/// Checks that the scene's geometry can be meshed; throws pvdf::InputError naming the
/// electrode, load or key and the rule broken: non-positive or non-finite sizes; electrodes
/// outside the film, crossing or touching the rim (closer than the fine mesh size),
/// overlapping or touching each other, smaller than the fine mesh size, self-intersecting
/// polygons; probe footprints (load position, load radius or probe radius) partly outside
/// the film.
void validate_geometry(const pvdf::Scene& scene);

/// Validates the scene geometry (throws pvdf::InputError) and meshes it with Gmsh into quads.
/// Electrode outlines and probe footprints are mesh edges; electrode k gets material id k+1,
/// the film 0, rim edges boundary id 0 (see film_mesh.hpp).
/// `extra_probe_positions_m` lists extra probe footprints to embed (disks of the scene's probe
/// radius), in addition to the scene's loads (embedded when scene.mesh.embed_probes).
/// Throws pvdf::NumericalError when Gmsh fails or the mesh is below
/// scene.mesh.min_scaled_jacobian (the report, if given, is filled before throwing).
FilmMesh build_film_mesh(const pvdf::Scene& scene, MeshReport* report = nullptr,
                         const std::vector<std::array<double, 2>>& extra_probe_positions_m = {});
/// Same with extra parameters (size factor for refinement studies, Gmsh verbosity).
FilmMesh build_film_mesh(const pvdf::Scene& scene, const MeshParameters& parameters, MeshReport* report = nullptr,
                         const std::vector<std::array<double, 2>>& extra_probe_positions_m = {});

/// Meshes the scene and writes a Gmsh .msh (format 4.1, ASCII, metres) file atomically, with
/// physical groups "film", one per electrode (its name), "rim" (curve) and "probe_<j>" (curves)
/// tagged as above; scene.mesh.order = 2 writes 9-node quads whose rim nodes lie on the exact
/// outline. Returns the same (first-order) FilmMesh build_film_mesh gives; throws as it does.
FilmMesh write_msh(const pvdf::Scene& scene, const std::string& path, MeshReport* report = nullptr);
/// Same with extra parameters.
FilmMesh write_msh(const pvdf::Scene& scene, const std::string& path, const MeshParameters& parameters,
               MeshReport* report = nullptr);

/// Reads a .msh file written by write_msh (or any Gmsh quad mesh with the same physical-group
/// names: surface "film", one surface per electrode in tag order, curve "rim") back into a
/// FilmMesh: corner vertices only (second-order nodes dropped), quads counter-clockwise,
/// material ids and electrode names from the groups. The rim is reported as a circle when all
/// rim vertices lie on one circle about the origin (relative spread < 1e-9), else polygonal.
/// Throws pvdf::InputError naming the file when it cannot be read, has no "rim" group, or
/// holds elements other than quadrilaterals in its surfaces.
FilmMesh read_msh(const std::string& path);

/// Checks that a mesh read from `source` (a .msh file) can carry the scene's solve; throws
/// pvdf::InputError naming the file, the value and the rule: at least one quad and one rim edge; every
/// quad counter-clockwise and not degenerate (scaled Jacobian > 0); every vertex on the film (within
/// 1e-3 of its characteristic radius of the outline); the meshed area within 5 % of the outline's
/// (a mesh of another film is refused); electrode groups, when the mesh has any, named and ordered
/// as the scene's electrodes (a mesh without electrode groups is accepted: the solver integrates
/// charges over the scene's electrode outlines, not over mesh groups).
void check_mesh_fits_scene(const pvdf::Scene& scene, const FilmMesh& mesh, const std::string& source);

/// Quality of a quad mesh (fills n_cells, n_vertices, size_min/max, min scaled Jacobian, max
/// aspect ratio; leaves wall_s and target sizes alone).
void measure_quality(const FilmMesh& mesh, MeshReport& report);

/// Scaled Jacobian of a quad (vertices in order): the minimum over the four corners of
/// cross(e_next, e_prev) / (|e_next| |e_prev|); 1 for a rectangle, <= 0 for a degenerate or
/// inverted (or clockwise) quad.
double scaled_jacobian(const std::array<std::array<double, 2>, 4>& corners);

/// Area of the cells with a given material id (m²), by the shoelace formula on each quad.
double material_area_m2(const FilmMesh& mesh, std::uint8_t material_id);
/// Total length of the rim edges (m).
double rim_length_m(const FilmMesh& mesh);

/// Writes a PNG preview of the mesh: cell edges, electrodes coloured with a legend of their
/// names, probe footprints outlined, axes in mm.
void write_preview_png(const pvdf::Scene& scene, const FilmMesh& mesh, const std::string& path);

}  // namespace pvdf::mesh
