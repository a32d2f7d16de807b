// Must show (issue 32): the charge maps of three layouts that are not in the atlas's scene, read from
// the atlas, against ordinary FEM maps of those layouts (pvdf::mapping::generate_map, which
// integrates each electrode over its own FE mesh: an independent path) at every node:
//   |atlas − direct| ≤ the atlas's stated error + the direct map's stated error, and
//   |atlas − direct| ≤ tolerance × the press's largest charge.
// Layouts on a 12 mm film (the issue's, scaled to it): four 3 mm squares on a 10 mm square; five
// 2 mm squares turned 45° on a pentagon turned 45°; three 1 × 6 mm strips at 30°. Also the file
// round trip and the refusal of an atlas of another film.
#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/mapping/atlas.hpp"
#include "pvdf/mapping/generate.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include "../test_worst.hpp"

using namespace pvdf::mapping;

namespace {

const double tolerance = 0.04;

nlohmann::json film_json() {
  return nlohmann::json::parse(R"({
    "membrane": {"shape": "circle", "radius_m": 0.012, "thickness_m": 25e-6},
    "material": {"E1_Pa": 2.2e9, "E2_Pa": 1.8e9, "G12_Pa": 0.58e9, "nu12": 0.35,
                 "draw_angle_deg": 0.0, "d31_C_per_N": 6.5e-12, "d32_C_per_N": 0.65e-12},
    "electrodes": [{"name": "A", "center_m": [0.0, 0.0], "size_m": [0.004, 0.004]}],
    "probe": {"radius_m": 0.00075},
    "model": {"kinematics": "auto", "tolerance": 0.04, "max_refinements": 0}
  })");
}

nlohmann::json square(const std::string& name, double x, double y, double w, double h, double angle_deg) {
  return {{"name", name}, {"center_m", {x, y}}, {"size_m", {w, h}}, {"angle_deg", angle_deg}};
}

pvdf::Scene layout(const std::string& which) {
  nlohmann::json j = film_json();
  nlohmann::json e = nlohmann::json::array();
  if (which == "four squares") {
    int k = 0;
    for (double x : {-0.005, 0.005})
      for (double y : {-0.005, 0.005}) e.push_back(square("S" + std::to_string(++k), x, y, 0.003, 0.003, 0));
  } else if (which == "pentagon") {
    for (int k = 0; k < 5; ++k) {
      const double t = (45.0 + 72.0 * k) * pvdf::pi / 180;
      e.push_back(square("P" + std::to_string(k + 1), 0.006 * std::cos(t), 0.006 * std::sin(t), 0.002, 0.002, 45));
    }
  } else {
    e.push_back(square("T1", -0.005, 0.0, 0.001, 0.006, 30));
    e.push_back(square("T2", 0.0, 0.0, 0.001, 0.006, 30));
    e.push_back(square("T3", 0.005, 0.0, 0.001, 0.006, 30));
  }
  j["electrodes"] = e;
  return pvdf::parse_scene(j, which);
}

double cpu_s() { return double(std::clock()) / CLOCKS_PER_SEC; }

}  // namespace

