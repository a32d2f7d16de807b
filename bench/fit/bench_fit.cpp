// bench_fit: how long `pvdfkit fit` takes for 50 presses and 3 parameters (pretension_N_per_m,
// E_scale, d31_C_per_N) on the seed-001 scene, and what the same FEM work would cost as direct
// solves (the peer: one adaptive `pvdf::fem::solve` per needed solve, cold).
//
//   build/bench/fit/bench_fit [n_presses=50]
//
// Synthetic data: a known film (N0 = 10 N/m, E_scale = 0.6, d31 = 5 pC/N) solved on a finer sweep
// mesh (tolerance 0.0025) than the fit's (the scene's 0.01), 2 % Gaussian noise, seed 1.
#include "pvdf/core/scene.hpp"
#include "pvdf/fem/solver.hpp"
#include "pvdf/fit/fit.hpp"

#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>

using namespace pvdf::fit;
using Clock = std::chrono::steady_clock;

static double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
/// CPU time of this process (s): the honest measure on a shared, loaded machine.
static double cpu_s() { return double(std::clock()) / CLOCKS_PER_SEC; }

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 50;
  const pvdf::Scene scene = pvdf::load_scene(PVDF_SOURCE_DIR "/examples/scenes/seed001.json");
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-0.018, 0.018);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Press> ps;
  const double forces[] = {0.25, 0.5, 1.0};
  while (static_cast<int>(ps.size()) < n) {
    const double x = u(rng), y = u(rng);
    ps.push_back({x, y, forces[ps.size() % 3]});
  }
  const double T = 10.0, E = 0.6, d31 = 5e-12;
  PredictorOptions fine;
  fine.use_scene_model = false;
  fine.sweep.solver = pvdf::fem::options_from_scene(scene);
  fine.sweep.solver.tolerance = 0.0025;
  fine.sweep.n_setup_checks = 0;
  auto t0 = Clock::now();
  Predictor truth(scene, ps, fine);
  const auto clean = truth.predict({T, E});
  std::printf("synthetic data: %d presses on a finer mesh (%zu DOFs), %.1f s wall\n", n,
              truth.stats().reference_setup.n_dofs, since(t0));
  std::fflush(stdout);

  MeasuredTable m;
  m.source = "bench";
  const char* names[] = {"deflection_m", "charge_A_C", "charge_B_C", "charge_C_C"};
  for (int c = 0; c < 4; ++c) {
    ObservedColumn o;
    o.name = names[c];
    o.electrode = c - 1;
    o.has_sigma = true;
    m.observed.push_back(o);
  }
  for (int i = 0; i < n; ++i) {
    m.line.push_back(i + 2);
    m.x_m.push_back(ps[i].x_m);
    m.y_m.push_back(ps[i].y_m);
    m.force_N.push_back(ps[i].force_N);
    const auto q = charges_C(clean[i], truth.electrode_areas_m2(), scene.membrane.thickness_m, d31,
                             scene.material.d32_C_per_N, {1, 1, 1});
    const double v[4] = {clean[i].deflection_m, q[0], q[1], q[2]};
    for (int c = 0; c < 4; ++c) {
      const double s = 0.02 * std::abs(v[c]);
      m.observed[c].value.push_back(v[c] + s * normal(rng));
      m.observed[c].sigma.push_back(s);
    }
  }

  FitOptions fo;
  fo.parameters = {"pretension_N_per_m", "E_scale", "d31_C_per_N"};
  fo.start = {{"pretension_N_per_m", 0.0}};  // the scene's film: taut, E_scale 1, d31 6.5 pC/N
  t0 = Clock::now();
  const double c0 = cpu_s();
  const FitResult r = fit_film(scene, m, fo);
  const double fit_s = since(t0), fit_cpu = cpu_s() - c0;
  std::printf("fit: %s, %d iterations, %zu FEM solves (%.1f s), %zu sweep meshes (%.1f s incl. the reference setup), "
              "wall %.1f s, CPU %.1f s\n",
              status_name(r.status).c_str(), r.iterations, r.fem.n_solves, r.fem.solve_s, r.fem.n_sweeps, r.fem.setup_s,
              fit_s, fit_cpu);
  const double truth_values[3] = {T, E, d31};
  for (int j = 0; j < 3; ++j) {
    const auto& p = r.parameters[j];
    std::printf("  %-20s %.5g +- %.3g  (true %.5g, %+.2f sigma)\n", p.name.c_str(), p.value, p.sigma, truth_values[j],
                (p.value - truth_values[j]) / p.sigma);
  }
  std::printf("  reduced chi2 %.3f over %d degrees of freedom\n", r.reduced_chi2, r.degrees_of_freedom);

  // Peer: direct adaptive solves (cold, the scene's tolerance) at a few presses; their mean time
  // times the number of solves the fit needed.
  const int n_peer = 3;
  t0 = Clock::now();
  const double c1 = cpu_s();
  for (int i = 0; i < n_peer; ++i) {
    const auto d = pvdf::fem::solve(pvdf::with_probe_load(scene, ps[i].x_m, ps[i].y_m, ps[i].force_N),
                                    pvdf::fem::options_from_scene(scene));
    if (!pvdf::fem::usable(d.summary.status)) std::printf("  peer solve %d: %s\n", i, d.summary.message.c_str());
  }
  const double direct_s = since(t0) / n_peer, direct_cpu = (cpu_s() - c1) / n_peer;
  std::printf("peer: one direct adaptive solve %.2f s wall, %.2f s CPU; the fit's %zu solves that way: %.0f s CPU "
              "(%.1fx the fit's CPU time)\n",
              direct_s, direct_cpu, r.fem.n_solves, direct_cpu * double(r.fem.n_solves),
              direct_cpu * double(r.fem.n_solves) / fit_cpu);
  return r.status == FitStatus::converged ? 0 : 3;
}
