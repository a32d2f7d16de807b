// `pvdfkit solve` on the seed-001 scene: converges, prints the JSON contract of the fem issue,
// and obeys the scene's mirror symmetry (electrodes B and C mirror each other about x = 0 with
// the draw along x, so N11, N22 are equal and N12 opposite) and the exact probe force.
#include "../app/cli_runner.hpp"

#include "axisymmetric_plate.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

using pvdf::test::run_pvdfkit;

TEST_CASE("pvdfkit solve seed-001 --json converges and prints the contract", "[fem][cli]") {
  const auto r = run_pvdfkit("solve " + std::string(PVDF_SOURCE_DIR) +
                             "/examples/scenes/seed001.json --json --sample 0.01,0 --sample -0.01,0");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const auto j = nlohmann::json::parse(r.out);
  for (const char* key : {"status", "model", "n_dofs", "newton_iterations", "wall_s", "estimated_relative_error",
                          "max_deflection_m", "deflection_at_load_m", "electrodes", "samples"}) {
    INFO(key);
    CHECK(j.contains(key));
  }
  CHECK(j.at("status") == "converged");
  CHECK(j.at("estimated_relative_error").get<double>() <= 0.01);
  // (The deflection's accuracy is checked against the oracle in the isotropic test below.)
  CHECK(std::isfinite(j.at("deflection_at_load_m").get<double>()));
  const auto& e = j.at("electrodes");
  REQUIRE(e.size() == 3);
  for (const auto& el : e) {
    CHECK(el.at("area_m2").get<double>() == Approx(4e-6).epsilon(1e-9));
    CHECK(el.at("mean_membrane_force_material_N_per_m").size() == 3);
  }
  const auto& b = e[1].at("mean_membrane_force_material_N_per_m");
  const auto& c = e[2].at("mean_membrane_force_material_N_per_m");
  CHECK(b[0].get<double>() == Approx(c[0].get<double>()).epsilon(1e-6));
  CHECK(b[1].get<double>() == Approx(c[1].get<double>()).epsilon(1e-6));
  CHECK(b[2].get<double>() == Approx(-c[2].get<double>()).epsilon(1e-6));
  // Electrode A sits on the mirror axis: no shear there.
  const auto& a = e[0].at("mean_membrane_force_material_N_per_m");
  CHECK(std::abs(a[2].get<double>()) < 1e-6 * std::abs(a[1].get<double>()));
  // The two mirrored samples see the same deflection and mirrored forces.
  const auto& s = j.at("samples");
  REQUIRE(s.size() == 2);
  CHECK(s[0].at("w_m").get<double>() == Approx(s[1].at("w_m").get<double>()).epsilon(1e-6));
  const auto& n0 = s[0].at("membrane_force_global_N_per_m");
  const auto& n1 = s[1].at("membrane_force_global_N_per_m");
  CHECK(n0[0].get<double>() == Approx(n1[0].get<double>()).epsilon(1e-5));
  // On the x axis the shear vanishes by symmetry: pointwise values carry the discretization error.
  CHECK(std::abs(n0[2].get<double>()) < 1e-3 * std::abs(n0[0].get<double>()));
  CHECK(std::abs(n1[2].get<double>()) < 1e-3 * std::abs(n1[0].get<double>()));
  // The model choice is reported with its reason.
  CHECK_THAT(j.at("model_reason").get<std::string>(), Catch::Contains("bending"));
}

// The same command on the seed-001 geometry with an isotropic film (E = 2 GPa, ν = 0.3), where the
// axisymmetric Green–Lagrange membrane oracle is exact: the deflection under the probe and the radial
// membrane force at 10 mm must be within the tolerance the command was given (1 %).
TEST_CASE("pvdfkit solve on an isotropic seed-001 film agrees with the oracle within --tolerance", "[fem][cli][oracle]") {
  nlohmann::json scene = nlohmann::json::parse(std::ifstream(std::string(PVDF_SOURCE_DIR) + "/examples/scenes/seed001.json"));
  scene["material"] = {{"E_Pa", 2e9}, {"nu", 0.3}, {"draw_angle_deg", 0.0}, {"d31_C_per_N", 6.5e-12}, {"d32_C_per_N", 0.65e-12}};
  const std::string path = (std::filesystem::temp_directory_path() / "pvdf_iso_seed001.json").string();
  std::ofstream(path) << scene.dump();
  const double tolerance = 0.01;
  const auto r = run_pvdfkit("solve " + path + " --json --tolerance " + std::to_string(tolerance) +
                             " --sample 0.0095533,0.0029552");  // 10 mm at 0.3 rad
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const auto j = nlohmann::json::parse(r.out);
  INFO(j.dump());
  REQUIRE(j.at("status") == "converged");
  pvdf::fem::oracles::AxisymmetricProblem p;  // a = 45 mm, h = 25 µm, E = 2 GPa, ν = 0.3, 1 N on c = 1 mm
  p.kinematics = pvdf::fem::oracles::Kinematics::green_lagrange;
  const auto oracle = pvdf::fem::oracles::solve_axisymmetric(p);
  REQUIRE(oracle.converged);
  const double w = j.at("deflection_at_load_m").get<double>();
  CHECK(std::abs(w - oracle.centre_deflection_m()) <= tolerance * oracle.centre_deflection_m());
  const double nr = j.at("samples")[0].at("membrane_force_polar_N_per_m")[0].get<double>();
  CHECK(std::abs(nr - oracle.radial_force_N_per_m(0.01)) <= tolerance * oracle.radial_force_N_per_m(0.01));
  std::filesystem::remove(path);
}