TEST_CASE("maps read from the atlas agree with direct FEM maps within their stated errors", "[atlas][slow]") {
  const pvdf::Scene film = pvdf::parse_scene(film_json(), "atlas-film");
  AtlasOptions ao;
  ao.spacing_m = 0.003;
  ao.forces_N = {1.0};
  ao.tolerance = tolerance;
  ao.cell_m = 0.001;
  ao.threads = 1;  // one sweep setup (a second thread would build its own sweep mesh again)
  AtlasReport ar;
  const double t_atlas = cpu_s();
  const auto wall0 = std::chrono::steady_clock::now();
  const ChargeAtlas generated = generate_atlas(film, ao, &ar);
  const double atlas_cpu = cpu_s() - t_atlas;
  const double atlas_wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  REQUIRE(ar.n_failed == 0);
  REQUIRE(ar.n_positions > 20);

  // The file round trip: what map --atlas reads is what was generated.
  const std::string path = (std::filesystem::temp_directory_path() / "pvdf_test_atlas.atlas.h5").string();
  write_atlas(path, generated);
  const ChargeAtlas atlas = read_atlas(path);
  REQUIRE(atlas.moments.size() == generated.moments.size());
  for (std::size_t k = 0; k < atlas.moments.size(); ++k)
    if (!std::isnan(generated.moments[k])) REQUIRE(atlas.moments[k] == generated.moments[k]);
  std::printf("atlas: %zu positions (%zu solved, the rest mirror images, %zu by the rim model), %zu DOFs, FE size %g mm, largest press estimate %.3g, %.1f CPU s, %.1f s wall (setup %.1f s)\n", ar.n_positions,
              ar.n_solved_positions, ar.n_rim_solves, atlas.n_dofs, 1e3 * atlas.fe_size_m, ar.estimated_relative_error, atlas_cpu, atlas_wall, ar.setup_s);

  for (const std::string which : {"four squares", "pentagon", "strips"}) {
    const pvdf::Scene scene = layout(which);
    const double t_read = cpu_s();
    const ChargeMap from_atlas = map_from_atlas(atlas, scene, path);
    const double read_cpu = cpu_s() - t_read;
    MapOptions mo;
    mo.spacing_m = ao.spacing_m;
    mo.forces_N = ao.forces_N;
    mo.tolerance = tolerance;
    mo.threads = 2;
    const double t_map = cpu_s();
    const ChargeMap direct = generate_map(scene, mo);
    const double map_cpu = cpu_s() - t_map;
    REQUIRE(direct.x_m == from_atlas.x_m);
    REQUIRE(direct.y_m == from_atlas.y_m);
    std::size_t nodes = 0;
    double worst_vs_errors = 0, worst_vs_tolerance = 0, worst_atlas_error = 0;
    for (std::size_t f = 0; f < direct.nf(); ++f)
      for (std::size_t j = 0; j < direct.ny(); ++j)
        for (std::size_t i = 0; i < direct.nx(); ++i) {
          const std::size_t p = direct.point(f, j, i);
          if (!direct.mask[j * direct.nx() + i]) continue;
          REQUIRE(int(direct.status[p]) == int(PointStatus::ok));
          REQUIRE(int(from_atlas.status[p]) == int(PointStatus::ok));
          double largest = 0;
          for (std::size_t k = 0; k < direct.ne(); ++k) largest = pvdf::testing::worst_of(largest, std::abs(direct.charge_C[direct.charge_index(f, j, i, k)]));
          REQUIRE(largest > 0);
          for (std::size_t k = 0; k < direct.ne(); ++k) {
            const std::size_t c = direct.charge_index(f, j, i, k);
            const double diff = std::abs(from_atlas.charge_C[c] - direct.charge_C[c]);
            const double stated = from_atlas.estimated_charge_error_C[c] + direct.estimated_charge_error_C[c];
            INFO(which << " node (" << direct.x_m[i] << ", " << direct.y_m[j] << ") electrode " << direct.electrode_names[k]
                       << ": atlas " << from_atlas.charge_C[c] << " C, direct " << direct.charge_C[c] << " C, stated errors "
                       << from_atlas.estimated_charge_error_C[c] << " + " << direct.estimated_charge_error_C[c]);
            CHECK(diff <= stated);                   // false for NaN
            CHECK(diff <= tolerance * largest);
            worst_vs_errors = pvdf::testing::worst_of(worst_vs_errors, diff / stated);
            worst_vs_tolerance = pvdf::testing::worst_of(worst_vs_tolerance, diff / (tolerance * largest));
            worst_atlas_error = pvdf::testing::worst_of(worst_atlas_error, from_atlas.estimated_charge_error_C[c] / largest);
          }
          ++nodes;
        }
    CHECK(nodes == ar.n_positions);
    std::printf("%s: %zu nodes, max |diff| / (stated errors) = %.3f, max |diff| / (tolerance x largest charge) = %.3f, "
                "largest atlas error / largest charge = %.3g; map from atlas %.3f CPU s, direct map %.1f CPU s\n",
                which.c_str(), nodes, worst_vs_errors, worst_vs_tolerance, worst_atlas_error, read_cpu, map_cpu);
  }

  // An atlas of another film is refused, naming what differs.
  nlohmann::json other = film_json();
  other["membrane"]["thickness_m"] = 28e-6;
  try {
    (void)map_from_atlas(atlas, pvdf::parse_scene(other, "thicker.json"), path);
    FAIL("an atlas of a 25 um film was accepted for a 28 um one");
  } catch (const pvdf::InputError& e) {
    CHECK(std::string(e.what()).find("thickness_m") != std::string::npos);
  }
  other = film_json();
  other["probe"]["radius_m"] = 0.001;
  CHECK_THROWS_AS(map_from_atlas(atlas, pvdf::parse_scene(other, "probe.json"), path), pvdf::InputError);

  // The keep-out band along the clamp (default 1 mm) is written and read back, and a layout reaching
  // into it is refused; one just inside it is served.
  CHECK(atlas.keep_out_m == 0.001);
  other = film_json();
  other["electrodes"] = nlohmann::json::array({square("E", 0.0105, 0.0, 0.002, 0.002, 0)});  // reaches r = 11.5 mm
  try {
    (void)map_from_atlas(atlas, pvdf::parse_scene(other, "near-clamp.json"), path);
    FAIL("an electrode 0.5 mm from the clamp was read from an atlas that serves 1 mm inside it");
  } catch (const pvdf::InputError& e) {
    CHECK(std::string(e.what()).find("keep-out") != std::string::npos);
  }
  other["electrodes"] = nlohmann::json::array({square("E", 0.0095, 0.0, 0.001, 0.001, 0)});  // corners at r < 10.02 mm
  CHECK_NOTHROW(map_from_atlas(atlas, pvdf::parse_scene(other, "inside.json"), path));
  std::filesystem::remove(path);
}
