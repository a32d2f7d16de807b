// Writes a recorded-style charge stream for the deployment test (deploy_example.sh): CSV
// `t_s,charge_<name>_C,...` at 10 kHz — a press that slides across the map while its force ramps
// up and down, a gap with nothing pressed, a still press, and one malformed row — with Gaussian
// charge noise (fixed seed). Charges are the map's own prediction (Locator::predict).
//   make_press_stream MAP.h5 > stream.csv
//   make_press_stream --with-errors MAP.h5 OUT.h5   (a copy of the map with a per-node charge error
//                                                    estimate, 0.1–0.5 % of each charge: the
//                                                    flat map's version-2 section end to end)
#include "pvdf/core/constants.hpp"
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/map_io.hpp"

#include <cmath>
#include <cstdio>
#include <random>
#include <algorithm>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  using namespace pvdf::mapping;
  if (argc == 4 && std::string(argv[1]) == "--with-errors") {
    ChargeMap map = read_map(argv[2]);
    map.estimated_charge_error_C.assign(map.charge_C.size(), 0.0);
    for (std::size_t n = 0; n < map.charge_C.size(); ++n) {
      const bool ok = map.status[n / map.ne()] == std::uint8_t(PointStatus::ok);
      map.estimated_charge_error_C[n] = ok ? std::abs(map.charge_C[n]) * 1e-3 * double(1 + n % 5) : std::nan("");
    }
    write_map(argv[3], map);
    return 0;
  }
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_press_stream MAP.h5 | make_press_stream --with-errors MAP.h5 OUT.h5\n");
    return 2;
  }
  const ChargeMap map = read_map(argv[1]);
  const Locator locator(map);
  std::mt19937 rng(17);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::printf("t_s");
  for (const auto& n : map.electrode_names) std::printf(",charge_%s_C", n.c_str());
  std::printf("\n");
  const double lo = map.forces_N.front(), hi = map.forces_N.back();
  std::vector<double> q(map.ne());
  int row = 0;
  auto emit = [&](bool pressed, double x, double y, double F) {
    if (!pressed || !locator.predict(x, y, F, q.data())) std::fill(q.begin(), q.end(), 0.0);
    std::printf("%.4f", row++ * 1e-4);
    for (std::size_t k = 0; k < q.size(); ++k) std::printf(",%.6e", q[k] + map.noise_C[k] * noise(rng));
    std::printf("\n");
  };
  for (int i = 0; i < 800; ++i) {  // sliding press, force ramp lo..hi..lo
    const double s = i / 799.0;
    emit(true, -6e-3 + 12e-3 * s, -3e-3 + 5e-3 * s, lo + (hi - lo) * std::sin(pvdf::pi * s));
  }
  for (int i = 0; i < 100; ++i) emit(false, 0, 0, 0);  // released
  std::printf("%.4f,not-a-number", row++ * 1e-4);     // a malformed row: both programs skip it
  for (std::size_t k = 1; k < q.size(); ++k) std::printf(",0");
  std::printf("\n");
  for (int i = 0; i < 600; ++i) emit(true, 2.5e-3, 4e-3, 0.5 * (lo + hi));  // still press
  return 0;
}
