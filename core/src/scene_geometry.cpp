// Geometric consistency of a scene, checked by the scene reader (see scene_geometry.hpp).
#include "pvdf/core/scene_geometry.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/membrane_scaling.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace pvdf {

namespace {

[[noreturn]] void fail(const Scene& s, const std::string& what) { throw InputError(s.source + ": " + what); }

std::string label(const Scene& s, std::size_t k) {
  return "electrodes[" + std::to_string(k) + "] (\"" + escape_control_bytes(s.electrodes[k].name) + "\")";
}

std::string outline_key(const FilmOutline& o) {
  switch (o.shape) {
    case FilmOutline::Shape::circle: return "membrane.radius_m";
    case FilmOutline::Shape::rectangle: return "membrane.size_m";
    case FilmOutline::Shape::ellipse: return "membrane.semi_axes_m";
    case FilmOutline::Shape::polygon: return "membrane.vertices_m";
  }
  return "membrane";
}

void check_film(const Scene& s) {
  using namespace scene_limits;
  const auto& o = s.membrane.outline;
  const double r = o.characteristic_radius_m();
  if (!(r >= film_radius_min_m && r <= film_radius_max_m)) {
    fail(s, outline_key(o) + ": film size " + format_g(r) + " m is outside the physical range [" +
                format_g(film_radius_min_m) + ", " + format_g(film_radius_max_m) +
                "] m (radius, half the longer side, larger semi-axis); check the unit (metres)");
  }
  const double inscribed = o.inscribed_radius_m();
  if (!(inscribed * film_aspect_max >= r)) {
    fail(s, outline_key(o) + ": the film is " + format_g(r / inscribed) + " times longer than wide; at most " +
                format_g(film_aspect_max) + " is supported; widen it");
  }
}

void check_sizes(const Scene& s) {
  using namespace scene_limits;
  const double r = s.membrane.outline.characteristic_radius_m();
  const double smallest = feature_ratio_min * r;
  const std::string why = " (" + format_g(feature_ratio_min) + " of the film size " + format_g(r) +
                          " m: a mesh resolving less cannot span the film)";
  const double p = s.probe.radius_m;
  const double p_max = probe_radius_max_ratio * s.membrane.outline.inscribed_radius_m();
  if (!(p >= smallest && p <= p_max)) {
    fail(s, "probe.radius_m = " + format_g(p) + " must lie in [" + format_g(smallest) + ", " + format_g(p_max) +
                "] m" + why + "; the upper bound is " + format_g(probe_radius_max_ratio) + " of the inscribed radius");
  }
  for (std::size_t i = 0; i < s.loads.size(); ++i) {
    const double lr = s.loads[i].radius_m;
    if (s.loads[i].kind == Load::Kind::probe && lr != 0 && !(lr >= smallest && lr <= p_max)) {
      fail(s, "loads[" + std::to_string(i) + "].radius_m = " + format_g(lr) + " must lie in [" + format_g(smallest) +
                  ", " + format_g(p_max) + "] m" + why);
    }
  }
  for (std::size_t k = 0; k < s.electrodes.size(); ++k) {
    const auto& e = s.electrodes[k];
    const double f = electrode_feature_size_m(e);
    if (!(f >= smallest)) {
      const char* key = e.shape == Electrode::Shape::rectangle ? ".size_m"
                        : e.shape == Electrode::Shape::circle  ? ".radius_m"
                                                               : ".vertices_m";
      fail(s, "electrodes[" + std::to_string(k) + "]" + key + ": electrode size " + format_g(f) +
                  " m is below the smallest " + format_g(smallest) + " m" + why + "; enlarge the electrode");
    }
  }
  for (const auto& [key, v] : {std::pair<const char*, double>{"mesh.size_min_m", s.mesh.size_min_m},
                               std::pair<const char*, double>{"mesh.size_max_m", s.mesh.size_max_m}}) {
    if (v != 0 && !(v >= smallest && v <= 2 * r)) {
      fail(s, std::string(key) + " = " + format_g(v) + " must be 0 (derived) or lie in [" + format_g(smallest) + ", " +
                  format_g(2 * r) + "] m" + why);
    }
  }
}

void check_electrodes(const Scene& s) {
  for (std::size_t k = 0; k < s.electrodes.size(); ++k) {
    const RimRelation rel = rim_relation(s.membrane.outline, s.electrodes[k]);
    if (rel.kind == RimRelation::Kind::outside) {
      fail(s, label(s, k) + " lies outside the film; move its centre or vertices inside the clamped outline");
    }
    if (rel.kind == RimRelation::Kind::crossing) {
      fail(s, label(s, k) + " crosses or touches the rim; move it inward or shrink it (electrodes lie inside the film)");
    }
  }
  for (std::size_t a = 0; a < s.electrodes.size(); ++a) {
    const planar::Region ra = electrode_region(s.electrodes[a]);
    for (std::size_t b = a + 1; b < s.electrodes.size(); ++b) {
      const planar::Region rb = electrode_region(s.electrodes[b]);
      if (planar::regions_overlap(ra, rb) || !(planar::boundary_distance(ra, rb) > 0)) {
        fail(s, label(s, b) + " overlaps " + label(s, a) +
                    "; electrodes must be disjoint (each is the overlap of a top and bottom electrode)");
      }
    }
  }
}

}  // namespace

