// The lookup-accuracy study: Monte-Carlo presses on a map, the lookup against the triangulation.
#include "pvdf/mapping/lookup_accuracy.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/triangulation.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <ctime>
#include <random>

namespace pvdf::mapping {

namespace {

struct Press {
  double x, y, F;
  std::array<double, max_electrodes> q;
};

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

/// Presses inside the map (truth defined) and within the radius; at most 100 draws per press wanted.
std::vector<Press> draw_presses(const Locator& truth, const LookupAccuracyOptions& o, double f_lo, double f_hi,
                                std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Press> presses;
  std::size_t attempts = 0;
  const std::size_t n_wanted = o.n_presses;
  while (presses.size() < n_wanted && attempts++ < 100 * n_wanted) {
    Press p{};
    p.x = (2 * u(rng) - 1) * o.radius_m;
    p.y = (2 * u(rng) - 1) * o.radius_m;
    p.F = f_lo * std::pow(f_hi / f_lo, u(rng));
    if (std::hypot(p.x, p.y) > o.radius_m || !truth.predict(p.x, p.y, p.F, p.q.data())) continue;
    presses.push_back(p);
  }
  return presses;
}

/// One noise level: the same presses with fresh noise, located three ways.
LookupAccuracyRow noise_level(const ChargeMap& map, const LocatorOptions& base, const Triangulation& tri,
                              const std::vector<Press>& presses, double sigma, std::mt19937& rng) {
  LocatorOptions lo = base;
  lo.noise_C = {sigma};
  const Locator locator(map, lo);
  std::normal_distribution<double> n(0.0, sigma);
  std::vector<std::array<double, max_electrodes>> q(presses.size());
  for (std::size_t i = 0; i < presses.size(); ++i) {
    for (std::size_t k = 0; k < map.ne(); ++k) q[i][k] = presses[i].q[k] + n(rng);
  }
  std::vector<double> a, b, c, s;
  int ambiguous = 0;
  std::clock_t t0 = std::clock();
  for (std::size_t i = 0; i < presses.size(); ++i) {
    const Location r = locator.locate(q[i].data());
    if (!r.has_position()) continue;
    double e = std::hypot(r.x_m - presses[i].x, r.y_m - presses[i].y);
    if (r.flags & flag::ambiguous) ++ambiguous;
    for (int k = 0; k < r.n_alternatives; ++k) {
      const auto& alt = r.alternatives[std::size_t(k)];
      e = std::min(e, std::hypot(alt.x_m - presses[i].x, alt.y_m - presses[i].y));
    }
    b.push_back(e);
  }
  const double lookup_rate = double(presses.size()) / std::max(1e-9, double(std::clock() - t0) / CLOCKS_PER_SEC);
  for (std::size_t i = 0; i < presses.size(); ++i) {
    const Location r = locator.locate(q[i].data(), presses[i].F);
    if (!r.has_position()) continue;
    a.push_back(std::hypot(r.x_m - presses[i].x, r.y_m - presses[i].y));
    s.push_back(std::hypot(r.sigma_x_m, r.sigma_y_m));
  }
  t0 = std::clock();
  for (std::size_t i = 0; i < presses.size(); ++i) {
    const Location r = tri.locate(q[i].data(), presses[i].F);
    if (r.has_position()) c.push_back(std::hypot(r.x_m - presses[i].x, r.y_m - presses[i].y));
  }
  const double tri_rate = double(presses.size()) / std::max(1e-9, double(std::clock() - t0) / CLOCKS_PER_SEC);
  LookupAccuracyRow row;
  row.noise_C = sigma;
  row.median_error_force_known_m = median(a);
  row.median_sigma_force_known_m = median(s);
  row.median_error_force_unknown_m = median(b);
  row.median_error_triangulation_m = median(c);
  row.n_ambiguous = ambiguous;
  row.lookup_per_cpu_s = lookup_rate;
  row.triangulation_per_cpu_s = tri_rate;
  return row;
}

}  // namespace

LookupAccuracy lookup_accuracy(const ChargeMap& map, const LookupAccuracyOptions& options,
                               const std::function<void(const LookupAccuracy&)>& on_row) {
  for (double s : options.noise_C) {
    if (!(s > 0)) throw InputError("lookup accuracy: noise level " + format_g(s) + " C must be > 0");
  }
  LocatorOptions base;
  base.use_calibration = false;     // truth and lookup both use the raw map
  base.interpolation_error = false;  // the truth is the map's own interpolant: no interpolation error
  const Locator truth(map, base);
  const Triangulation tri(truth, map);
  LookupAccuracy study;
  study.min_force_N = map.forces_N.front();
  study.max_force_N = map.forces_N.back();

  std::mt19937 rng(options.seed);
  const std::vector<Press> presses = draw_presses(truth, options, study.min_force_N, study.max_force_N, rng);
  study.n_presses = presses.size();
  if (presses.size() < options.min_presses) return study;
  for (double sigma : options.noise_C) {
    study.rows.push_back(noise_level(map, base, tri, presses, sigma, rng));
    if (on_row) on_row(study);
  }
  return study;
}

}  // namespace pvdf::mapping
