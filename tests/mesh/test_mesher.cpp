// Meshing scenes with Gmsh: electrode areas against nominal areas, film area and rim length
// against the circle, all-quad counter-clockwise cells, determinism, scale robustness (1 mm
// and 1 m films), O(h²) convergence of curved areas, quality refusal, .msh files Gmsh reopens.
#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/mesh/mesher.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace {

using pvdf::pi;
using pvdf::mesh::FilmMesh;

/// Edges of the cells with material `id` that belong to only one such cell: its outline.
std::vector<std::array<unsigned int, 2>> region_boundary(const FilmMesh& m, std::uint8_t id) {
  std::map<std::pair<unsigned int, unsigned int>, int> count;
  for (std::size_t i = 0; i < m.quads.size(); ++i) {
    if (m.material_ids[i] != id) continue;
    for (int c = 0; c < 4; ++c) {
      const unsigned a = m.quads[i][c], b = m.quads[i][(c + 1) % 4];
      ++count[{std::min(a, b), std::max(a, b)}];
    }
  }
  std::vector<std::array<unsigned int, 2>> out;
  for (const auto& [e, n] : count) {
    if (n == 1) out.push_back({e.first, e.second});
  }
  return out;
}

double edge_length(const FilmMesh& m, const std::array<unsigned int, 2>& e) {
  return std::hypot(m.vertices[e[1]][0] - m.vertices[e[0]][0], m.vertices[e[1]][1] - m.vertices[e[0]][1]);
}

double total_area(const FilmMesh& m) {
  double a = pvdf::mesh::material_area_m2(m, pvdf::mesh::film_material_id);
  for (std::size_t k = 0; k < m.electrode_names.size(); ++k) {
    a += pvdf::mesh::material_area_m2(m, pvdf::mesh::electrode_material_id(k));
  }
  return a;
}

/// Checks the mesh invariants every FilmMesh must satisfy.
void check_invariants(const FilmMesh& m) {
  REQUIRE(m.quads.size() == m.material_ids.size());
  REQUIRE(!m.quads.empty());
  for (const auto& q : m.quads) {
    double a2 = 0;
    for (int c = 0; c < 4; ++c) {
      REQUIRE(q[c] < m.vertices.size());
      const auto& p = m.vertices[q[c]];
      const auto& r = m.vertices[q[(c + 1) % 4]];
      a2 += p[0] * r[1] - r[0] * p[1];
    }
    REQUIRE(a2 > 0);  // counter-clockwise, not degenerate
  }
  // The rim edges are exactly the boundary of the whole mesh.
  std::map<std::pair<unsigned int, unsigned int>, int> count;
  for (const auto& q : m.quads) {
    for (int c = 0; c < 4; ++c) {
      const unsigned a = q[c], b = q[(c + 1) % 4];
      ++count[{std::min(a, b), std::max(a, b)}];
    }
  }
  std::size_t n_boundary = 0;
  for (const auto& kv : count) {
    REQUIRE(kv.second <= 2);
    n_boundary += kv.second == 1;
  }
  CHECK(n_boundary == m.rim_edges.size());
  for (const auto& e : m.rim_edges) CHECK(count[{std::min(e[0], e[1]), std::max(e[0], e[1])}] == 1);
}

/// A scene with every electrode shape: a rotated rectangle, a non-convex polygon, a circle.
pvdf::Scene mixed_scene() {
  auto s = pvdf::default_scene();
  s.electrodes[0].angle_rad = 0.3;
  s.electrodes[0].size_m = {0.003, 0.0015};
  s.electrodes[1].shape = pvdf::Electrode::Shape::polygon;  // an L around (-8.7, -5) mm
  s.electrodes[1].vertices_m = {{-0.0107, -0.0070}, {-0.0067, -0.0070}, {-0.0067, -0.0055},
                                {-0.0092, -0.0055}, {-0.0092, -0.0030}, {-0.0107, -0.0030}};
  s.electrodes[2].shape = pvdf::Electrode::Shape::circle;
  s.electrodes[2].center_m = {0.0087, -0.005};
  s.electrodes[2].radius_m = 0.0015;
  return s;
}

