// An electrode read from the atlas (pvdf::fem::atlas_electrode) against closed forms: with a
// linear density the reading is exact for any polygon (rotated rectangles, a non-convex L), at any
// scale (×1e3, ×1e-3); fully covered cells carry weight (1, 0, 0) and no integration error; the
// integration-error estimate vanishes for a constant density and is positive where a cut cell
// sees a gradient.
#include "pvdf/fem/atlas.hpp"
#include "pvdf/mapping/atlas.hpp"
#include "pvdf/mapping/generate.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>

namespace {

using pvdf::Point2;

// A grid whose cells are all full squares of film (geometry of a square of side a about its centre).
std::vector<double> full_geometry(const pvdf::fem::AtlasGrid& g) {
  std::vector<double> geo(g.nx * g.ny * 6, 0.0);
  const double a = g.cell_m;
  for (std::size_t c = 0; c < g.nx * g.ny; ++c) {
    geo[c * 6 + 0] = a * a;
    geo[c * 6 + 3] = a * a * a * a / 12;
    geo[c * 6 + 5] = a * a * a * a / 12;
  }
  return geo;
}

// Exact moments of q = c0 + c1 x + c2 y over each full cell: ∫q = a²·q(centre), ∫q dx = c1 a⁴/12, ∫q dy = c2 a⁴/12.
std::vector<double> linear_moments(const pvdf::fem::AtlasGrid& g, double c0, double c1, double c2) {
  std::vector<double> m(g.nx * g.ny * 3);
  const double a = g.cell_m;
  for (std::size_t j = 0; j < g.ny; ++j)
    for (std::size_t i = 0; i < g.nx; ++i) {
      const auto c = g.centre_m(i, j);
      const std::size_t k = j * g.nx + i;
      m[k * 3 + 0] = a * a * (c0 + c1 * c[0] + c2 * c[1]);
      m[k * 3 + 1] = c1 * a * a * a * a / 12;
      m[k * 3 + 2] = c2 * a * a * a * a / 12;
    }
  return m;
}

// ∫ (c0 + c1 x + c2 y) dA over polygon v: area·q(centroid) (shoelace).
double exact_linear_integral(const std::vector<Point2>& v, double c0, double c1, double c2) {
  double A = 0, mx = 0, my = 0;
  for (std::size_t k = 0; k < v.size(); ++k) {
    const auto& p = v[k];
    const auto& q = v[(k + 1) % v.size()];
    const double cr = p[0] * q[1] - q[0] * p[1];
    A += cr / 2;
    mx += (p[0] + q[0]) * cr / 6;
    my += (p[1] + q[1]) * cr / 6;
  }
  return c0 * A + c1 * mx + c2 * my;
}

std::vector<Point2> rectangle(double cx, double cy, double w, double h, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  std::vector<Point2> v;
  for (const auto& u : {Point2{-w / 2, -h / 2}, Point2{w / 2, -h / 2}, Point2{w / 2, h / 2}, Point2{-w / 2, h / 2}})
    v.push_back({cx + c * u[0] - s * u[1], cy + s * u[0] + c * u[1]});
  return v;
}

}  // namespace

TEST_CASE("a linear density is read exactly over any polygon, at any scale", "[atlas]") {
  for (const double scale : {1.0, 1e3, 1e-3}) {
    pvdf::FilmOutline film;
    film.radius_m = 0.012 * scale;
    const pvdf::fem::AtlasGrid g = pvdf::fem::atlas_grid_for(film, 0.001 * scale);
    REQUIRE(g.nx == 24);
    const auto geo = full_geometry(g);
    const double c0 = 3e-4, c1 = -2e-2 / scale, c2 = 5e-2 / scale;  // C/m², C/m³
    const auto m = linear_moments(g, c0, c1, c2);
    const std::vector<std::vector<Point2>> outlines{
        rectangle(0.0021 * scale, -0.0013 * scale, 0.003 * scale, 0.001 * scale, 0.3),
        rectangle(-0.005 * scale, 0.004 * scale, 0.0011 * scale, 0.006 * scale, -1.1),
        {{0, 0}, {0.004 * scale, 0}, {0.004 * scale, 0.001 * scale}, {0.0013 * scale, 0.001 * scale},
         {0.0013 * scale, 0.0037 * scale}, {0, 0.0037 * scale}}};  // an L: not convex
    for (const auto& v : outlines) {
      const pvdf::fem::AtlasElectrode e = pvdf::fem::atlas_electrode(g, geo, v);
      double q = 0, err = 0;
      pvdf::fem::integrate_atlas_electrode(e, m.data(), q, err);
      const double exact = exact_linear_integral(v, c0, c1, c2);
      CHECK(std::abs(q - exact) <= 1e-11 * std::abs(exact));
      CHECK(err > 0);  // cut cells see the gradient: the constant reconstruction differs
    }
  }
}

