// Geometric validation of scenes: every bad input of the mesh issue gives an InputError whose
// message names the electrode or key (no Gmsh involved).
#include "pvdf/core/error.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/mesh/mesher.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using pvdf::mesh::validate_geometry;

namespace {

pvdf::Scene seed() { return pvdf::default_scene(); }

/// The InputError message validate_geometry throws, or "" if it accepts the scene.
std::string rejection(const pvdf::Scene& s) {
  try {
    validate_geometry(s);
  } catch (const pvdf::InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("the seed-001 scene is valid", "[mesh][validate]") { CHECK(rejection(seed()).empty()); }

TEST_CASE("default sizes follow the geometry", "[mesh][validate]") {
  const auto s = seed();
  const auto sizes = pvdf::mesh::target_sizes_m(s);
  // probe radius 1 mm / 2 = 0.5 mm; electrode side 2 mm / 4 = 0.5 mm; film radius 45 mm / 8.
  CHECK(sizes[0] == Approx(0.0005));
  CHECK(sizes[1] == Approx(0.045 / 8));
  auto t = s;
  t.mesh.size_min_m = 1e-4;
  t.mesh.size_max_m = 2e-3;
  const auto given = pvdf::mesh::target_sizes_m(t);
  CHECK(given[0] == 1e-4);
  CHECK(given[1] == 2e-3);
}

TEST_CASE("overlapping electrodes are refused, naming both", "[mesh][validate]") {
  auto s = seed();
  s.electrodes[1].center_m = {0.0005, 0.0105};  // onto A
  const auto msg = rejection(s);
  CHECK_THAT(msg, Catch::Contains("\"B\"") && Catch::Contains("overlaps") && Catch::Contains("\"A\""));
  // A circle inside a rectangle (nested, boundaries apart) also overlaps.
  auto n = seed();
  n.electrodes[1].shape = pvdf::Electrode::Shape::circle;
  n.electrodes[1].center_m = {0.0, 0.010};
  n.electrodes[1].radius_m = 0.0003;
  n.mesh.size_min_m = 1e-4;
  CHECK_THAT(rejection(n), Catch::Contains("overlaps"));
}

TEST_CASE("electrodes closer than half the finest size are touching", "[mesh][validate]") {
  auto s = seed();
  s.electrodes[1].center_m = {0.0021, 0.010};  // 0.1 mm gap to A, size_min 0.5 mm
  CHECK_THAT(rejection(s), Catch::Contains("\"B\"") && Catch::Contains("touches") && Catch::Contains("\"A\""));
}

TEST_CASE("electrodes crossing, touching or outside the rim are refused", "[mesh][validate]") {
  auto crossing = seed();
  crossing.electrodes[2].center_m = {0.0445, 0.0};
  CHECK_THAT(rejection(crossing), Catch::Contains("\"C\"") && Catch::Contains("crosses"));
  auto touching = seed();
  touching.electrodes[2].center_m = {0.0438, 0.0};  // corners 0.19 mm from the rim, clearance 0.25 mm
  CHECK_THAT(rejection(touching), Catch::Contains("\"C\"") && Catch::Contains("touches the rim"));
  auto outside = seed();
  outside.electrodes[0].center_m = {0.0, 0.08};
  CHECK_THAT(rejection(outside), Catch::Contains("\"A\"") && Catch::Contains("outside the film"));
  // Same checks against an ellipse and a polygon (non-convex) film.
  auto ellipse = seed();
  ellipse.membrane.outline.shape = pvdf::FilmOutline::Shape::ellipse;
  ellipse.membrane.outline.semi_axes_m = {0.045, 0.0105};
  CHECK_THAT(rejection(ellipse), Catch::Contains("\"A\"") && Catch::Contains("crosses"));
  auto notch = seed();
  notch.membrane.outline.shape = pvdf::FilmOutline::Shape::polygon;
  // A square with a notch cut down to y = 0.0095 right where electrode A sits.
  notch.membrane.outline.vertices_m = {{-0.03, -0.03}, {0.03, -0.03}, {0.03, 0.03}, {0.0005, 0.03},
                                       {0.0005, 0.0095}, {-0.0005, 0.0095}, {-0.0005, 0.03}, {-0.03, 0.03}};
  CHECK_THAT(rejection(notch), Catch::Contains("\"A\"") && Catch::Contains("crosses"));
}

TEST_CASE("electrodes smaller than the finest mesh size are refused", "[mesh][validate]") {
  auto s = seed();
  s.mesh.size_min_m = 0.003;
  s.mesh.size_max_m = 0.005;
  CHECK_THAT(rejection(s), Catch::Contains("\"A\"") && Catch::Contains("smaller than the finest mesh size"));
}

TEST_CASE("zero or negative sizes are refused, naming the key", "[mesh][validate]") {
  auto rect = seed();
  rect.electrodes[1].size_m = {0.0, 0.002};
  CHECK_THAT(rejection(rect), Catch::Contains("electrodes[1]") && Catch::Contains("size_m"));
  auto circle = seed();
  circle.electrodes[2].shape = pvdf::Electrode::Shape::circle;
  circle.electrodes[2].radius_m = -0.001;
  CHECK_THAT(rejection(circle), Catch::Contains("\"C\"") && Catch::Contains("radius_m"));
  auto film = seed();
  film.membrane.outline.radius_m = 0;
  CHECK_THAT(rejection(film), Catch::Contains("membrane.radius_m"));
  auto mesh = seed();
  mesh.mesh.size_min_m = -1e-3;
  CHECK_THAT(rejection(mesh), Catch::Contains("mesh.size_min_m"));
  auto probe = seed();
  probe.probe.radius_m = 0;
  CHECK_THAT(rejection(probe), Catch::Contains("probe.radius_m"));
  auto many = seed();
  many.electrodes.resize(255, many.electrodes[0]);
  CHECK_THAT(rejection(many), Catch::Contains("at most 254"));
  auto nan = seed();
  nan.electrodes[0].center_m = {std::nan(""), 0.0};
  CHECK_THAT(rejection(nan), Catch::Contains("\"A\"") && Catch::Contains("center_m"));
}

TEST_CASE("self-intersecting polygons are refused", "[mesh][validate]") {
  auto s = seed();
  s.electrodes[0].shape = pvdf::Electrode::Shape::polygon;
  s.electrodes[0].vertices_m = {{-0.001, 0.009}, {0.001, 0.011}, {0.001, 0.009}, {-0.001, 0.011}};  // bow tie
  CHECK_THAT(rejection(s), Catch::Contains("\"A\"") && Catch::Contains("self-intersecting"));
  auto film = seed();
  film.membrane.outline.shape = pvdf::FilmOutline::Shape::polygon;
  film.membrane.outline.vertices_m = {{-0.04, -0.04}, {0.04, 0.04}, {0.04, -0.04}, {-0.04, 0.04}};
  CHECK_THAT(rejection(film), Catch::Contains("membrane.vertices_m") && Catch::Contains("self-intersecting"));
}

TEST_CASE("probe footprints partly outside the film are refused", "[mesh][validate]") {
  auto s = seed();
  s.loads[0].position_m = {0.0445, 0.0};  // inside, but the 1 mm disk reaches 0.5 mm past the rim
  CHECK_THAT(rejection(s), Catch::Contains("loads[0]") && Catch::Contains("outside the film"));
  auto r = seed();
  r.loads[0].position_m = {0.040, 0.0};
  r.loads[0].radius_m = 0.006;
  CHECK_THAT(rejection(r), Catch::Contains("loads[0].radius_m"));
  auto ok = seed();
  ok.loads[0].position_m = {0.043, 0.0};
  CHECK(rejection(ok).empty());
  // Extra probe positions are checked by build_film_mesh before Gmsh runs.
  CHECK_THROWS_AS(pvdf::mesh::build_film_mesh(seed(), nullptr, {{0.0, -0.0445}}), pvdf::InputError);
}

TEST_CASE("the scene reader refuses what the mesh validation refuses, with the same message", "[mesh][validate]") {
  // Overlapping electrodes are caught once, when the file is read, for every command.
  auto j = nlohmann::json::parse(pvdf::default_scene_json());
  j["electrodes"][2]["center_m"] = {-0.0080, -0.0050};
  const std::string expected = "overlap.json: electrodes[2] (\"C\") overlaps electrodes[1] (\"B\")";
  try {
    pvdf::parse_scene(j, "overlap.json");
    FAIL("overlap accepted by the scene reader");
  } catch (const pvdf::InputError& e) {
    CHECK_THAT(std::string(e.what()), Catch::StartsWith(expected));
  }
  // A scene built in code (not read from a file) is still checked by the mesher.
  auto s = seed();
  s.source = "overlap.json";
  s.electrodes[2].center_m = {-0.0080, -0.0050};
  CHECK_THAT(rejection(s), Catch::StartsWith(expected));
}
