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

#include "film_solver.hpp"

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

// The film cut into its four quadrants (polygons: centre, then the rim from one axis to the next,
// vertices on the outline so that the chords stay inside); a non-circular film is cut by its
// bounding box's quadrants clipped nowhere (the FE integrals see only the film).
std::vector<pvdf::Electrode> quadrants(const pvdf::FilmOutline& outline) {
  std::vector<pvdf::Electrode> out;
  const int n_arc = 16;
  for (int k = 0; k < 4; ++k) {
    pvdf::Electrode e;
    e.name = "Q" + std::to_string(k + 1);
    e.shape = pvdf::Electrode::Shape::polygon;
    e.vertices_m.push_back({0.0, 0.0});
    for (int s = 0; s <= n_arc; ++s) {
      const double t = 0.5 * pvdf::pi * (k + double(s) / n_arc);
      const pvdf::Point2 dir{std::cos(t), std::sin(t)};
      // Walk out to the outline along dir (bisection on contains): the vertex on the rim.
      double lo = 0, hi = 2 * outline.characteristic_radius_m() + 1e-9;
      for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (lo + hi);
        (outline.contains({mid * dir[0], mid * dir[1]}) ? lo : hi) = mid;
      }
      e.vertices_m.push_back({lo * dir[0], lo * dir[1]});
    }
    out.push_back(std::move(e));
  }
  return out;
}

}  // namespace

struct AtlasSweep::Impl {
  pvdf::Scene scene;  // the film with the reference electrodes (outlives `copy`, which keeps a reference)
  AtlasSweepOptions options;
  AtlasGrid grid;
  std::vector<double> geometry;
  double fe_size_m = 0;
  std::unique_ptr<ProbeSweep> sweep;
  std::unique_ptr<detail::FilmSolver> copy;  // the sweep mesh again (see the file comment)
  Model model = Model::large_rotation;
  std::size_t presses = 0;
  std::string model_reason;
};

AtlasSweep::AtlasSweep(const pvdf::Scene& scene, const AtlasSweepOptions& options) : impl_(std::make_unique<Impl>()) {
  Impl& im = *impl_;
  im.options = options;
  im.grid = atlas_grid_for(scene.membrane.outline, options.cell_m);
  im.scene = scene;
  im.scene.loads.clear();
  im.scene.electrodes = quadrants(scene.membrane.outline);
  const double tolerance = options.solver.tolerance;
  const double shrink = std::clamp(std::sqrt(tolerance / 0.01), 0.25, 1.0);
  im.fe_size_m = options.fe_size_m > 0 ? options.fe_size_m
                                       : std::min(options.cell_m, 2 * scene.probe.radius_m) * shrink;
  // 1. The sweep: the whole film at the FE size (every cell lies in a quadrant), no per-probe
  // refinement (the footprint is resolved by that size already), the sweep's model only.
  SweepOptions so;
  so.solver = options.solver;
  so.forces_N = options.forces_N;
  so.rim_margin_m = options.rim_margin_m;
  so.n_setup_checks = options.n_setup_checks;
  so.region_size_m = im.fe_size_m;
  so.electrode_size_m = im.fe_size_m;
  so.grading = 1.0;
  so.probe_size_m = -1;
  so.rim_model = SweepOptions::RimModel::never;
  so.estimate_errors = true;
  // The kinematics of the `auto` rule over the force range, with bending kept at every press and the
  // mesh graded toward the whole clamp to its bending layer: the direct map's rim model, everywhere.
  const double f_min = options.forces_N.empty() ? 1.0 : *std::min_element(options.forces_N.begin(), options.forces_N.end());
  const double f_max = options.forces_N.empty() ? 1.0 : *std::max_element(options.forces_N.begin(), options.forces_N.end());
  const detail::ForceRange range{f_min, f_max};
  const detail::ModelChoice choice = detail::choose_model(im.scene, detail::with_clamp_layer_switch(options.solver), &range);
  so.solver.model = choice.model;
  so.solver.include_bending = true;
  so.sweep_rim_size_m = detail::rim_boundary_layer_m(im.scene, f_min);
  so.rim_grading = 0.5;
  im.model_reason = choice.reason + "; bending kept at every press, mesh graded toward the clamp to " +
                    std::to_string(so.sweep_rim_size_m * 1e3) + " mm";
  im.sweep = std::make_unique<ProbeSweep>(im.scene, so);
  const SweepSetup& setup = im.sweep->setup();
  im.fe_size_m = setup.electrode_size_m;  // the setup may have halved it
  im.model = setup.model;
  // 2. The copy of its mesh: SweepEngine's construction with the sizes the setup settled on.
  detail::SweepMeshSizes sizes;
  sizes.region_size_m = setup.region_size_m;
  sizes.electrode_size_m = setup.electrode_size_m;
  sizes.probe_size_m = 0;
  sizes.grading = 1.0;
  sizes.rim_size_m = so.sweep_rim_size_m;
  sizes.rim_grading = so.rim_grading;
  Options o = detail::with_clamp_layer_switch(so.solver);
  o.model = setup.model;
  o.include_bending = setup.include_bending;
  o.adaptive = false;
  o.grade_rim_for_bending = false;
  o.coarse_size_m = sizes.region_size_m;
  o.probe_size_m = sizes.region_size_m;
  o.electrode_size_m = sizes.electrode_size_m;
  o.grading = sizes.grading;
  o.initial_global_refinements = 0;
  o.sample_points_m.clear();
  o.vtu_directory.clear();
  im.copy = std::make_unique<detail::FilmSolver>(im.scene, o);
  if (!setup.include_bending) im.copy->keep_bending_pattern(false);
  im.copy->prepare_sweep(sizes, nullptr);
  if (im.copy->n_dofs() != setup.n_dofs) {
    throw std::runtime_error("atlas: the copy of the sweep mesh has " + std::to_string(im.copy->n_dofs()) +
                             " DOFs, the sweep " + std::to_string(setup.n_dofs) + " (internal error)");
  }
  im.copy->prepare_atlas(im.grid, im.geometry);
}

