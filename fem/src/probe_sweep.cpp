// ProbeSweep: many single-probe solves on one fixed mesh (docs/bench-fem.md, "ProbeSweep").
// The setup picks the model (the `auto` rule, model_choice.cpp), one mesh graded to the electrodes and
// nowhere coarser than a size that serves every probe position, checks the electrode charges on
// it against direct solves at a few probe positions, and keeps DOFs, sparsity and the symbolic
// factorization. Each probe solve re-integrates the load exactly and warm-starts Newton from a
// given state (chord steps reuse the factorized tangent while Newton contracts fast).
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

/// Relative charge difference: max_k |Q_k − Q_ref,k| / max_k |Q_ref,k| (the largest electrode
/// charge sets the scale, so an electrode far from the probe does not inflate the error).
double charge_difference(const std::vector<double>& q, const std::vector<double>& ref) {
  double scale = 0, d = 0;
  for (double r : ref) scale = std::max(scale, std::abs(r));
  if (q.size() != ref.size() || !(scale > 0)) return q.size() == ref.size() ? 0.0 : 1.0;
  for (std::size_t k = 0; k < q.size(); ++k) d = std::max(d, std::abs(q[k] - ref[k]) / scale);
  return d;
}

// Step 2 of the setup: one mesh for every probe position, nowhere coarser than `region` (8 probe
// radii or a/6), electrodes at half their side, graded away from them. Measured on seed 001
// (docs/bench-fem.md): these sizes keep the charges within 0.7 % of once-refined direct solves at
// 9 probe positions on, beside, between and far from the electrodes (grading 0.5 brings that to
// 0.36 % at twice the DOFs). Smaller tolerances shrink the sizes and the grading; the setup
// check decides. Sizes given in the options win.
detail::SweepMeshSizes initial_mesh_sizes(const pvdf::Scene& scene, const SweepOptions& options) {
  const double tolerance = options.solver.tolerance;
  const double a = scene.membrane.outline.characteristic_radius_m();
  const double shrink = std::clamp(std::sqrt(tolerance / 0.01), 0.25, 1.0);
  detail::SweepMeshSizes sizes;
  sizes.region_size_m = std::min(a / 6.0, 8.0 * scene.probe.radius_m) * shrink;
  sizes.electrode_size_m = (scene.electrodes.empty() ? sizes.region_size_m : 0.5 * smallest_electrode_side(scene)) * shrink;
  sizes.grading = std::clamp(2.0 * tolerance / 0.01, 0.5, 2.0);
  if (options.region_size_m > 0) sizes.region_size_m = options.region_size_m;
  if (options.electrode_size_m > 0) sizes.electrode_size_m = options.electrode_size_m;
  if (options.grading > 0) sizes.grading = options.grading;
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

/// The sweep mesh against direct solves (pvdf::fem::solve on meshes graded to each probe) at the
/// check positions: the largest relative charge and deflection differences.
struct CheckOutcome {
  double charge_error = 0;      // max_k |dQ_k| / max_k |Q_k|, worst position
  double deflection_error = 0;  // |w/w_direct − 1|, worst position
  std::string where;            // worst position (or the failed check)
  bool failed = false;          // a check solve did not converge
};

CheckOutcome run_checks(detail::SweepEngine& engine, const pvdf::Scene& scene, const Options& solver_options,
                        Model model, bool bending, const std::vector<std::array<double, 2>>& checks, double force_N) {
  CheckOutcome c;
  for (const auto& p : checks) {
    std::vector<double> state;
    const detail::EngineSolution s = engine.solve(p[0], p[1], force_N, state, false);
    Options o = solver_options;
    o.model = model;
    o.include_bending = bending;
    o.adaptive = false;
    const Result r = pvdf::fem::solve(pvdf::with_probe_load(scene, p[0], p[1], force_N), o);
    if (!usable(s.status) || !usable(r.summary.status)) {
      c.failed = true;
      c.where = "check solve at (" + fmt(p[0]) + ", " + fmt(p[1]) + ") m did not converge";
      continue;
    }
    std::vector<double> ref;
    for (const auto& e : r.electrodes) ref.push_back(e.charge_C);
    const double d = charge_difference(s.charge_C, ref);
    if (d >= c.charge_error) {
      c.charge_error = d;
      c.where = "(" + fmt(p[0]) + ", " + fmt(p[1]) + ") m";
    }
    if (r.deflection_at_load_m != 0)
      c.deflection_error = std::max(c.deflection_error, std::abs(s.deflection_at_load_m / r.deflection_at_load_m - 1));
  }
  return c;
}

}  // namespace

struct ProbeSweep::Impl {
  pvdf::Scene scene;
  SweepOptions options;
  SweepSetup setup;
  std::unique_ptr<detail::SweepEngine> engine;
};

