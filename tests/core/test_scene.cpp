// Scene files: defaults, every documented key, and each kind of bad input named precisely.
#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/core/json_reader.hpp"
#include "pvdf/core/scene.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <string>

namespace {

pvdf::Scene parse(const std::string& text) {
  return pvdf::parse_scene(pvdf::parse_json_text(text, "test.json"), "test.json");
}

std::string error_of(const std::string& text) {
  try {
    parse(text);
  } catch (const pvdf::InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("the built-in seed-001 scene is the documented example", "[scene]") {
  const auto s = pvdf::default_scene();
  CHECK(s.membrane.outline.shape == pvdf::FilmOutline::Shape::circle);
  CHECK(s.membrane.outline.radius_m == Approx(0.045));
  CHECK(s.membrane.thickness_m == Approx(25e-6));
  REQUIRE(s.electrodes.size() == 3);
  // Equilateral triangle of circumradius 10 mm centred on the film.
  for (const auto& e : s.electrodes) {
    CHECK(std::hypot(e.center_m[0], e.center_m[1]) == Approx(0.010).epsilon(1e-12));
    CHECK(e.area_m2() == Approx(4e-6).epsilon(1e-14));
  }
  const auto& a = s.electrodes[0].center_m;
  const auto& b = s.electrodes[1].center_m;
  CHECK(std::hypot(a[0] - b[0], a[1] - b[1]) == Approx(0.010 * std::sqrt(3.0)).epsilon(1e-12));
  // The scene leaves nu21 to reciprocity (Table 1's 0.28 is not reciprocal: see below).
  CHECK(s.warnings.empty());
  CHECK(s.material.nu21() == Approx(0.35 * 1.8 / 2.2));
  // The example file in examples/scenes is the same scene.
  const auto f = pvdf::load_scene(std::string(PVDF_SOURCE_DIR) + "/examples/scenes/seed001.json");
  CHECK(pvdf::scene_to_json(f) == pvdf::scene_to_json(s));
}

TEST_CASE("Table 1's non-reciprocal nu21 draws one warning; the law keeps nu12*E2/E1", "[scene]") {
  const auto s = parse(R"({"material": {"E1_Pa": 2.2e9, "E2_Pa": 1.8e9, "nu12": 0.35, "nu21": 0.28}})");
  REQUIRE(s.warnings.size() == 1);
  CHECK_THAT(s.warnings[0], Catch::Contains("material.nu21") && Catch::Contains("0.286"));
  CHECK(s.material.nu21() == Approx(0.35 * 1.8 / 2.2).epsilon(1e-15));
  CHECK(s.material.nu21_table == 0.28);
  // Within 0.5 %: silent.
  CHECK(parse(R"({"material": {"nu21": 0.2865}})").warnings.empty());
}

TEST_CASE("defaults fill every optional key; the minimal scene is {}", "[scene]") {
  const auto s = parse("{}");
  CHECK(s.membrane.outline.radius_m == 0.045);
  CHECK(s.material.E1_Pa == 2.2e9);
  CHECK(s.electrodes.empty());
  REQUIRE(s.loads.size() == 1);
  CHECK(s.loads[0].force_N == 1.0);
  CHECK(s.model.kinematics == "auto");
  // Round trip through scene_to_json keeps everything.
  const auto again = pvdf::parse_scene(pvdf::scene_to_json(s), "again");
  CHECK(pvdf::scene_to_json(again) == pvdf::scene_to_json(s));
}

TEST_CASE("isotropic material, other outlines and electrode shapes parse", "[scene]") {
  const auto s = parse(R"({"membrane": {"shape": "ellipse", "semi_axes_m": [0.04, 0.03]},
    "material": {"E_Pa": 2e9, "nu": 0.3},
    "electrodes": [{"name": "R", "center_m": [0.01, 0], "size_m": [0.002, 0.001], "angle_deg": 30},
                   {"name": "C", "shape": "circle", "center_m": [-0.01, 0], "radius_m": 0.001},
                   {"name": "P", "shape": "polygon", "vertices_m": [[0, 0.01], [0.002, 0.01], [0.001, 0.012]]}]})");
  CHECK(s.material.isotropic);
  CHECK(s.material.G12_Pa == Approx(2e9 / 2.6));
  CHECK(s.membrane.outline.area_m2() == Approx(pvdf::pi * 0.04 * 0.03));
  CHECK(s.electrodes[0].area_m2() == Approx(2e-6));
  CHECK(s.electrodes[1].area_m2() == Approx(pvdf::pi * 1e-6));
  CHECK(s.electrodes[2].area_m2() == Approx(2e-6));
  const auto o = s.electrodes[0].outline();
  CHECK(o.size() == 4);
  // Rotated rectangle keeps its side lengths.
  CHECK(std::hypot(o[1][0] - o[0][0], o[1][1] - o[0][1]) == Approx(0.002));
  const auto r = parse(R"({"membrane": {"shape": "rectangle", "size_m": [0.08, 0.06]}})");
  CHECK(r.membrane.outline.perimeter_m() == Approx(0.28));
  CHECK(r.membrane.outline.inscribed_radius_m() == Approx(0.03));
  const auto p = parse(R"({"membrane": {"shape": "polygon", "vertices_m": [[-0.03,-0.03],[0.03,-0.03],[0,0.04]]}})");
  CHECK(p.membrane.outline.area_m2() == Approx(0.5 * 0.06 * 0.07));
}

TEST_CASE("bad input is rejected with a message naming the key", "[scene][errors]") {
  CHECK_THAT(error_of(R"({"membrane": {"thickness_m": -2.5e-5}})"),
             Catch::Contains("membrane.thickness_m") && Catch::Contains("-2.5e-05"));
  CHECK_THAT(error_of(R"({"membrane": {"thicknes_m": 2.5e-5}})"),
             Catch::Contains("unknown key membrane.thicknes_m"));
  CHECK_THAT(error_of(R"({"membrane": {"radius_m": "big"}})"),
             Catch::Contains("membrane.radius_m") && Catch::Contains("must be a number"));
  CHECK_THAT(error_of(R"({"electrodes": [{"name": "A", "center_m": [0, 1e400]}]})"),
             Catch::Contains("center_m") && Catch::Contains("1e400"));
  CHECK_THAT(error_of(R"({"electrodes": [{"name": "A", "center_m": [0, 0]}, {"name": "A", "center_m": [0.01, 0]}]})"),
             Catch::Contains("electrodes[1].name"));
  CHECK_THAT(error_of(R"({"electrodes": [{"name": "A", "center_m": [0, 0], "size_m": [0, 0.002]}]})"),
             Catch::Contains("electrodes[0].size_m"));
  CHECK_THAT(error_of(R"({"electrodes": [{"shape": "polygon", "vertices_m": [[0,0],[1e-3,1e-3],[1e-3,0],[0,1e-3]]}]})"),
             Catch::Contains("self-intersecting"));
  CHECK_THAT(error_of(R"({"material": {"nu12": 0.35, "nu21": 0.9}})"), Catch::Contains("material.nu21"));
  CHECK_THAT(error_of(R"({"material": {"E_Pa": 2e9, "E1_Pa": 2e9}})"), Catch::Contains("material.E1_Pa"));
  CHECK_THAT(error_of(R"({"loads": [{"position_m": [0.05, 0.0]}]})"), Catch::Contains("loads[0].position_m"));
  CHECK_THAT(error_of(R"({"model": {"kinematics": "magic"}})"), Catch::Contains("model.kinematics"));
  CHECK_THAT(error_of(R"([1, 2])"), Catch::Contains("JSON object"));
  CHECK_THAT(error_of(R"({"mesh": {"size_min_m": 0.01, "size_max_m": 0.001}})"), Catch::Contains("mesh.size_max_m"));
}

TEST_CASE("syntax errors and NaN name the line and the key", "[scene][errors]") {
  try {
    pvdf::parse_json_text("{\n  \"membrane\": {\"thickness_m\": NaN}\n}", "s.json");
    FAIL("NaN accepted");
  } catch (const pvdf::InputError& e) {
    const std::string m = e.what();
    CHECK_THAT(m, Catch::Contains("s.json:2:") && Catch::Contains("thickness_m") && Catch::Contains("NaN"));
  }
  try {
    pvdf::parse_json_text("{\"a\": 1,}", "s.json");
    FAIL("trailing comma accepted");
  } catch (const pvdf::InputError& e) {
    CHECK_THAT(std::string(e.what()), Catch::Contains("s.json:1:"));
  }
  try {
    pvdf::load_scene("/nonexistent/scene.json");
    FAIL("missing file accepted");
  } catch (const pvdf::InputError& e) {
    CHECK_THAT(std::string(e.what()), Catch::Contains("/nonexistent/scene.json"));
  }
}

// ---------------------------------------------------------------------------- hostile input

namespace {

/// A valid scene whose description is `n` characters long (so the file is about n bytes).
std::string scene_with_description(std::size_t n) {
  return "{\"description\": \"" + std::string(n, 'x') + "\",\n \"membrane\": {\"radius_m\": 0.045}}";
}

}  // namespace

TEST_CASE("a large JSON file with a syntax error gets its line, not a crash", "[scene][errors][hostile]") {
  for (const std::size_t n : {20000u, 40000u, 1000000u}) {
    std::string text = scene_with_description(n);
    text.pop_back();  // the final '}' is missing
    INFO("description of " << n << " characters");
    try {
      pvdf::parse_json_text(text, "big.json");
      FAIL("truncated file accepted");
    } catch (const pvdf::InputError& e) {
      CHECK_THAT(std::string(e.what()), Catch::StartsWith("big.json:2:"));
    }
  }
  // A truncated long array: the key under which the file ends is named.
  std::string arr = "{\"electrodes\": [";
  for (int i = 0; i < 5000; ++i) arr += "{\"name\": \"E" + std::to_string(i) + "\", \"center_m\": [0, 0]},";
  CHECK_THROWS_AS(pvdf::parse_json_text(arr, "arr.json"), pvdf::InputError);
}

TEST_CASE("deeply nested JSON is refused at a depth limit with its position", "[scene][errors][hostile]") {
  for (const char* open : {"[", "{\"a\":"}) {
    std::string text;
    for (int i = 0; i < 100000; ++i) text += open;
    try {
      pvdf::parse_json_text(text, "deep.json");
      FAIL("deep nesting accepted");
    } catch (const pvdf::InputError& e) {
      CHECK_THAT(std::string(e.what()), Catch::StartsWith("deep.json:1:") && Catch::Contains("nest"));
    }
  }
  // A nested value that is valid JSON is refused as well (never dumped recursively).
  std::string ok;
  for (int i = 0; i < 50000; ++i) ok += "[";
  for (int i = 0; i < 50000; ++i) ok += "]";
  CHECK_THROWS_AS(parse("{\"name\": " + ok + "}"), pvdf::InputError);
  // json_excerpt of a deep value built in code is short and does not recurse.
  nlohmann::json deep = nlohmann::json::array();
  nlohmann::json* leaf = &deep;
  for (int i = 0; i < 200000; ++i) {
    leaf->push_back(nlohmann::json::array());
    leaf = &leaf->back();
  }
  CHECK(pvdf::json_excerpt(deep).size() <= 64);
}

TEST_CASE("a duplicate key is refused, naming the key", "[scene][errors][hostile]") {
  CHECK_THAT(error_of(R"({"membrane": {"radius_m": 0.045, "radius_m": 0.03}})"),
             Catch::Contains("duplicate key") && Catch::Contains("membrane.radius_m"));
  CHECK_THAT(error_of(R"({"model": {}, "model": {}})"), Catch::Contains("duplicate key") && Catch::Contains("model"));
  // The same key in two different objects is fine.
  CHECK_NOTHROW(parse(R"({"electrodes": [{"name": "A", "center_m": [0, 0.01]}, {"name": "B", "center_m": [0, -0.01]}]})"));
}

TEST_CASE("control bytes in a garbage file are escaped in the message", "[scene][errors][hostile]") {
  const std::string garbage("\x01\x02\x1b[31m\x00\x7f zz", 12);
  try {
    pvdf::parse_json_text(garbage, "garbage.json");
    FAIL("garbage accepted");
  } catch (const pvdf::InputError& e) {
    const std::string m = e.what();
    CHECK_THAT(m, Catch::StartsWith("garbage.json:1:1"));
    for (const char c : m) CHECK_FALSE((static_cast<unsigned char>(c) < 0x20 || c == 0x7f));
    CHECK_THAT(m, Catch::Contains("\\x01"));
  }
}

TEST_CASE("electrode geometry is checked by the scene reader", "[scene][errors][hostile]") {
  // Outside the film, across the rim, two overlapping: refused for every command.
  CHECK_THAT(error_of(R"({"electrodes": [{"name": "A", "center_m": [0, 0.06]}]})"),
             Catch::Contains("electrodes[0]") && Catch::Contains("outside the film"));
  CHECK_THAT(error_of(R"({"electrodes": [{"name": "A", "center_m": [0, 0.0445]}]})"),
             Catch::Contains("electrodes[0]") && Catch::Contains("rim"));
  CHECK_THAT(error_of(R"({"electrodes": [{"name": "A", "center_m": [0, 0.01]}, {"name": "B", "center_m": [0.001, 0.0105]}]})"),
             Catch::Contains("electrodes[1]") && Catch::Contains("overlaps") && Catch::Contains("electrodes[0]"));
  CHECK_THAT(error_of(R"({"electrodes": [{"shape": "circle", "center_m": [0, 0.01], "radius_m": 0.003},
                                         {"shape": "polygon", "vertices_m": [[0, 0.01], [0.01, 0.01], [0.01, 0.02]]}]})"),
             Catch::Contains("electrodes[1]") && Catch::Contains("overlaps"));
  // The seed-001 layout and a layout near (not at) the rim are fine.
  CHECK_NOTHROW(parse(R"({"electrodes": [{"name": "A", "center_m": [0, 0.040]}, {"name": "B", "center_m": [0, 0.036]}]})"));
}

