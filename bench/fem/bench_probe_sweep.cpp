// bench_probe_sweep — cost per probe position of pvdf::fem::ProbeSweep (one fixed mesh, kept
// factorization pattern, warm starts, chord steps) against the naive path (an independent
// pvdf::fem::solve per position), on the seed-001 scene at 1 N, one thread. Prints one table:
// path, positions, wall and CPU time per position, Newton iterations and factorizations per
// position, charge difference against direct solves; then the projected time of the seed-001 1 mm map
// (seed 001, 1 mm spacing, ~5000 positions, one force, 2 cores).
//
// Usage: bench_probe_sweep [--scene FILE] [--patch N] [--spacing-m S]
//   --patch N     warm-started raster of N x N positions (serpentine, default 8)
//   --spacing-m S raster spacing (default 0.001)
#include "pvdf/core/scene.hpp"
#include "pvdf/fem/probe_sweep.hpp"
#include "pvdf/fem/solver.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <iostream>
#include <string>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;

double cpu_s() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }
double wall_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }


double charge_difference(const std::vector<double>& a, const std::vector<double>& ref) {
  double d = 0, scale = 0;
  for (double r : ref) scale = std::max(scale, std::abs(r));
  for (std::size_t k = 0; k < a.size() && k < ref.size(); ++k) d = std::max(d, std::abs(a[k] - ref[k]));
  return scale > 0 ? d / scale : NAN;
}

struct Line {
  std::string path;
  int n = 0;
  double wall = 0, cpu = 0, its = 0, facts = 0, err = NAN;
};

// 2. Naive: an adaptive direct solve per position, and a direct solve on a mesh graded to the
// probe (no adaptivity); the latter's charges are the references of the charge differences.
void naive_lines(const pvdf::Scene& scene, const std::vector<std::array<double, 2>>& probes, double F,
                 std::vector<Line>& lines, std::vector<std::vector<double>>& ref_charges) {
  for (const bool adaptive : {true, false}) {
    Line l;
    l.path = adaptive ? "naive: adaptive solve() per position" : "direct solve() on a mesh graded to the probe";
    for (const auto& p : probes) {
      pvdf::fem::Options o = pvdf::fem::options_from_scene(scene);
      o.adaptive = adaptive;
      const double c0 = cpu_s();
      const auto t0 = Clock::now();
      const auto r = pvdf::fem::solve(pvdf::with_probe_load(scene, p[0], p[1], F), o);
      l.wall += wall_since(t0);
      l.cpu += cpu_s() - c0;
      l.its += r.summary.newton_iterations;
      ++l.n;
      if (!adaptive) {
        std::vector<double> q;
        for (const auto& e : r.electrodes) q.push_back(e.charge_C);
        ref_charges.push_back(q);
      }
    }
    lines.push_back(l);
  }
}

// 3. Sweep, cold (continuation from the flat film) at the same positions.
Line sweep_cold_line(pvdf::fem::ProbeSweep& sweep, const std::vector<std::array<double, 2>>& probes, double F,
                     const std::vector<std::vector<double>>& ref_charges) {
  Line l;
  l.path = "ProbeSweep cold (from flat)";
  l.err = 0;
  for (std::size_t i = 0; i < probes.size(); ++i) {
    const auto before = sweep.timing();
    const double c0 = cpu_s();
    const auto s = sweep.solve(probes[i][0], probes[i][1], F);
    l.cpu += cpu_s() - c0;
    l.wall += s.wall_s;
    l.its += s.newton_iterations;
    l.facts += sweep.timing().factorizations - before.factorizations;
    l.err = std::max(l.err, charge_difference(s.charge_C, ref_charges[i]));
    ++l.n;
  }
  return l;
}

// 4. Sweep, warm: serpentine raster, each position from its neighbour; `states` gets every usable state.
Line sweep_warm_line(pvdf::fem::ProbeSweep& sweep, int patch, double spacing, double F,
                     std::vector<pvdf::fem::SweepState>& states) {
  Line l;
  l.path = "ProbeSweep warm (neighbour 1 grid step away)";
  pvdf::fem::SweepState state;
  bool first = true;
  for (int j = 0; j < patch; ++j)
    for (int k = 0; k < patch; ++k) {
      const int i = j % 2 == 0 ? k : patch - 1 - k;
      const double x = -0.5 * (patch - 1) * spacing + i * spacing, y = -0.5 * (patch - 1) * spacing + j * spacing;
      const auto before = sweep.timing();
      const double c0 = cpu_s();
      pvdf::fem::SweepState out;
      const auto s = sweep.solve(x, y, F, first ? nullptr : &state, &out);
      const double c = cpu_s() - c0;
      if (!pvdf::fem::usable(s.status)) {
        std::printf("  position (%g, %g): %s\n", x, y, s.message.c_str());
        first = true;
        continue;
      }
      states.push_back(out);
      state = out;
      if (first) {  // the raster's first position is a cold solve
        first = false;
        continue;
      }
      l.cpu += c;
      l.wall += s.wall_s;
      l.its += s.newton_iterations;
      l.facts += sweep.timing().factorizations - before.factorizations;
      ++l.n;
    }
  return l;
}

