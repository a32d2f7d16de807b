// Example: locating presses on a deployed membrane sensor with pvdf::mapping.
//
// What it shows: the deployment runtime — read a charge map, build a Locator once, then turn
// electrode charges into (x, y, F) with a 1-sigma uncertainty and flags, thousands of times
// per second, without deal.II. The map here is the analytic stand-in (SyntheticModel) until
// FEM maps exist; with a real one, skip step 1 and pass its path.
//
// Run:      example_locate_presses [MAP.h5]       (writes a synthetic map there first)
// Expect:   a located press within a few µm of the truth, the same press with charge noise
//           inside its reported 1-sigma most of the time, a no-press and an outside-map
//           result, and the rate of a stream of noisy presses.
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/map_io.hpp"
#include "pvdf/mapping/synthetic.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>

using namespace pvdf::mapping;

int main(int argc, char** argv) {
  const std::string path = argc > 1 ? argv[1] : "example_map.h5";

  // 1. A map file. `pvdfkit map SCENE -o MAP.h5` will compute one with the FEM solver; here the
  //    analytic seed-001-like model is sampled every 1 mm at five force levels and written.
  SyntheticModel model;
  model.force_skew = 0.05;
  write_map(path, build_synthetic_map(model, 1e-3, 3e-3, {0.25, 0.5, 1.0, 2.0, 4.0}, 0.05e-12));

  // 2. Read it back (validated) and build the Locator once: interpolant + coarse table.
  const ChargeMap map = read_map(path);
  LocatorOptions options;
  options.noise_C = {0.1e-12};                       // 0.1 pC charge-amplifier noise
  options.min_force_N = 0.25;                        // the forces this sensor expects
  options.max_force_N = 4.0;
  const Locator locator(map, options);
  std::printf("map %s: %zu x %zu positions, %zu force levels, electrodes", path.c_str(), map.nx(), map.ny(), map.nf());
  for (const auto& n : map.electrode_names) std::printf(" %s", n.c_str());
  std::printf("\n");

  // 3. One press, charges straight from the model (between grid nodes).
  const double x = 0.00437, y = -0.00213, F = 1.3;
  double q[3];
  for (std::size_t k = 0; k < 3; ++k) q[k] = model.charge_C(x, y, F, k);
  Location r = locator.locate(q);
  std::printf("press at (%.3f, %.3f) mm, %.2f N -> (%.4f, %.4f) mm, %.4f N, flags %s\n", x * 1e3, y * 1e3, F,
              r.x_m * 1e3, r.y_m * 1e3, r.force_N, flags_text(r.flags).c_str());
  if (r.flags & flag::ambiguous) {
    std::printf("  also fits: (%.4f, %.4f) mm, %.4f N — three charges, unknown force (docs/lookup.md)\n",
                r.alternative.x_m * 1e3, r.alternative.y_m * 1e3, r.alternative.force_N);
  }
  // With the force known (a force transducer), only (x, y) is fitted: no ambiguity here.
  r = locator.locate(q, F);
  std::printf("with the force known: (%.4f, %.4f) mm ± (%.4f, %.4f) mm, flags %s\n", r.x_m * 1e3, r.y_m * 1e3,
              r.sigma_x_m * 1e3, r.sigma_y_m * 1e3, flags_text(r.flags).c_str());
  const bool accurate = std::hypot(r.x_m - x, r.y_m - y) < 0.05e-3;

  // 4. Nothing pressed, and a press the map cannot explain.
  const double quiet[3] = {0.05e-12, -0.02e-12, 0.1e-12};
  const double strange[3] = {200e-12, 0.5e-12, 0.5e-12};
  const Location none = locator.locate(quiet), outside = locator.locate(strange);
  std::printf("quiet sensor: %s; impossible charges: %s\n", flags_text(none.flags).c_str(),
              flags_text(outside.flags).c_str());

  // 5. A stream of noisy presses (one thread; Locator::locate is const and allocation-free,
  //    so several threads may share one Locator).
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.1e-12);
  std::uniform_real_distribution<double> u(-0.01, 0.01);
  const int n = 5000;
  int within = 0, located = 0;
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < n; ++i) {
    const double px = u(rng), py = u(rng), pf = 1.0;
    double c[3];
    for (std::size_t k = 0; k < 3; ++k) c[k] = model.charge_C(px, py, pf, k) + noise(rng);
    const Location s = locator.locate(c, pf);
    if (!s.has_position()) continue;
    ++located;
    within += std::abs(s.x_m - px) <= s.sigma_x_m;
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("%d noisy presses: %d located, %.1f %% with |x error| <= sigma_x (expect ~68 %%), %.0f locates/s\n", n,
              located, 100.0 * within / std::max(located, 1), n / seconds);
  const bool ok = accurate && (none.flags & flag::no_press) && (outside.flags & flag::outside_map) && located > n * 9 / 10;
  std::printf("%s\n", ok ? "example finished as expected" : "UNEXPECTED RESULT");
  return ok ? 0 : 1;
}
