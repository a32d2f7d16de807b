// ProbeSweep: many single-probe solves on one fixed mesh (docs/bench-fem.md, "ProbeSweep";
// docs/map-generation.md §6). The setup picks the model (the `auto` rule, model_choice.cpp), one
// mesh graded to the electrodes and nowhere coarser than a size that serves every probe position,
// sized by the sweep's own error estimate at a few check positions; when that model drops bending
// it also builds the rim model (bending kept, mesh graded toward the clamped rim). Each probe solve
// runs on that mesh refined around the probe's own footprint where the mesh does not resolve it
// (sweep_engine.cpp), warm-starts Newton from a given state, and carries the solver's
// adjoint-weighted estimates of its discretization and model errors for every electrode charge;
// where the cheap model's model-error estimate exceeds its share of the tolerance the probe is
// solved again near the clamp: first with the clamp's bending layer as a boundary condition on the
// probe's own mesh (clamp_layer.cpp, docs/fem.md §3.4), and with the rim model only where that
// condition's own estimate exceeds its share of the tolerance (or it fails), as `solve` does.
#include "pvdf/core/membrane_scaling.hpp"
#include "pvdf/core/constants.hpp"
#include "pvdf/fem/probe_sweep.hpp"

#include "sweep_engine.hpp"

#include "pvdf/core/error.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