pvdf::Scene scaled(pvdf::Scene s, double f) {
  s.membrane.outline.radius_m *= f;
  for (auto& e : s.electrodes) {
    e.center_m = {e.center_m[0] * f, e.center_m[1] * f};
    e.size_m = {e.size_m[0] * f, e.size_m[1] * f};
    e.radius_m *= f;
    for (auto& v : e.vertices_m) v = {v[0] * f, v[1] * f};
  }
  s.probe.radius_m *= f;
  for (auto& l : s.loads) l.position_m = {l.position_m[0] * f, l.position_m[1] * f};
  return s;
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// Gmsh element types present in a .msh 4.1 ASCII file (from the $Elements block headers).
std::set<int> msh_element_types(const std::string& text) {
  std::set<int> types;
  std::istringstream in(text.substr(text.find("$Elements")));
  std::string tag;
  std::size_t n_blocks = 0, n_elements = 0, lo = 0, hi = 0;
  in >> tag >> n_blocks >> n_elements >> lo >> hi;
  for (std::size_t b = 0; b < n_blocks && in; ++b) {
    int dim = 0, entity = 0, type = 0;
    std::size_t n = 0;
    in >> dim >> entity >> type >> n;
    types.insert(type);
    std::string line;
    std::getline(in, line);
    for (std::size_t i = 0; i < n; ++i) std::getline(in, line);
  }
  return types;
}

}  // namespace

TEST_CASE("seed-001: all-quad mesh with exact electrode areas, right film area and rim", "[mesh]") {
  const auto scene = pvdf::default_scene();
  pvdf::mesh::MeshReport report;
  const FilmMesh m = pvdf::mesh::build_film_mesh(scene, &report);
  check_invariants(m);
  CHECK(report.n_cells == m.quads.size());
  CHECK(report.n_cells >= 1000);
  CHECK(report.n_cells <= 3000);
  CHECK(report.min_scaled_jacobian >= scene.mesh.min_scaled_jacobian);
  CHECK(report.n_probes_embedded == 1);
  REQUIRE(m.electrode_names == std::vector<std::string>{"A", "B", "C"});
  for (std::size_t k = 0; k < 3; ++k) {
    const double a = pvdf::mesh::material_area_m2(m, pvdf::mesh::electrode_material_id(k));
    CHECK(std::abs(a / scene.electrodes[k].area_m2() - 1) < 1e-9);
  }
  // Rim: vertices on the circle; chords of angle θ lose R(θ - 2 sin(θ/2)) ≤ Rθ³/24 each in length
  // and R²(θ - sin θ)/2 ≤ R²θ³/12 each in area.
  const double R = 0.045;
  double theta_max = 0, length_deficit_bound = 0, area_deficit_bound = 0;
  for (const auto& e : m.rim_edges) {
    for (unsigned v : e) CHECK(std::abs(std::hypot(m.vertices[v][0], m.vertices[v][1]) / R - 1) < 1e-12);
    const double theta = 2 * std::asin(0.5 * edge_length(m, e) / R);
    theta_max = std::max(theta_max, theta);
    length_deficit_bound += R * std::pow(theta, 3) / 24;
    area_deficit_bound += R * R * std::pow(theta, 3) / 12;
  }
  const double length_deficit = 2 * pi * R - pvdf::mesh::rim_length_m(m);
  CHECK(length_deficit > 0);
  CHECK(length_deficit <= length_deficit_bound * 1.0001);
  const double area_deficit = pi * R * R - total_area(m);
  CHECK(area_deficit > 0);
  CHECK(area_deficit <= area_deficit_bound * 1.0001);
  CHECK(m.rim_shape == FilmMesh::RimShape::circle);
  CHECK(m.rim_radius_m == R);
  // The probe footprint circle is resolved by mesh edges: vertices at radius 1 mm exist.
  std::size_t on_probe = 0;
  for (const auto& v : m.vertices) on_probe += std::abs(std::hypot(v[0], v[1]) - 0.001) < 1e-12;
  CHECK(on_probe >= 8);
}