AtlasSweep::~AtlasSweep() = default;

const SweepSetup& AtlasSweep::setup() const { return impl_->sweep->setup(); }
const std::string& AtlasSweep::model_reason() const { return impl_->model_reason; }
const AtlasGrid& AtlasSweep::grid() const { return impl_->grid; }
const std::vector<pvdf::Electrode>& AtlasSweep::reference_electrodes() const { return impl_->scene.electrodes; }
const std::vector<double>& AtlasSweep::cell_geometry() const { return impl_->geometry; }
double AtlasSweep::fe_size_m() const { return impl_->fe_size_m; }

AtlasPress AtlasSweep::solve(double x_m, double y_m, double force_N, const SweepState* warm_start, SweepState* state_out) {
  Impl& im = *impl_;
  AtlasPress press;
  SweepState state;
  press.solution = im.sweep->solve(x_m, y_m, force_N, warm_start, &state);
  if (!usable(press.solution.status)) return press;
  dealii::Vector<double> u(state.dofs.size());
  std::copy(state.dofs.begin(), state.dofs.end(), u.begin());
  im.copy->atlas_moments(u, im.model, press.moments);
  // The copy must be the sweep's mesh: its reference charges from the same state agree (checked at
  // the first press and every 64th after it: the check costs a residual assembly).
  if (im.presses++ % 64 != 0) {
    if (state_out) *state_out = std::move(state);
    return press;
  }
  detail::EngineSolution check;
  im.copy->set_probe(x_m, y_m, force_N);
  im.copy->probe_outputs(u, im.model, check);
  double scale = 0, diff = 0;
  for (std::size_t k = 0; k < check.charge_C.size() && k < press.solution.charge_C.size(); ++k) {
    scale = std::max(scale, std::abs(press.solution.charge_C[k]));
    diff = std::max(diff, std::abs(press.solution.charge_C[k] - check.charge_C[k]));
  }
  if (!(diff <= 1e-9 * scale)) {
    throw std::runtime_error("atlas: the copy of the sweep mesh gives reference charges " + std::to_string(diff / scale) +
                             " (relative) off the sweep's (internal error)");
  }
  if (state_out) *state_out = std::move(state);
  return press;
}

}  // namespace pvdf::fem