TEST_CASE("sizes outside the documented physical range are refused", "[scene][errors][hostile]") {
  CHECK_THAT(error_of(R"({"membrane": {"radius_m": 1e308}})"), Catch::Contains("membrane.radius_m") && Catch::Contains("1e+308"));
  CHECK_THAT(error_of(R"({"membrane": {"radius_m": 1e-9}})"), Catch::Contains("membrane.radius_m"));
  CHECK_THAT(error_of(R"({"membrane": {"shape": "rectangle", "size_m": [1e300, 0.05]}})"), Catch::Contains("membrane.size_m"));
  CHECK_THAT(error_of(R"({"probe": {"radius_m": 1e-20}})"), Catch::Contains("probe.radius_m") && Catch::Contains("1e-20"));
  CHECK_THAT(error_of(R"({"probe": {"radius_m": 1e-300}})"), Catch::Contains("probe.radius_m"));
  CHECK_THAT(error_of(R"({"probe": {"radius_m": 0.04}})"), Catch::Contains("probe.radius_m"));
  CHECK_THAT(error_of(R"({"electrodes": [{"name": "A", "center_m": [0, 0.01], "size_m": [1e-9, 0.002]}]})"),
             Catch::Contains("electrodes[0].size_m"));
  CHECK_THAT(error_of(R"({"mesh": {"size_min_m": 1e-9}})"), Catch::Contains("mesh.size_min_m"));
  // The probe footprint must stay a probe radius clear of the rim (the margin maps keep).
  CHECK_THAT(error_of(R"({"loads": [{"position_m": [0, 0.044]}]})"), Catch::Contains("loads[0]") && Catch::Contains("rim"));
  CHECK_THAT(error_of(R"({"loads": [{"position_m": [0, 0.0435]}]})"), Catch::Contains("loads[0]"));
  CHECK_NOTHROW(parse(R"({"loads": [{"position_m": [0, 0.043]}]})"));
  CHECK_NOTHROW(parse(R"({"probe": {"radius_m": 1e-4}})"));
}