namespace pvdf::fem {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// A slack or wrinkling film (the relaxed membrane of tension_field.cpp): no per-probe refinement,
// and no rim-model fallback where its sweep model fails (ProbeSweep::solve).
bool slack_or_wrinkling(const pvdf::Membrane& m) { return m.pretension_N_per_m < 0 || m.slack_strain > 0 || m.tension_field; }

std::string fmt(double x, int precision = 3) {
  std::ostringstream os;
  os.precision(precision);
  os << x;
  return os.str();
}

double smallest_electrode_side(const pvdf::Scene& scene) {
  double side = std::numeric_limits<double>::max();
  for (const auto& e : scene.electrodes) {
    if (e.shape == pvdf::Electrode::Shape::circle) side = std::min(side, 2 * e.radius_m);
    else if (e.shape == pvdf::Electrode::Shape::rectangle) side = std::min({side, e.size_m[0], e.size_m[1]});
    else side = std::min(side, std::sqrt(e.area_m2()));
  }
  return side;
}

// Step 2 of the setup: one mesh for every probe position, nowhere coarser than `region` (8 probe
// radii or a/6), electrodes at half their side, graded away from them. Measured on seed 001
// (docs/bench-fem.md): these sizes keep the charges within 0.7 % of once-refined direct solves at
// 9 probe positions on, beside, between and far from the electrodes (grading 0.5 brings that to
// 0.36 % at twice the DOFs). Smaller tolerances shrink the sizes and the grading; the setup
// check decides. Under each probe the cells are refined to the footprint's diameter (probe_size_m):
// without it a 1 mm footprint in 7.5 mm cells left charges 1.6 % off with an estimate of 0.28 %
// (docs/map-generation.md §6). Sizes given in the options win.
detail::SweepMeshSizes initial_mesh_sizes(const pvdf::Scene& scene, const SweepOptions& options) {
  const double tolerance = options.solver.tolerance;
  const double a = scene.membrane.outline.characteristic_radius_m();
  const double shrink = std::clamp(std::sqrt(tolerance / 0.01), 0.25, 1.0);
  detail::SweepMeshSizes sizes;
  sizes.region_size_m = std::min(a / 6.0, 8.0 * scene.probe.radius_m) * shrink;
  sizes.electrode_size_m = (scene.electrodes.empty() ? sizes.region_size_m : 0.5 * smallest_electrode_side(scene)) * shrink;
  sizes.grading = std::clamp(2.0 * tolerance / 0.01, 0.5, 2.0);
  sizes.probe_size_m = 2.0 * scene.probe.radius_m * shrink;
  // Slack and wrinkling films: no per-probe refinement. Their warm starts must carry the cone the
  // film hangs in from one press to the next (the walk of walk_probe), which the round trip
  // through the sweep mesh would smooth away (measured: the walk then no longer converges).
  if (slack_or_wrinkling(scene.membrane)) sizes.probe_size_m = 0;
  if (options.probe_size_m > 0) sizes.probe_size_m = options.probe_size_m;
  if (options.probe_size_m < 0) sizes.probe_size_m = 0;
  if (options.region_size_m > 0) sizes.region_size_m = options.region_size_m;
  if (options.electrode_size_m > 0) sizes.electrode_size_m = options.electrode_size_m;
  if (options.grading > 0) sizes.grading = options.grading;
  if (options.sweep_rim_size_m > 0) {  // the whole rim (the atlas, docs/atlas.md §3)
    sizes.rim_size_m = options.sweep_rim_size_m;
    sizes.rim_grading = options.rim_grading > 0 ? options.rim_grading : 0.5;
  }
  return sizes;
}

// Step 3: check positions, each inside the served region (at least `margin` from the rim): the
// film centre, the first electrode's centre, next to the last electrode (4 probe radii beyond
// its edge, away from the centre: the probe then sits on the coarser cells between electrodes,
// where the sweep mesh's error peaks, measured), and a far point opposite the first electrode.
std::vector<std::array<double, 2>> check_positions(const pvdf::Scene& scene, double margin, int n_checks) {
  const auto& outline = scene.membrane.outline;
  std::vector<std::array<double, 2>> candidates{{0.0, 0.0}};
  std::array<double, 2> dir{0.0, -1.0};
  if (!scene.electrodes.empty()) {
    const auto c = scene.electrodes.front().center_m;
    candidates.push_back({c[0], c[1]});
    const double n = std::hypot(c[0], c[1]);
    if (n > 0) dir = {-c[0] / n, -c[1] / n};
    const auto& last = scene.electrodes.back();
    const double nl = std::hypot(last.center_m[0], last.center_m[1]);
    const std::array<double, 2> out = nl > 0 ? std::array<double, 2>{last.center_m[0] / nl, last.center_m[1] / nl}
                                             : std::array<double, 2>{1.0, 0.0};
    double half = 0;
    for (const auto& v : last.outline(16))
      half = std::max(half, std::hypot(v[0] - last.center_m[0], v[1] - last.center_m[1]));
    const double d = half + 4 * scene.probe.radius_m;
    candidates.push_back({last.center_m[0] + d * out[0], last.center_m[1] + d * out[1]});
  }
  const double reach = std::max(0.0, outline.inscribed_radius_m() - margin);
  candidates.push_back({0.7 * reach * dir[0], 0.7 * reach * dir[1]});
  std::vector<std::array<double, 2>> checks;
  for (const auto& p : candidates)
    if (outline.contains(p, margin) && static_cast<int>(checks.size()) < n_checks) checks.push_back(p);
  return checks;
}

/// Relative size of per-electrode absolute errors: max_k err_k / max_k |Q_k| (1 when Q = 0).
double relative(const std::vector<double>& err, const std::vector<double>& q) {
  double scale = 0, e = 0;
  for (double v : q) scale = std::max(scale, std::abs(v));
  for (double v : err) e = std::max(e, std::abs(v));
  return scale > 0 ? e / scale : (e > 0 ? 1.0 : 0.0);
}

}  // namespace

// t += r for the work counters of a rim engine (its rim_solves and rim_s are counted by the sweep).
static void add_timing(SweepTiming& t, const SweepTiming& r) {
  t.assembly_s += r.assembly_s;
  t.linear_solve_s += r.linear_solve_s;
  t.load_vector_s += r.load_vector_s;
  t.outputs_s += r.outputs_s;
  t.newton_iterations += r.newton_iterations;
  t.factorizations += r.factorizations;
  t.estimate_s += r.estimate_s;
  t.probe_mesh_s += r.probe_mesh_s;
}