TEST_CASE("rotated rectangles and polygons have exact areas; circles converge at O(h^2)", "[mesh]") {
  const auto scene = mixed_scene();
  REQUIRE_NOTHROW(pvdf::mesh::validate_geometry(scene));
  double previous_error = 0, previous_h = 0;
  for (double factor : {1.0, 0.5}) {
    pvdf::mesh::MeshParameters p;
    p.size_factor = factor;
    pvdf::mesh::MeshReport report;
    const FilmMesh m = pvdf::mesh::build_film_mesh(scene, p, &report);
    check_invariants(m);
    for (std::size_t k = 0; k < 2; ++k) {
      const double a = pvdf::mesh::material_area_m2(m, pvdf::mesh::electrode_material_id(k));
      CHECK(std::abs(a / scene.electrodes[k].area_m2() - 1) < 1e-9);
    }
    // The circle's outline is inscribed: deficit per chord of angle θ is r²(θ - sin θ)/2.
    const auto& c = scene.electrodes[2];
    const auto outline = region_boundary(m, pvdf::mesh::electrode_material_id(2));
    double bound = 0, h = 0;
    for (const auto& e : outline) {
      for (unsigned v : e) {
        CHECK(std::abs(std::hypot(m.vertices[v][0] - c.center_m[0], m.vertices[v][1] - c.center_m[1]) / c.radius_m -
                       1) < 1e-9);
      }
      const double theta = 2 * std::asin(0.5 * edge_length(m, e) / c.radius_m);
      bound += 0.5 * c.radius_m * c.radius_m * (theta - std::sin(theta));
      h = std::max(h, edge_length(m, e));
    }
    const double error = c.area_m2() - pvdf::mesh::material_area_m2(m, pvdf::mesh::electrode_material_id(2));
    CHECK(error > 0);
    CHECK(error == Approx(bound).epsilon(1e-6));
    CHECK(error / c.area_m2() < 0.02);
    if (previous_error > 0) {
      // O(h²): the error ratio follows the square of the outline edge ratio.
      const double order = std::log(previous_error / error) / std::log(previous_h / h);
      CHECK(order > 1.5);
      CHECK(order < 2.5);
    }
    previous_error = error;
    previous_h = h;
  }
}

TEST_CASE("rectangle, ellipse and polygon films mesh with the right area and rim", "[mesh]") {
  SECTION("rectangle") {
    auto s = pvdf::default_scene();
    s.membrane.outline.shape = pvdf::FilmOutline::Shape::rectangle;
    s.membrane.outline.size_m = {0.06, 0.04};
    const FilmMesh m = pvdf::mesh::build_film_mesh(s);
    check_invariants(m);
    CHECK(std::abs(total_area(m) / 0.0024 - 1) < 1e-9);
    CHECK(std::abs(pvdf::mesh::rim_length_m(m) / 0.2 - 1) < 1e-9);
    CHECK(m.rim_shape == FilmMesh::RimShape::polygonal);
  }
  SECTION("polygon (hexagon)") {
    auto s = pvdf::default_scene();
    s.membrane.outline.shape = pvdf::FilmOutline::Shape::polygon;
    s.membrane.outline.vertices_m.clear();
    for (int i = 0; i < 6; ++i) {
      s.membrane.outline.vertices_m.push_back({0.03 * std::cos(pi * i / 3), 0.03 * std::sin(pi * i / 3)});
    }
    const FilmMesh m = pvdf::mesh::build_film_mesh(s);
    check_invariants(m);
    CHECK(std::abs(total_area(m) / s.membrane.outline.area_m2() - 1) < 1e-9);
    CHECK(std::abs(pvdf::mesh::rim_length_m(m) / 0.18 - 1) < 1e-9);
  }
  SECTION("ellipse, taller than wide") {
    auto s = pvdf::default_scene();
    s.membrane.outline.shape = pvdf::FilmOutline::Shape::ellipse;
    s.membrane.outline.semi_axes_m = {0.03, 0.045};
    const FilmMesh m = pvdf::mesh::build_film_mesh(s);
    check_invariants(m);
    for (const auto& e : m.rim_edges) {
      for (unsigned v : e) {
        const double x = m.vertices[v][0] / 0.03, y = m.vertices[v][1] / 0.045;
        CHECK(std::abs(x * x + y * y - 1) < 1e-9);
      }
    }
    const double rel_area = 1 - total_area(m) / s.membrane.outline.area_m2();
    const double rel_length = 1 - pvdf::mesh::rim_length_m(m) / s.membrane.outline.perimeter_m();
    CHECK(rel_area > 0);
    CHECK(rel_area < 0.01);
    CHECK(rel_length > 0);
    CHECK(rel_length < 0.005);
    CHECK(m.rim_shape == FilmMesh::RimShape::ellipse);
    CHECK(m.rim_semi_axes_m[1] == 0.045);
  }
}

TEST_CASE("the same scene gives the same mesh twice", "[mesh]") {
  const auto scene = mixed_scene();
  const FilmMesh a = pvdf::mesh::build_film_mesh(scene);
  const FilmMesh b = pvdf::mesh::build_film_mesh(scene);
  CHECK(a.vertices == b.vertices);
  CHECK(a.quads == b.quads);
  CHECK(a.material_ids == b.material_ids);
  CHECK(a.rim_edges == b.rim_edges);
}

