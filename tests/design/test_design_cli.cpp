// End-to-end: `pvdfkit design` on synthetic previews — ranking JSON, coincident electrodes
// (unable to locate: exit 3 when no layout can), bad --vary keys (exit 2), rotation through
// --vary @rotation_deg, figures written.
#include "../app/cli_runner.hpp"

#include "pvdf/core/scene.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>

using pvdf::test::run_pvdfkit;

namespace {

std::string dir() {
  const auto d = std::filesystem::temp_directory_path() / "pvdf_test_design_cli";
  std::filesystem::create_directories(d);
  return d.string();
}

std::string seed_scene() { return std::string(PVDF_SOURCE_DIR) + "/examples/scenes/seed001.json"; }

/// The seed-001 scene with electrode C moved onto B (parse_scene accepts it; only meshing refuses overlaps).
std::string coincident_scene() {
  nlohmann::json j = nlohmann::json::parse(pvdf::default_scene_json());
  j["electrodes"][2]["center_m"] = j["electrodes"][1]["center_m"];
  const std::string path = dir() + "/coincident.json";
  std::ofstream(path) << j.dump(2);
  return path;
}

}  // namespace

TEST_CASE("design ranks a layout; coincident electrodes are refused as bad input", "[design][cli]") {
  const std::string out = dir() + "/out1";
  const auto r = run_pvdfkit("design " + seed_scene() + " --synthetic --spacing-m 0.002 --json --out-dir " + out);
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  CHECK(r.out.find("nan") == std::string::npos);
  CHECK(r.out.find("inf\"") == std::string::npos);
  const auto j = nlohmann::json::parse(r.out);
  CHECK(j["synthetic"] == true);
  REQUIRE(j["layouts"].size() == 1);
  CHECK(j["layouts"][0]["label"] == "seed001");
  CHECK(j["layouts"][0]["status"] == "ok");
  CHECK(j["best"] == "seed001");
  CHECK(std::filesystem::file_size(out + "/design_position.png") > 10000);
  CHECK(std::filesystem::file_size(out + "/design_force.png") > 10000);
  CHECK(std::filesystem::exists(out + "/design.json"));

  // Two electrodes in one place overlap: the scene reader refuses the file (exit 2), naming it.
  const auto alone = run_pvdfkit("design " + coincident_scene() + " --synthetic --spacing-m 0.002 --no-plots");
  CHECK(alone.exit_code == 2);
  CHECK(alone.err.find("electrodes[2]") != std::string::npos);
  CHECK(alone.err.find("overlaps") != std::string::npos);
}

TEST_CASE("design --vary sweeps a scene key; rotation leaves the figures of merit unchanged", "[design][cli]") {
  const std::string out = dir() + "/out2";
  const auto r = run_pvdfkit("design " + seed_scene() +
                             " --vary @rotation_deg=0:90:90 --synthetic --spacing-m 0.0015 --json --out-dir " + out);
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const auto j = nlohmann::json::parse(r.out);
  REQUIRE(j["layouts"].size() == 2);
  CHECK(j["vary"]["key"] == "@rotation_deg");
  CHECK(j["layouts"][0]["coverage"].get<double>() ==
        Approx(j["layouts"][1]["coverage"].get<double>()).margin(0.002));
  CHECK(j["layouts"][0]["median_sigma_pos_m"].get<double>() ==
        Approx(j["layouts"][1]["median_sigma_pos_m"].get<double>()).epsilon(1e-6));
  CHECK(std::filesystem::file_size(out + "/design_sweep.png") > 10000);

  // A sweep of a key the layout depends on changes the result.
  const auto s = run_pvdfkit("design " + seed_scene() +
                             " --vary material.draw_angle_deg=0:45:45 --synthetic --spacing-m 0.002 --json --no-plots");
  REQUIRE(s.exit_code == 0);
  const auto k = nlohmann::json::parse(s.out);
  const double m0 = k["layouts"][0]["median_sigma_pos_m"].get<double>(), m1 = k["layouts"][1]["median_sigma_pos_m"].get<double>();
  CHECK(std::abs(m0 - m1) > 0.01 * m0);
}

TEST_CASE("design refuses bad input with exit 2 and a one-line message", "[design][cli]") {
  const auto bad_key = run_pvdfkit("design " + seed_scene() + " --vary material.draw_angel_deg=0:15:30 --synthetic --no-plots");
  CHECK(bad_key.exit_code == 2);
  CHECK(bad_key.err.find("draw_angel_deg") != std::string::npos);
  const auto bad_range = run_pvdfkit("design " + seed_scene() + " --vary @layout_scale=1:0:2 --synthetic --no-plots");
  CHECK(bad_range.exit_code == 2);
  const auto nothing = run_pvdfkit("design --synthetic");
  CHECK(nothing.exit_code == 2);
  const auto noise = run_pvdfkit("design " + seed_scene() + " --synthetic --noise-C -1 --no-plots");
  CHECK(noise.exit_code == 2);
  CHECK(noise.err.find("noise") != std::string::npos);
}