struct ProbeSweep::Impl {
  pvdf::Scene scene;
  SweepOptions options;
  SweepSetup setup;
  std::unique_ptr<detail::SweepEngine> engine;
  // Bending kept, mesh graded toward the clamp along one sector of the rim each (built lazily).
  std::vector<std::unique_ptr<detail::SweepEngine>> rim_engines;
  // Memory bound: at most max_live_rim_engines of them are alive at once (the least recently used
  // is dropped and rebuilt when its sector is visited again). Each holds a mesh graded to the
  // bending layer, its Q(p+1) estimator space and factorizations (~0.1–0.2 GB on seed 001): kept
  // for all 16 sectors of every thread's sweep, a map's resident memory grew with the positions
  // solved (3.1 GB after 4 minutes of the 4 mm seed-001 map, 12 GiB in the README's `design`).
  // A map row visits the rim at its two ends, so two live engines serve it.
  static constexpr std::size_t max_live_rim_engines = 2;
  std::vector<int> rim_recent;  // sectors with a live engine, most recently used last
  SweepTiming retired_rim;      // timing of the rim engines already dropped
  detail::SweepMeshSizes rim_sizes;
  int sector_of(double x_m, double y_m) const;
  detail::SweepEngine& rim_engine(int sector);
  double rim_s = 0;
  int rim_solves = 0;
  double clamp_s = 0;
  int clamp_solves = 0;
  ProbeSolution from_engine(const detail::EngineSolution& e, SweepModel used) const;
  detail::EngineSolution walk_probe(double x_m, double y_m, double force_N, std::vector<double>& state, bool warm,
                                    double state_force_N, const SweepState* from);
};

// The cheap engine's solve, with a walk for slack films with the residual stiffness
// (Options::tension_field_residual_stiffness > 0): their cold solve is a long continuation (tens of
// seconds, and on a coarse sweep mesh it may not converge), and Newton from a neighbour's state fails
// when the probe moved far, because the cone a slack film hangs in moves with it. So a failed warm
// start walks the probe from the neighbour's position to this one, each step a warm Newton solve
// from the last (steps of two probe radii, doubled after a success, halved after a failure, down to
// a quarter radius); only if the walk fails is the film solved from flat. Elsewhere: one solve.
detail::EngineSolution ProbeSweep::Impl::walk_probe(double x_m, double y_m, double force_N, std::vector<double>& state,
                                                    bool warm, double state_force_N, const SweepState* from) {
  const bool slack = scene.membrane.pretension_N_per_m < 0 || scene.membrane.slack_strain > 0;
  if (!warm || !slack || !(options.solver.tension_field_residual_stiffness > 0))
    return engine->solve(x_m, y_m, force_N, state, warm, state_force_N);
  detail::EngineSolution e = engine->solve(x_m, y_m, force_N, state, true, state_force_N, false);
  if (e.status == Status::converged) return e;
  int iterations = e.newton_iterations;
  const double r = scene.probe.radius_m;
  double px = from->x_m, py = from->y_m, step = 2 * r, force = state_force_N;
  std::vector<double> walked = state;
  while (step >= 0.25 * r) {
    const double dx = x_m - px, dy = y_m - py, d = std::hypot(dx, dy);
    if (d <= 0) break;
    const double t = std::min(1.0, step / d);
    std::vector<double> trial = walked;
    e = engine->solve(px + t * dx, py + t * dy, force_N, trial, true, force, false);
    iterations += e.newton_iterations;
    if (e.status != Status::converged) {
      step = 0.5 * std::min(step, d);
      continue;
    }
    walked = std::move(trial);
    force = force_N;
    px += t * dx;
    py += t * dy;
    step *= 2;
    if (t >= 1) {
      state = std::move(walked);
      e.newton_iterations = iterations;
      e.warm_started = true;
      return e;
    }
  }
  e = engine->solve(x_m, y_m, force_N, state, false);
  e.newton_iterations += iterations;
  return e;
}

