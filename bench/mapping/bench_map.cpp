// Map generation speed against charge error on the seed-001 scene (45 mm film, 3 electrodes)
// at 1 mm spacing, one force level. Measures, in one run (so machine load affects all rows
// alike): per-position time of warm-started rows vs independent cold solves, the real pipeline
// (generate_map) on a two-row strip, the symmetry factor of the full grid, the force-scaling
// check error, and the charge error against a refined sweep at sample points. Projects the
// full map time; `--full` generates it for real.
//   bench_map [--full] [--threads N] [--sample N]
#include "pvdf/core/scene.hpp"
#include "pvdf/core/membrane_scaling.hpp"
#include "pvdf/fem/probe_sweep.hpp"
#include "pvdf/mapping/generate.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double relative_charge_error(const std::vector<double>& q, const std::vector<double>& reference) {
  double diff = 0, scale = 0;
  for (std::size_t k = 0; k < reference.size(); ++k) {
    diff = std::max(diff, std::abs(q[k] - reference[k]));
    scale = std::max(scale, std::abs(reference[k]));
  }
  return diff / scale;
}

// Grid counts of the full map (the command's grid: multiples of the spacing inside R - margin).
void count_grid(const pvdf::Scene& scene, double spacing, double margin, std::size_t& n_positions,
                std::size_t& n_canonical) {
  n_positions = 0;
  n_canonical = 0;
  const double R = scene.membrane.outline.radius_m;
  for (long j = -long(R / spacing) - 1; j <= long(R / spacing) + 1; ++j) {
    for (long i = -long(R / spacing) - 1; i <= long(R / spacing) + 1; ++i) {
      if (!scene.membrane.outline.contains({double(i) * spacing, double(j) * spacing}, margin)) continue;
      ++n_positions;
      if (i >= 0) ++n_canonical;  // seed 001 is mirror-symmetric about the y axis only
    }
  }
}

// The sample row solved twice: every position cold, then as the warm-started chain the generator uses.
struct RowTiming {
  std::vector<std::vector<double>> cold_q, warm_q;
  double cold_s = 0, warm_s = 0;  // per position
  double warm_vs_cold = 0;        // largest relative charge difference
};

RowTiming time_row(pvdf::fem::ProbeSweep& sweep, const std::vector<std::array<double, 2>>& row, double force) {
  RowTiming t;
  // Naive: every position cold.
  auto t0 = std::chrono::steady_clock::now();
  for (const auto& p : row) t.cold_q.push_back(sweep.solve(p[0], p[1], force).charge_C);
  t.cold_s = seconds_since(t0) / double(row.size());

  // Warm: the row chain the generator uses.
  pvdf::fem::SweepState state;
  bool have = false;
  t0 = std::chrono::steady_clock::now();
  for (const auto& p : row) {
    pvdf::fem::SweepState next;
    const auto s = sweep.solve(p[0], p[1], force, have ? &state : nullptr, &next);
    have = pvdf::fem::usable(s.status);
    if (have) state = std::move(next);
    t.warm_q.push_back(s.charge_C);
  }
  t.warm_s = seconds_since(t0) / double(row.size());
  for (std::size_t n = 0; n < row.size(); ++n) {
    if (!t.cold_q[n].empty() && !t.warm_q[n].empty())
      t.warm_vs_cold = std::max(t.warm_vs_cold, relative_charge_error(t.warm_q[n], t.cold_q[n]));
  }
  return t;
}

// Accuracy: a refined sweep (tolerance / 8) at three sample points; `reference_s` its time.
double refined_accuracy(const pvdf::Scene& scene, const pvdf::fem::SweepOptions& so, double tolerance,
                        const std::vector<std::array<double, 2>>& row, const RowTiming& timing, double force,
                        double& reference_s) {
  pvdf::fem::SweepOptions ref_options = so;
  ref_options.solver.tolerance = tolerance / 8;
  ref_options.n_setup_checks = 0;
  const auto t0 = std::chrono::steady_clock::now();
  pvdf::fem::ProbeSweep reference(scene, ref_options);
  double accuracy = 0;
  for (std::size_t n : {std::size_t(0), row.size() / 2, row.size() - 1}) {
    const auto r = reference.solve(row[n][0], row[n][1], force);
    if (pvdf::fem::usable(r.status) && !timing.warm_q[n].empty())
      accuracy = std::max(accuracy, relative_charge_error(timing.warm_q[n], r.charge_C));
  }
  reference_s = seconds_since(t0);
  return accuracy;
}

