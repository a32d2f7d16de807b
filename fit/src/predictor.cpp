// Predictor: FEM responses of a list of presses as functions of (N0, E_scale), by warm-started
// probe solves on sweeps of the scene's own material (see the exact rescaling in predictor.hpp).
#include "pvdf/fit/predictor.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/piezo.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <limits>
#include <mutex>
#include <thread>
#include <sstream>

namespace pvdf::fit {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

}  // namespace

struct Predictor::Impl {
  pvdf::Scene scene;
  std::vector<Press> presses;
  PredictorOptions options;
  fem::SweepOptions fixed;                                  ///< model and mesh frozen after the reference setup
  std::map<double, std::unique_ptr<fem::ProbeSweep>> sweeps;  ///< by N0/E_scale (N/m)
  std::vector<fem::SweepState> warm;                        ///< last converged state of each press
  std::vector<double> areas_m2;
  PredictorStats stats;

  /// The sweep at this pre-tension, prepared if new; the one at `keep` (if any) is never evicted.
  fem::ProbeSweep& sweep(double tension_N_per_m, double keep = std::numeric_limits<double>::quiet_NaN()) {
    auto it = sweeps.find(tension_N_per_m);
    if (it != sweeps.end()) return *it->second;
    // Keep a few: the current point, its difference partner and the previous point.
    while (sweeps.size() >= 4) {
      auto far = sweeps.end();
      for (auto j = sweeps.begin(); j != sweeps.end(); ++j) {
        if (j->first == keep) continue;
        if (far == sweeps.end() || std::abs(j->first - tension_N_per_m) > std::abs(far->first - tension_N_per_m)) far = j;
      }
      sweeps.erase(far);
    }
    const auto t0 = Clock::now();
    pvdf::Scene s = scene;
    s.membrane.pretension_N_per_m = tension_N_per_m;
    auto sw = std::make_unique<fem::ProbeSweep>(s, fixed);
    stats.setup_s += seconds_since(t0);
    ++stats.n_sweeps;
    return *sweeps.emplace(tension_N_per_m, std::move(sw)).first->second;
  }

  /// One probe solve in base units (E_scale = 1): deflection and press-caused mean forces.
  /// `states`: the warm starts this pass reads and updates; `st`: where its cost is counted (each
  /// thread has its own of both).
  void solve(fem::ProbeSweep& sw, double tension, std::size_t i, double force_N, double& w,
             std::vector<std::array<double, 2>>& n, std::vector<fem::SweepState>& states, PredictorStats& st) const {
    const auto t0 = Clock::now();
    const Press& p = presses[i];
    fem::SweepState out;
    // A press never solved before starts from the previous press's state (a neighbour, usually
    // closer than the flat film), as map generation does.
    const fem::SweepState* start = &states[i];
    if (states[i].dofs.empty() && i > 0 && !states[i - 1].dofs.empty()) start = &states[i - 1];
    const fem::ProbeSolution s = sw.solve(p.x_m, p.y_m, force_N, start, &out);
    st.solve_s += seconds_since(t0);
    ++st.n_solves;
    if (!fem::usable(s.status)) {
      std::ostringstream m;
      m << "FEM solve of the press at (" << p.x_m * 1e3 << ", " << p.y_m * 1e3 << ") mm under " << force_N
        << " N (base-material units), pre-tension " << tension << " N/m did not converge: " << fem::status_name(s.status)
        << " (" << s.message << ")";
      throw pvdf::NumericalError(m.str());
    }
    states[i] = std::move(out);
    w = s.deflection_at_load_m;
    n.resize(s.mean_membrane_force_material_N_per_m.size());
    for (std::size_t k = 0; k < n.size(); ++k) {
      // The isotropic pre-tension is (N0, N0, 0) in any axes; the amplifier sees only the change. A
      // slack film (N0 < 0) is stress-free when flat (tension-field membrane): nothing to remove.
      const double flat = std::max(tension, 0.0);
      n[k] = {s.mean_membrane_force_material_N_per_m[k][0] - flat, s.mean_membrane_force_material_N_per_m[k][1] - flat};
    }
  }
};

