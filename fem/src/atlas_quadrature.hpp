// Internal to pvdf::fem: AtlasQuadrature, the quadrature of every FE cell ∩ atlas cell on the mesh
// of one FilmSolver (docs/atlas.md §3), and the charge-density moments of the atlas cells at a
// state on that mesh. Used by AtlasSweep (atlas_sweep.cpp) on its copies of the sweep mesh;
// implemented in atlas_quadrature.cpp (a friend of FilmSolver: it reads the solver's mesh, finite
// element and membrane law).
#pragma once

#include "pvdf/fem/atlas.hpp"

#include "film_solver.hpp"

#include <memory>
#include <vector>

namespace pvdf::fem::detail {

class AtlasQuadrature {
 public:
  /// Builds, once for the current mesh of `solver` (which must outlive this object and keep its
  /// mesh), the quadrature of every FE cell ∩ atlas cell (the exact intersection of the cell's
  /// straight-sided quadrilateral with the atlas square, electrode_cells.hpp) and returns the
  /// geometry of each atlas cell ∩ film, [ny][nx][6]: ∫dA, ∫dx, ∫dy, ∫dx², ∫dx·dy, ∫dy² with
  /// (dx, dy) = (x − xc, y − yc).
  AtlasQuadrature(const FilmSolver& solver, const AtlasGrid& grid, std::vector<double>& geometry);
  /// [ny][nx][3]: ∫q dA, ∫q·dx dA, ∫q·dy dA at the state u of `model`, q = charge density (C/m²).
  void moments(const Vector<double>& u, Model model, std::vector<double>& moments) const;

 private:
  // Per FE cell, its points (unit cell) with their weight (m²), atlas cell index and offsets from
  // that cell's centre (m).
  struct CellPoints {
    DoFHandler<dim>::active_cell_iterator cell;
    std::unique_ptr<dealii::FEValues<dim>> values;
    std::vector<double> jxw, dx, dy;
    std::vector<std::size_t> atlas_cell;
  };
  const FilmSolver& solver_;
  std::vector<CellPoints> points_;
  std::size_t n_cells_ = 0;
};

}  // namespace pvdf::fem::detail