int ProbeSweep::Impl::sector_of(double x_m, double y_m) const {
  const int n = static_cast<int>(rim_engines.size());
  if (n <= 1) return 0;
  const double turn = std::atan2(y_m, x_m) / (2 * pvdf::pi);  // (-1/2, 1/2]
  return ((static_cast<int>(std::lround(turn * n)) % n) + n) % n;
}

detail::SweepEngine& ProbeSweep::Impl::rim_engine(int sector) {
  auto& e = rim_engines[static_cast<std::size_t>(sector)];
  rim_recent.erase(std::remove(rim_recent.begin(), rim_recent.end(), sector), rim_recent.end());
  rim_recent.push_back(sector);
  while (rim_recent.size() > max_live_rim_engines) {
    auto& old = rim_engines[static_cast<std::size_t>(rim_recent.front())];
    if (old) add_timing(retired_rim, old->timing());
    old.reset();
    rim_recent.erase(rim_recent.begin());
  }
  if (!e) {
    const int n = static_cast<int>(rim_engines.size());
    detail::SweepMeshSizes sizes = rim_sizes;
    sizes.rim_angle_rad = 2 * pvdf::pi * sector / std::max(1, n);
    sizes.rim_half_angle_rad = n <= 1 ? 4.0 : 1.5 * 2 * pvdf::pi / n;  // its sector and half of each neighbour, and more
    Options so = options.solver;
    e = std::make_unique<detail::SweepEngine>(scene, so, setup.model, true, sizes, true);
    if (setup.rim_n_dofs == 0) setup.rim_n_dofs = e->n_dofs();
  }
  return *e;
}

// The estimates of one engine solve: each part by magnitude, summed per electrode.
ProbeSolution ProbeSweep::Impl::from_engine(const detail::EngineSolution& e, SweepModel used) const {
  ProbeSolution s;
  s.status = e.status;
  s.message = e.message;
  s.newton_iterations = e.newton_iterations;
  s.warm_started = e.warm_started;
  s.model_used = used;
  if (!usable(e.status)) return s;
  const std::size_t ne = e.charge_C.size();
  s.charge_C = e.charge_C;
  s.deflection_at_load_m = e.deflection_at_load_m;
  s.rim_reaction_N = e.rim_reaction_N;
  s.mean_membrane_force_material_N_per_m = e.mean_membrane_force_material_N_per_m;
  if (!e.errors_estimated) {
    s.estimated_relative_error = std::numeric_limits<double>::quiet_NaN();
    return s;
  }
  s.charge_error_discretization_C.assign(ne, 0.0);
  s.charge_error_model_C.assign(ne, 0.0);
  s.charge_error_C.assign(ne, 0.0);
  for (std::size_t k = 0; k < ne; ++k) {
    if (k < e.charge_error_discretization_C.size()) s.charge_error_discretization_C[k] = std::abs(e.charge_error_discretization_C[k]);
    if (k < e.charge_error_model_C.size()) s.charge_error_model_C[k] = std::abs(e.charge_error_model_C[k]);
    s.charge_error_C[k] = s.charge_error_discretization_C[k] + s.charge_error_model_C[k];
  }
  if (e.clamp_layer && e.charge_error_clamp_layer_C.size() == ne) {  // the condition's own estimate
    s.charge_error_clamp_layer_C = e.charge_error_clamp_layer_C;
    for (std::size_t k = 0; k < ne; ++k) s.charge_error_C[k] += std::abs(e.charge_error_clamp_layer_C[k]);
    s.clamp_layer_relative_error = e.clamp_layer_relative_error;
  }
  s.estimated_relative_error = relative(s.charge_error_C, s.charge_C);
  s.deflection_error_m = std::abs(e.deflection_error_discretization_m) + std::abs(e.deflection_error_model_m);
  return s;
}