Predictor::Predictor(const pvdf::Scene& scene, std::vector<Press> presses, const PredictorOptions& options)
    : impl_(std::make_unique<Impl>()) {
  Impl& im = *impl_;
  im.scene = scene;
  im.presses = std::move(presses);
  im.options = options;
  if (im.presses.empty()) throw pvdf::InputError("fit: no presses to predict");
  for (const auto& e : scene.electrodes) im.areas_m2.push_back(e.area_m2());
  im.warm.resize(im.presses.size());

  fem::SweepOptions ref = options.sweep;
  if (options.use_scene_model) {
    const fem::Options from_scene = fem::options_from_scene(scene);
    ref.solver.model = from_scene.model;
    ref.solver.tolerance = from_scene.tolerance;
  }
  if (ref.forces_N.empty()) {
    for (const auto& p : im.presses) ref.forces_N.push_back(p.force_N);
    std::sort(ref.forces_N.begin(), ref.forces_N.end());
    ref.forces_N.erase(std::unique(ref.forces_N.begin(), ref.forces_N.end()), ref.forces_N.end());
  }
  // The fit solves the same presses many times: no per-probe estimates and no rim model (a second,
  // rim-graded mesh with bending); the fit's model and mesh are the reference setup's, whose
  // estimate is reported.
  ref.estimate_errors = false;
  // The grading the sweep would choose, made explicit so that later sweeps build the same mesh.
  if (!(ref.grading > 0)) ref.grading = std::clamp(2.0 * ref.solver.tolerance / 0.01, 0.5, 2.0);
  const auto t0 = Clock::now();
  auto first = std::make_unique<fem::ProbeSweep>(scene, ref);
  im.stats.setup_s += seconds_since(t0);
  im.stats.n_sweeps = 1;
  im.stats.reference_setup = first->setup();

  im.fixed = ref;
  im.fixed.solver.model = first->setup().model;
  im.fixed.solver.include_bending = first->setup().include_bending;
  im.fixed.region_size_m = first->setup().region_size_m;
  im.fixed.electrode_size_m = first->setup().electrode_size_m;
  im.fixed.n_setup_checks = 0;
  im.sweeps.emplace(scene.membrane.pretension_N_per_m, std::move(first));
}

Predictor::~Predictor() = default;

const std::vector<Press>& Predictor::presses() const { return impl_->presses; }
const pvdf::Scene& Predictor::scene() const { return impl_->scene; }
const std::vector<double>& Predictor::electrode_areas_m2() const { return impl_->areas_m2; }
PredictorStats Predictor::stats() const { return impl_->stats; }

