// The force-ramp design metric of a map (pvdf::mapping::ramp_ambiguity_share, docs/lookup.md
// §2 "Force ramps"): the share of the map's nodes whose peak charges fit more than one press
// with the force unknown, and the share still ambiguous after the noise-free ramp test, at
// each noise level given. The noisy study is bench/mapping/ramp_study.py.
//   ramp_metric MAP.h5 [--noise-pC 0.05,0.2,1] [--samples 30] [--ramp-start 0.25] [--peak-force-N F]
#include "pvdf/core/error.hpp"
#include "pvdf/mapping/map_io.hpp"
#include "pvdf/mapping/ramp.hpp"

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <sstream>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  try {
    if (argc < 2 || std::strcmp(argv[1], "--help") == 0) {
      std::printf("usage: ramp_metric MAP.h5 [--noise-pC L1,L2,...] [--samples N] [--ramp-start R] [--peak-force-N F]\n");
      return argc < 2 ? 2 : 0;
    }
    const pvdf::mapping::ChargeMap map = pvdf::mapping::read_map(argv[1]);
    std::vector<double> noise_pC{0.05, 0.2, 1.0};
    pvdf::mapping::RampOptions o;
    for (int a = 2; a + 1 < argc; a += 2) {
      const std::string key = argv[a], value = argv[a + 1];
      if (key == "--noise-pC") {
        noise_pC.clear();
        std::stringstream ss(value);
        for (std::string item; std::getline(ss, item, ',');) noise_pC.push_back(std::stod(item));
      } else if (key == "--samples") {
        o.n_samples = std::stoi(value);
      } else if (key == "--ramp-start") {
        o.ramp_start = std::stod(value);
      } else if (key == "--peak-force-N") {
        o.peak_force_N = std::stod(value);
      } else {
        throw pvdf::InputError("ramp_metric: unknown option " + key + "; see --help");
      }
    }
    if (o.n_samples < 2 || !(o.ramp_start > 0 && o.ramp_start <= 1)) {
      throw pvdf::InputError("ramp_metric: --samples must be >= 2 and --ramp-start in (0, 1]");
    }
    std::printf("map %s: %d samples %.3g F .. F\n", argv[1], o.n_samples, o.ramp_start);
    std::printf("noise_pC  nodes  missed  peak_N  dof  limit  ambiguous@peak  after_ramp  after_hold  own_rejected  median_sep  wall_s\n");
    for (const double n : noise_pC) {
      o.noise_C.assign(map.ne(), n * 1e-12);
      const auto t0 = std::chrono::steady_clock::now();
      const pvdf::mapping::RampAmbiguity r = pvdf::mapping::ramp_ambiguity_share(map, o);
      const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::printf("%8.3g %6zu %7zu %7.3g %4d %6.1f %14.1f%% %10.1f%% %10.1f%% %12.1f%% %11.3g %7.2f\n", n, r.nodes,
                  r.nodes_truth_missed, r.peak_force_N, r.dof, r.limit, 100 * r.ambiguous_at_peak,
                  100 * r.ambiguous_after_ramp, 100 * r.ambiguous_after_hold, 100 * r.own_rejected, r.median_separation,
                  wall);
    }
    return 0;
  } catch (const pvdf::InputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 3;
  }
}
