// bench_rim_model — the probe sweep's two models side by side at chosen probe positions: the
// cheap model (the `auto` choice, bending dropped, sweep mesh) and the rim model (bending kept,
// mesh graded toward the clamped rim), with their estimates, cost and DOFs. With --reference
// the charges of converged direct solves with bending (e.g. `pvdfkit solve --tolerance 0.001
// --model large-rotation --json`) give each model's true error and the estimate's effectivity.
//
// Usage: bench_rim_model [--scene FILE] [--force-N F] [--rim-size-m S] [--rim-grading G]
//                        [--rim-sectors N] [--tolerance T] X_M,Y_M[,QA_C,QB_C,...] ...
#include "pvdf/core/io.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/fem/probe_sweep.hpp"
#include "pvdf/fem/solver.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;
double wall_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

double relative(const std::vector<double>& a, const std::vector<double>& ref) {
  double d = 0, scale = 0;
  for (double r : ref) scale = std::max(scale, std::abs(r));
  for (std::size_t k = 0; k < a.size() && k < ref.size(); ++k) d = std::max(d, std::abs(a[k] - ref[k]));
  return scale > 0 ? d / scale : NAN;
}

void row(const char* name, const pvdf::fem::ProbeSolution& s, const std::vector<double>& ref) {
  std::printf("  %-6s %-18s Q/pC", name, pvdf::fem::status_name(s.status).c_str());
  for (double q : s.charge_C) std::printf(" %9.4f", q * 1e12);
  double model = 0, scale = 0;
  for (std::size_t k = 0; k < s.charge_C.size(); ++k) {
    model = std::max(model, s.charge_error_model_C[k]);
    scale = std::max(scale, std::abs(s.charge_C[k]));
  }
  std::printf("  est %.3e (model %.3e)", s.estimated_relative_error, scale > 0 ? model / scale : NAN);
  if (!ref.empty() && !s.charge_C.empty()) {
    const double err = relative(s.charge_C, ref);
    std::printf("  true %.3e  eff %.2f", err, s.estimated_relative_error / err);
  }
  std::printf("  %.2f s\n", s.wall_s);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    std::string scene_path = std::string(PVDF_SOURCE_DIR) + "/examples/scenes/seed001.json";
    double force = 1.0, tolerance = 0.01;
    pvdf::fem::SweepOptions rim;
    std::vector<std::vector<double>> points;
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      if (a == "--scene" && i + 1 < argc) scene_path = argv[++i];
      else if (a == "--force-N" && i + 1 < argc) force = std::stod(argv[++i]);
      else if (a == "--tolerance" && i + 1 < argc) tolerance = std::stod(argv[++i]);
      else if (a == "--rim-size-m" && i + 1 < argc) rim.rim_size_m = std::stod(argv[++i]);
      else if (a == "--rim-grading" && i + 1 < argc) rim.rim_grading = std::stod(argv[++i]);
      else if (a == "--rim-sectors" && i + 1 < argc) rim.rim_sectors = std::stoi(argv[++i]);
      else if (a == "--help" || a == "-h") {
        std::cout << "usage: bench_rim_model [--scene FILE] [--force-N F] [--rim-size-m S] [--rim-grading G] "
                     "[--rim-sectors N] [--tolerance T] X_M,Y_M[,Q1_C,...] ...\n";
        return 0;
      } else if (!a.empty() && (std::isdigit(static_cast<unsigned char>(a[0])) || a[0] == '-' || a[0] == '.')) {
        points.push_back(pvdf::parse_number_list(a, "probe position X_M,Y_M[,Q_C...]"));
      } else {
        std::cerr << "error: unknown argument " << a << "\n";
        return 2;
      }
    }
    const pvdf::Scene scene = pvdf::load_scene(scene_path);
    rim.solver = pvdf::fem::options_from_scene(scene);
    rim.solver.model = pvdf::fem::Model::automatic;
    rim.solver.tolerance = tolerance;
    rim.forces_N = {force};
    rim.n_setup_checks = 0;
    rim.rim_model = pvdf::fem::SweepOptions::RimModel::always;
    auto t0 = Clock::now();
    pvdf::fem::ProbeSweep sweep(scene, rim);
    const auto& st = sweep.setup();
    std::printf("setup %.1f s: %s, bending %s, sweep %zu DOFs; rim cells %.3g mm, %d sectors\n", wall_since(t0),
                pvdf::fem::model_name(st.model).c_str(), st.include_bending ? "kept" : "dropped", st.n_dofs,
                st.rim_size_m * 1e3, rim.rim_sectors);
    pvdf::fem::SweepOptions cheap_options = rim;
    cheap_options.rim_model = pvdf::fem::SweepOptions::RimModel::never;
    pvdf::fem::ProbeSweep cheap(scene, cheap_options);
    for (const auto& p : points) {
      if (p.size() < 2) continue;
      const std::vector<double> ref(p.begin() + 2, p.end());
      std::printf("(%.1f, %.1f) mm\n", p[0] * 1e3, p[1] * 1e3);
      row("cheap", cheap.solve(p[0], p[1], force), ref);
      const auto t_rim = Clock::now();
      row("rim", sweep.solve(p[0], p[1], force), ref);
      std::printf("         rim mesh %zu DOFs (first built), %.1f s with the mesh build\n", sweep.setup().rim_n_dofs,
                  wall_since(t_rim));
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 2;
  }
}