// Setup, in four steps: check the input; choose the model (the `auto` rule over the force
// range); size one mesh for every probe position; build it and measure its charge error against
// direct solves at a few positions, halving the sizes (at most twice) until the error meets the
// tolerance.
ProbeSweep::ProbeSweep(const pvdf::Scene& scene, const SweepOptions& options) : impl_(std::make_unique<Impl>()) {
  const auto t0 = Clock::now();
  Impl& im = *impl_;
  im.scene = scene;
  im.options = options;
  im.options.solver = detail::with_clamp_layer_switch(options.solver);  // PVDF_CLAMP_LAYER, as `solve`
  if (!(options.rim_margin_m >= 0) || !std::isfinite(options.rim_margin_m)) {
    throw pvdf::InputError("probe sweep: rim margin = " + fmt(options.rim_margin_m) + " m must be >= 0 and finite");
  }
  if (!(scene.probe.radius_m > 0)) {
    throw pvdf::InputError(scene.source + ": probe.radius_m = " + fmt(scene.probe.radius_m) + " must be > 0");
  }
  if (im.options.rim_margin_m < scene.probe.radius_m) im.options.rim_margin_m = scene.probe.radius_m;
  std::vector<double> forces = options.forces_N;
  if (forces.empty()) forces.push_back(scene.loads.empty() ? 1.0 : std::abs(scene.loads.front().force_N));
  for (double f : forces) {
    if (!(f > 0) || !std::isfinite(f)) {
      throw pvdf::InputError("probe sweep: force level " + fmt(f) + " N must be > 0 and finite");
    }
  }
  const double f_max = *std::max_element(forces.begin(), forces.end());
  const double f_min = *std::min_element(forces.begin(), forces.end());
  const Options& so = im.options.solver;
  if (!(so.tolerance > 0)) throw pvdf::InputError("fem options: tolerance = " + fmt(so.tolerance) + " must be > 0");

  // 1. Model: the `auto` rule over the force range (bending judged at the smallest force, where
  // its boundary layer sqrt(D/N) is widest as N ∝ F^(2/3) falls; kinematics at the largest).
  const detail::ForceRange range{f_min, f_max};
  const detail::ModelChoice choice = detail::choose_model(scene, so, &range);
  const Model model = choice.model;
  const bool bending = choice.include_bending;
  im.setup.model = model;
  im.setup.model_reason = choice.reason;
  im.setup.include_bending = bending;

  // 2.–4. Mesh sizes, check positions, build and measure: the sweep's own estimate at the check
  // positions (discretization part) sizes the mesh, halving it (at most twice) while that
  // estimate exceeds half the tolerance, the other half being the model's share.
  detail::SweepMeshSizes sizes = initial_mesh_sizes(scene, options);
  const std::vector<std::array<double, 2>> checks =
      check_positions(scene, im.options.rim_margin_m, options.n_setup_checks);
  for (int attempt = 0;; ++attempt) {
    // Estimates are needed to size the mesh (checks) and per probe (estimate_errors); without
    // either, the engine keeps no bending pattern, whose face couplings fill the tangent's factor.
    const bool estimating = options.estimate_errors || !checks.empty();
    im.engine = std::make_unique<detail::SweepEngine>(scene, so, model, bending, sizes, estimating, options.mesh.get());
    double disc = 0, total = 0, deflection = 0;
    std::string where = "none";
    bool failed = false;
    std::size_t n_checked = 0;
    for (const auto& p : checks) {
      std::vector<double> state;
      const ProbeSolution c = im.from_engine(im.engine->solve(p[0], p[1], f_max, state, false), SweepModel::cheap);
      if (options.on_setup_check) options.on_setup_check(++n_checked, checks.size());
      if (!usable(c.status)) {
        failed = true;
        where = "check solve at (" + fmt(p[0]) + ", " + fmt(p[1]) + ") m did not converge";
        continue;
      }
      const double d = relative(c.charge_error_discretization_C, c.charge_C);
      if (d >= disc) {
        disc = d;
        where = "(" + fmt(p[0]) + ", " + fmt(p[1]) + ") m";
      }
      total = std::max(total, c.estimated_relative_error);
      if (c.deflection_at_load_m != 0) deflection = std::max(deflection, c.deflection_error_m / std::abs(c.deflection_at_load_m));
    }
    im.setup.n_dofs = im.engine->n_dofs();
    im.setup.n_cells = im.engine->n_cells();
    im.setup.estimated_relative_error = checks.empty() ? 0.0 : (failed ? 1.0 : total);
    im.setup.estimated_discretization_error = checks.empty() ? 0.0 : (failed ? 1.0 : disc);
    im.setup.estimated_deflection_relative_error = checks.empty() ? 0.0 : (failed ? 1.0 : deflection);
    im.setup.error_estimator =
        "per probe: adjoint-weighted residual estimates of every electrode charge on the sweep mesh "
        "(discretization) plus, for a model that drops bending, the bending residual weighted by the same adjoint "
        "(model); setup: " + std::to_string(checks.size()) + " check positions at " + fmt(f_max) +
        " N, worst discretization estimate " + fmt(disc) + " at " + where + (failed ? "; a check solve failed" : "");
    if ((disc <= 0.5 * so.tolerance && !failed) || attempt == 2) break;
    sizes.region_size_m *= 0.5;
    sizes.electrode_size_m *= 0.5;
    sizes.probe_size_m *= 0.5;
  }
  im.setup.region_size_m = sizes.region_size_m;
  im.setup.electrode_size_m = sizes.electrode_size_m;
  im.setup.probe_size_m = sizes.probe_size_m;

  // 5. The rim model: bending kept on a mesh graded toward the clamp, for the probes where the
  // cheap model's estimate says bending matters (ProbeSweep::solve).
  if (!options.estimate_errors && !checks.empty()) {  // sized with estimates; solved without
    im.engine = std::make_unique<detail::SweepEngine>(scene, so, model, bending, sizes, false, options.mesh.get());
  }
  if (!bending && options.estimate_errors && options.rim_model != SweepOptions::RimModel::never) {
    im.rim_sizes = sizes;
    const double layer = detail::rim_boundary_layer_m(scene, f_min);
    im.rim_sizes.rim_size_m = options.rim_size_m > 0 ? options.rim_size_m : layer;
    im.rim_sizes.rim_grading = options.rim_grading > 0 ? options.rim_grading : 0.5;
    im.rim_engines.resize(static_cast<std::size_t>(std::max(1, options.rim_sectors)));
    im.setup.rim_model_available = true;
    im.setup.rim_size_m = im.rim_sizes.rim_size_m;
    im.setup.clamp_layer_condition = so.clamp_layer_condition;
  }
  im.setup.setup_s = seconds_since(t0);
}