planar::Region film_region(const FilmOutline& o) {
  planar::Region r;
  switch (o.shape) {
    case FilmOutline::Shape::circle:
      r.is_circle = true;
      r.radius = o.radius_m;
      break;
    case FilmOutline::Shape::rectangle: {
      const double hx = 0.5 * o.size_m[0], hy = 0.5 * o.size_m[1];
      r.vertices = {{-hx, -hy}, {hx, -hy}, {hx, hy}, {-hx, hy}};
      break;
    }
    case FilmOutline::Shape::ellipse: {
      const int n = 1024;
      for (int i = 0; i < n; ++i) {
        const double t = 2 * pi * i / n;
        r.vertices.push_back({o.semi_axes_m[0] * std::cos(t), o.semi_axes_m[1] * std::sin(t)});
      }
      break;
    }
    case FilmOutline::Shape::polygon: r.vertices = o.vertices_m; break;
  }
  return r;
}

planar::Region electrode_region(const Electrode& e) {
  planar::Region r;
  if (e.shape == Electrode::Shape::circle) {
    r.is_circle = true;
    r.center = e.center_m;
    r.radius = e.radius_m;
  } else {
    r.vertices = e.outline();
  }
  return r;
}

double electrode_feature_size_m(const Electrode& e) {
  switch (e.shape) {
    case Electrode::Shape::rectangle: return std::min(e.size_m[0], e.size_m[1]);
    case Electrode::Shape::circle: return 2 * e.radius_m;
    case Electrode::Shape::polygon: return 4 * std::abs(planar::signed_area(e.vertices_m)) / planar::perimeter(e.vertices_m);
  }
  return 0;
}

RimRelation rim_relation(const FilmOutline& o, const Electrode& e) {
  RimRelation rel;
  if (o.shape == FilmOutline::Shape::ellipse) {
    // The ellipse is convex: the signed distance to its outline is concave inside, so its
    // minimum over a polygon is at a vertex; circles are sampled and the sagitta subtracted.
    const int n = 256;
    const auto pts = e.outline(n);
    const double sagitta = e.shape == Electrode::Shape::circle ? e.radius_m * (1 - std::cos(pi / n)) : 0.0;
    double lo = 1e300, hi = -1e300;
    for (const auto& p : pts) {
      const double d = o.inside_distance_m(p);
      lo = std::min(lo, d);
      hi = std::max(hi, d);
    }
    lo -= sagitta;
    if (lo > 0) rel.clearance_m = lo;
    else rel.kind = hi > 0 ? RimRelation::Kind::crossing : RimRelation::Kind::outside;
    return rel;
  }
  const planar::Region film = film_region(o);
  const planar::Region reg = electrode_region(e);
  const double d = planar::boundary_distance(film, reg);
  if (d <= 0) {
    rel.kind = RimRelation::Kind::crossing;
  } else if (!planar::region_contains(film, planar::boundary_point(reg))) {
    rel.kind = RimRelation::Kind::outside;
  } else {
    rel.clearance_m = d;
  }
  return rel;
}

std::string probe_footprint_problem(const Scene& s, const Point2& c, double radius_m) {
  if (!std::isfinite(c[0]) || !std::isfinite(c[1])) return "the probe position is not finite";
  const double inside = s.membrane.outline.inside_distance_m(c);
  const std::string where = "the probe centre [" + format_g(c[0]) + ", " + format_g(c[1]) + "] m";
  if (!(inside > 0)) return where + " lies outside the film; give a point inside the clamped outline";
  if (inside - radius_m < radius_m) {
    return where + " with radius " + format_g(radius_m) + " m comes within " + format_g(inside - radius_m) +
           " m of the rim; keep the footprint at least one probe radius clear (centre at least " +
           format_g(2 * radius_m) + " m inside the rim, as charge maps do)";
  }
  return "";
}

