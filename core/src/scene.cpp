// Scene parsing and validation: per key here, then the scene's geometry as a whole
// (scene_geometry.cpp); pvdf::mesh adds the clearances that depend on mesh sizes.
#include "pvdf/core/scene.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/core/json_reader.hpp"
#include "pvdf/core/planar.hpp"
#include "pvdf/core/scene_geometry.hpp"

#include <cmath>
#include <set>
#include <sstream>

namespace pvdf {

namespace {

constexpr double deg = pi / 180.0;

double polygon_signed_area(const std::vector<Point2>& v) { return planar::signed_area(v); }

Point2 polygon_centroid(const std::vector<Point2>& v) {
  double cx = 0, cy = 0;
  const double a = polygon_signed_area(v);
  for (std::size_t i = 0; i < v.size(); ++i) {
    const auto& p = v[i];
    const auto& q = v[(i + 1) % v.size()];
    const double cross = p[0] * q[1] - q[0] * p[1];
    cx += (p[0] + q[0]) * cross;
    cy += (p[1] + q[1]) * cross;
  }
  return {cx / (6 * a), cy / (6 * a)};
}

// Physical bounds of a scene (docs/scene.md "Physical bounds"), refused by the scene reader.
// Kept here, not in scene.hpp, so that tuning them rebuilds one file.
constexpr double modulus_min_Pa = 1e5;          // E_Pa, E1_Pa, E2_Pa, G12_Pa: soft rubber
constexpr double modulus_max_Pa = 1e12;         // ... to diamond
constexpr double auxetic_limit = -0.5;         // nu12 (or nu) below this: refused, see material()
constexpr double poisson_margin = 0.05;         // 1 - nu12*nu21 >= this: positive definite with a margin
constexpr double pretension_max_strain = 0.1;   // |pretension| <= this x sqrt(E1 E2) x thickness
constexpr double force_min_N = 1e-9;            // loads[].force_N (the app's force flags use the same)
constexpr double force_max_N = 1e4;

std::string fmt(double x) {
  std::ostringstream os;
  os.precision(6);
  os << x;
  return os.str();
}

}  // namespace

// ---------------------------------------------------------------------------- FilmOutline

double FilmOutline::area_m2() const {
  switch (shape) {
    case Shape::circle: return pi * radius_m * radius_m;
    case Shape::rectangle: return size_m[0] * size_m[1];
    case Shape::ellipse: return pi * semi_axes_m[0] * semi_axes_m[1];
    case Shape::polygon: return std::abs(polygon_signed_area(vertices_m));
  }
  return 0;
}

double FilmOutline::perimeter_m() const {
  switch (shape) {
    case Shape::circle: return 2 * pi * radius_m;
    case Shape::rectangle: return 2 * (size_m[0] + size_m[1]);
    case Shape::ellipse: {
      const double a = semi_axes_m[0], b = semi_axes_m[1];
      const double h = (a - b) * (a - b) / ((a + b) * (a + b));
      return pi * (a + b) * (1 + 3 * h / (10 + std::sqrt(4 - 3 * h)));
    }
    case Shape::polygon: {
      double L = 0;
      for (std::size_t i = 0; i < vertices_m.size(); ++i) {
        const auto& p = vertices_m[i];
        const auto& q = vertices_m[(i + 1) % vertices_m.size()];
        L += std::hypot(q[0] - p[0], q[1] - p[1]);
      }
      return L;
    }
  }
  return 0;
}

double FilmOutline::inside_distance_m(const Point2& p) const {
  switch (shape) {
    case Shape::circle: return radius_m - std::hypot(p[0], p[1]);
    case Shape::rectangle: {
      const double dx = 0.5 * size_m[0] - std::abs(p[0]);
      const double dy = 0.5 * size_m[1] - std::abs(p[1]);
      if (dx >= 0 && dy >= 0) return std::min(dx, dy);
      const double ox = std::max(-dx, 0.0), oy = std::max(-dy, 0.0);
      return -std::hypot(ox, oy);
    }
    case Shape::ellipse: {
      // Distance to an ellipse by sampling the boundary finely, then a local refinement.
      const double a = semi_axes_m[0], b = semi_axes_m[1];
      const int n = 720;
      double best = 1e300, best_t = 0;
      for (int i = 0; i < n; ++i) {
        const double t = 2 * pi * i / n;
        const double d = std::hypot(a * std::cos(t) - p[0], b * std::sin(t) - p[1]);
        if (d < best) {
          best = d;
          best_t = t;
        }
      }
      double lo = best_t - 2 * pi / n, hi = best_t + 2 * pi / n;
      for (int it = 0; it < 60; ++it) {  // golden-section search
        const double m1 = lo + (hi - lo) * 0.381966, m2 = lo + (hi - lo) * 0.618034;
        const double d1 = std::hypot(a * std::cos(m1) - p[0], b * std::sin(m1) - p[1]);
        const double d2 = std::hypot(a * std::cos(m2) - p[0], b * std::sin(m2) - p[1]);
        if (d1 < d2) hi = m2; else lo = m1;
      }
      const double t = 0.5 * (lo + hi);
      best = std::hypot(a * std::cos(t) - p[0], b * std::sin(t) - p[1]);
      const bool inside = (p[0] * p[0]) / (a * a) + (p[1] * p[1]) / (b * b) < 1.0;
      return inside ? best : -best;
    }
    case Shape::polygon: {
      double d = 1e300;
      for (std::size_t i = 0; i < vertices_m.size(); ++i) {
        d = std::min(d, planar::point_segment_distance(p, vertices_m[i], vertices_m[(i + 1) % vertices_m.size()]));
      }
      return planar::polygon_contains(vertices_m, p) ? d : -d;
    }
  }
  return 0;
}

bool FilmOutline::contains(const Point2& p, double margin_m) const {
  return inside_distance_m(p) > margin_m;
}

double FilmOutline::inscribed_radius_m() const { return inside_distance_m({0.0, 0.0}); }

double FilmOutline::characteristic_radius_m() const {
  switch (shape) {
    case Shape::circle: return radius_m;
    case Shape::rectangle: return 0.5 * std::max(size_m[0], size_m[1]);
    case Shape::ellipse: return std::max(semi_axes_m[0], semi_axes_m[1]);
    case Shape::polygon: {
      double r = 0;
      for (const auto& v : vertices_m) r = std::max(r, std::hypot(v[0], v[1]));
      return r;
    }
  }
  return 0;
}

std::array<double, 4> FilmOutline::bounding_box_m() const {
  switch (shape) {
    case Shape::circle: return {-radius_m, radius_m, -radius_m, radius_m};
    case Shape::rectangle: return {-size_m[0] / 2, size_m[0] / 2, -size_m[1] / 2, size_m[1] / 2};
    case Shape::ellipse: return {-semi_axes_m[0], semi_axes_m[0], -semi_axes_m[1], semi_axes_m[1]};
    case Shape::polygon: break;
  }
  std::array<double, 4> b{1e300, -1e300, 1e300, -1e300};
  for (const auto& v : vertices_m) {
    b[0] = std::min(b[0], v[0]);
    b[1] = std::max(b[1], v[0]);
    b[2] = std::min(b[2], v[1]);
    b[3] = std::max(b[3], v[1]);
  }
  return b;
}

// ---------------------------------------------------------------------------- Electrode

std::vector<Point2> Electrode::outline(int n_circle) const {
  std::vector<Point2> out;
  switch (shape) {
    case Shape::rectangle: {
      const double c = std::cos(angle_rad), s = std::sin(angle_rad);
      const double hx = 0.5 * size_m[0], hy = 0.5 * size_m[1];
      const double corners[4][2] = {{-hx, -hy}, {hx, -hy}, {hx, hy}, {-hx, hy}};
      for (const auto& k : corners) {
        out.push_back({center_m[0] + c * k[0] - s * k[1], center_m[1] + s * k[0] + c * k[1]});
      }
      break;
    }
    case Shape::circle:
      for (int i = 0; i < n_circle; ++i) {
        const double t = 2 * pi * i / n_circle;
        out.push_back({center_m[0] + radius_m * std::cos(t), center_m[1] + radius_m * std::sin(t)});
      }
      break;
    case Shape::polygon: out = vertices_m; break;
  }
  return out;
}

double Electrode::area_m2() const {
  switch (shape) {
    case Shape::rectangle: return size_m[0] * size_m[1];
    case Shape::circle: return pi * radius_m * radius_m;
    case Shape::polygon: return std::abs(polygon_signed_area(vertices_m));
  }
  return 0;
}

Point2 Electrode::centroid_m() const {
  if (shape == Shape::polygon) return polygon_centroid(vertices_m);
  return center_m;
}

// ---------------------------------------------------------------------------- parsing

namespace {

void check_simple_polygon(const JsonObjectReader& r, const std::string& key,
                          const std::vector<Point2>& v) {
  const std::size_t n = v.size();
  const auto crossing = planar::first_self_intersection(v);
  if (crossing[0] >= 0) {
    r.fail(key, "is self-intersecting (edge " + std::to_string(crossing[0]) + " crosses edge " +
                    std::to_string(crossing[1]) + "); list the vertices in order around a simple outline");
  }
  for (std::size_t i = 0; i < n; ++i) {
    const auto& a = v[i];
    const auto& b = v[(i + 1) % n];
    if (a[0] == b[0] && a[1] == b[1]) {
      r.fail(key, "repeats vertex " + std::to_string(i) + "; remove the duplicate point");
    }
  }
  if (std::abs(polygon_signed_area(v)) <= 0) r.fail(key, "encloses zero area; give at least three non-collinear points");
}

FilmOutline parse_outline(const JsonObjectReader& r) {
  FilmOutline o;
  const std::string shape = r.choice_or("shape", "circle", {"circle", "rectangle", "ellipse", "polygon"});
  if (shape == "circle") {
    o.shape = FilmOutline::Shape::circle;
    o.radius_m = r.positive_or("radius_m", 0.045);
  } else if (shape == "rectangle") {
    o.shape = FilmOutline::Shape::rectangle;
    o.size_m = r.pair("size_m");
    if (!(o.size_m[0] > 0 && o.size_m[1] > 0)) r.fail("size_m", "must hold two sizes > 0 [width_m, height_m]");
  } else if (shape == "ellipse") {
    o.shape = FilmOutline::Shape::ellipse;
    o.semi_axes_m = r.pair("semi_axes_m");
    if (!(o.semi_axes_m[0] > 0 && o.semi_axes_m[1] > 0)) r.fail("semi_axes_m", "must hold two semi-axes > 0 [a_m, b_m]");
  } else {
    o.shape = FilmOutline::Shape::polygon;
    o.vertices_m = r.points("vertices_m", 3);
    check_simple_polygon(r, "vertices_m", o.vertices_m);
    if (!(o.inside_distance_m({0, 0}) > 0)) {
      r.fail("vertices_m", "must enclose the origin (0, 0), the film's reference point; shift the outline");
    }
  }
  return o;
}

Material parse_material(const JsonObjectReader& r, std::vector<std::string>& warnings) {
  Material m;
  if (r.has("E_Pa") || r.has("nu")) {
    // Isotropic film.
    for (const char* k : {"E1_Pa", "E2_Pa", "G12_Pa", "nu12", "nu21"}) {
      if (r.has(k)) r.fail(k, "cannot be combined with the isotropic keys E_Pa/nu; give either E_Pa and nu, or E1_Pa, E2_Pa, G12_Pa and nu12");
    }
    m.isotropic = true;
    const double E = r.positive("E_Pa");
    const double nu = r.in_range_or("nu", 0.3, -0.99, 0.499999);
    if (nu < auxetic_limit) {
      r.fail("nu", "is below " + fmt(auxetic_limit) + ": a strongly auxetic film is no PVDF film (nu ~ 0.35); check the sign");
    }
    m.E1_Pa = m.E2_Pa = E;
    m.nu12 = nu;
    m.G12_Pa = E / (2 * (1 + nu));
    m.nu21_table = nu;
  } else {
    m.E1_Pa = r.positive_or("E1_Pa", m.E1_Pa);
    m.E2_Pa = r.positive_or("E2_Pa", m.E2_Pa);
    m.G12_Pa = r.positive_or("G12_Pa", m.G12_Pa);
    m.nu12 = r.in_range_or("nu12", m.nu12, -0.99, 10.0);
    // Strongly auxetic films are no polymer film of these sensors (PVDF: 0.3-0.45) and the solve
    // of one stagnates (nu12 = -0.99: > 60 s on a 10 mm film that takes 1 s at 0.35, issue 30).
    if (m.nu12 < auxetic_limit) {
      r.fail("nu12", "is below " + fmt(auxetic_limit) +
                         ": a strongly auxetic film is no PVDF film (nu12 ~ 0.35); check the sign");
    }
    m.nu21_given = r.has("nu21");
    m.nu21_table = r.in_range_or("nu21", m.nu12 * m.E2_Pa / m.E1_Pa, -0.99, 10.0);
    if (m.nu21_given) {
      const double reciprocal = m.nu21();
      const double rel = std::abs(m.nu21_table - reciprocal) / std::max(std::abs(reciprocal), 1e-12);
      if (rel > reciprocity_reject_tolerance) {
        r.fail("nu21", "differs by " + fmt(100 * rel) + " % from nu12*E2/E1 = " + fmt(reciprocal) +
                           " (reciprocity); fix the typo or omit nu21 (it is derived from nu12)");
      }
      if (rel > reciprocity_warn_tolerance) {
        warnings.push_back(r.source() + ": " + r.key_path("nu21") + " = " + fmt(m.nu21_table) +
                           " is not reciprocal: nu12*E2/E1 = " + fmt(reciprocal) + " (" + fmt(100 * rel) +
                           " % off); pvdfkit uses nu21 = nu12*E2/E1 (docs/material.md)");
      }
    }
  }
  // Plausibility (docs/scene.md "Physical bounds"): moduli from soft rubber to diamond, and a
  // compliance that is positive definite with a margin; outside, the solver would work for minutes
  // on an absurd film (E = 1e-30 Pa deflects a 45 mm film by 4e10 m) instead of refusing.
  for (const char* k : {"E_Pa", "E1_Pa", "E2_Pa", "G12_Pa"}) {
    if (!r.has(k)) continue;
    const double v = std::string(k) == "E_Pa" ? m.E1_Pa : std::string(k) == "E1_Pa" ? m.E1_Pa
                                                : std::string(k) == "E2_Pa" ? m.E2_Pa : m.G12_Pa;
    if (!(v >= modulus_min_Pa && v <= modulus_max_Pa)) {
      r.fail(k, "must lie in [" + fmt(modulus_min_Pa) + ", " + fmt(modulus_max_Pa) +
                    "] Pa (soft rubber to diamond); check the unit (Pa: PVDF is about 2e9)");
    }
  }
  if (m.E1_Pa > 0 && m.E2_Pa > 0 && m.nu12 * m.nu21() < 1.0 && !(1.0 - m.nu12 * m.nu21() >= poisson_margin)) {
    r.fail(m.isotropic ? "nu" : "nu12",
           "gives 1 - nu12*nu21 = " + fmt(1.0 - m.nu12 * m.nu21()) + " < " + fmt(poisson_margin) +
               ": the compliance is within a hair of losing positive definiteness (no real film); use |nu12| < " +
               fmt(std::sqrt((1 - poisson_margin) * m.E1_Pa / m.E2_Pa)) + " (PVDF: about 0.35)");
  }
  m.draw_angle_rad = r.in_range_or("draw_angle_deg", 0.0, -360.0, 360.0) * deg;
  m.d31_C_per_N = r.in_range_or("d31_C_per_N", m.d31_C_per_N, -1e-9, 1e-9);
  m.d32_C_per_N = r.in_range_or("d32_C_per_N", m.d32_C_per_N, -1e-9, 1e-9);
  const std::string problem = m.positive_definiteness_problem();
  if (!problem.empty()) r.fail_object(problem);
  return m;
}

Electrode parse_electrode(const JsonObjectReader& r, std::size_t index) {
  Electrode e;
  e.name = r.string_or("name", "E" + std::to_string(index + 1));
  if (e.name.empty()) r.fail("name", "is empty; give the electrode a name such as \"A\"");
  const std::string shape = r.choice_or("shape", "rectangle", {"rectangle", "circle", "polygon"});
  if (shape == "rectangle") {
    e.shape = Electrode::Shape::rectangle;
    e.center_m = r.pair("center_m");
    e.size_m = r.pair_or("size_m", {0.002, 0.002});
    if (!(e.size_m[0] > 0 && e.size_m[1] > 0)) {
      r.fail("size_m", "must hold two sizes > 0 [width_m, height_m] (electrode " + e.name + ")");
    }
    e.angle_rad = r.in_range_or("angle_deg", 0.0, -360.0, 360.0) * deg;
  } else if (shape == "circle") {
    e.shape = Electrode::Shape::circle;
    e.center_m = r.pair("center_m");
    e.radius_m = r.positive_or("radius_m", 0.001);
  } else {
    e.shape = Electrode::Shape::polygon;
    e.vertices_m = r.points("vertices_m", 3);
    check_simple_polygon(r, "vertices_m", e.vertices_m);
    e.center_m = e.centroid_m();
  }
  r.finish();
  return e;
}

}  // namespace

Scene parse_scene(const nlohmann::json& json, const std::string& source) {
  Scene s;
  s.source = source;
  s.original = json;
  const JsonObjectReader top(source, "", json);

  if (auto m = top.object_if("membrane")) {
    s.membrane.outline = parse_outline(*m);
    s.membrane.thickness_m = m->in_range_or("thickness_m", 25e-6, 1e-7, 0.01);
    if (m->has("thickness_m") && !(s.membrane.thickness_m > 0)) m->fail("thickness_m", "must be > 0");
    // Negative pre-tension = a slack film (docs/scene.md); slack_strain says the same as a length.
    s.membrane.pretension_N_per_m = m->number_or("pretension_N_per_m", 0.0);
    s.membrane.slack_strain = m->in_range_or("slack_strain", 0.0, 0.0, 0.5);
    if (s.membrane.slack_strain > 0 && s.membrane.pretension_N_per_m != 0)
      m->fail("slack_strain", "is given together with a non-zero pretension_N_per_m; give one of the two");
    s.membrane.tension_field = m->boolean_or("tension_field", false);
    m->finish();
  }
  if (auto m = top.object_if("material")) {
    s.material = parse_material(*m, s.warnings);
    m->finish();
  }
  {
    // |pretension| beyond a tenth of the film's membrane stiffness is a pre-strain of more than
    // 10 % (PVDF yields at a few %): a typo, or a unit mistake (N/m, not N/mm or Pa).
    const double bound = pretension_max_strain * std::sqrt(s.material.E1_Pa * s.material.E2_Pa) * s.membrane.thickness_m;
    if (!(std::abs(s.membrane.pretension_N_per_m) <= bound)) {
      top.object_if("membrane")->fail(
          "pretension_N_per_m", "must lie in [" + fmt(-bound) + ", " + fmt(bound) + "] N/m: |N0| <= " +
                                    fmt(pretension_max_strain) + " x sqrt(E1 E2) x thickness (a pre-strain of at most " +
                                    fmt(100 * pretension_max_strain) + " %); check the unit (N per metre of film)");
    }
  }
  const auto electrodes = top.objects("electrodes");
  std::set<std::string> names;
  for (std::size_t i = 0; i < electrodes.size(); ++i) {
    Electrode e = parse_electrode(electrodes[i], i);
    if (!names.insert(e.name).second) {
      electrodes[i].fail("name", "repeats another electrode's name; names must be unique");
    }
    s.electrodes.push_back(std::move(e));
  }
  if (auto p = top.object_if("probe")) {
    s.probe.radius_m = p->positive_or("radius_m", 0.001);
    p->finish();
  }
  if (top.has("loads")) {
    for (const auto& l : top.objects("loads")) {
      Load load;
      const std::string kind = l.choice_or("type", "probe", {"probe", "pressure"});
      if (kind == "probe") {
        load.kind = Load::Kind::probe;
        load.position_m = l.pair_or("position_m", {0.0, 0.0});
        load.force_N = l.number_or("force_N", 1.0);
        if (!(load.force_N >= force_min_N && load.force_N <= force_max_N)) {
          l.fail("force_N", "must lie in [" + fmt(force_min_N) + ", " + fmt(force_max_N) +
                                "] N (a probe pushes the film: 1 nN to 10 kN)");
        }
        load.radius_m = l.positive_or("radius_m", 0.0);
        if (!s.membrane.outline.contains(load.position_m)) {
          l.fail("position_m", "lies outside the film; give a point inside the clamped outline");
        }
      } else {
        load.kind = Load::Kind::pressure;
        load.pressure_Pa = l.number("pressure_Pa");
        if (!(std::abs(load.pressure_Pa) <= 1e8)) l.fail("pressure_Pa", "must lie in [-1e8, 1e8] Pa");
      }
      l.finish();
      s.loads.push_back(load);
    }
  } else {
    s.loads.push_back(Load{});  // default: 1 N probe at the centre
  }
  if (auto m = top.object_if("mesh")) {
    s.mesh.size_min_m = m->non_negative_or("size_min_m", 0.0);
    s.mesh.size_max_m = m->non_negative_or("size_max_m", 0.0);
    if (s.mesh.size_min_m > 0 && s.mesh.size_max_m > 0 && s.mesh.size_max_m < s.mesh.size_min_m) {
      m->fail("size_max_m", "is smaller than size_min_m; the coarse size must be >= the fine size");
    }
    s.mesh.growth = m->in_range_or("growth", 1.3, 1.01, 3.0);
    s.mesh.order = static_cast<int>(m->integer_or("order", 1, 1, 2));
    s.mesh.embed_probes = m->boolean_or("embed_probes", true);
    s.mesh.min_scaled_jacobian = m->in_range_or("min_scaled_jacobian", 0.2, 0.0, 1.0);
    m->finish();
  }
  if (auto m = top.object_if("model")) {
    s.model.kinematics = m->choice_or("kinematics", "auto", {"auto", "linear", "von-karman", "large-rotation"});
    s.model.tolerance = m->in_range_or("tolerance", 0.01, 1e-8, 0.5);
    s.model.load_kind = m->choice_or("load_kind", "vertical", {"vertical", "follower"});
    s.model.max_refinements = static_cast<int>(m->integer_or("max_refinements", 6, 0, 20));
    m->finish();
  }
  if (top.has("name") || top.has("description")) {
    top.string_or("name", "");
    top.string_or("description", "");
  }
  top.finish();
  check_scene_geometry(s);
  return s;
}

Scene load_scene(const std::string& path) { return parse_scene(read_json_file(path), path); }

const char* default_scene_json() {
  // The seed-001 membrane sensor. Seed 001 gives no electrode coordinates; pvdfkit places the
  // three 2 mm square electrodes at the vertices of an equilateral triangle of circumradius
  // 10 mm centred on the film (A at 90°, B at 210°, C at 330°), the draw direction along x.
  return R"({
  "name": "seed-001 membrane tactile sensor",
  "description": "25 um drawn PVDF clamped over a 90 mm hole; three 2 mm electrodes in a triangle",
  "membrane": {"shape": "circle", "radius_m": 0.045, "thickness_m": 25e-6, "pretension_N_per_m": 0.0},
  "material": {"E1_Pa": 2.2e9, "E2_Pa": 1.8e9, "G12_Pa": 0.58e9, "nu12": 0.35,
               "draw_angle_deg": 0.0, "d31_C_per_N": 6.5e-12, "d32_C_per_N": 0.65e-12},
  "electrodes": [
    {"name": "A", "center_m": [0.0, 0.010], "size_m": [0.002, 0.002], "angle_deg": 0.0},
    {"name": "B", "center_m": [-0.00866025403784439, -0.005], "size_m": [0.002, 0.002], "angle_deg": 0.0},
    {"name": "C", "center_m": [0.00866025403784439, -0.005], "size_m": [0.002, 0.002], "angle_deg": 0.0}
  ],
  "probe": {"radius_m": 0.001},
  "loads": [{"position_m": [0.0, 0.0], "force_N": 1.0}],
  "model": {"kinematics": "auto", "tolerance": 0.01}
})";
}

