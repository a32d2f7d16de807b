// The charge-density atlas of a film (docs/atlas.md): one probe sweep whose presses keep, per
// square cell of a regular atlas grid, the moments ∫q dA, ∫q (x−xc) dA, ∫q (y−yc) dA of the
// piezoelectric charge density q = (d31·N11 + d32·N22)/h, so that the charge map of any electrode
// layout on that film follows by integration, without a solve. Public types are std/pvdf only.
#pragma once

#include "pvdf/core/scene.hpp"
#include "pvdf/fem/probe_sweep.hpp"

#include <array>
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

namespace pvdf::fem {

/// A regular grid of square atlas cells: cell (i, j) spans [x0 + i·a, x0 + (i+1)·a] ×
/// [y0 + j·a, y0 + (j+1)·a], a = cell_m; arrays over cells are [ny][nx] row-major.
struct AtlasGrid {
  double x0_m = 0, y0_m = 0;  ///< lower-left corner of cell (0, 0) (m)
  double cell_m = 0;          ///< side a of every cell (m)
  std::size_t nx = 0, ny = 0;
  /// Centre (xc, yc) of cell (i, j) (m).
  std::array<double, 2> centre_m(std::size_t i, std::size_t j) const {
    return {x0_m + (double(i) + 0.5) * cell_m, y0_m + (double(j) + 0.5) * cell_m};
  }
  /// The cell's square, counter-clockwise from its lower-left corner (m).
  std::array<pvdf::Point2, 4> square(std::size_t i, std::size_t j) const {
    const double x = x0_m + double(i) * cell_m, y = y0_m + double(j) * cell_m, a = cell_m;
    return {pvdf::Point2{x, y}, pvdf::Point2{x + a, y}, pvdf::Point2{x + a, y + a}, pvdf::Point2{x, y + a}};
  }
};

/// The atlas grid covering the film's bounding box with cells of side `cell_m` (m), centred on the
/// origin (so a film symmetric about the axes has a symmetric grid).
AtlasGrid atlas_grid_for(const pvdf::FilmOutline& outline, double cell_m);

/// Settings of an atlas sweep.
struct AtlasSweepOptions {
  /// Model, tolerance, Newton settings (as for any sweep); forces and rim margin as in SweepOptions.
  Options solver;
  std::vector<double> forces_N;
  double rim_margin_m = 0;
  int n_setup_checks = 3;
  /// Side of the atlas cells (m), > 0.
  double cell_m = 0.001;
  /// FE cell size over the whole film (m); 0 = min(cell_m, probe diameter) scaled with the
  /// tolerance like the sweep's own sizes (sqrt(tolerance/0.01), within [0.25, 1]).
  double fe_size_m = 0;
  /// Keep-out band along the clamp (m): the atlas serves electrodes at least this far inside the
  /// outline. The reference quadrants end there, so the per-press estimates (and the choice of the
  /// rim model) speak for the served region only; the clamp's bending layer inside the band is
  /// resolved only where a press needs the rim model. 0 = the whole film is served.
  double keep_out_m = 0.001;
};

/// One press of the atlas sweep.
struct AtlasPress {
  ProbeSolution solution;  ///< the sweep's own solution (charges and estimates of the reference electrodes)
  /// [ny][nx][3] over the atlas cells: ∫q dA (C), ∫q (x−xc) dA and ∫q (y−yc) dA (C·m), q in C/m².
  std::vector<double> moments;
};

/// A probe sweep over a film that returns the charge-density moments on an atlas grid (docs/atlas.md).
/// The scene's electrodes are replaced by `reference_electrodes` (the film cut into four quadrants,
/// which sets the FE mesh to fe_size_m over the whole film and carries the press's error estimate);
/// every probe is solved on that one mesh (no per-probe refinement: the footprint is already at
/// fe_size_m) with the `auto` rule's model, and again with the map path's rim model (bending kept,
/// mesh graded toward the clamp along the probe's sector) where the cheap model's estimate says
/// bending matters; the moments are taken on the mesh of the solution kept (docs/atlas.md §3).
/// Not thread-safe: one instance per thread.
class AtlasSweep {
 public:
  AtlasSweep(const pvdf::Scene& scene, const AtlasSweepOptions& options);
  ~AtlasSweep();
  AtlasSweep(const AtlasSweep&) = delete;
  AtlasSweep& operator=(const AtlasSweep&) = delete;

  const SweepSetup& setup() const;
  /// Why this model (the `auto` rule's reason, and bending kept with the rim grading).
  const std::string& model_reason() const;
  const AtlasGrid& grid() const;
  /// The reference electrodes (the served region's quadrants) whose charges and estimates every press carries.
  const std::vector<pvdf::Electrode>& reference_electrodes() const;
  /// [ny][nx][6] geometry of each cell ∩ FE film: ∫dA, ∫(x−xc), ∫(y−yc), ∫(x−xc)², ∫(x−xc)(y−yc), ∫(y−yc)²
  /// (m², m³, m³, m⁴, m⁴, m⁴), by the same quadrature as the moments.
  const std::vector<double>& cell_geometry() const;
  /// FE mesh size used over the film (m).
  double fe_size_m() const;
  /// The keep-out band along the clamp (m): electrodes are served at least this far inside.
  double keep_out_m() const;
  /// Cost breakdown of the sweep's solves (rim-model solves counted in it).
  SweepTiming timing() const;

  /// One press (see ProbeSweep::solve); `moments` is filled when the solution is usable.
  AtlasPress solve(double x_m, double y_m, double force_N, const SweepState* warm_start = nullptr,
                   SweepState* state_out = nullptr);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// How one electrode reads an atlas (docs/atlas.md §4): for every atlas cell its outline meets,
/// the weights w of its charge Q = Σ_cells w·m (m the cell's three moments) under the cell's linear
/// reconstruction of q, and the weight r = |P|/A of the constant reconstruction (P the electrode
/// within the cell, A the film within it). Fully covered cells have w = (1, 0, 0): exact.
struct AtlasElectrode {
  std::vector<std::size_t> cell;                ///< atlas cell index j·nx + i
  std::vector<std::array<double, 3>> weight;    ///< w, per cell
  std::vector<double> constant_weight;          ///< r, per cell
  std::vector<unsigned char> partial;           ///< 1 = the electrode covers the cell partly
  double area_m2 = 0;                           ///< Σ|P|: the outline's area within the atlas
};

/// The reading of the simple polygon `outline_m` (m, either orientation) on `grid`, whose
/// `geometry` is AtlasSweep::cell_geometry ([ny][nx][6]).
AtlasElectrode atlas_electrode(const AtlasGrid& grid, const std::vector<double>& geometry,
                               const std::vector<pvdf::Point2>& outline_m);

/// The electrode's charge from one press's moments ([ny][nx][3]) (C), and its integration-error
/// estimate (C): Σ over partly covered cells of |linear − constant reconstruction|.
void integrate_atlas_electrode(const AtlasElectrode& electrode, const double* moments, double& charge_C,
                               double& integration_error_C);

}  // namespace pvdf::fem