// Force scaling check at two points (0.5 N vs 1 N): what a multi-level map would gain.
double force_scaling_error(pvdf::fem::ProbeSweep& sweep, const std::vector<std::array<double, 2>>& row) {
  double scaling_error = 0;
  for (std::size_t n : {std::size_t(0), row.size() - 1}) {
    const auto a = sweep.solve(row[n][0], row[n][1], 0.5);
    const auto b = sweep.solve(row[n][0], row[n][1], 1.0);
    if (!pvdf::fem::usable(a.status) || !pvdf::fem::usable(b.status)) continue;
    std::vector<double> predicted = b.charge_C;
    for (auto& q : predicted) q *= pvdf::membrane_charge_factor(0.5);
    scaling_error = std::max(scaling_error, relative_charge_error(predicted, a.charge_C));
  }
  return scaling_error;
}

// `--full`: the whole map for real, written to bench_map_seed001_1mm.h5.
void generate_full_map(const pvdf::Scene& scene, pvdf::mapping::MapOptions mo) {
  mo.region_m.reset();
  mo.n_setup_checks = 3;
  pvdf::mapping::MapReport r;
  const auto t0 = std::chrono::steady_clock::now();
  const auto map = pvdf::mapping::generate_map(scene, mo, &r);
  const double total = seconds_since(t0);
  std::printf("FULL map: %zu positions, %zu solved, %zu mirrored, %zu failed, %.1f s (%.1f min), %.3f s/position, "
              "estimated charge error %.3g\n",
              r.n_positions, r.n_solved, r.n_mirrored, r.n_failed, total, total / 60, total / double(r.n_positions),
              r.estimated_relative_error);
  pvdf::mapping::write_generated_map("bench_map_seed001_1mm.h5", map, r.provenance);
}

}  // namespace

