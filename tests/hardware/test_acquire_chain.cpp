// The whole chain without hardware: a simulated front end driven by a charge map (presses at
// known positions and forces, amplifier noise, 12-bit ADC), streamed by `pvdfkit acquire` into
// the mapping module's locator (--locate). The located positions and forces must be the ones
// the scene pressed. Built only when the mapping module and the pvdfkit command exist.
#include "pvdf/core/io.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/synthetic.hpp"

#include <catch2/catch.hpp>

#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <fstream>

namespace {
std::string temp_path(const char* name) { return std::string(PVDF_BINARY_DIR) + "/tests/hardware/" + name; }
}  // namespace

TEST_CASE("sim driven by a charge map, located by --locate, returns the pressed positions and forces", "[hardware][chain]") {
  const pvdf::mapping::SyntheticModel model;
  const auto map = pvdf::mapping::build_synthetic_map(model, 0.001, 0.003, {0.5, 1.0, 2.0}, 2e-14);
  const std::string map_path = temp_path("chain_map.h5"), scene_path = temp_path("chain_scene.json"),
                    csv_path = temp_path("chain_locations.csv");
  pvdf::mapping::write_map(map_path, map);
  // Two presses of 1 N, each held 0.2 s: 0.07-0.27 s and 0.37-0.57 s.
  const std::array<std::array<double, 3>, 2> presses{{{0.002, 0.004, 1.0}, {-0.004, -0.002, 1.0}}};
  {
    std::ofstream scene(scene_path);
    scene << R"({"channels": 3, "duration_s": 0.65, "noise_V": 0.0005, "gain_V_per_C": 2e10, "map": ")" << map_path
          << R"(", "presses": [)";
    for (std::size_t k = 0; k < presses.size(); ++k)
      scene << (k ? ", " : "") << R"({"start_s": )" << 0.05 + 0.3 * k << R"(, "rise_s": 0.02, "hold_s": 0.2, "force_N": )"
            << presses[k][2] << R"(, "position_m": [)" << presses[k][0] << ", " << presses[k][1] << "]}";
    scene << "]}";
  }
  // Three electrodes often admit a second exact solution at another force (docs/lookup.md §2);
  // a plausible force range removes it.
  const std::string command = std::string(PVDFKIT_EXE) + " acquire --quiet --device sim:" + scene_path + " --locate " +
                              map_path + " --force-range-N 0.85,1.2 --output " + csv_path;
  const int status = std::system(command.c_str());
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 0);

  std::ifstream in(csv_path);
  std::string line;
  REQUIRE(std::getline(in, line));
  CHECK(line == "t_s,x_m,y_m,force_N,residual,sigma_x_m,sigma_y_m,sigma_F_N,flags");
  std::array<int, 2> n_hold{0, 0};
  int n_rows = 0, n_quiet = 0;
  while (std::getline(in, line)) {
    ++n_rows;
    const auto fields = pvdf::split_csv_line(line);
    REQUIRE(fields.size() == 9);
    const double t = std::stod(fields[0]);
    const bool quiet = t < 0.045 || (t > 0.30 && t < 0.345) || t > 0.60;
    if (quiet) {
      ++n_quiet;
      CHECK(fields[8] == "no_press");
      CHECK(fields[1].empty());
      continue;
    }
    for (std::size_t k = 0; k < presses.size(); ++k) {
      const double hold_begin = 0.07 + 0.3 * k + 0.01, hold_end = 0.27 + 0.3 * k - 0.01;
      if (t < hold_begin || t > hold_end) continue;
      ++n_hold[k];
      INFO("t = " << t << " s, row: " << line);
      CHECK(fields[8] == "ok");
      CHECK(std::stod(fields[1]) == Approx(presses[k][0]).margin(2e-4));
      CHECK(std::stod(fields[2]) == Approx(presses[k][1]).margin(2e-4));
      CHECK(std::stod(fields[3]) == Approx(presses[k][2]).epsilon(0.03));
    }
  }
  CHECK(n_rows == 65);  // one location per 10 ms frame
  CHECK(n_hold[0] >= 17);
  CHECK(n_hold[1] >= 17);
  CHECK(n_quiet >= 10);
}
