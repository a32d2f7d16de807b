// Shared test helpers: synthetic maps from the analytic model (the oracle), random presses
// between grid nodes.
#pragma once

#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/synthetic.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace pvdf_test {

struct Press {
  double x_m, y_m, force_N;
};

/// Presses uniformly over a disk of radius r_max (m), log-uniform force in [f_lo, f_hi].
inline std::vector<Press> random_presses(std::size_t n, double r_max, double f_lo, double f_hi, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Press> out;
  while (out.size() < n) {
    const double x = (2 * u(rng) - 1) * r_max, y = (2 * u(rng) - 1) * r_max;
    if (std::hypot(x, y) > r_max) continue;
    out.push_back({x, y, f_lo * std::pow(f_hi / f_lo, u(rng))});
  }
  return out;
}

inline std::vector<double> charges(const pvdf::mapping::SyntheticModel& model, const Press& p) {
  std::vector<double> q(model.n_electrodes());
  for (std::size_t k = 0; k < q.size(); ++k) q[k] = model.charge_C(p.x_m, p.y_m, p.force_N, k);
  return q;
}

inline double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace pvdf_test
