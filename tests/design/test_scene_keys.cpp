// `--vary` keys: JSON paths into the scene and derived layout keys.
#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/mapping/design.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

using namespace pvdf::mapping;

namespace {
double mean_radius(const pvdf::Scene& s) {
  double cx = 0, cy = 0, r = 0;
  for (const auto& e : s.electrodes) {
    cx += e.center_m[0] / double(s.electrodes.size());
    cy += e.center_m[1] / double(s.electrodes.size());
  }
  for (const auto& e : s.electrodes) r += std::hypot(e.center_m[0] - cx, e.center_m[1] - cy) / double(s.electrodes.size());
  return r;
}
}  // namespace

TEST_CASE("--vary parses KEY=START:STEP:STOP", "[design][keys]") {
  const SceneSweep s = parse_scene_sweep("material.draw_angle_deg=0:15:90");
  CHECK(s.key == "material.draw_angle_deg");
  REQUIRE(s.values.size() == 7);
  CHECK(s.values.back() == Approx(90));
  CHECK_THROWS_AS(parse_scene_sweep("material.draw_angle_deg"), pvdf::InputError);
  CHECK_THROWS_AS(parse_scene_sweep("=0:1:2"), pvdf::InputError);
  CHECK_THROWS_AS(parse_scene_sweep("a=0:x:2"), pvdf::InputError);
}

TEST_CASE("scene keys set JSON paths and validate the result", "[design][keys]") {
  const nlohmann::json seed = pvdf::default_scene().original;
  auto parsed = [](const nlohmann::json& j) { return pvdf::parse_scene(j, "test"); };

  const auto a = parsed(set_scene_key(seed, "electrodes[0].center_m[1]", 0.012, "seed"));
  CHECK(a.electrodes[0].center_m[1] == 0.012);
  CHECK(a.electrodes[1].center_m[1] == -0.005);
  CHECK(parsed(set_scene_key(seed, "membrane.pretension_N_per_m", 20, "seed")).membrane.pretension_N_per_m == 20);
  const auto all = parsed(set_scene_key(seed, "electrodes[*].size_m", 0.003, "seed"));
  for (const auto& e : all.electrodes) CHECK((e.size_m[0] == 0.003 && e.size_m[1] == 0.003));
  CHECK(parsed(set_scene_key(seed, "material.draw_angle_deg", 30, "seed")).material.draw_angle_rad ==
        Approx(30 * pvdf::pi / 180));

  // Unknown keys and non-numeric targets are refused with the key named.
  try {
    set_scene_key(seed, "material.draw_angel_deg", 30, "seed.json");
    FAIL("no error");
  } catch (const pvdf::InputError& e) {
    CHECK(std::string(e.what()).find("draw_angel_deg") != std::string::npos);
  }
  CHECK_THROWS_AS(set_scene_key(seed, "electrodes[7].center_m", 0.0, "seed"), pvdf::InputError);
  CHECK_THROWS_AS(set_scene_key(seed, "electrodes[0].name", 1.0, "seed"), pvdf::InputError);
  CHECK_THROWS_AS(set_scene_key(seed, "@nonsense", 1.0, "seed"), pvdf::InputError);
  // The scene reader's rules still apply to the edited scene.
  CHECK_THROWS_AS(set_scene_key(seed, "membrane.thickness_m", -1.0, "seed"), pvdf::InputError);
}

TEST_CASE("derived keys scale, size and rotate the layout", "[design][keys]") {
  const pvdf::Scene seed = pvdf::default_scene();
  const double r0 = mean_radius(seed);
  CHECK(r0 == Approx(0.010));
  const auto doubled = pvdf::parse_scene(set_scene_key(seed.original, "@layout_scale", 2.0, "seed"), "t");
  CHECK(mean_radius(doubled) == Approx(2 * r0));
  CHECK(doubled.electrodes[0].center_m[1] == Approx(0.020));
  const auto radius = pvdf::parse_scene(set_scene_key(seed.original, "@layout_radius_m", 0.015, "seed"), "t");
  CHECK(mean_radius(radius) == Approx(0.015));
  const auto sized = pvdf::parse_scene(set_scene_key(seed.original, "@electrode_size_m", 0.004, "seed"), "t");
  CHECK(sized.electrodes[2].area_m2() == Approx(16e-6));

  const auto turned = pvdf::parse_scene(set_scene_key(seed.original, "@rotation_deg", 90, "seed"), "t");
  // A at (0, 10) mm goes to (−10, 0) mm; the draw direction from 0° to 90°.
  CHECK(turned.electrodes[0].center_m[0] == Approx(-0.010));
  CHECK(turned.electrodes[0].center_m[1] == Approx(0.0).margin(1e-15));
  CHECK(turned.material.draw_angle_rad == Approx(pvdf::pi / 2));
  // A rectangular film rotated by 30° becomes the rotated polygon with the same area.
  nlohmann::json rect = seed.original;
  rect["membrane"] = {{"shape", "rectangle"}, {"size_m", {0.09, 0.06}}};
  const auto r30 = pvdf::parse_scene(rotate_scene(rect, pvdf::pi / 6, "rect"), "t");
  CHECK(r30.membrane.outline.shape == pvdf::FilmOutline::Shape::polygon);
  CHECK(r30.membrane.outline.area_m2() == Approx(0.09 * 0.06));
}

TEST_CASE("the ranking rule: able to locate first, then usable area, coverage, median sigma; ties keep their order",
          "[design]") {
  using pvdf::mapping::DesignStatus;
  using pvdf::mapping::DesignSummary;
  auto layout = [](DesignStatus status, double usable, double coverage, double median_m) {
    DesignSummary s;
    s.status = status;
    s.usable_fraction = usable;
    s.coverage = coverage;
    s.median_sigma_pos_m = median_m;
    return s;
  };
  const std::vector<DesignSummary> s{
      layout(DesignStatus::unable_to_locate, 0.9, 0.9, 1e-4),  // cannot locate: last despite its numbers
      layout(DesignStatus::ok, 0.3, 0.5, 2e-4),
      layout(DesignStatus::ok, 0.3, 0.6, 3e-4),        // same usable area, more coverage
      layout(DesignStatus::ok, 0.3, 0.6, 1e-4),        // same again, smaller median σ
      layout(DesignStatus::ok, 0.5, 0.1, 9e-4),        // most usable area
      layout(DesignStatus::ok, 0.3, 0.5, 2e-4),        // equal to index 1: stays after it
  };
  CHECK(pvdf::mapping::rank_designs(s) == std::vector<std::size_t>{4, 3, 2, 1, 5, 0});
  CHECK(pvdf::mapping::ranks_before(s[1], s[0]));
  CHECK_FALSE(pvdf::mapping::ranks_before(s[1], s[5]));
  CHECK_FALSE(pvdf::mapping::ranks_before(s[5], s[1]));
}