TEST_CASE("a 1 mm and a 1 m film both mesh alike", "[mesh]") {
  const auto base = pvdf::default_scene();
  const auto small = scaled(base, 0.001 / 0.045);
  const auto large = scaled(base, 1.0 / 0.045);
  pvdf::mesh::MeshReport rs, rl;
  const FilmMesh ms = pvdf::mesh::build_film_mesh(small, &rs);
  const FilmMesh ml = pvdf::mesh::build_film_mesh(large, &rl);
  check_invariants(ms);
  check_invariants(ml);
  // Gmsh works in units of the film radius, so both are the seed mesh up to round-off (which
  // can flip a few Delaunay decisions, hence not bit-identical).
  const double ratio = static_cast<double>(rs.n_cells) / static_cast<double>(rl.n_cells);
  CHECK(ratio > 0.97);
  CHECK(ratio < 1.03);
  CHECK(rs.min_scaled_jacobian >= base.mesh.min_scaled_jacobian);
  CHECK(rl.min_scaled_jacobian >= base.mesh.min_scaled_jacobian);
  CHECK(rs.target_size_min_m / 0.001 == Approx(rl.target_size_min_m / 1.0).epsilon(1e-12));
  for (std::size_t k = 0; k < 3; ++k) {
    const auto id = pvdf::mesh::electrode_material_id(k);
    CHECK(std::abs(pvdf::mesh::material_area_m2(ms, id) / small.electrodes[k].area_m2() - 1) < 1e-9);
    CHECK(std::abs(pvdf::mesh::material_area_m2(ml, id) / large.electrodes[k].area_m2() - 1) < 1e-9);
  }
}

TEST_CASE("a mesh below the quality threshold is refused with a clear message", "[mesh]") {
  auto s = pvdf::default_scene();
  s.mesh.min_scaled_jacobian = 0.999;  // no unstructured quad mesh of a disk reaches this
  pvdf::mesh::MeshReport report;
  try {
    pvdf::mesh::build_film_mesh(s, &report);
    FAIL("a mesh below the threshold was accepted");
  } catch (const pvdf::NumericalError& e) {
    CHECK_THAT(std::string(e.what()), Catch::Contains("min_scaled_jacobian") && Catch::Contains("refused"));
  }
  CHECK(report.n_cells > 0);
  CHECK(report.min_scaled_jacobian < 0.999);
}

TEST_CASE("probe footprints that would make slivers are left out, with a note", "[mesh]") {
  auto s = pvdf::default_scene();
  // A 1 mm probe centred on 2 mm electrode A is tangent to all four of its sides.
  s.loads[0].position_m = {0.0, 0.010};
  pvdf::mesh::MeshReport report;
  const FilmMesh m = pvdf::mesh::build_film_mesh(s, &report, {{0.02, 0.0}});
  check_invariants(m);
  CHECK(report.n_probes_embedded == 1);  // the extra one at (20, 0) mm
  REQUIRE(report.notes.size() == 1);
  CHECK_THAT(report.notes[0], Catch::Contains("loads[0]") && Catch::Contains("\"A\""));
  std::size_t on_extra = 0;
  for (const auto& v : m.vertices) on_extra += std::abs(std::hypot(v[0] - 0.02, v[1]) - 0.001) < 1e-12;
  CHECK(on_extra >= 8);
  // A probe crossing an electrode edge transversally is embedded, and the electrode area stays exact.
  auto t = pvdf::default_scene();
  t.loads[0].position_m = {0.001, 0.010};  // a 0.4 mm disk centred on A's right edge
  t.loads[0].radius_m = 0.0004;
  const FilmMesh mt = pvdf::mesh::build_film_mesh(t, &report);
  CHECK(report.n_probes_embedded == 1);
  CHECK(std::abs(pvdf::mesh::material_area_m2(mt, 1) / 4e-6 - 1) < 1e-9);
}