// The same raster at 0.5 N, each warm-started from its own 1 N state scaled by the membrane law.
Line force_scaled_line(pvdf::fem::ProbeSweep& sweep, std::vector<pvdf::fem::SweepState>& states) {
  Line l;
  l.path = "ProbeSweep 0.5 N from its 1 N state (force scaling)";
  for (std::size_t i = 0; i < states.size() && i < 16; ++i) {
    const auto before = sweep.timing();
    const double c0 = cpu_s();
    const auto s = sweep.solve(states[i].x_m, states[i].y_m, 0.5, &states[i]);
    l.cpu += cpu_s() - c0;
    l.wall += s.wall_s;
    l.its += s.newton_iterations;
    l.facts += sweep.timing().factorizations - before.factorizations;
    ++l.n;
  }
  return l;
}

// The table, the projected map time and the time split of the sweep.
void print_results(const std::vector<Line>& lines, const pvdf::fem::ProbeSweep& sweep) {
  std::printf("\n| path | positions | wall s / position | CPU s / position | Newton its / position | "
              "factorizations / position | charge diff. vs direct |\n|---|---:|---:|---:|---:|---:|---:|\n");
  for (const Line& l : lines) {
    const double n = std::max(1, l.n);
    std::printf("| %s | %d | %.3f | %.3f | %.1f | %s | %s |\n", l.path.c_str(), l.n, l.wall / n, l.cpu / n, l.its / n,
                l.facts > 0 ? std::to_string(l.facts / n).substr(0, 4).c_str() : "—",
                std::isfinite(l.err) ? (std::to_string(l.err).substr(0, 8)).c_str() : "—");
  }
  const Line& warm = lines[3];
  const double per = warm.cpu / std::max(1, warm.n);
  std::printf("\nprojected map (seed 001, 1 mm spacing, ~5000 positions, 1 force, 2 cores): %.0f s of CPU "
              "per core, %.0f s with the mirror symmetry (plus setup %.0f s)\n",
              5000 * per / 2, 2500 * per / 2, sweep.setup().setup_s);
  const auto t = sweep.timing();
  std::printf("time split over all sweep solves: assembly %.2f s, linear solves %.2f s, load vectors %.2f s, "
              "outputs %.2f s; %d Newton iterations, %d factorizations\n",
              t.assembly_s, t.linear_solve_s, t.load_vector_s, t.outputs_s, t.newton_iterations, t.factorizations);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    std::string scene_path = std::string(PVDF_SOURCE_DIR) + "/examples/scenes/seed001.json";
    int patch = 8;
    double spacing = 1e-3;
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      if (a == "--scene" && i + 1 < argc) scene_path = argv[++i];
      else if (a == "--patch" && i + 1 < argc) patch = std::stoi(argv[++i]);
      else if (a == "--spacing-m" && i + 1 < argc) spacing = std::stod(argv[++i]);
      else if (a == "--help" || a == "-h") {
        std::cout << "usage: bench_probe_sweep [--scene FILE] [--patch N] [--spacing-m S]\n";
        return 0;
      } else {
        std::cerr << "error: bench_probe_sweep: unknown argument '" << a << "'; see --help\n";
        return 2;
      }
    }
    const pvdf::Scene scene = pvdf::load_scene(scene_path);
    const double F = 1.0;
    std::vector<Line> lines;

    // 1. Setup.
    const double c0 = cpu_s();
    const auto t0 = Clock::now();
    pvdf::fem::ProbeSweep sweep(scene, pvdf::fem::SweepOptions{});
    const auto& st = sweep.setup();
    std::printf("setup: %.2f s wall, %.2f s CPU; %zu DOFs, %zu cells; model %s (%s)\n  estimated charge error %.2e, "
                "deflection %.2e: %s\n",
                wall_since(t0), cpu_s() - c0, st.n_dofs, st.n_cells, pvdf::fem::model_name(st.model).c_str(),
                st.model_reason.c_str(), st.estimated_relative_error, st.estimated_deflection_relative_error,
                st.error_estimator.c_str());

    const std::vector<std::array<double, 2>> probes{{0.003, 0.004}, {-0.012, -0.009}};
    std::vector<std::vector<double>> ref_charges;
    naive_lines(scene, probes, F, lines, ref_charges);
    lines.push_back(sweep_cold_line(sweep, probes, F, ref_charges));
    std::vector<pvdf::fem::SweepState> states;
    lines.push_back(sweep_warm_line(sweep, patch, spacing, F, states));
    lines.push_back(force_scaled_line(sweep, states));
    print_results(lines, sweep);
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