// Setup, in four steps: check the input; choose the model (the `auto` rule over the force
// range); size one mesh for every probe position; build it and measure its charge error against
// direct solves at a few positions, halving the sizes (at most twice) until the error meets the
// tolerance.
ProbeSweep::ProbeSweep(const pvdf::Scene& scene, const SweepOptions& options) : impl_(std::make_unique<Impl>()) {
  const auto t0 = Clock::now();
  Impl& im = *impl_;
  im.scene = scene;
  im.options = options;
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
  const Options& so = options.solver;
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

  // 2.–4. Mesh sizes, check positions, build and measure.
  detail::SweepMeshSizes sizes = initial_mesh_sizes(scene, options);
  const std::vector<std::array<double, 2>> checks =
      check_positions(scene, im.options.rim_margin_m, options.n_setup_checks);
  for (int attempt = 0;; ++attempt) {
    im.engine = std::make_unique<detail::SweepEngine>(scene, so, model, bending, sizes, options.mesh.get());
    const CheckOutcome c = run_checks(*im.engine, scene, so, model, bending, checks, f_max);
    im.setup.n_dofs = im.engine->n_dofs();
    im.setup.n_cells = im.engine->n_cells();
    if (checks.empty()) {
      im.setup.estimated_relative_error = 1.0;
      im.setup.error_estimator = "not estimated (no setup checks requested)";
      break;
    }
    // Four positions do not find the worst one: on seed 001, nine further positions against
    // once-refined direct solves peaked at 2.4x the check maximum (docs/bench-fem.md), hence the
    // factor (the checks' own references are direct solves with error <= 1.4e-3).
    constexpr double worst_case_factor = 2.5;
    im.setup.estimated_relative_error = c.failed ? 1.0 : std::min(1.0, worst_case_factor * c.charge_error);
    // The deflection under the probe is resolved far worse than the charges (the mesh is graded
    // to the electrodes, not to the probe): on seed 001 five map nodes off the checks against
    // direct adaptive solves were up to 14x the check maximum (9.4 % at (-36, 12) mm against
    // 0.67 %; docs/map-generation.md), hence its own factor.
    constexpr double deflection_worst_case_factor = 15.0;
    im.setup.estimated_deflection_relative_error =
        c.failed ? 1.0 : std::min(1.0, deflection_worst_case_factor * c.deflection_error);
    im.setup.error_estimator =
        "max over " + std::to_string(checks.size()) + " probe positions (centre, on an electrode, beside one, far) at " +
        fmt(f_max) + " N of max_k |dQ_k| / max_k |Q_k| against direct solves on meshes graded to each probe (" +
        fmt(c.charge_error) + ", worst at " + c.where + "), times " + fmt(worst_case_factor) +
        " for positions between the checks (calibrated on seed 001)" + (c.failed ? "; a check solve failed" : "");
    if ((c.charge_error <= so.tolerance && !c.failed) || attempt == 2) break;
    sizes.region_size_m *= 0.5;
    sizes.electrode_size_m *= 0.5;
  }
  im.setup.region_size_m = sizes.region_size_m;
  im.setup.electrode_size_m = sizes.electrode_size_m;
  im.setup.setup_s = seconds_since(t0);
}

ProbeSweep::~ProbeSweep() = default;

const SweepSetup& ProbeSweep::setup() const { return impl_->setup; }

SweepTiming ProbeSweep::timing() const {
  return impl_->engine->timing();
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
  std::vector<double> state;
  double state_force = 0;
  const bool warm = warm_start && !warm_start->dofs.empty() && warm_start->dofs.size() == im.setup.n_dofs;
  if (warm) {
    state = warm_start->dofs;
    state_force = warm_start->force_N;
  }
  const detail::EngineSolution e = im.engine->solve(x_m, y_m, force_N, state, warm, state_force);

  ProbeSolution s;
  s.x_m = x_m;
  s.y_m = y_m;
  s.force_N = force_N;
  s.newton_iterations = e.newton_iterations;
  s.warm_started = e.warm_started;
  s.status = e.status;
  s.message = e.message;
  if (usable(e.status)) {
    const double tol = im.options.solver.tolerance;
    if (im.options.n_setup_checks <= 0) {
      s.status = Status::converged;
      s.message = "Newton converged; no setup check requested, charge error not estimated";
    } else if (im.setup.estimated_relative_error > tol) {
      s.status = Status::tolerance_not_met;
      s.message = "Newton converged; the sweep mesh's estimated charge error " +
                  fmt(im.setup.estimated_relative_error) + " > tolerance " + fmt(tol);
    } else {
      s.status = Status::converged;
      s.message = "Newton converged; sweep mesh estimated charge error " + fmt(im.setup.estimated_relative_error);
    }
    s.deflection_at_load_m = e.deflection_at_load_m;
    s.rim_reaction_N = e.rim_reaction_N;
    s.charge_C = e.charge_C;
    s.mean_membrane_force_material_N_per_m = e.mean_membrane_force_material_N_per_m;
    if (state_out) {
      state_out->dofs = std::move(state);
      state_out->force_N = force_N;
      state_out->x_m = x_m;
      state_out->y_m = y_m;
    }
  }
  s.wall_s = seconds_since(t0);
  return s;
}

}  // namespace pvdf::fem