TEST_CASE("write_msh writes a mesh Gmsh reopens, with the physical groups", "[mesh]") {
  const std::string path = std::string(PVDF_BINARY_DIR) + "/test_mesh_seed001.msh";
  std::remove(path.c_str());
  pvdf::mesh::MeshReport report;
  const FilmMesh m = pvdf::mesh::write_msh(pvdf::default_scene(), path, &report);
  const std::string text = read_text(path);
  REQUIRE(!text.empty());
  CHECK_THAT(text, Catch::StartsWith("$MeshFormat\n4.1 0 8"));
  CHECK_THAT(text, Catch::Contains("2 1 \"film\"") && Catch::Contains("2 2 \"A\"") && Catch::Contains("2 3 \"B\"") &&
                       Catch::Contains("2 4 \"C\"") && Catch::Contains("1 1 \"rim\"") &&
                       Catch::Contains("1 101 \"probe_0\""));
  CHECK(m.n_cells() == report.n_cells);
#ifdef PVDF_GMSH_EXECUTABLE
  const std::string log = path + ".check.log";
  const int rc = std::system((std::string(PVDF_GMSH_EXECUTABLE) + " -check " + path + " > " + log + " 2>&1").c_str());
  CHECK(rc == 0);
  const std::string check = read_text(log);
  CHECK_THAT(check, Catch::Contains("Done checking mesh coherence"));
  CHECK_THAT(check, !Catch::Contains("Error"));
#endif
  // Second order: 9-node quadrangles (Gmsh element type 10) whose rim nodes lie on the circle.
  auto s2 = pvdf::default_scene();
  s2.mesh.order = 2;
  const std::string path2 = std::string(PVDF_BINARY_DIR) + "/test_mesh_seed001_order2.msh";
  pvdf::mesh::write_msh(s2, path2);
  const std::string text2 = read_text(path2);
  const auto types2 = msh_element_types(text2);
  CHECK(types2.count(10) == 1);  // 9-node quadrangle
  CHECK(types2.count(8) == 1);   // 3-node line (rim)
  CHECK(types2.count(3) == 0);
  CHECK(msh_element_types(text) == std::set<int>{1, 3});  // lines, 4-node quads
  std::remove(path.c_str());
  std::remove(path2.c_str());
}

TEST_CASE("read_msh gives back the mesh write_msh wrote", "[mesh]") {
  auto scene = mixed_scene();
  const std::string path = std::string(PVDF_BINARY_DIR) + "/test_mesh_roundtrip.msh";
  const FilmMesh written = pvdf::mesh::write_msh(scene, path);
  const FilmMesh read = pvdf::mesh::read_msh(path);
  CHECK(read.electrode_names == written.electrode_names);
  REQUIRE(read.vertices.size() == written.vertices.size());
  REQUIRE(read.n_cells() == written.n_cells());
  CHECK(read.rim_edges.size() == written.rim_edges.size());
  CHECK(read.rim_shape == FilmMesh::RimShape::circle);
  CHECK(read.rim_radius_m == Approx(0.045).epsilon(1e-12));
  // Same vertices (ASCII round trip) and the same cells with the same materials, as sets.
  double worst = 0;
  for (std::size_t i = 0; i < read.vertices.size(); ++i) {
    worst = std::max({worst, std::abs(read.vertices[i][0] - written.vertices[i][0]),
                      std::abs(read.vertices[i][1] - written.vertices[i][1])});
  }
  CHECK(worst < 1e-15);
  auto canonical = [](const FilmMesh& m) {
    std::vector<std::array<unsigned int, 5>> cells;
    for (std::size_t i = 0; i < m.quads.size(); ++i) {
      auto q = m.quads[i];
      std::rotate(q.begin(), std::min_element(q.begin(), q.end()), q.end());
      cells.push_back({q[0], q[1], q[2], q[3], m.material_ids[i]});
    }
    std::sort(cells.begin(), cells.end());
    return cells;
  };
  CHECK(canonical(read) == canonical(written));
  for (std::size_t k = 0; k < 3; ++k) {
    const auto id = pvdf::mesh::electrode_material_id(k);
    CHECK(pvdf::mesh::material_area_m2(read, id) == Approx(pvdf::mesh::material_area_m2(written, id)).epsilon(1e-14));
  }
  // A second-order file reads back to the same corner mesh.
  scene.mesh.order = 2;
  pvdf::mesh::write_msh(scene, path);
  const FilmMesh read2 = pvdf::mesh::read_msh(path);
  CHECK(canonical(read2) == canonical(written));
  std::remove(path.c_str());
  // Bad files are input errors naming the file.
  CHECK_THROWS_WITH(pvdf::mesh::read_msh(path), Catch::Contains(path));
  const std::string junk = std::string(PVDF_BINARY_DIR) + "/test_mesh_junk.msh";
  {
    std::ofstream out(junk);
    out << "$MeshFormat\n4.1 0 8\n$EndMeshFormat\n";
  }
  CHECK_THROWS_AS(pvdf::mesh::read_msh(junk), pvdf::InputError);
  std::remove(junk.c_str());
}
