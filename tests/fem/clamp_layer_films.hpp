// Shared by the clamp-layer tests (test_fem_clamp_layer: the one-shot solve; test_sweep_clamp_layer:
// the map sweep): the isotropic 15 mm films whose clamp bending layer is a few % of the radius, with
// three 2 mm electrodes out to 1.3 mm from the clamp, and the charge comparison they use.
#pragma once

#include "oracle_compare.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace pvdf::fem::testing::clamp_films {

constexpr double a = 0.015, E = 2e9, nu = 0.3;

inline pvdf::Scene clamp_scene(double h_m, double force_N) {
  pvdf::Scene s = centred_probe_scene(a, h_m, E, nu, force_N, 0.003);
  s.material.draw_angle_rad = 0.5;
  s.material.d31_C_per_N = 6.5e-12;
  s.material.d32_C_per_N = 0.65e-12;
  const double rects[3][3] = {{0.004, 0.0, 0.0}, {0.008, 0.003, 0.3}, {0.0115, -0.002, 0.0}};
  const char* names[3] = {"inner", "mid", "outer"};
  for (int i = 0; i < 3; ++i) {
    pvdf::Electrode e;
    e.name = names[i];
    e.center_m = {rects[i][0], rects[i][1]};
    e.size_m = {0.002, 0.002};
    e.angle_rad = rects[i][2];
    s.electrodes.push_back(e);
  }
  return s;
}

// max_k |q_k − ref_k| / max_k |ref_k|; NaN in, NaN out (so every comparison with it fails).
inline double relative_error(const std::vector<double>& q, const std::vector<double>& ref) {
  if (q.size() != ref.size() || q.empty()) return std::nan("");
  double scale = 0, diff = 0;
  for (std::size_t k = 0; k < q.size(); ++k) {
    if (!std::isfinite(q[k]) || !std::isfinite(ref[k])) return std::nan("");
    scale = std::max(scale, std::abs(ref[k]));
    diff = std::max(diff, std::abs(q[k] - ref[k]));
  }
  return diff / scale;
}

}  // namespace pvdf::fem::testing::clamp_films