int main(int argc, char** argv) {
  std::setvbuf(stdout, nullptr, _IOLBF, 0);  // progress visible when redirected
  bool full = false;
  int threads = 0, sample = 10;
  for (int a = 1; a < argc; ++a) {
    if (!std::strcmp(argv[a], "--full")) full = true;
    else if (!std::strcmp(argv[a], "--threads") && a + 1 < argc) threads = std::atoi(argv[++a]);
    else if (!std::strcmp(argv[a], "--sample") && a + 1 < argc) sample = std::max(2, std::atoi(argv[++a]));
    else {
      std::fprintf(stderr, "usage: bench_map [--full] [--threads N] [--sample N]\n");
      return 2;
    }
  }
  const pvdf::Scene scene = pvdf::default_scene();  // seed 001
  const double spacing = 0.001, force = 1.0, tolerance = 0.01;
  const double margin = 2 * scene.probe.radius_m;
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  if (threads <= 0) threads = int(hw);
  std::size_t n_positions = 0, n_canonical = 0;
  count_grid(scene, spacing, margin, n_positions, n_canonical);
  const double R = scene.membrane.outline.radius_m;

  pvdf::fem::SweepOptions so;
  so.solver = pvdf::fem::options_from_scene(scene);
  so.solver.tolerance = tolerance;
  so.rim_margin_m = margin;
  so.forces_N = {force};
  auto t0 = std::chrono::steady_clock::now();
  pvdf::fem::ProbeSweep sweep(scene, so);
  const double setup_s = seconds_since(t0);
  const auto& setup = sweep.setup();
  std::printf("seed-001 scene, %zu positions at %.0f mm spacing (%zu after x -> -x symmetry), 1 force level\n",
              n_positions, spacing * 1e3, n_canonical);
  std::printf("sweep setup %.2f s: %s, %zu DOFs, estimated charge error %.3g (%s)\n", setup_s,
              pvdf::fem::model_name(setup.model).c_str(), setup.n_dofs, setup.estimated_relative_error,
              setup.error_estimator.c_str());

  // Sample row: y = 5 mm, x = 0 .. (sample-1) mm.
  std::vector<std::array<double, 2>> row;
  for (int i = 0; i < sample; ++i) row.push_back({i * spacing, 0.005});
  const RowTiming timing = time_row(sweep, row, force);
  const double cold_s = timing.cold_s, warm_s = timing.warm_s;
  std::printf("measured: cold %.3f s/position, warm rows %.3f s/position (%zu positions), warm vs cold %.2e\n", cold_s,
              warm_s, row.size(), timing.warm_vs_cold);

  double reference_s = 0;
  const double accuracy = refined_accuracy(scene, so, tolerance, row, timing, force, reference_s);
  std::printf("measured: charge error vs refined sweep %.2e (%.1f s)\n", accuracy, reference_s);
  const double scaling_error = force_scaling_error(sweep, row);

  // The real pipeline on a strip of two rows (y = 4, 5 mm), all threads.
  pvdf::mapping::MapOptions mo;
  mo.spacing_m = spacing;
  mo.placement = pvdf::mapping::Placement::uniform;  // its strip and full-map figures (docs/map-generation.md §9) are of uniform maps
  mo.forces_N = {force};
  mo.tolerance = tolerance;
  mo.region_m = std::array<double, 4>{-R, R, 0.004, 0.005};
  mo.threads = threads;
  mo.n_setup_checks = 0;
  pvdf::mapping::MapReport strip;
  t0 = std::chrono::steady_clock::now();
  pvdf::mapping::generate_map(scene, mo, &strip);
  const double strip_s = seconds_since(t0);
  const std::size_t strip_solved = strip.n_solved;
  const double strip_per_position = strip_s / double(std::max<std::size_t>(1, strip.n_positions));

  const double naive_total = setup_s + double(n_positions) * cold_s;
  const double projected = setup_s + double(n_canonical) * warm_s / threads;
  const double projected_pipeline = setup_s + strip_per_position * double(n_positions);
  std::printf("\n%-44s %10s %12s %9s %12s\n", "method (1 mm, 1 N, tolerance 0.01)", "solves", "s/position", "speed-up",
              "charge err");
  std::printf("%-44s %10zu %12.3f %9.2f %12.2e\n", "naive: every position cold, 1 thread", n_positions, cold_s, 1.0, accuracy);
  std::printf("%-44s %10zu %12.3f %9.2f %12.2e\n", "warm-started rows, 1 thread", n_positions, warm_s, cold_s / warm_s,
              accuracy);
  std::printf("%-44s %10zu %12.3f %9.2f %12.2e\n", "+ mirror symmetry (x -> -x)", n_canonical,
              warm_s * double(n_canonical) / double(n_positions), cold_s / warm_s * double(n_positions) / double(n_canonical),
              accuracy);
  std::printf("%-44s %10zu %12.3f %9.2f %12s\n", ("+ threads: generate_map strip, " + std::to_string(threads) + " threads").c_str(),
              strip_solved, strip_per_position, cold_s / strip_per_position, "same");
  std::printf("\nwarm vs cold charges differ by %.2e (relative); refined reference (tolerance %.4g) took %.1f s\n",
              timing.warm_vs_cold, tolerance / 8, reference_s);
  std::printf("force scaling Q ~ F^(2/3), 0.5 N from 1 N: worst relative error %.2e (check threshold %.3g) -> with 3 "
              "levels and a stride-4 check lattice a map solves ~%.2f x fewer points\n",
              scaling_error, tolerance / 2, 3.0 / (1.0 + 2.0 / 16.0));
  std::printf("full map: naive %.0f s (%.1f min); projected %.0f s (%.1f min) from the row timing / %d threads; "
              "%.0f s (%.1f min) from the strip pipeline\n",
              naive_total, naive_total / 60, projected, projected / 60, threads, projected_pipeline, projected_pipeline / 60);

  if (full) generate_full_map(scene, mo);
  return 0;
}
