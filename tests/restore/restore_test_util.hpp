// Shared helpers of the restore tests: the seed-000 identification pair and edge/texture measurements.
#pragma once

#include "pvdf/restore/apply.hpp"
#include "pvdf/restore/filter.hpp"
#include "pvdf/restore/scanner.hpp"

#include <cmath>
#include <string>
#include <vector>

namespace restore_test {

inline pvdf::restore::ScannerScene example_scene(const std::string& name) {
  return pvdf::restore::load_scanner_scene(std::string(PVDF_SOURCE_DIR) + "/examples/restore/" + name);
}

/// The seed-000 pair: edges (0.6, 0.9) and (0.2, 1.0) N at x = -12.5 mm, simulated with the example scenes.
inline std::vector<pvdf::restore::IdentificationScan> paper_identification(bool noise = true, std::uint64_t seed = 0) {
  std::vector<pvdf::restore::IdentificationScan> ids(2);
  pvdf::restore::SimulateOptions so;
  so.noise = noise;
  so.adc = noise;
  const char* names[2] = {"edge_a.json", "edge_b.json"};
  for (int i = 0; i < 2; ++i) {
    auto scene = example_scene(names[i]);
    if (seed) scene.seed = seed + i;
    ids[i].scan = pvdf::restore::simulate_scan(scene, so);
    ids[i].fx_N = scene.edges[0].fx_N;
    ids[i].fz_N = scene.edges[0].fz_N;
    ids[i].edge_x_m = scene.edges[0].x_m;
  }
  return ids;
}

struct EdgeMeasure {
  double mu_peak = 0;      ///< f_x / f_z at the f_z peak
  double shift_samples = 0;///< centroid of the f_z main lobe (f_z > half peak) minus the true position
  double peak_N = 0;
};

/// Looks for the f_z peak within +-1 mm of x_true.
inline EdgeMeasure measure_edge(const pvdf::restore::RestoredForces& r, double x_true, double dx) {
  EdgeMeasure m;
  std::size_t ip = 0;
  double pk = -1;
  for (std::size_t i = 0; i < r.x_m.size(); ++i) {
    if (std::abs(r.x_m[i] - x_true) < 1e-3 && r.fz_N[i] > pk) {
      pk = r.fz_N[i];
      ip = i;
    }
  }
  double c0 = 0, c1 = 0;
  std::size_t lo = ip, hi = ip;
  while (lo > 0 && r.fz_N[lo - 1] > 0.5 * pk) --lo;
  while (hi + 1 < r.fz_N.size() && r.fz_N[hi + 1] > 0.5 * pk) ++hi;
  for (std::size_t i = lo; i <= hi; ++i) {
    c0 += r.fz_N[i];
    c1 += r.fz_N[i] * r.x_m[i];
  }
  m.mu_peak = r.fx_N[ip] / r.fz_N[ip];
  m.shift_samples = (c1 / c0 - x_true) / dx;
  m.peak_N = pk;
  return m;
}

}  // namespace restore_test