void check_scene_geometry(const Scene& s) {
  check_film(s);
  check_sizes(s);
  check_electrodes(s);
  for (std::size_t i = 0; i < s.loads.size(); ++i) {
    const auto& l = s.loads[i];
    if (l.kind != Load::Kind::probe) continue;
    const std::string problem = probe_footprint_problem(s, l.position_m, l.radius_m > 0 ? l.radius_m : s.probe.radius_m);
    if (!problem.empty()) fail(s, "loads[" + std::to_string(i) + "].position_m: " + problem);
    // After the film's own checks: the estimate needs a film of physical size.
    const std::string unresolved = force_resolution_problem(s, l.force_N);
    if (!unresolved.empty()) fail(s, "loads[" + std::to_string(i) + "].force_N = " + format_g(l.force_N) + " is too small: " + unresolved);
  }
}

double estimated_deflection_m(const Scene& scene, double force_N) {
  const double a = scene.membrane.outline.inscribed_radius_m();
  const double h = scene.membrane.thickness_m;
  const Material& m = scene.material;
  const double E = std::max(m.E1_Pa, m.E2_Pa);
  const double D = E * h * h * h / (12.0 * std::max(1.0 - m.nu12 * m.nu21(), 0.05));
  const double r_p = std::min(std::max(scene.probe.radius_m, 1e-3 * a), 0.5 * a);
  // Stiffnesses F/w of the three mechanisms at this force (the membrane's is secant: F^(2/3)).
  const double k_plate = 16.0 * pi * D / (a * a);
  const double N0 = std::max(scene.membrane.pretension_N_per_m, 0.0);
  const double k_tension = 2.0 * pi * N0 / std::log(a / r_p);
  const double w_membrane = membrane_deflection_scale_m(E * h, force_N, a);
  const double k_membrane = w_membrane > 0 ? force_N / w_membrane : 0.0;
  const double k = k_plate + k_tension + k_membrane;
  return k > 0 ? force_N / k : 0.0;
}

std::string force_levels_problem(const std::vector<double>& forces_N, std::size_t& index) {
  for (index = 0; index < forces_N.size(); ++index) {
    const double f = forces_N[index];
    if (!(f >= 1e-9 && f <= 1e4)) {
      return format_g(f) + " must lie in [1e-9, 1e4] N (a press pushes the film; the rule of loads[].force_N)";
    }
  }
  std::vector<double> sorted = forces_N;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 1; i < sorted.size(); ++i) {
    if (sorted[i] - sorted[i - 1] <= 1e-6 * sorted[i]) {
      char a[32], b[32];
      std::snprintf(a, sizeof a, "%.17g", sorted[i - 1]);
      std::snprintf(b, sizeof b, "%.17g", sorted[i]);
      return std::string("the levels ") + a + " and " + b +
             " N are not distinct (closer than a relative 1e-6); give each force level once";
    }
  }
  index = forces_N.size();
  return "";
}

std::string force_resolution_problem(const Scene& scene, double force_N) {
  const double size = scene.membrane.outline.inscribed_radius_m();
  const double w_min = scene_limits::deflection_ratio_min * size;
  if (!(size > 0) || !(force_N > 0)) return "";  // the outline's and the force's own rules refuse these
  const double w = estimated_deflection_m(scene, force_N);
  if (w >= w_min) return "";
  // The deflection grows monotonically with the force: bisect in log F for the smallest force.
  double lo = std::log(std::max(force_N, 1e-300)), hi = std::log(1e4);
  for (int it = 0; it < 100; ++it) {
    const double mid = 0.5 * (lo + hi);
    (estimated_deflection_m(scene, std::exp(mid)) >= w_min ? hi : lo) = mid;
  }
  return "a press of " + format_g(force_N) + " N deflects this film by about " + format_g(w) + " m, below " +
         format_g(scene_limits::deflection_ratio_min) + " of its size " + format_g(size) +
         " m (lost to rounding); use a force >= " + format_g(std::exp(hi)) + " N";
}

}  // namespace pvdf
