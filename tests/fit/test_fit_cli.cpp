// `pvdfkit fit` and `pvdfkit compare SCENE`: bad measured CSVs and parameter names exit 2 naming
// the line; an end-to-end fit writes a scene that loads again and carries the fitted stiffness.
#include "../app/cli_runner.hpp"

#include "pvdf/core/scene.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>

namespace {

const std::string scene = PVDF_FIT_TEST_DIR "/film.json";

std::string write(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::temp_directory_path() / ("pvdf_fit_cli_" + name);
  std::ofstream(path) << text;
  return path.string();
}

pvdf::test::CliResult fit(const std::string& csv, const std::string& extra = "") {
  return pvdf::test::run_pvdfkit("fit '" + scene + "' '" + csv + "' -o " +
                                 (std::filesystem::temp_directory_path() / "pvdf_fit_cli_out.json").string() + " " + extra);
}

}  // namespace

TEST_CASE("fit: bad measured CSVs exit 2 naming the line", "[fit][cli]") {
  SECTION("missing column: the header's line") {
    const auto r = fit(write("missing.csv", "# a comment\nx_m,y_m,charge_A_C\n0,0,1e-11\n"));
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("missing.csv:2:") != std::string::npos);
    CHECK(r.err.find("force_N") != std::string::npos);
  }
  SECTION("NaN in a value: its line") {
    const auto r = fit(write("nan.csv", "x_m,y_m,force_N,charge_A_C\n0,0,1,1e-11\n0.002,0,1,nan\n"));
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("nan.csv:3:") != std::string::npos);
    CHECK(r.err.find("charge_A_C") != std::string::npos);
  }
  SECTION("a charge column of an electrode the scene does not have") {
    const auto r = fit(write("electrode.csv", "x_m,y_m,force_N,charge_Z_C\n0,0,1,1e-11\n"));
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("electrode.csv:1:") != std::string::npos);
    CHECK(r.err.find("charge_Z_C") != std::string::npos);
  }
  SECTION("a value without its sigma") {
    const auto r = fit(write("sigma.csv", "x_m,y_m,force_N,charge_A_C,sigma_charge_A_C\n0,0,1,1e-11,1e-12\n0,0.001,1,1e-11,\n"));
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("sigma.csv:3:") != std::string::npos);
  }
  SECTION("a force <= 0") {
    const auto r = fit(write("force.csv", "x_m,y_m,force_N,deflection_m\n0,0,1,0.003\n0,0,-1,0.003\n"));
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("force.csv:3:") != std::string::npos);
  }
}

TEST_CASE("fit: unknown parameter names and a pre-tension slacker than the bound exit 2", "[fit][cli]") {
  const auto csv = write("good.csv", "x_m,y_m,force_N,deflection_m,charge_A_C\n0,0,1,0.003,1e-10\n0.002,0,1,0.003,1e-10\n");
  const auto r = fit(csv, "--params E_scal,d31_C_per_N");
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("'E_scal'") != std::string::npos);
  CHECK(r.err.find("gain_A") != std::string::npos);  // the list of valid names
  // Negative = slack is a valid start (tension-field membrane); beyond a ~5 % slack strain it is refused.
  const auto s = fit(csv, "--params pretension_N_per_m --start pretension_N_per_m=-1e5");
  CHECK(s.exit_code == 2);
  CHECK(s.err.find("slacker") != std::string::npos);
}

TEST_CASE("fit: a residual stiffness that is negative, >= 1 or not a number exits 2 with one line", "[fit][cli]") {
  const auto csv = write("good_eps.csv", "x_m,y_m,force_N,deflection_m,charge_A_C\n0,0,1,0.003,1e-10\n0.002,0,1,0.003,1e-10\n");
  for (const char* bad : {"-1e-3", "1", "nan", "inf", "1e-3x"}) {
    INFO(bad);
    const auto r = fit(csv, std::string("--residual-stiffness ") + bad);
    CHECK(r.exit_code == 2);
    CHECK(r.err.find("--residual-stiffness") != std::string::npos);
    CHECK(r.err.find("[0, 1)") != std::string::npos);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  }
}

TEST_CASE("fit end to end: the fitted scene loads and carries the stiffness the data demand; compare SCENE runs",
          "[fit][cli]") {
  // Deflections of a film 8x softer than the scene's, by the pure-membrane law w ∝ E^(-1/3):
  // twice the scene's own FEM deflection (taken from `compare SCENE`).
  const auto probe = write("probe.csv", "x_m,y_m,force_N,deflection_m\n0,0,1,0.001\n0.003,0.002,0.5,0.001\n");
  const auto c = pvdf::test::run_pvdfkit("compare '" + scene + "' '" + probe + "' --json");
  REQUIRE(c.exit_code == 0);
  const auto j = nlohmann::json::parse(c.out);
  REQUIRE(j["presses"].size() == 2);
  std::string csv = "x_m,y_m,force_N,deflection_m\n";
  for (const auto& p : j["presses"]) {
    csv += std::to_string(p["x_m"].get<double>()) + "," + std::to_string(p["y_m"].get<double>()) + "," +
           std::to_string(p["force_N"].get<double>()) + "," + std::to_string(2 * p["deflection_fem_m"].get<double>()) + "\n";
  }
  const auto out = (std::filesystem::temp_directory_path() / "pvdf_fit_cli_fitted.json").string();
  const auto r = pvdf::test::run_pvdfkit("fit '" + scene + "' '" + write("soft.csv", csv) + "' --params E_scale -o " + out + " --json");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const auto f = nlohmann::json::parse(r.out);
  CHECK(f["status"] == "converged");
  // Not exactly 1/8: large rotations and the probe footprint break the pure-membrane law slightly.
  CHECK(f["film"]["E_scale"].get<double>() == Approx(0.125).epsilon(0.05));
  const pvdf::Scene fitted = pvdf::load_scene(out);
  const pvdf::Scene base = pvdf::load_scene(scene);
  CHECK(fitted.material.E1_Pa / base.material.E1_Pa == Approx(f["film"]["E_scale"].get<double>()).epsilon(1e-9));
}

TEST_CASE("compare MAP warns about presses closer to an electrode than twice the map's spacing", "[fit][cli]") {
  const auto dir = std::filesystem::temp_directory_path();
  const std::string coarse = (dir / "pvdf_fit_cli_4mm.h5").string(), fine = (dir / "pvdf_fit_cli_1mm.h5").string();
  REQUIRE(pvdf::test::run_pvdfkit("synthetic-map -o " + coarse + " --spacing-m 0.004").exit_code == 0);
  REQUIRE(pvdf::test::run_pvdfkit("synthetic-map -o " + fine + " --spacing-m 0.001").exit_code == 0);
  // Line 2: 4 mm from electrode A (0, 10) mm; line 3: >= 17 mm from every electrode.
  const auto csv = write("near.csv", "x_m,y_m,force_N,charge_A_C,charge_B_C,charge_C_C\n0,0.006,1,1e-10,1e-10,1e-10\n"
                                     "0,-0.02,1,1e-10,1e-10,1e-10\n");
  const auto c = pvdf::test::run_pvdfkit("compare " + coarse + " " + csv);
  CHECK(c.err.find("warning: line 2: the press is 4.0 mm from electrode A") != std::string::npos);
  CHECK(c.err.find("line 3") == std::string::npos);
  const auto f = pvdf::test::run_pvdfkit("compare " + fine + " " + csv);
  CHECK(f.err.find("warning: line") == std::string::npos);
}
