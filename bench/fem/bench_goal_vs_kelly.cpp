// bench_goal_vs_kelly — how fast the adaptive loop of pvdf::fem::solve drives the true error of the
// electrode charges down with goal-oriented (dual-weighted residual) indicators, with Kelly's
// indicators and with uniform refinement, side by side on the seed-001 scene (docs/fem.md §6.2).
//
// Every method starts from the same coarse mesh (far field a/3, probe cells 4 mm, no grading toward
// the electrodes; --start-* change it), so that the indicators have something to find: solve's own
// a-priori mesh is already within 3e-5 on the centred press. Cycle n
// of an adaptive method is the solve with max_refinements = n and a tolerance it never meets (the
// loop is deterministic, so that solve passes through cycles 0 .. n−1 exactly as a longer run does):
// its wall and CPU time are what a user pays to get that mesh's answer (cumulative over cycles).
// Uniform refinement: initial_global_refinements = n, no adaptivity.
//
// True error = max over electrodes |Q_k − Q_ref,k| / max_k |Q_ref,k| (the normalisation of
// solve's estimated_discretization_error). Reference: Richardson extrapolation of uniformly refined
// solves of a finer start mesh (electrode cells 0.5 mm, probe cells c/2), per electrode from the
// last three levels L−2, L−1, L with their observed contraction; the correction it makes to level L
// (printed) bounds its own error, since the extrapolation is closer to the limit than level L.
//
// Usage: bench_goal_vs_kelly [--scene FILE] [--cycles N] [--uniform-levels N] [--reference-level L]
//                            [--start-probe-size-m S] [--start-electrode-size-m S] [--start-grading G]
//                            [--press X_M,Y_M] ...   (default presses (0, 0) and (3, 7) mm, 1 N)
// Defaults: 8 cycles, uniform levels 0-3, reference levels 0-2 (~4 min CPU in all, docs/fem.md §6.2).
#include "pvdf/core/io.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/fem/solver.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <iostream>
#include <string>
#include <vector>