Scene with_probe_load(const Scene& scene, double x_m, double y_m, double force_N) {
  Scene s = scene;
  Load load;
  load.kind = Load::Kind::probe;
  load.position_m = {x_m, y_m};
  load.force_N = force_N;
  s.loads = {load};
  return s;
}

Scene default_scene() { return parse_scene(parse_json_text(default_scene_json(), "<built-in seed-001 scene>"), "<built-in seed-001 scene>"); }

nlohmann::json scene_to_json(const Scene& s) {
  using nlohmann::json;
  json j;
  const auto& o = s.membrane.outline;
  json mem;
  switch (o.shape) {
    case FilmOutline::Shape::circle: mem["shape"] = "circle"; mem["radius_m"] = o.radius_m; break;
    case FilmOutline::Shape::rectangle: mem["shape"] = "rectangle"; mem["size_m"] = o.size_m; break;
    case FilmOutline::Shape::ellipse: mem["shape"] = "ellipse"; mem["semi_axes_m"] = o.semi_axes_m; break;
    case FilmOutline::Shape::polygon: mem["shape"] = "polygon"; mem["vertices_m"] = o.vertices_m; break;
  }
  mem["thickness_m"] = s.membrane.thickness_m;
  mem["pretension_N_per_m"] = s.membrane.pretension_N_per_m;
  if (s.membrane.slack_strain > 0) mem["slack_strain"] = s.membrane.slack_strain;
  if (s.membrane.tension_field) mem["tension_field"] = true;
  j["membrane"] = mem;
  const auto& m = s.material;
  if (m.isotropic) {
    j["material"] = {{"E_Pa", m.E1_Pa}, {"nu", m.nu12}};
  } else {
    j["material"] = {{"E1_Pa", m.E1_Pa}, {"E2_Pa", m.E2_Pa}, {"G12_Pa", m.G12_Pa}, {"nu12", m.nu12}};
    if (m.nu21_given) j["material"]["nu21"] = m.nu21_table;
  }
  j["material"]["draw_angle_deg"] = m.draw_angle_rad / deg;
  j["material"]["d31_C_per_N"] = m.d31_C_per_N;
  j["material"]["d32_C_per_N"] = m.d32_C_per_N;
  j["electrodes"] = json::array();
  for (const auto& e : s.electrodes) {
    json je{{"name", e.name}};
    switch (e.shape) {
      case Electrode::Shape::rectangle:
        je["shape"] = "rectangle"; je["center_m"] = e.center_m; je["size_m"] = e.size_m;
        je["angle_deg"] = e.angle_rad / deg; break;
      case Electrode::Shape::circle:
        je["shape"] = "circle"; je["center_m"] = e.center_m; je["radius_m"] = e.radius_m; break;
      case Electrode::Shape::polygon:
        je["shape"] = "polygon"; je["vertices_m"] = e.vertices_m; break;
    }
    j["electrodes"].push_back(je);
  }
  j["probe"] = {{"radius_m", s.probe.radius_m}};
  j["loads"] = json::array();
  for (const auto& l : s.loads) {
    if (l.kind == Load::Kind::probe) {
      json jl{{"type", "probe"}, {"position_m", l.position_m}, {"force_N", l.force_N}};
      if (l.radius_m > 0) jl["radius_m"] = l.radius_m;
      j["loads"].push_back(jl);
    } else {
      j["loads"].push_back({{"type", "pressure"}, {"pressure_Pa", l.pressure_Pa}});
    }
  }
  j["mesh"] = {{"size_min_m", s.mesh.size_min_m}, {"size_max_m", s.mesh.size_max_m},
               {"growth", s.mesh.growth}, {"order", s.mesh.order},
               {"embed_probes", s.mesh.embed_probes}, {"min_scaled_jacobian", s.mesh.min_scaled_jacobian}};
  j["model"] = {{"kinematics", s.model.kinematics}, {"tolerance", s.model.tolerance},
                {"load_kind", s.model.load_kind}, {"max_refinements", s.model.max_refinements}};
  return j;
}

}  // namespace pvdf