ProbeSweep::~ProbeSweep() = default;

const SweepSetup& ProbeSweep::setup() const { return impl_->setup; }

SweepTiming ProbeSweep::timing() const {
  SweepTiming t = impl_->engine->timing();
  add_timing(t, impl_->retired_rim);
  for (const auto& engine : impl_->rim_engines)
    if (engine) add_timing(t, engine->timing());
  t.rim_solves = impl_->rim_solves;
  t.rim_s = impl_->rim_s;
  t.clamp_layer_solves = impl_->clamp_solves;
  t.clamp_layer_s = impl_->clamp_s;
  return t;
}

ProbeSolution ProbeSweep::solve(double x_m, double y_m, double force_N, const SweepState* warm_start,
                                SweepState* state_out) {
  const auto t0 = Clock::now();
  Impl& im = *impl_;
  if (!std::isfinite(x_m) || !std::isfinite(y_m) || !(force_N > 0) || !std::isfinite(force_N)) {
    std::ostringstream m;
    m << "probe sweep: probe (" << x_m << ", " << y_m << ") m, " << force_N
      << " N: position must be finite and force > 0";
    throw pvdf::InputError(m.str());
  }
  if (!im.scene.membrane.outline.contains({x_m, y_m}, im.options.rim_margin_m)) {
    std::ostringstream m;
    m << "probe sweep: probe centre (" << x_m << ", " << y_m << ") m is not inside the film at least "
      << im.options.rim_margin_m << " m from the rim; choose a position inside the served region";
    throw pvdf::InputError(m.str());
  }
  const double tol = im.options.solver.tolerance;
  std::vector<double> state;
  double state_force = 0;
  const bool warm = warm_start && !warm_start->dofs.empty() && warm_start->dofs.size() == im.setup.n_dofs;
  if (warm) {
    state = warm_start->dofs;
    state_force = warm_start->force_N;
  }
  if (warm && warm_start->fresh_history) {  // the atlas's row starts (never set by maps)
    im.engine->forget_history();
    for (auto& e : im.rim_engines)
      if (e) e->forget_history();
  }
  if (!warm) {
    // A cold solve (a map row's first) depends on nothing solved before it: no chord tangent or
    // LDLᵀ countdown from another row, so the map is bitwise the same for any thread count.
    im.engine->forget_history();
    for (auto& e : im.rim_engines)
      if (e) e->forget_history();
  }
  ProbeSolution s = im.from_engine(im.walk_probe(x_m, y_m, force_N, state, warm, state_force, warm_start), SweepModel::cheap);
  std::vector<double> rim_state;
  double rim_force = 0, rim_x = 0, rim_y = 0;
  int rim_sector = -1;
  if (warm_start && !im.rim_engines.empty() && !warm_start->rim_dofs.empty()) {
    rim_state = warm_start->rim_dofs;
    rim_force = warm_start->rim_force_N;
    rim_x = warm_start->rim_x_m;
    rim_y = warm_start->rim_y_m;
    rim_sector = warm_start->rim_sector;
  }
  // The rim model where the cheap model's estimate says bending matters: its model part above
  // half the tolerance (the discretization's share is the other half), or the total above it; and
  // where the cheap model did not converge at all. Next to the clamp a membrane without bending on
  // the sweep mesh can stall in its continuation (the atlas's outermost ring on seed 001, 2 mm FE
  // cells: "stagnated at artificial pretension 6 N/m"), where the rim model, which keeps bending and
  // resolves the clamp's layer, is the model the press needs anyway (docs/atlas.md §3). Taut films
  // only: a slack film's rim-model solve from flat can run for many minutes (docs/fem.md §3.3), so
  // its failure stays a failure.
  const bool taut = !slack_or_wrinkling(im.scene.membrane);
  const bool cheap_usable = usable(s.status);
  const std::string cheap_message = cheap_usable ? std::string() : s.message;
  const double cheap_model = cheap_usable ? relative(s.charge_error_model_C, s.charge_C) : 0.0;
  const bool bending_matters = cheap_usable && (im.options.rim_model == SweepOptions::RimModel::always ||
                                                cheap_model > 0.5 * tol || s.estimated_relative_error > tol);
  const bool want_rim = !im.rim_engines.empty() && (bending_matters || (!cheap_usable && taut));
  // First the clamp's bending layer as a boundary condition on this probe's own mesh, kept where
  // its estimate is within its share of the tolerance (3/4 of it minus bending's remaining
  // estimated effect), its Newton converged and its lagged passes settled: solve's rule
  // (docs/fem.md §3.4). Otherwise the reference path, the rim model.
  bool near_clamp_done = false;
  std::string clamp_note;
  if (want_rim && im.setup.clamp_layer_condition) {
    const auto t_clamp = Clock::now();
    const detail::EngineSolution e = im.engine->solve_clamp_layer();
    if (e.clamp_layer) {
      ++im.clamp_solves;
      ProbeSolution c = im.from_engine(e, SweepModel::clamp_layer);
      if (usable(c.status)) {
        const double remaining = relative(c.charge_error_model_C, c.charge_C);
        const double share = detail::clamp_layer_share(tol, remaining);
        if (e.clamp_layer_settled && c.clamp_layer_relative_error <= share) {
          c.cheap_model_relative_error = cheap_model;
          c.newton_iterations += s.newton_iterations;
          clamp_note = "clamp-layer condition (" + std::to_string(e.clamp_layer_passes) + " passes, l_b " +
                      fmt(e.clamp_layer_width_m * 1e3) + " mm" + (e.clamp_layer_bending ? ", bending kept" : "") +
                      "): its estimate " + fmt(c.clamp_layer_relative_error) + " <= its share " + fmt(share);
          s = std::move(c);
          near_clamp_done = true;
        } else {
          clamp_note = e.clamp_layer_settled ? "clamp-layer estimate " + fmt(c.clamp_layer_relative_error) +
                                                   " > its share " + fmt(share)
                                             : "clamp-layer passes did not settle";
        }
      } else {
        clamp_note = "clamp-layer condition did not converge (" + c.message + ")";
      }
    }
    im.clamp_s += seconds_since(t_clamp);
  }
  if (want_rim && !near_clamp_done) {
    const auto t_rim = Clock::now();
    // Warm only from a rim state converged nearby (a chain's rim probes are its row's ends).
    const double reach = 8 * im.scene.probe.radius_m;
    const int sector = im.sector_of(x_m, y_m);
    detail::SweepEngine& engine = im.rim_engine(sector);
    const bool rim_warm = !rim_state.empty() && sector == rim_sector && rim_state.size() == engine.n_dofs() &&
                          std::hypot(rim_x - x_m, rim_y - y_m) <= reach;
    std::vector<double> rs = rim_warm ? rim_state : std::vector<double>{};
    ProbeSolution r = im.from_engine(engine.solve(x_m, y_m, force_N, rs, rim_warm, rim_force), SweepModel::rim);
    ++im.rim_solves;
    im.rim_s += seconds_since(t_rim);
    if (usable(r.status)) {
      r.cheap_model_relative_error = cheap_usable ? cheap_model : std::numeric_limits<double>::quiet_NaN();
      r.newton_iterations += s.newton_iterations;
      s = std::move(r);
      rim_state = std::move(rs);
      rim_force = force_N;
      rim_x = x_m;
      rim_y = y_m;
      rim_sector = sector;
    } else if (cheap_usable) {
      s.message += "; the rim model did not converge here (" + r.message + "), the cheap model's result is kept";
    } else {
      s.message += "; the rim model did not converge either (" + r.message + ")";
    }
  }
  s.x_m = x_m;
  s.y_m = y_m;
  s.force_N = force_N;
  if (usable(s.status)) {
    const std::string which = s.model_used == SweepModel::rim           ? "rim model (bending, rim-graded mesh)"
                              : s.model_used == SweepModel::clamp_layer ? "clamp-layer condition"
                                                                         : "sweep model";
    if (s.estimated_relative_error > tol) {
      s.status = Status::tolerance_not_met;
      s.message = "Newton converged; " + which + " estimated charge error " + fmt(s.estimated_relative_error) +
                  " > tolerance " + fmt(tol);
    } else {
      s.status = Status::converged;
      s.message = std::isnan(s.estimated_relative_error)
                      ? "Newton converged; per-probe estimate off (the setup's estimate " +
                            fmt(im.setup.estimated_relative_error) + ")"
                      : "Newton converged; " + which + " estimated charge error " + fmt(s.estimated_relative_error);
    }
    if (!clamp_note.empty()) s.message += "; " + clamp_note + (s.model_used == SweepModel::rim ? ": rim model" : "");
    if (!cheap_usable) s.message += "; the sweep model did not converge here (" + cheap_message + ")";
    if (state_out) {
      // The sweep model's state: this press's, or, where the sweep model did not converge, the warm
      // start's as given (its own position and force), so that the next press starts from it.
      state_out->dofs = std::move(state);
      state_out->force_N = cheap_usable ? force_N : state_force;
      state_out->x_m = cheap_usable ? x_m : (warm ? warm_start->x_m : x_m);
      state_out->y_m = cheap_usable ? y_m : (warm ? warm_start->y_m : y_m);
      state_out->rim_dofs = std::move(rim_state);
      state_out->rim_force_N = rim_force;
      state_out->rim_x_m = rim_x;
      state_out->rim_y_m = rim_y;
      state_out->rim_sector = rim_sector;
    }
  }
  s.wall_s = seconds_since(t0);
  return s;
}

}  // namespace pvdf::fem
