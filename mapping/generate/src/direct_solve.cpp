// A node the sweep could not bring within the tolerance, solved again on its own adaptive mesh
// (docs/map-generation.md §9.4).
#include "generator.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/fem/solver.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <malloc.h>

namespace pvdf::mapping::detail {

// The sweep mesh is graded to the electrodes and the centre, not under every probe, and the rim
// model only toward the clamp; where a node's estimate still exceeds the tolerance, `solve`
// itself runs at this press alone, goal-oriented refinement of its own mesh until its estimate of
// every charge meets the tolerance. With the map's model `auto` it is what `pvdfkit solve` does
// by default: bending by its estimated effect, and near the clamp the clamp's bending layer as a
// boundary condition (docs/fem.md §3.4), the whole rim graded only when that condition's own
// estimate misses its share. (Until r11 bending was forced on, which grades the whole rim to the
// layer: 126 k DOFs and GBs near the clamp, 250 s per direct solve on a loaded machine.) With an
// explicit model: that kinematics with bending kept. Its result replaces the sweep's when its
// estimate is the smaller (and keeps the tolerance_not_met status when it is still above).
void Generator::improve_by_direct_solve(double x_m, double y_m, fem::ProbeSolution& s) {
  // Waits while another thread's direct solve runs (memory, not time: they are rare, and the
  // waiting thread's CPU time is not counted as solve time).
  std::unique_lock<std::mutex> one_at_a_time(direct_solve_mutex_);
  const auto t0 = std::chrono::steady_clock::now();
  fem::Options options = sweep_options_.solver;
  const bool automatic = sweep_options_.solver.model == fem::Model::automatic;
  options.model = automatic ? fem::Model::automatic : sweeps_[0]->setup().model;
  options.include_bending = true;  // with `auto`: allowed, by its estimated effect
  options.tolerance = tolerance_;
  options.adaptive = true;
  options.refinement = fem::Refinement::goal;
  options.vtu_directory.clear();
  options.sample_points_m.clear();
  options.verbose = false;
  const pvdf::Scene scene = pvdf::with_probe_load(scene_, x_m, y_m, s.force_N);
  fem::Result r;
  try {
    r = o_.mesh ? fem::solve(scene, *o_.mesh, options) : fem::solve(scene, options);
  } catch (const NumericalError&) {
    r.summary.status = fem::Status::no_convergence;
  }
  malloc_trim(0);  // its meshes, matrices and factors (GBs near the clamp) go back to the system now
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  one_at_a_time.unlock();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++direct_solves_;
    direct_s_ += seconds;
  }
  if (!fem::usable(r.summary.status) || r.electrodes.size() != s.charge_C.size() || r.loads.empty()) return;
  double q_max = 0, e_max = 0;
  for (const auto& e : r.electrodes) {
    q_max = std::max(q_max, std::abs(e.charge_C));
    e_max = std::max(e_max, e.charge_error_C);
  }
  const double estimate = q_max > 0 ? e_max / q_max : 1.0;
  if (!(estimate < s.estimated_relative_error)) return;
  const double sweep_estimate = s.estimated_relative_error;
  for (std::size_t k = 0; k < r.electrodes.size(); ++k) {
    const auto& e = r.electrodes[k];
    s.charge_C[k] = e.charge_C;
    s.charge_error_C[k] = e.charge_error_C;
    if (k < s.charge_error_discretization_C.size()) s.charge_error_discretization_C[k] = e.charge_discretization_error_C;
    if (k < s.charge_error_model_C.size()) s.charge_error_model_C[k] = e.charge_model_error_C;
  }
  s.deflection_at_load_m = r.deflection_at_load_m;
  s.deflection_error_m = r.loads.front().deflection_error_m;
  s.rim_reaction_N = r.rim_reaction_N;
  s.estimated_relative_error = estimate;
  s.model_used = direct_model;
  s.newton_iterations += r.summary.newton_iterations;
  s.status = estimate <= tolerance_ ? fem::Status::converged : fem::Status::tolerance_not_met;
  s.message = "direct adaptive solve (" + std::to_string(r.summary.n_dofs) + " DOFs, " + fem::model_name(r.summary.model) +
              ", clamp layer " + r.summary.clamp_layer + "): estimated charge error " +
              num(estimate) + " (the sweep's " + num(sweep_estimate) + ")";
}

}  // namespace pvdf::mapping::detail
