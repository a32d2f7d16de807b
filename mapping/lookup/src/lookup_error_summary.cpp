// lookup_error_summary (pvdf/mapping/locator.hpp): what a map states about the error the lookup
// will carry at a press, whatever the placement (docs/lookup.md §1.12).
#include "pvdf/mapping/locator.hpp"

#include "pvdf/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <vector>

namespace pvdf::mapping {

LookupErrorSummary lookup_error_summary(const ChargeMap& map) {
  LookupErrorSummary summary;
  if (map.ne() < 3 || map.nx() < 2 || map.ny() < 2) return summary;
  std::unique_ptr<Locator> locator;
  try {
    locator = std::make_unique<Locator>(map);
  } catch (const InputError&) {
    return summary;  // no lookup on this map (e.g. no usable cell)
  }
  // Five points a side in every cell (the corners pulled in by 2 %, so that each point belongs to
  // its cell): the node shares peak at the corners, the interpolation shares mid-cell.
  const double at[5] = {0.02, 0.25, 0.5, 0.75, 0.98};
  const std::size_t ne = map.ne();
  std::vector<double> q(ne), e(ne);
  std::vector<double> relative;
  // At every level and half way (in ln F) between consecutive ones, where the error between the
  // levels peaks.
  std::vector<double> forces;
  for (std::size_t f = 0; f < map.nf(); ++f) {
    forces.push_back(map.forces_N[f]);
    if (f + 1 < map.nf()) forces.push_back(std::sqrt(map.forces_N[f] * map.forces_N[f + 1]));
  }
  for (const double force : forces) {
    for (std::size_t j = 0; j + 1 < map.ny(); ++j) {
      for (std::size_t i = 0; i + 1 < map.nx(); ++i) {
        for (const double v : at) {
          for (const double u : at) {
            const double x = map.x_m[i] + u * (map.x_m[i + 1] - map.x_m[i]);
            const double y = map.y_m[j] + v * (map.y_m[j + 1] - map.y_m[j]);
            if (!locator->predict(x, y, force, q.data()) ||
                !locator->charge_error(x, y, force, e.data()))
              continue;
            double q_max = 0, e_max = 0;
            for (std::size_t k = 0; k < ne; ++k) {
              q_max = std::max(q_max, std::abs(q[k]));
              e_max = std::max(e_max, std::abs(e[k]));
            }
            if (!(q_max > 0) || !std::isfinite(e_max)) continue;
            relative.push_back(e_max / q_max);
          }
        }
      }
    }
  }
  if (relative.empty()) return summary;
  // Nearest-rank quantiles of the sample (each cell weighs the same: the grid is uniform).
  const auto quantile = [&relative](double p) {
    const std::size_t n = relative.size();
    const std::size_t at = std::min(n - 1, static_cast<std::size_t>(std::ceil(p * double(n))) - (p > 0 ? 1 : 0));
    std::nth_element(relative.begin(), relative.begin() + std::ptrdiff_t(at), relative.end());
    return relative[at];
  };
  summary.median = quantile(0.5);
  summary.p90 = quantile(0.9);
  summary.max = *std::max_element(relative.begin(), relative.end());
  summary.n_points = relative.size();
  return summary;
}

}  // namespace pvdf::mapping
