// AtlasSweep (pvdf/fem/atlas.hpp, docs/atlas.md): a ProbeSweep of the film with its electrodes
// replaced by four reference quadrants, plus a copy of the sweep mesh that turns each converged
// state into the charge-density moments of the atlas cells.
//
// Why a copy of the mesh: the sweep's engine keeps its FE objects to itself (sweep_engine.cpp); the
// state it returns (SweepState::dofs) lives on its mesh. The sweep mesh is a deterministic function
// of the scene, the options and the sizes the setup reports, so the same construction here gives
// the same mesh and DOF numbering; that is checked on every press by recomputing the reference
// electrodes' charges from the state on the copy (they must agree to 1e-9 of the largest).
#include "pvdf/fem/atlas.hpp"

#include "atlas_quadrature.hpp"
#include "probe_solver.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace pvdf::fem {

AtlasGrid atlas_grid_for(const pvdf::FilmOutline& outline, double cell_m) {
  if (!(cell_m > 0) || !std::isfinite(cell_m)) {
    std::ostringstream m;
    m << "atlas: cell size " << cell_m << " m must be > 0 and finite";
    throw pvdf::InputError(m.str());
  }
  double hx = 0, hy = 0;
  switch (outline.shape) {
    case pvdf::FilmOutline::Shape::circle: hx = hy = outline.radius_m; break;
    case pvdf::FilmOutline::Shape::rectangle: hx = outline.size_m[0] / 2; hy = outline.size_m[1] / 2; break;
    case pvdf::FilmOutline::Shape::ellipse: hx = outline.semi_axes_m[0]; hy = outline.semi_axes_m[1]; break;
    case pvdf::FilmOutline::Shape::polygon:
      for (const auto& v : outline.vertices_m) {
        hx = std::max(hx, std::abs(v[0]));
        hy = std::max(hy, std::abs(v[1]));
      }
      break;
  }
  AtlasGrid g;
  g.cell_m = cell_m;
  g.nx = std::size_t(std::ceil(2 * hx / cell_m - 1e-9));
  g.ny = std::size_t(std::ceil(2 * hy / cell_m - 1e-9));
  g.x0_m = -0.5 * double(g.nx) * cell_m;
  g.y0_m = -0.5 * double(g.ny) * cell_m;
  if (g.nx * g.ny > 4'000'000) {
    std::ostringstream m;
    m << "atlas: cell size " << cell_m << " m gives " << g.nx << " x " << g.ny << " cells, too many; use a larger one";
    throw pvdf::InputError(m.str());
  }
  return g;
}

namespace {

// The served region cut into its four quadrants (polygons: centre, then the outline shrunk by the
// keep-out band from one axis to the next, vertices on that shrunk outline so that the chords stay
// inside it); a non-circular film is cut by its bounding box's quadrants clipped nowhere (the FE
// integrals see only the film).
std::vector<pvdf::Electrode> quadrants(const pvdf::FilmOutline& outline, double keep_out_m) {
  std::vector<pvdf::Electrode> out;
  const int n_arc = 32;
  for (int k = 0; k < 4; ++k) {
    pvdf::Electrode e;
    e.name = "Q" + std::to_string(k + 1);
    e.shape = pvdf::Electrode::Shape::polygon;
    e.vertices_m.push_back({0.0, 0.0});
    for (int s = 0; s <= n_arc; ++s) {
      const double t = 0.5 * pvdf::pi * (k + double(s) / n_arc);
      const pvdf::Point2 dir{std::cos(t), std::sin(t)};
      // Walk out to the shrunk outline along dir (bisection on contains): the vertex there.
      double lo = 0, hi = 2 * outline.characteristic_radius_m() + 1e-9;
      for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (lo + hi);
        (outline.contains({mid * dir[0], mid * dir[1]}, keep_out_m) ? lo : hi) = mid;
      }
      e.vertices_m.push_back({lo * dir[0], lo * dir[1]});
    }
    out.push_back(std::move(e));
  }
  return out;
}

// The mesh SweepEngine builds for (sizes, bending) again, and the atlas quadrature on it: the
// construction of sweep_engine.cpp's constructor, so that the DOF numbering is the engine's
// (checked by the caller).
struct MeshCopy {
  std::unique_ptr<detail::ProbeSolver> solver;
  std::unique_ptr<detail::AtlasQuadrature> atlas;  // on solver's mesh: dropped before it
  void reset() {
    atlas.reset();
    solver.reset();
  }
};

MeshCopy engine_mesh_copy(const pvdf::Scene& scene, const Options& solver, Model model, bool include_bending,
                          const detail::SweepMeshSizes& sizes, const AtlasGrid& grid, std::vector<double>& geometry) {
  MeshCopy copy;
  // an estimating engine without bending keeps the bending pattern (its DOF coupling) as well
  copy.solver = std::make_unique<detail::ProbeSolver>(
      scene, detail::engine_solver_options(solver, model, include_bending, sizes), sizes, !include_bending);
  copy.atlas = std::make_unique<detail::AtlasQuadrature>(copy.solver->film(), grid, geometry);
  return copy;
}

}  // namespace

