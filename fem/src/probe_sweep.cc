// ProbeSweep — first implementation: every probe solve is an independent adaptive solve of the
// scene with that one probe (no reuse, no warm start). It fixes the contract that map
// generation builds on; the reusing implementation replaces it (docs/fem.md).
#include "pvdf/fem/probe_sweep.hpp"

#include "pvdf/core/error.hpp"

#include <chrono>
#include <cmath>
#include <sstream>

namespace pvdf::fem {

struct ProbeSweep::Impl {
  pvdf::Scene scene;
  SweepOptions options;
  SweepSetup setup;
};

ProbeSweep::ProbeSweep(const pvdf::Scene& scene, const SweepOptions& options) : impl_(std::make_unique<Impl>()) {
  impl_->scene = scene;
  impl_->options = options;
  if (!(options.rim_margin_m >= 0) || !std::isfinite(options.rim_margin_m)) {
    std::ostringstream m;
    m << "probe sweep: rim margin = " << options.rim_margin_m << " m must be >= 0 and finite";
    throw pvdf::InputError(m.str());
  }
  if (impl_->options.rim_margin_m == 0) impl_->options.rim_margin_m = scene.probe.radius_m;
  impl_->setup.model = options.solver.model;
  impl_->setup.model_reason = "chosen per probe solve (independent adaptive solves)";
  impl_->setup.include_bending = options.solver.include_bending;
  impl_->setup.estimated_relative_error = options.solver.tolerance;
  impl_->setup.error_estimator = "per-solve adaptive estimate";
}

ProbeSweep::~ProbeSweep() = default;

const SweepSetup& ProbeSweep::setup() const { return impl_->setup; }

ProbeSolution ProbeSweep::solve(double x_m, double y_m, double force_N, const SweepState* /*warm_start*/,
                                SweepState* /*state_out*/) {
  const auto t0 = std::chrono::steady_clock::now();
  if (!std::isfinite(x_m) || !std::isfinite(y_m) || !(force_N > 0) || !std::isfinite(force_N)) {
    std::ostringstream m;
    m << "probe sweep: probe (" << x_m << ", " << y_m << ") m, " << force_N
      << " N: position must be finite and force > 0";
    throw pvdf::InputError(m.str());
  }
  if (!impl_->scene.membrane.outline.contains({x_m, y_m}, impl_->options.rim_margin_m)) {
    std::ostringstream m;
    m << "probe sweep: probe centre (" << x_m << ", " << y_m << ") m is not inside the film at least "
      << impl_->options.rim_margin_m << " m from the rim; choose a position inside the served region";
    throw pvdf::InputError(m.str());
  }
  pvdf::Scene scene = impl_->scene;
  pvdf::Load load;
  load.kind = pvdf::Load::Kind::probe;
  load.position_m = {x_m, y_m};
  load.force_N = force_N;
  scene.loads = {load};
  const Result r = pvdf::fem::solve(scene, impl_->options.solver);

  ProbeSolution s;
  s.status = r.summary.status;
  s.message = r.summary.message;
  s.x_m = x_m;
  s.y_m = y_m;
  s.force_N = force_N;
  s.newton_iterations = r.summary.newton_iterations;
  if (usable(s.status)) {
    s.deflection_at_load_m = r.deflection_at_load_m;
    s.rim_reaction_N = r.rim_reaction_N;
    for (const auto& e : r.electrodes) {
      s.charge_C.push_back(e.charge_C);
      s.mean_membrane_force_material_N_per_m.push_back(e.mean_membrane_force_material_N_per_m);
    }
    impl_->setup.model = r.summary.model;
    impl_->setup.model_reason = r.summary.model_reason;
    impl_->setup.n_dofs = r.summary.n_dofs;
    impl_->setup.n_cells = r.summary.n_cells;
    impl_->setup.estimated_relative_error = r.summary.estimated_relative_error;
  }
  s.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

}  // namespace pvdf::fem
