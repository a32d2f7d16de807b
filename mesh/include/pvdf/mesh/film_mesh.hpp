// The mesh handed from pvdf::mesh to pvdf::fem: a plain, deal.II-free description of a
// quadrilateral film mesh with its physical groups. The id table below is the one contract
// between the two modules (docs/mesh.md repeats it).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace pvdf::mesh {

/// Physical-group → deal.II id table.
///   cell material_id 0            : bare film (physical surface "film")
///   cell material_id k + 1        : electrode k of the scene, k = 0..n-1 (physical surface = its name)
///   cell material_id field        : probe footprints are NOT a material: they are resolved by
///                                   mesh edges only; the fem integrates loads by quadrature
///   boundary_id 0                 : clamped rim (physical curve "rim")
///   manifold_id 1                 : the rim when the outline is a circle or ellipse (exact curve)
inline constexpr std::uint8_t film_material_id = 0;
inline constexpr std::uint8_t rim_boundary_id = 0;
inline constexpr std::uint8_t rim_manifold_id = 1;
inline std::uint8_t electrode_material_id(std::size_t electrode_index) {
  return static_cast<std::uint8_t>(electrode_index + 1);
}

/// A quadrilateral film mesh in the plane z = 0.
struct FilmMesh {
  /// Vertex coordinates (m), #vertices.
  std::vector<std::array<double, 2>> vertices;
  /// Quadrilaterals as four vertex indices, counter-clockwise, #cells.
  std::vector<std::array<unsigned int, 4>> quads;
  /// deal.II material id of each quad (see the table above), #cells.
  std::vector<std::uint8_t> material_ids;
  /// Boundary edges on the clamped rim as vertex-index pairs.
  std::vector<std::array<unsigned int, 2>> rim_edges;
  /// Names of the electrodes in material-id order (material id k+1 ↔ electrode_names[k]).
  std::vector<std::string> electrode_names;

  /// Exact description of a curved rim, so refinement stays on the curve.
  enum class RimShape { polygonal, circle, ellipse };
  RimShape rim_shape = RimShape::polygonal;
  std::array<double, 2> rim_center_m{0, 0};
  double rim_radius_m = 0;                      ///< circle
  std::array<double, 2> rim_semi_axes_m{0, 0};  ///< ellipse (axis-aligned)

  std::size_t n_cells() const { return quads.size(); }
};

}  // namespace pvdf::mesh
