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
  double residual_stiffness = 0;                            ///< ε of the tension-field law (fixed.solver)
  /// Per worker thread (a sweep is not shared between threads), by N0/E_scale (N/m).
  std::vector<std::map<double, std::unique_ptr<fem::ProbeSweep>>> sweeps = std::vector<std::map<double, std::unique_ptr<fem::ProbeSweep>>>(1);
  std::vector<fem::SweepState> warm;                        ///< last converged state of each press
  std::vector<double> areas_m2;
  PredictorStats stats;

  /// Worker `worker`'s sweep at this pre-tension, prepared if new; the one at `keep` (if any) is
  /// never evicted. Called from one thread at a time.
  fem::ProbeSweep& sweep(std::size_t worker, double tension_N_per_m, double keep = std::numeric_limits<double>::quiet_NaN()) {
    if (sweeps.size() <= worker) sweeps.resize(worker + 1);
    auto& cache = sweeps[worker];
    auto it = cache.find(tension_N_per_m);
    if (it != cache.end()) return *it->second;
    // Keep a few: the current point, its difference partner and the previous point.
    while (cache.size() >= 4) {
      auto far = cache.end();
      for (auto j = cache.begin(); j != cache.end(); ++j) {
        if (j->first == keep) continue;
        if (far == cache.end() || std::abs(j->first - tension_N_per_m) > std::abs(far->first - tension_N_per_m)) far = j;
      }
      cache.erase(far);
    }
    const auto t0 = Clock::now();
    pvdf::Scene s = scene;
    s.membrane.pretension_N_per_m = tension_N_per_m;
    auto sw = std::make_unique<fem::ProbeSweep>(s, fixed);
    stats.setup_s += seconds_since(t0);
    ++stats.n_sweeps;
    return *cache.emplace(tension_N_per_m, std::move(sw)).first->second;
  }

  /// One probe solve of press i in base units (E_scale = 1): deflection and press-caused mean
  /// forces, from `start` (empty: the flat film), the converged state into `out`; `st`: where its
  /// cost is counted (each thread has its own).
  void solve(fem::ProbeSweep& sw, double tension, std::size_t i, double force_N, double& w,
             std::vector<std::array<double, 2>>& n, const fem::SweepState* start, fem::SweepState& out,
             PredictorStats& st) const {
    const auto t0 = Clock::now();
    const Press& p = presses[i];
    fem::SweepState next;
    const fem::ProbeSolution s = sw.solve(p.x_m, p.y_m, force_N, start, &next);
    st.solve_s += seconds_since(t0);
    ++st.n_solves;
    if (!fem::usable(s.status)) {
      std::ostringstream m;
      m << "FEM solve of the press at (" << p.x_m * 1e3 << ", " << p.y_m * 1e3 << ") mm under " << force_N
        << " N (base-material units), pre-tension " << tension << " N/m did not converge: " << fem::status_name(s.status)
        << " (" << s.message << ")";
      throw pvdf::NumericalError(m.str());
    }
    out = std::move(next);
    w = s.deflection_at_load_m;
    n.resize(s.mean_membrane_force_material_N_per_m.size());
    for (std::size_t k = 0; k < n.size(); ++k) {
      // The isotropic pre-tension is (N0, N0, 0) in any axes; the amplifier sees only the change. A
      // slack film (N0 < 0) is stress-free when flat under the exact relaxed law; with the residual
      // stiffness ε its flat state keeps ε·C·e0 = ε·N0·I (all of it slack), which is removed too.
      const double flat = tension >= 0 ? tension : residual_stiffness * tension;
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
  const double eps = ref.solver.tension_field_residual_stiffness;
  if (!(eps >= 0 && eps < 1)) {
    std::ostringstream m;
    m << "fit: residual stiffness " << eps << " must be in [0, 1) (0 = the exact relaxed law; 1e-3 converges on strongly slack films)";
    throw pvdf::InputError(m.str());
  }
  im.residual_stiffness = eps;
  im.stats.residual_stiffness = eps;
  if (eps > 0) {
    // Slack films with the residual stiffness converge with bending kept (docs/fem.md §3.3): the
    // auto rule, which would drop it for a thin film, is not asked.
    ref.solver.include_bending = true;
    if (ref.solver.model == fem::Model::automatic) ref.solver.model = fem::Model::large_rotation;
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
  im.sweeps[0].emplace(scene.membrane.pretension_N_per_m, std::move(first));
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
  // The presses are split between (at most) two worker threads, each with its own sweeps at τ and
  // τ + h_τ (prepared here, one thread at a time). Per press: the base solve from its last state
  // (kept: the next evaluation is near it), then the force and pre-tension differences, each
  // warm-started from the base solve just made.
  const std::size_t workers = im.options.parallel && std::thread::hardware_concurrency() > 1 && n > 1 ? 2 : 1;
  std::vector<fem::ProbeSweep*> base(workers), shifted(workers, nullptr);
  for (std::size_t t = 0; t < workers; ++t) {
    base[t] = &im.sweep(t, tau);
    if (want_tau) shifted[t] = &im.sweep(t, tau + h_tau, tau);
  }
  std::vector<PredictorStats> stats(workers);
  // With the residual stiffness (slack films), a press never solved before starts from the nearest
  // press solved so far (the sweep walks the probe from there: a slack film's cold solve is long),
  // copied before the workers start; the first press of the first evaluation is solved alone first.
  const bool seed_nearest = im.residual_stiffness > 0;
  std::vector<fem::SweepState> seeds(n);
  auto make_seeds = [&] {
    for (std::size_t i = 0; i < n; ++i) {
      if (!im.warm[i].dofs.empty()) continue;
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t j = 0; j < n; ++j) {
        if (im.warm[j].dofs.empty()) continue;
        const double d = std::hypot(im.presses[j].x_m - im.presses[i].x_m, im.presses[j].y_m - im.presses[i].y_m);
        if (d < best) {
          best = d;
          seeds[i] = im.warm[j];
        }
      }
    }
  };
  auto work = [&](std::size_t t, std::size_t lo, std::size_t hi) {
    for (std::size_t i = lo; i < hi; ++i) {
      const double f = im.presses[i].force_N / E;
      // A press never solved before starts from the previous press of this worker (a neighbour,
      // usually closer than the flat film), as map generation does.
      const fem::SweepState* start = &im.warm[i];
      if (seed_nearest) {
        if (im.warm[i].dofs.empty() && !seeds[i].dofs.empty()) start = &seeds[i];
      } else if (im.warm[i].dofs.empty() && i > lo && !im.warm[i - 1].dofs.empty()) {
        start = &im.warm[i - 1];
      }
      fem::SweepState solved, scratch;
      im.solve(*base[t], tau, i, f, w0[i], n0[i], start, solved, stats[t]);
      im.warm[i] = std::move(solved);
      tick();
      if (want_f) {
        im.solve(*base[t], tau, i, f * (1 + h_f), wf[i], nf[i], &im.warm[i], scratch, stats[t]);
        tick();
      }
      if (want_tau) {
        im.solve(*shifted[t], tau + h_tau, i, f, wt[i], nt[i], &im.warm[i], scratch, stats[t]);
        tick();
      }
    }
  };
  std::size_t first = 0;
  if (seed_nearest) {
    const bool none = std::all_of(im.warm.begin(), im.warm.end(), [](const fem::SweepState& w) { return w.dofs.empty(); });
    if (none) {
      work(0, 0, 1);
      first = 1;
    }
    make_seeds();
  }
  const std::size_t split = workers == 2 ? first + (n - first) / 2 : n;
  std::future<void> second;
  if (workers == 2) second = std::async(std::launch::async, work, std::size_t(1), split, n);
  try {
    work(0, first, split);
  } catch (...) {
    if (second.valid()) second.wait();  // never leave the thread running on a sweep we may free
    throw;
  }
  if (second.valid()) second.get();  // rethrows the worker's exception
  for (const auto& st : stats) {
    im.stats.n_solves += st.n_solves;
    im.stats.solve_s += st.solve_s;
  }

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
