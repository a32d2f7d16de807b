// Shared test helpers: synthetic maps from the analytic model (the oracle), random presses
// between grid nodes.
#pragma once

#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/synthetic.hpp"

#include <functional>

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

/// Where the true charges of a press come from. Today: the analytic model the map was sampled
/// from. With `pvdfkit map`, the FEM acceptance test plugs in an oracle
/// that runs pvdf::fem::solve with the probe at the press and returns each electrode's
/// charge_C — the rest of the test (measure_accuracy and its thresholds) stays as it is.
using ChargeOracle = std::function<std::vector<double>(const Press&)>;

inline ChargeOracle synthetic_oracle(const pvdf::mapping::SyntheticModel& model) {
  return [model](const Press& p) { return charges(model, p); };
}

/// Accuracy of a locator over presses whose charges come from `oracle`.
struct Accuracy {
  std::vector<double> position_error_m;  ///< of the reported answer nearest the truth
  std::vector<double> force_error;       ///< relative, same answer
  int flagged = 0;                       ///< no position (outside_map / no_press)
  int ambiguous = 0;
  int silent_wrong = 0;  ///< unflagged answers off by > 0.2 mm and > 3 sigma
};

inline Accuracy measure_accuracy(const pvdf::mapping::Locator& locator, const ChargeOracle& oracle,
                                 const std::vector<Press>& presses, bool known_force) {
  using namespace pvdf::mapping;
  Accuracy a;
  for (const auto& p : presses) {
    const auto q = oracle(p);
    const Location r = known_force ? locator.locate(q, p.force_N) : locator.locate(q);
    if (!r.has_position()) {
      ++a.flagged;
      continue;
    }
    double e = std::hypot(r.x_m - p.x_m, r.y_m - p.y_m), f = std::abs(r.force_N - p.force_N) / p.force_N;
    if (r.flags & flag::ambiguous) {
      ++a.ambiguous;
      for (int k = 0; k < r.n_alternatives; ++k) {
        const auto& alt = r.alternatives[std::size_t(k)];
        const double ea = std::hypot(alt.x_m - p.x_m, alt.y_m - p.y_m);
        if (ea < e) {
          e = ea;
          f = std::abs(alt.force_N - p.force_N) / p.force_N;
        }
      }
    } else {
      a.silent_wrong += e > 0.2e-3 && e > 3 * std::hypot(r.sigma_x_m, r.sigma_y_m);
    }
    a.position_error_m.push_back(e);
    a.force_error.push_back(f);
  }
  return a;
}

}  // namespace pvdf_test