std::vector<PressResponse> Predictor::predict(const FilmState& state, std::array<bool, 2> derivatives) {
  Impl& im = *impl_;
  const double E = state.E_scale, T = state.pretension_N_per_m;
  if (!(E > 0) || !std::isfinite(E)) {
    throw pvdf::NumericalError("fit: E_scale = " + std::to_string(E) + " is not a positive finite stiffness factor");
  }
  if (!std::isfinite(T)) throw pvdf::NumericalError("fit: pretension_N_per_m = " + std::to_string(T) + " is not finite");
  const double tau = T / E;
  const bool want_f = derivatives[1];
  const bool want_tau = derivatives[0] || (derivatives[1] && tau != 0);
  const double h_f = im.options.relative_step;
  const double h_tau = im.options.relative_step * std::max(std::abs(tau), im.options.pretension_floor_N_per_m);
  const std::size_t n = im.presses.size();
  const std::size_t planned = n * (1 + (want_f ? 1 : 0) + (want_tau ? 1 : 0));
  std::size_t done = 0;
  std::mutex tick_mutex;
  auto tick = [&] {
    const std::lock_guard<std::mutex> lock(tick_mutex);
    ++done;
    if (im.options.progress) im.options.progress(done, planned);
  };

  std::vector<PressResponse> out(n);
  std::vector<double> w0(n), wf(n), wt(n);
  std::vector<std::vector<std::array<double, 2>>> n0(n), nf(n), nt(n);
  // Both sweeps first (the sweep cache is not shared between threads), then the pre-tension pass
  // on its own sweep and its own copy of the warm states, beside the base and force passes; the
  // warm states kept are the base point's (the next evaluation is near it).
  fem::ProbeSweep& base = im.sweep(tau);
  fem::ProbeSweep* shifted = want_tau ? &im.sweep(tau + h_tau, tau) : nullptr;
  std::vector<fem::SweepState> tau_states;
  PredictorStats tau_stats;
  auto tau_pass = [&] {
    for (std::size_t i = 0; i < n; ++i) {
      im.solve(*shifted, tau + h_tau, i, im.presses[i].force_N / E, wt[i], nt[i], tau_states, tau_stats);
      tick();
    }
  };
  std::future<void> tau_job;
  if (want_tau) {
    tau_states = im.warm;
    if (im.options.parallel && std::thread::hardware_concurrency() > 1) tau_job = std::async(std::launch::async, tau_pass);
  }
  try {
    for (std::size_t i = 0; i < n; ++i) {
      im.solve(base, tau, i, im.presses[i].force_N / E, w0[i], n0[i], im.warm, im.stats);
      tick();
    }
    // Force difference on the same sweep, warm-started from the point just solved (a copy of the
    // states, so that the base point's are kept).
    if (want_f) {
      std::vector<fem::SweepState> f_states = im.warm;
      for (std::size_t i = 0; i < n; ++i) {
        im.solve(base, tau, i, im.presses[i].force_N / E * (1 + h_f), wf[i], nf[i], f_states, im.stats);
        tick();
      }
    }
  } catch (...) {
    if (tau_job.valid()) tau_job.wait();  // never leave the thread running on a sweep we may free
    throw;
  }
  if (tau_job.valid()) tau_job.get();  // rethrows the pass's exception
  else if (want_tau) tau_pass();
  im.stats.n_solves += tau_stats.n_solves;
  im.stats.solve_s += tau_stats.solve_s;

  for (std::size_t i = 0; i < n; ++i) {
    PressResponse& r = out[i];
    const double f = im.presses[i].force_N / E;
    const std::size_t ne = n0[i].size();
    r.deflection_m = w0[i];
    r.force_basis_N_per_m.resize(ne);
    for (std::size_t k = 0; k < ne; ++k) r.force_basis_N_per_m[k] = {E * n0[i][k][0], E * n0[i][k][1]};
    // Base-unit partials: dw/dτ, dw/df, dn/dτ, dn/df (one-sided differences).
    const double dw_dtau = want_tau ? (wt[i] - w0[i]) / h_tau : 0.0;
    const double dw_df = want_f ? (wf[i] - w0[i]) / (h_f * f) : 0.0;
    if (derivatives[0]) {
      r.d_deflection[0] = dw_dtau / E;
      r.d_force_basis[0].resize(ne);
      for (std::size_t k = 0; k < ne; ++k)
        for (int c = 0; c < 2; ++c) r.d_force_basis[0][k][c] = (nt[i][k][c] - n0[i][k][c]) / h_tau;
    }
    if (derivatives[1]) {
      // w(E, T) = w(τ, f), τ = T/E, f = F/E;  N = E·n(τ, f).
      r.d_deflection[1] = -(tau * dw_dtau + f * dw_df) / E;
      r.d_force_basis[1].resize(ne);
      for (std::size_t k = 0; k < ne; ++k) {
        for (int c = 0; c < 2; ++c) {
          const double dn_dtau = want_tau ? (nt[i][k][c] - n0[i][k][c]) / h_tau : 0.0;
          const double dn_df = (nf[i][k][c] - n0[i][k][c]) / (h_f * f);
          r.d_force_basis[1][k][c] = n0[i][k][c] - tau * dn_dtau - f * dn_df;
        }
      }
    }
  }
  return out;
}

std::vector<double> charges_C(const PressResponse& response, const std::vector<double>& areas_m2, double thickness_m,
                              double d31_C_per_N, double d32_C_per_N, const std::vector<double>& gains) {
  std::vector<double> q(response.force_basis_N_per_m.size());
  for (std::size_t k = 0; k < q.size(); ++k) {
    const auto& b = response.force_basis_N_per_m[k];
    q[k] = gains[k] * pvdf::piezo_charge_C(areas_m2[k], b[0], b[1], thickness_m, d31_C_per_N, d32_C_per_N);
  }
  return q;
}

}  // namespace pvdf::fit