struct AtlasSweep::Impl {
  pvdf::Scene scene;  // the film with the reference electrodes (outlives the copies, which keep a reference)
  AtlasSweepOptions options;
  AtlasGrid grid;
  std::vector<double> geometry;
  double fe_size_m = 0;
  std::unique_ptr<ProbeSweep> sweep;
  Options solver;  // the options the sweep's engines were built with
  MeshCopy copy;  // the sweep mesh again (see the file comment)
  // The rim model's meshes again, one per rim sector, built when a press first needs it; at most
  // two alive (as the sweep's own rim engines), the least recently used dropped.
  detail::SweepMeshSizes rim_sizes;
  int rim_sectors = 16;
  std::vector<MeshCopy> rim_copies;
  std::vector<bool> rim_checked;  // the sector's copy has passed its first identity check
  std::vector<int> rim_recent;
  MeshCopy& rim_copy(int sector, std::size_t expected_dofs);
  Model model = Model::large_rotation;
  std::size_t presses = 0;
  std::string model_reason;
};

MeshCopy& AtlasSweep::Impl::rim_copy(int sector, std::size_t expected_dofs) {
  if (sector < 0 || sector >= rim_sectors) throw std::runtime_error("atlas: rim sector " + std::to_string(sector) + " out of range (internal error)");
  auto& c = rim_copies[std::size_t(sector)];
  rim_recent.erase(std::remove(rim_recent.begin(), rim_recent.end(), sector), rim_recent.end());
  rim_recent.push_back(sector);
  while (rim_recent.size() > 2) {
    rim_copies[std::size_t(rim_recent.front())].reset();
    rim_recent.erase(rim_recent.begin());
  }
  if (!c.solver) {
    detail::SweepMeshSizes sizes = rim_sizes;  // ProbeSweep::Impl::rim_engine's sector arc
    sizes.rim_angle_rad = 2 * pvdf::pi * sector / std::max(1, rim_sectors);
    sizes.rim_half_angle_rad = rim_sectors <= 1 ? 4.0 : 1.5 * 2 * pvdf::pi / rim_sectors;
    std::vector<double> geometry;
    c = engine_mesh_copy(scene, solver, model, true, sizes, grid, geometry);
  }
  if (c.solver->n_dofs() != expected_dofs) {
    throw std::runtime_error("atlas: the copy of the rim mesh of sector " + std::to_string(sector) + " has " +
                             std::to_string(c.solver->n_dofs()) + " DOFs, the rim model's state " +
                             std::to_string(expected_dofs) + " (internal error)");
  }
  return c;
}

AtlasSweep::AtlasSweep(const pvdf::Scene& scene, const AtlasSweepOptions& options) : impl_(std::make_unique<Impl>()) {
  Impl& im = *impl_;
  im.options = options;
  im.grid = atlas_grid_for(scene.membrane.outline, options.cell_m);
  if (!(options.keep_out_m >= 0) || !std::isfinite(options.keep_out_m) ||
      !scene.membrane.outline.contains({0.0, 0.0}, options.keep_out_m + 2 * scene.probe.radius_m)) {
    std::ostringstream m;
    m << "atlas: keep-out band " << options.keep_out_m << " m must be >= 0 and leave the film centre served";
    throw pvdf::InputError(m.str());
  }
  im.scene = scene;
  im.scene.loads.clear();
  im.scene.electrodes = quadrants(scene.membrane.outline, options.keep_out_m);
  const double tolerance = options.solver.tolerance;
  const double shrink = std::clamp(std::sqrt(tolerance / 0.01), 0.25, 1.0);
  im.fe_size_m = options.fe_size_m > 0 ? options.fe_size_m
                                       : std::min(options.cell_m, 2 * scene.probe.radius_m) * shrink;
  // 1. The sweep: the whole film at the FE size (every cell of the served region lies in a
  // quadrant), no per-probe refinement (the footprint is resolved by that size already), the
  // `auto` rule's model, and the map path's rim model (bending kept, mesh graded toward the clamp
  // along the probe's sector) where the cheap model's estimate says bending matters for the
  // quadrants. No clamp-layer condition: its state is not returned, so its density could not be
  // integrated.
  SweepOptions so;
  so.solver = options.solver;
  so.solver.clamp_layer_condition = false;
  so.forces_N = options.forces_N;
  so.rim_margin_m = options.rim_margin_m;
  so.n_setup_checks = options.n_setup_checks;
  so.region_size_m = im.fe_size_m;
  so.electrode_size_m = im.fe_size_m;
  so.grading = 1.0;
  so.probe_size_m = -1;
  so.rim_model = SweepOptions::RimModel::by_estimate;
  so.rim_grading = 0.5;
  so.rim_sectors = im.rim_sectors;
  so.estimate_errors = true;
  im.sweep = std::make_unique<ProbeSweep>(im.scene, so);
  const SweepSetup& setup = im.sweep->setup();
  im.fe_size_m = setup.electrode_size_m;  // the setup may have halved it
  im.model = setup.model;
  im.solver = detail::with_clamp_layer_switch(so.solver);
  std::ostringstream reason;
  reason << setup.model_reason;
  if (setup.rim_model_available)
    reason << "; the rim model (bending kept, mesh graded to " << setup.rim_size_m * 1e3
           << " mm along the probe's sector of the clamp) where the estimate says bending matters";
  if (options.keep_out_m > 0) reason << "; served region: " << options.keep_out_m * 1e3 << " mm inside the clamp";
  im.model_reason = reason.str();
  // 2. The copy of its mesh: SweepEngine's construction with the sizes the setup settled on.
  detail::SweepMeshSizes sizes;
  sizes.region_size_m = setup.region_size_m;
  sizes.electrode_size_m = setup.electrode_size_m;
  sizes.probe_size_m = 0;
  sizes.grading = 1.0;
  im.copy = engine_mesh_copy(im.scene, im.solver, setup.model, setup.include_bending, sizes, im.grid, im.geometry);
  if (im.copy.solver->n_dofs() != setup.n_dofs) {
    throw std::runtime_error("atlas: the copy of the sweep mesh has " + std::to_string(im.copy.solver->n_dofs()) +
                             " DOFs, the sweep " + std::to_string(setup.n_dofs) + " (internal error)");
  }
  if (setup.rim_model_available) {
    im.rim_sizes = sizes;
    im.rim_sizes.rim_size_m = setup.rim_size_m;
    im.rim_sizes.rim_grading = so.rim_grading;
    im.rim_copies.resize(std::size_t(im.rim_sectors));
    im.rim_checked.assign(std::size_t(im.rim_sectors), false);
  }
}

