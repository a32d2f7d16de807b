// The pvdfkit command end to end: moduli contract, --help everywhere, exit codes and one-line
// errors for malformed scene files.
#include "cli_runner.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/material.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

using pvdf::test::line_count;
using pvdf::test::run_pvdfkit;

namespace {

using pvdf::pi;

std::string write_temp(const std::string& name, const std::string& text) {
  const auto p = std::filesystem::temp_directory_path() / name;
  std::ofstream(p) << text;
  return p.string();
}

// Independent compliance rotation: Ex(β) = 1/S'1111 with S' from rotating the 2-D compliance
// tensor by direction cosines (the classical closed form 1/Ex = m⁴/E1 + (1/G12 − 2ν12/E1)m²n² + n⁴/E2,
// and likewise for the others), evaluated here from the compliance matrix entries directly.
struct Ref {
  double Ex, Ey, Gxy, nuxy, nuyx;
};
Ref reference(double beta) {
  const double E1 = 2.2e9, E2 = 1.8e9, G12 = 0.58e9, nu12 = 0.35;
  const double S11 = 1 / E1, S22 = 1 / E2, S12 = -nu12 / E1, S66 = 1 / G12;
  const double m = std::cos(beta), n = std::sin(beta);
  const double m2 = m * m, n2 = n * n;
  const double Sb11 = S11 * m2 * m2 + (2 * S12 + S66) * m2 * n2 + S22 * n2 * n2;
  const double Sb22 = S11 * n2 * n2 + (2 * S12 + S66) * m2 * n2 + S22 * m2 * m2;
  const double Sb12 = (S11 + S22 - S66) * m2 * n2 + S12 * (m2 * m2 + n2 * n2);
  const double Sb66 = 2 * (2 * S11 + 2 * S22 - 4 * S12 - S66) * m2 * n2 + S66 * (m2 * m2 + n2 * n2);
  return {1 / Sb11, 1 / Sb22, 1 / Sb66, -Sb12 / Sb11, -Sb12 / Sb22};
}

}  // namespace

TEST_CASE("pvdfkit moduli --json agrees with an independent compliance rotation to 1e-12", "[cli][moduli]") {
  const auto r = run_pvdfkit("moduli --json --angles-deg 0:7.5:180");
  REQUIRE(r.exit_code == 0);
  const auto j = nlohmann::json::parse(r.out);
  REQUIRE(j.is_array());
  REQUIRE(j.size() == 25);
  for (const auto& row : j) {
    const double beta = row.at("angle_deg").get<double>() * pi / 180;
    const Ref ref = reference(beta);
    INFO("angle " << row.at("angle_deg"));
    CHECK(std::abs(row.at("Ex_Pa").get<double>() / ref.Ex - 1) < 1e-12);
    CHECK(std::abs(row.at("Ey_Pa").get<double>() / ref.Ey - 1) < 1e-12);
    CHECK(std::abs(row.at("Gxy_Pa").get<double>() / ref.Gxy - 1) < 1e-12);
    CHECK(std::abs(row.at("nuxy").get<double>() / ref.nuxy - 1) < 1e-12);
    CHECK(std::abs(row.at("nuyx").get<double>() / ref.nuyx - 1) < 1e-12);
  }
}

TEST_CASE("pvdfkit moduli table, CSV and plot", "[cli][moduli]") {
  const auto table = run_pvdfkit("moduli");
  CHECK(table.exit_code == 0);
  CHECK_THAT(table.out, Catch::Contains("Ex_GPa"));
  const auto csv = run_pvdfkit("moduli --csv --angles-deg 0:45:90");
  CHECK(csv.exit_code == 0);
  CHECK(line_count(csv.out) == 4);
  CHECK_THAT(csv.out, Catch::StartsWith("angle_deg,Ex_Pa,Ey_Pa,Gxy_Pa,nuxy,nuyx"));
  const auto png = (std::filesystem::temp_directory_path() / "pvdf_test_moduli.png").string();
  std::filesystem::remove(png);
  const auto plot = run_pvdfkit("moduli --plot " + png);
  CHECK(plot.exit_code == 0);
  REQUIRE(std::filesystem::exists(png));
  std::ifstream in(png, std::ios::binary);
  char sig[8] = {};
  in.read(sig, 8);
  CHECK(std::string(sig + 1, 3) == "PNG");
  CHECK(std::filesystem::file_size(png) > 10000);
}

TEST_CASE("every subcommand answers --help with exit 0", "[cli]") {
  const auto top = run_pvdfkit("--help");
  REQUIRE(top.exit_code == 0);
  // Subcommand names are listed under "Subcommands:" as the first word of indented lines.
  const auto pos = top.out.find("Subcommands:");
  REQUIRE(pos != std::string::npos);
  std::istringstream lines(top.out.substr(pos));
  std::string line;
  std::getline(lines, line);
  int n = 0;
  while (std::getline(lines, line)) {
    std::istringstream words(line);
    std::string name;
    if (!(words >> name)) continue;
    const auto r = run_pvdfkit(name + " --help");
    INFO(name);
    CHECK(r.exit_code == 0);
    CHECK_THAT(r.out, Catch::Contains("Usage"));
    ++n;
  }
  CHECK(n >= 1);
}

TEST_CASE("malformed scene files give exit 2 and one line naming the key", "[cli][errors]") {
  struct Case {
    std::string name, text, expect;
  };
  const std::vector<Case> cases = {
      {"bad_json.json", "{\"membrane\": {\"radius_m\": 0.045,, }}", "bad_json.json:1:"},
      {"unknown_key.json", "{\"membrane\": {\"thicknes_m\": 25e-6}}", "membrane.thicknes_m"},
      {"negative.json", "{\"membrane\": {\"thickness_m\": -2.5e-5}}", "membrane.thickness_m"},
      {"nan.json", "{\"membrane\": {\"thickness_m\": NaN}}", "thickness_m"},
      {"wrong_type.json", "{\"material\": {\"E1_Pa\": \"2.2 GPa\"}}", "material.E1_Pa"},
      {"top_array.json", "[]", "JSON object"},
  };
  for (const auto& c : cases) {
    const auto path = write_temp("pvdf_cli_" + c.name, c.text);
    const auto r = run_pvdfkit("moduli --scene " + path);
    INFO(c.name << ": " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(line_count(r.err) == 1);
    CHECK_THAT(r.err, Catch::StartsWith("error: ") && Catch::Contains(c.expect));
    CHECK(r.out.empty());
  }
  const auto missing = run_pvdfkit("moduli --scene /nonexistent/dir/scene.json");
  CHECK(missing.exit_code == 2);
  CHECK(line_count(missing.err) == 1);
  CHECK_THAT(missing.err, Catch::Contains("/nonexistent/dir/scene.json"));
}

TEST_CASE("bad flags give exit 2 with one error line", "[cli][errors]") {
  for (const std::string args : {"moduli --angles-deg 0:0:90", "moduli --angles-deg abc", "moduli --no-such-flag",
                                 "no-such-command", "moduli --json --csv", "moduli --plot /nonexistent/dir/x.png"}) {
    const auto r = run_pvdfkit(args);
    INFO(args << " -> " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(line_count(r.err) == 1);
    CHECK_THAT(r.err, Catch::StartsWith("error: "));
  }
}