TEST_CASE("fully covered cells are exact and carry no integration error", "[atlas]") {
  pvdf::FilmOutline film;
  film.radius_m = 0.01;
  const pvdf::fem::AtlasGrid g = pvdf::fem::atlas_grid_for(film, 0.001);
  const auto geo = full_geometry(g);
  // An electrode made of whole cells: [−2, 2] mm × [−1, 1] mm.
  const std::vector<Point2> v{{-0.002, -0.001}, {0.002, -0.001}, {0.002, 0.001}, {-0.002, 0.001}};
  const pvdf::fem::AtlasElectrode e = pvdf::fem::atlas_electrode(g, geo, v);
  REQUIRE(e.cell.size() == 8);
  for (std::size_t k = 0; k < e.cell.size(); ++k) {
    CHECK(e.partial[k] == 0);
    CHECK(e.weight[k][0] == 1.0);
  }
  // Any moments at all (not a linear field): the charge is the sum of the cells' integrals.
  std::vector<double> m(g.nx * g.ny * 3);
  for (std::size_t i = 0; i < m.size(); ++i) m[i] = std::sin(double(i)) * 1e-9;
  double q = 0, err = 0, sum = 0;
  pvdf::fem::integrate_atlas_electrode(e, m.data(), q, err);
  for (const std::size_t c : e.cell) sum += m[c * 3];
  CHECK(std::abs(q - sum) <= 1e-15 * 1e-9 * 8);
  CHECK(err == 0.0);
  // A constant density: a cut electrode has no integration error either.
  const auto mc = linear_moments(g, 1e-4, 0, 0);
  const pvdf::fem::AtlasElectrode cut = pvdf::fem::atlas_electrode(g, geo, rectangle(0.0003, 0.0007, 0.0025, 0.0013, 0.7));
  pvdf::fem::integrate_atlas_electrode(cut, mc.data(), q, err);
  CHECK(std::abs(q - 1e-4 * 0.0025 * 0.0013) <= 1e-12 * 1e-4 * 0.0025 * 0.0013);
  CHECK(err <= 1e-15 * std::abs(q));
}

// The tolerance flags of a map from the atlas: a hand-made 1 × 1 × 3 map with two electrodes,
// tolerance 1 %: a press whose largest error is 0.5 % of its largest charge is not flagged, one at
// 2 % is, one without an estimate (NaN) is (the tolerance is not shown to be met), and a press that
// was not computed is left alone.
TEST_CASE("atlas maps flag the presses whose stated error exceeds the tolerance", "[atlas]") {
  pvdf::mapping::ChargeMap map;
  map.tolerance = 0.01;
  map.x_m = {-1e-3, 0.0, 1e-3, 2e-3};
  map.y_m = {0.0};
  map.mask = {1, 1, 1, 1};
  map.forces_N = {1.0};
  map.electrode_names = {"A", "B"};
  map.electrode_centers_m = {{0, 0}, {1e-3, 0}};
  map.noise_C = {5e-14, 5e-14};
  map.allocate();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  map.charge_C = {-2e-12, 1e-12, -2e-12, 1e-12, -2e-12, 1e-12, nan, nan};
  map.estimated_charge_error_C = {0.5e-14, 1e-14, 1e-14, 4e-14, nan, 1e-15, nan, nan};
  for (std::size_t p = 0; p < 3; ++p) map.status[p] = std::uint8_t(pvdf::mapping::PointStatus::ok);
  std::size_t n = 99;
  const auto flags = pvdf::mapping::atlas_map_provenance(map, &n);
  REQUIRE(flags.size() == 4);
  CHECK(flags[0] == 0);
  CHECK(flags[1] == pvdf::mapping::provenance::tolerance_not_met);
  CHECK(flags[2] == pvdf::mapping::provenance::tolerance_not_met);
  CHECK(flags[3] == 0);
  CHECK(n == 2);
}