AtlasSweep::~AtlasSweep() = default;

const SweepSetup& AtlasSweep::setup() const { return impl_->sweep->setup(); }
SweepTiming AtlasSweep::timing() const { return impl_->sweep->timing(); }
const std::string& AtlasSweep::model_reason() const { return impl_->model_reason; }
const AtlasGrid& AtlasSweep::grid() const { return impl_->grid; }
const std::vector<pvdf::Electrode>& AtlasSweep::reference_electrodes() const { return impl_->scene.electrodes; }
const std::vector<double>& AtlasSweep::cell_geometry() const { return impl_->geometry; }
double AtlasSweep::fe_size_m() const { return impl_->fe_size_m; }
double AtlasSweep::keep_out_m() const { return impl_->options.keep_out_m; }

AtlasPress AtlasSweep::solve(double x_m, double y_m, double force_N, const SweepState* warm_start, SweepState* state_out) {
  Impl& im = *impl_;
  AtlasPress press;
  SweepState state;
  press.solution = im.sweep->solve(x_m, y_m, force_N, warm_start, &state);
  if (!usable(press.solution.status)) return press;
  // The moments of the solution kept: the cheap model's on the sweep mesh, or the rim model's on
  // its sector's mesh (the state's rim part, which the sweep sets when the rim model solved it).
  MeshCopy* on = &im.copy;
  const std::vector<double>* dofs = &state.dofs;
  Model model = im.model;
  bool check = im.presses++ % 64 == 0;
  if (press.solution.model_used == SweepModel::rim) {
    dofs = &state.rim_dofs;
    on = &im.rim_copy(state.rim_sector, state.rim_dofs.size());
    if (!im.rim_checked[std::size_t(state.rim_sector)]) check = true;
    im.rim_checked[std::size_t(state.rim_sector)] = true;
  } else if (press.solution.model_used != SweepModel::cheap) {
    throw std::runtime_error("atlas: a press solved by a model the atlas cannot integrate (internal error)");
  }
  dealii::Vector<double> u(dofs->size());
  std::copy(dofs->begin(), dofs->end(), u.begin());
  on->atlas->moments(u, model, press.moments);
  // The copy must be the solver's mesh: its reference charges from the same state agree (checked at
  // the first press, every 64th after it and the first press on each rim sector's copy: the check
  // costs a residual assembly).
  if (check) {
    detail::EngineSolution again;
    on->solver->set_probe(x_m, y_m, force_N);
    on->solver->outputs(u, model, again);
    double scale = 0, diff = 0;
    for (std::size_t k = 0; k < again.charge_C.size() && k < press.solution.charge_C.size(); ++k) {
      scale = std::max(scale, std::abs(press.solution.charge_C[k]));
      diff = std::max(diff, std::abs(press.solution.charge_C[k] - again.charge_C[k]));
    }
    if (!(diff <= 1e-9 * scale)) {
      throw std::runtime_error("atlas: the copy of the solver's mesh gives reference charges " + std::to_string(diff / scale) +
                               " (relative) off the sweep's (internal error)");
    }
  }
  if (state_out) *state_out = std::move(state);
  return press;
}

}  // namespace pvdf::fem
