// The whole chain without hardware: a simulated front end driven by a charge map (presses at
// known positions and forces, amplifier noise, 12-bit ADC), streamed by `pvdfkit acquire` into
// the mapping module's locator (--locate). The located positions and forces must be the ones
// the scene pressed. Built only when the mapping module and the pvdfkit command exist.
#include "pvdf/core/io.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/map_io.hpp"
#include "pvdf/mapping/synthetic.hpp"

#include <catch2/catch.hpp>

#include <sys/wait.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace {
std::string temp_path(const char* name) { return std::string(PVDF_BINARY_DIR) + "/tests/hardware/" + name; }

/// Writes a map-driven scene with one press of `force_N` at (x, y), held 0.07-0.27 s; `gain`
/// is the scene's gain_V_per_C line (empty: the default).
void write_scene(const std::string& path, const std::string& map_path, double x, double y, double force_N,
                 const std::string& gain) {
  std::ofstream scene(path);
  scene << R"({"channels": 3, "duration_s": 0.35, "noise_V": 0.0005, )" << gain << R"("map": ")" << map_path
        << R"(", "presses": [{"start_s": 0.05, "rise_s": 0.02, "hold_s": 0.2, "force_N": )" << force_N
        << R"(, "position_m": [)" << x << ", " << y << "]}]}";
}

struct RunResult {
  int exit_code = -1;
  std::vector<std::vector<std::string>> rows;  ///< data rows, split
  std::string errors;                          ///< stderr
};

RunResult run_locate(const std::string& scene_path, const std::string& map_path, const std::string& tag) {
  const std::string csv = temp_path((tag + ".csv").c_str()), err = temp_path((tag + ".err").c_str());
  const std::string command = std::string(PVDFKIT_EXE) + " acquire --device sim:" + scene_path + " --locate " + map_path +
                              " --force-range-N 0.85,1.2 --output " + csv + " 2> " + err;
  const int status = std::system(command.c_str());
  RunResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) r.rows.push_back(pvdf::split_csv_line(line));
  std::ifstream e(err);
  r.errors.assign(std::istreambuf_iterator<char>(e), std::istreambuf_iterator<char>());
  return r;
}
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
  CHECK(line.rfind("t_s,x_m,y_m,force_N,residual,sigma_x_m,sigma_y_m,sigma_F_N,flags,p_best,n_solutions,alt1_x_m,", 0) == 0);
  std::array<int, 2> n_hold{0, 0};
  int n_rows = 0, n_quiet = 0;
  while (std::getline(in, line)) {
    ++n_rows;
    const auto fields = pvdf::split_csv_line(line);
    REQUIRE(fields.size() == 11 + 4 * 7);
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

TEST_CASE("a saturated simulated stream is flagged saturated and not located; the default gain suits the map",
          "[hardware][chain][saturation]") {
  const pvdf::mapping::SyntheticModel model;
  const auto map = pvdf::mapping::build_synthetic_map(model, 0.001, 0.003, {0.5, 1.0, 2.0}, 2e-14);
  const std::string map_path = temp_path("saturation_map.h5");
  pvdf::mapping::write_map(map_path, map);
  double peak_C = 0;
  for (const double q : map.charge_C) peak_C = std::max(peak_C, std::abs(q));
  REQUIRE(peak_C > 0);

  // 1. A gain that puts a 1 N press far beyond the 2.5 V full scale: every frame of the hold
  //    clips. Those rows must say `saturated` and carry no position; the run warns about it.
  const std::string hot_scene = temp_path("saturation_hot.json");
  const double hot_gain = 40.0 * 2.5 / peak_C;
  write_scene(hot_scene, map_path, 0.002, 0.004, 1.0, "\"gain_V_per_C\": " + std::to_string(hot_gain) + ", ");
  const RunResult hot = run_locate(hot_scene, map_path, "saturation_hot");
  REQUIRE(hot.exit_code == 0);
  REQUIRE(hot.rows.size() == 35);
  int n_saturated = 0, n_hold = 0;
  for (const auto& f : hot.rows) {
    REQUIRE(f.size() == 11 + 4 * 7);
    const double t = std::stod(f[0]);
    if (f[8] == "saturated") {
      ++n_saturated;
      CHECK(f[1].empty());  // never located
      CHECK(f[3].empty());
    }
    if (t > 0.08 && t < 0.26) {
      ++n_hold;
      CHECK(f[8] == "saturated");
    }
  }
  CHECK(n_hold >= 17);
  CHECK(n_saturated >= n_hold);
  CHECK(hot.errors.find("beyond the front end") != std::string::npos);  // the map exceeds the front end's range
  CHECK(hot.errors.find("saturated") != std::string::npos);

  // 2. The same press with no gain in the scene: the simulator picks a gain that suits the
  //    map's charges, nothing clips and the press is located.
  const std::string scene = temp_path("saturation_default.json");
  write_scene(scene, map_path, 0.002, 0.004, 1.0, "");
  const RunResult plain = run_locate(scene, map_path, "saturation_default");
  REQUIRE(plain.exit_code == 0);
  int n_located = 0;
  for (const auto& f : plain.rows) {
    CHECK(f[8] != "saturated");
    const double t = std::stod(f[0]);
    if (t > 0.08 && t < 0.26 && !f[1].empty()) {
      ++n_located;
      CHECK(std::stod(f[1]) == Approx(0.002).margin(2e-4));
      CHECK(std::stod(f[2]) == Approx(0.004).margin(2e-4));
    }
  }
  CHECK(n_located >= 17);
  CHECK(plain.errors.find("beyond the front end") == std::string::npos);
}
