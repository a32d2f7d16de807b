// Audits the lookup's interpolation error estimate (docs/lookup.md §1.10) on a map of real solves:
// the map FINE.h5 at spacing h gives the maps at 2h and 4h (every other / every fourth node:
// the same solves a map at that spacing would make), and the nodes of FINE they lack are the
// truth between their nodes. Prints, for each coarse map, the effectivity of the stated error
// (interpolation only, and total with the per-node estimate) against |map − truth| relative to
// the press's largest charge, where that exceeds 1e-3.
//   interpolation_audit FINE.h5
#include "pvdf/mapping/interpolation_error.hpp"
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/map_io.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

using namespace pvdf::mapping;

namespace {

/// Every `step`-th node of `map` from node 0 (all levels, electrodes, estimates).
ChargeMap coarser(const ChargeMap& map, std::size_t step) {
  ChargeMap c = map;
  c.x_m.clear();
  c.y_m.clear();
  for (std::size_t i = 0; i < map.nx(); i += step) c.x_m.push_back(map.x_m[i]);
  for (std::size_t j = 0; j < map.ny(); j += step) c.y_m.push_back(map.y_m[j]);
  c.allocate();
  c.estimated_charge_error_C.assign(c.charge_C.size(), 0.0);
  const bool slopes = !map.dcharge_dx_C_per_m.empty();
  c.dcharge_dx_C_per_m.assign(slopes ? c.charge_C.size() : 0, 0.0);
  c.dcharge_dy_C_per_m.assign(slopes ? c.charge_C.size() : 0, 0.0);
  for (std::size_t j = 0; j < c.ny(); ++j) {
    for (std::size_t i = 0; i < c.nx(); ++i) {
      c.mask[j * c.nx() + i] = map.mask[j * step * map.nx() + i * step];
      for (std::size_t f = 0; f < c.nf(); ++f) {
        c.status[c.point(f, j, i)] = map.status[map.point(f, j * step, i * step)];
        c.deflection_at_load_m[c.point(f, j, i)] = map.deflection_at_load_m[map.point(f, j * step, i * step)];
        for (std::size_t k = 0; k < c.ne(); ++k) {
          c.charge_C[c.charge_index(f, j, i, k)] = map.charge_C[map.charge_index(f, j * step, i * step, k)];
          if (slopes) {
            c.dcharge_dx_C_per_m[c.charge_index(f, j, i, k)] = map.dcharge_dx_C_per_m[map.charge_index(f, j * step, i * step, k)];
            c.dcharge_dy_C_per_m[c.charge_index(f, j, i, k)] = map.dcharge_dy_C_per_m[map.charge_index(f, j * step, i * step, k)];
          }
          if (!map.estimated_charge_error_C.empty()) {
            c.estimated_charge_error_C[c.charge_index(f, j, i, k)] =
                map.estimated_charge_error_C[map.charge_index(f, j * step, i * step, k)];
          }
        }
      }
    }
  }
  if (map.estimated_charge_error_C.empty()) c.estimated_charge_error_C.clear();
  return c;
}

void audit(const ChargeMap& fine, std::size_t step) {
  const ChargeMap coarse = coarser(fine, step);
  ChargeMap no_node_estimate = coarse;
  no_node_estimate.estimated_charge_error_C.clear();
  const Locator total(coarse), interpolation(no_node_estimate);
  std::vector<double> eff_interp, eff_total;
  int under3 = 0, counted = 0;
  double worst = 0;
  for (std::size_t f = 0; f < fine.nf(); ++f) {
    for (std::size_t j = 0; j < fine.ny(); j += step / 2) {
      for (std::size_t i = 0; i < fine.nx(); i += step / 2) {
        if (i % step == 0 && j % step == 0) continue;  // a node of the coarse map
        if (fine.status[fine.point(f, j, i)] != std::uint8_t(PointStatus::ok)) continue;
        std::array<double, max_electrodes> q{}, e_i{}, e_t{};
        const double x = fine.x_m[i], y = fine.y_m[j], F = fine.forces_N[f];
        if (!total.predict(x, y, F, q.data()) || !interpolation.charge_error(x, y, F, e_i.data()) ||
            !total.charge_error(x, y, F, e_t.data())) {
          continue;
        }
        double largest = 0, truth = 0, ei = 0, et = 0;
        for (std::size_t k = 0; k < fine.ne(); ++k) {
          const double t = fine.charge_C[fine.charge_index(f, j, i, k)];
          largest = std::max(largest, std::abs(t));
          truth = std::max(truth, std::abs(q[k] - t));
          ei = std::max(ei, e_i[k]);
          et = std::max(et, e_t[k]);
        }
        if (truth <= 1e-3 * largest) continue;
        ++counted;
        eff_interp.push_back(ei / truth);
        eff_total.push_back(et / truth);
        under3 += et >= truth / 3;
        worst = std::max(worst, truth / et);
      }
    }
  }
  auto report = [&](const char* what, std::vector<double> v) {
    if (v.empty()) return;
    std::sort(v.begin(), v.end());
    int within = 0;
    for (const double r : v) within += r >= 0.5 && r <= 3;
    auto q = [&](double a) { return v[std::size_t(a * double(v.size() - 1))]; };
    std::printf("  %-28s median %.3g, 10%% %.3g, 90%% %.3g, within [0.5, 3] %.0f %%\n", what, q(0.5), q(0.1), q(0.9),
                100.0 * within / double(v.size()));
  };
  std::printf("spacing %.3g mm (%zu x %zu nodes): %d off-node points with a true error above 1e-3; true <= 3 x total "
              "estimate at %d, largest true/total %.3g\n",
              (coarse.x_m[1] - coarse.x_m[0]) * 1e3, coarse.nx(), coarse.ny(), counted, under3, worst);
  report("interpolation estimate/true", eff_interp);
  report("total estimate/true", eff_total);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: interpolation_audit FINE.h5\n");
    return 2;
  }
  const ChargeMap fine = read_map(argv[1]);
  audit(fine, 2);
  if (fine.nx() >= 9 && fine.ny() >= 9) audit(fine, 4);
  return 0;
}