namespace {

struct Cycle {
  int n = 0;
  std::size_t dofs = 0;
  double wall_s = 0, cpu_s = 0;
  std::vector<double> charge_C;
  double estimate = 0;         // solve's estimated_discretization_error (all outputs)
  double charge_estimate = 0;  // max_k |charge estimate| / max_k |Q|
  double true_error = 0;
};

double max_abs(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

double relative_error(const std::vector<double>& q, const std::vector<double>& ref) {
  double d = 0;
  for (std::size_t k = 0; k < q.size(); ++k) d = std::max(d, std::abs(q[k] - ref[k]));
  return d / max_abs(ref);
}

Cycle run_once(const pvdf::Scene& scene, const pvdf::fem::Options& o, int n) {
  const std::clock_t c0 = std::clock();
  const auto r = pvdf::fem::solve(scene, o);
  Cycle c;
  c.cpu_s = double(std::clock() - c0) / CLOCKS_PER_SEC;
  if (!pvdf::fem::usable(r.summary.status)) {
    std::cerr << "error: solve failed at cycle " << n << ": " << r.summary.message << "\n";
    std::exit(3);
  }
  c.n = n;
  c.dofs = r.summary.n_dofs;
  c.wall_s = r.summary.wall_s;
  double est = 0;
  for (const auto& e : r.electrodes) {
    c.charge_C.push_back(e.charge_C);
    est = std::max(est, std::abs(e.charge_discretization_error_C));
  }
  c.charge_estimate = est / max_abs(c.charge_C);
  c.estimate = r.summary.estimated_discretization_error;
  return c;
}

// The reference: Richardson extrapolation of uniform refinements of a fine start mesh.
struct Reference {
  std::vector<double> charge_C;
  double self_error = 0;  // relative: the extrapolation's correction to the finest level (a bound of its error)
  std::vector<Cycle> levels;
};

Reference reference(const pvdf::Scene& scene, pvdf::fem::Options o, int top_level) {
  o.adaptive = false;
  o.probe_size_m = scene.probe.radius_m / 2;
  o.electrode_size_m = 0.5e-3;
  Reference ref;
  for (int l = std::max(0, top_level - 3); l <= top_level; ++l) {
    o.initial_global_refinements = l;
    ref.levels.push_back(run_once(scene, o, l));
  }
  // Extrapolate with the observed order of each triple (Q_{l-2}, Q_{l-1}, Q_l), per electrode.
  auto extrapolate = [&](std::size_t i) {
    if (i < 2) return ref.levels[i].charge_C;
    std::vector<double> q;
    const auto &a = ref.levels[i - 2].charge_C, &b = ref.levels[i - 1].charge_C, &c = ref.levels[i].charge_C;
    for (std::size_t k = 0; k < c.size(); ++k) {
      const double d1 = b[k] - a[k], d2 = c[k] - b[k];
      const double rho = (std::abs(d1) > 0) ? d2 / d1 : 0.0;  // error contraction per level
      q.push_back(rho > 0 && rho < 0.9 ? c[k] + d2 * rho / (1 - rho) : c[k]);
    }
    return q;
  };
  const std::size_t last = ref.levels.size() - 1;
  ref.charge_C = extrapolate(last);
  ref.self_error = relative_error(ref.levels[last].charge_C, ref.charge_C);
  return ref;
}

// First cycle whose true error is below `level`, or nullptr.
const Cycle* first_below(const std::vector<Cycle>& cycles, double level) {
  for (const auto& c : cycles)
    if (c.true_error < level) return &c;
  return nullptr;
}

}  // namespace

int main(int argc, char** argv) {
  std::string scene_path = std::string(PVDF_SOURCE_DIR) + "/examples/scenes/seed001.json";
  int max_cycles = 8, uniform_levels = 3, reference_level = 2;
  double start_probe_m = 4e-3, start_electrode_m = 0.015, start_grading = 0.8;
  std::vector<std::vector<double>> presses;
  try {  // bad numbers: one line and exit 2, not an abort
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      if (a == "--scene" && i + 1 < argc) scene_path = argv[++i];
      else if (a == "--cycles" && i + 1 < argc) max_cycles = std::stoi(argv[++i]);
      else if (a == "--uniform-levels" && i + 1 < argc) uniform_levels = std::stoi(argv[++i]);
      else if (a == "--reference-level" && i + 1 < argc) reference_level = std::stoi(argv[++i]);
      else if (a == "--start-probe-size-m" && i + 1 < argc) start_probe_m = std::stod(argv[++i]);
      else if (a == "--start-electrode-size-m" && i + 1 < argc) start_electrode_m = std::stod(argv[++i]);
      else if (a == "--start-grading" && i + 1 < argc) start_grading = std::stod(argv[++i]);
      else if (a == "--press" && i + 1 < argc) presses.push_back(pvdf::parse_number_list(argv[++i], "--press", 2));
      else {
        std::cerr << "usage: bench_goal_vs_kelly [--scene FILE] [--cycles N] [--uniform-levels N] "
                     "[--reference-level L] [--start-probe-size-m S] [--start-electrode-size-m S] "
                     "[--start-grading G] [--press X_M,Y_M] ...\n";
        return a == "--help" || a == "-h" ? 0 : 2;
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  }
  if (presses.empty()) presses = {{0.0, 0.0}, {0.003, 0.007}};
  pvdf::Scene base;
  try {
    base = pvdf::load_scene(scene_path);
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  }
  for (const auto& p : presses) {
    pvdf::Scene scene = base;
    scene.loads.resize(1);
    scene.loads[0].position_m = {p.at(0), p.at(1)};
    scene.loads[0].force_N = 1.0;
    // The model solve picks for this press at its default tolerance, then held fixed.
    pvdf::fem::Options o = pvdf::fem::options_from_scene(scene);
    const auto picked = pvdf::fem::solve(scene, o);
    std::printf("\npress (%.1f, %.1f) mm, 1 N: solve picks %s; %s\n", p[0] * 1e3, p[1] * 1e3,
                pvdf::fem::model_name(picked.summary.model).c_str(), picked.summary.model_reason.c_str());
    o.model = picked.summary.model;
    o.include_bending = picked.summary.model_reason.find("bending left out") == std::string::npos &&
                        picked.summary.model_reason.find("bending neglected") == std::string::npos;
    o.tolerance = 1e-12;
    o.coarse_size_m = scene.membrane.outline.radius_m / 3;
    o.probe_size_m = start_probe_m;
    o.electrode_size_m = start_electrode_m;
    o.grading = start_grading;

    const Reference ref = reference(scene, o, reference_level);
    std::printf("reference (bending %s): uniform levels", o.include_bending ? "kept" : "left out");
    for (const auto& l : ref.levels) std::printf(" %zu", l.dofs);
    std::printf(" DOFs; Q_ref/pC");
    for (double q : ref.charge_C) std::printf(" %.5f", q * 1e12);
    std::printf("; finest level vs extrapolation %.2e (the reference's error is below this)\n", ref.self_error);
    for (const auto& l : ref.levels)
      std::printf("  ref level %d: %7zu DOFs, error vs extrapolation %.2e, wall %.1f s\n", l.n, l.dofs,
                  relative_error(l.charge_C, ref.charge_C), l.wall_s);

    struct Method {
      const char* name;
      std::vector<Cycle> cycles;
    };
    std::vector<Method> methods = {{"goal", {}}, {"kelly", {}}, {"uniform", {}}};
    for (auto& m : methods) {
      const bool uniform = std::string(m.name) == "uniform";
      const int n_max = uniform ? uniform_levels : max_cycles;
      for (int n = 0; n <= n_max; ++n) {
        pvdf::fem::Options on = o;
        if (uniform) {
          on.adaptive = false;
          on.initial_global_refinements = n;
        } else {
          on.refinement = std::string(m.name) == "goal" ? pvdf::fem::Refinement::goal : pvdf::fem::Refinement::kelly;
          on.max_refinements = n;
        }
        Cycle c = run_once(scene, on, n);
        c.true_error = relative_error(c.charge_C, ref.charge_C);
        std::printf("  %-7s %d: %7zu DOFs  wall %6.2f s  cpu %6.2f s  Q/pC", m.name, n, c.dofs, c.wall_s, c.cpu_s);
        for (double q : c.charge_C) std::printf(" %10.5f", q * 1e12);
        std::printf("  true %.2e  charge estimate %.2e  (estimate/true %.2f)\n", c.true_error, c.charge_estimate,
                    c.charge_estimate / c.true_error);
        m.cycles.push_back(c);
        if (c.true_error < 0.2 * 1e-3 && n >= 2) break;  // both targets passed with margin
      }
    }
    std::printf("\n  press (%.1f, %.1f) mm: first cycle with true charge error below\n", p[0] * 1e3, p[1] * 1e3);
    std::printf("  %-8s | %-30s | %-30s\n", "method", "1 %: DOFs, wall s, cpu s", "0.1 %: DOFs, wall s, cpu s");
    for (const auto& m : methods) {
      std::printf("  %-8s", m.name);
      for (double level : {1e-2, 1e-3}) {
        const Cycle* c = first_below(m.cycles, level);
        if (c) std::printf(" | %8zu %8.2f %8.2f     ", c->dofs, c->wall_s, c->cpu_s);
        else std::printf(" | %-30s", "not reached");
      }
      std::printf("\n");
    }
    for (const char* other : {"kelly", "uniform"}) {
      const auto& g = methods[0].cycles;
      const auto& k = std::string(other) == "kelly" ? methods[1].cycles : methods[2].cycles;
      std::printf("  goal/%-7s", other);
      for (double level : {1e-2, 1e-3}) {
        const Cycle *a = first_below(g, level), *b = first_below(k, level);
        if (a && b)
          std::printf(" | %8.2f %8.2f %8.2f     ", double(a->dofs) / double(b->dofs), a->wall_s / b->wall_s,
                      a->cpu_s / b->cpu_s);
        else std::printf(" | %-30s", "-");
      }
      std::printf("\n");
    }
  }
  return 0;
}
