// Geometric validation of a scene before meshing: everything Gmsh could choke on, or silently
// mesh into something the user did not mean, is refused here with a message naming the
// electrode or key, the value, the rule and the fix.
#include "scene_geometry.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/scene_geometry.hpp"
#include "pvdf/mesh/mesher.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace pvdf::mesh {

namespace detail {

std::string fmt(double x) {
  std::ostringstream os;
  os.precision(6);
  os << x;
  return os.str();
}

std::string electrode_label(const pvdf::Scene& scene, std::size_t index) {
  return "electrodes[" + std::to_string(index) + "] (\"" + scene.electrodes[index].name + "\")";
}

std::vector<Footprint> probe_footprints(const pvdf::Scene& scene, const std::vector<std::array<double, 2>>& extras,
                                        double sliver_gap_m) {
  std::vector<Footprint> out;
  if (scene.mesh.embed_probes) {
    for (std::size_t i = 0; i < scene.loads.size(); ++i) {
      const auto& l = scene.loads[i];
      if (l.kind != pvdf::Load::Kind::probe) continue;
      out.push_back({l.position_m, l.radius_m > 0 ? l.radius_m : scene.probe.radius_m,
                     "loads[" + std::to_string(i) + "]", true, ""});
    }
  }
  for (std::size_t i = 0; i < extras.size(); ++i) {
    out.push_back({extras[i], scene.probe.radius_m, "extra probe " + std::to_string(i), true, ""});
  }
  const auto& outline = scene.membrane.outline;
  for (std::size_t i = 0; i < out.size(); ++i) {
    Footprint& f = out[i];
    if (outline.inside_distance_m(f.center_m) - f.radius_m < sliver_gap_m) {
      f.embed = false;
      f.note = f.label + ": footprint not embedded: it comes within " + fmt(sliver_gap_m) + " m of the rim";
      continue;
    }
    for (std::size_t k = 0; k < scene.electrodes.size() && f.embed; ++k) {
      if (planar::tangency_gap(f.center_m, f.radius_m, electrode_region(scene.electrodes[k])) < sliver_gap_m) {
        f.embed = false;
        f.note = f.label + ": footprint not embedded: its circle nearly touches the outline of " +
                 electrode_label(scene, k) + " (would make slivers)";
      }
    }
    for (std::size_t j = 0; j < i && f.embed; ++j) {
      if (!out[j].embed) continue;
      planar::Region other;
      other.is_circle = true;
      other.center = out[j].center_m;
      other.radius = out[j].radius_m;
      if (planar::tangency_gap(f.center_m, f.radius_m, other) < sliver_gap_m) {
        f.embed = false;
        f.note = f.label + ": footprint not embedded: it coincides with or nearly touches " + out[j].label;
      }
    }
  }
  return out;
}

namespace {

bool finite_positive(double x) { return std::isfinite(x) && x > 0; }
bool finite_point(const std::array<double, 2>& p) { return std::isfinite(p[0]) && std::isfinite(p[1]); }

[[noreturn]] void fail(const pvdf::Scene& scene, const std::string& what) {
  throw pvdf::InputError(scene.source + ": " + what);
}

void check_sizes(const pvdf::Scene& s) {
  const auto& o = s.membrane.outline;
  switch (o.shape) {
    case pvdf::FilmOutline::Shape::circle:
      if (!finite_positive(o.radius_m)) fail(s, "membrane.radius_m = " + fmt(o.radius_m) + " must be > 0");
      break;
    case pvdf::FilmOutline::Shape::rectangle:
      if (!finite_positive(o.size_m[0]) || !finite_positive(o.size_m[1])) {
        fail(s, "membrane.size_m = [" + fmt(o.size_m[0]) + ", " + fmt(o.size_m[1]) + "] must hold two sizes > 0");
      }
      break;
    case pvdf::FilmOutline::Shape::ellipse:
      if (!finite_positive(o.semi_axes_m[0]) || !finite_positive(o.semi_axes_m[1])) {
        fail(s, "membrane.semi_axes_m = [" + fmt(o.semi_axes_m[0]) + ", " + fmt(o.semi_axes_m[1]) +
                    "] must hold two semi-axes > 0");
      }
      break;
    case pvdf::FilmOutline::Shape::polygon: {
      if (o.vertices_m.size() < 3) fail(s, "membrane.vertices_m needs at least 3 points");
      for (const auto& p : o.vertices_m) {
        if (!finite_point(p)) fail(s, "membrane.vertices_m holds a non-finite coordinate");
      }
      const auto bad = planar::first_self_intersection(o.vertices_m);
      if (bad[0] >= 0) {
        fail(s, "membrane.vertices_m is self-intersecting (edge " + std::to_string(bad[0]) + " meets edge " +
                    std::to_string(bad[1]) + "); list the vertices in order around a simple outline");
      }
      if (!(std::abs(planar::signed_area(o.vertices_m)) > 0)) fail(s, "membrane.vertices_m encloses zero area");
      if (!(o.inside_distance_m({0, 0}) > 0)) {
        fail(s, "membrane.vertices_m must enclose the origin (0, 0), the film's reference point; shift the outline");
      }
      break;
    }
  }
  const auto& m = s.mesh;
  if (!(std::isfinite(m.size_min_m) && m.size_min_m >= 0)) {
    fail(s, "mesh.size_min_m = " + fmt(m.size_min_m) + " must be > 0 (or 0 for the default)");
  }
  if (!(std::isfinite(m.size_max_m) && m.size_max_m >= 0)) {
    fail(s, "mesh.size_max_m = " + fmt(m.size_max_m) + " must be > 0 (or 0 for the default)");
  }
  if (m.size_min_m > 0 && m.size_max_m > 0 && m.size_max_m < m.size_min_m) {
    fail(s, "mesh.size_max_m = " + fmt(m.size_max_m) + " is smaller than mesh.size_min_m = " + fmt(m.size_min_m) +
                "; the coarse size must be >= the fine size");
  }
  if (!(m.growth > 1.0 && m.growth <= 10.0)) {
    fail(s, "mesh.growth = " + fmt(m.growth) + " must lie in (1, 10]; 1.3 is a good value");
  }
  if (m.order != 1 && m.order != 2) fail(s, "mesh.order = " + std::to_string(m.order) + " must be 1 or 2");
  if (!(m.min_scaled_jacobian >= 0 && m.min_scaled_jacobian <= 1)) {
    fail(s, "mesh.min_scaled_jacobian = " + fmt(m.min_scaled_jacobian) + " must lie in [0, 1]");
  }
  if (s.electrodes.size() > 254) {
    fail(s, "electrodes lists " + std::to_string(s.electrodes.size()) +
                " electrodes; at most 254 fit the 8-bit material ids of the mesh (film 0, electrode k -> k+1)");
  }
  if (!finite_positive(s.probe.radius_m)) fail(s, "probe.radius_m = " + fmt(s.probe.radius_m) + " must be > 0");
  for (std::size_t i = 0; i < s.loads.size(); ++i) {
    const auto& l = s.loads[i];
    if (l.kind != pvdf::Load::Kind::probe) continue;
    const std::string key = "loads[" + std::to_string(i) + "]";
    if (!finite_point(l.position_m)) fail(s, key + ".position_m holds a non-finite coordinate");
    if (!(std::isfinite(l.radius_m) && l.radius_m >= 0)) {
      fail(s, key + ".radius_m = " + fmt(l.radius_m) + " must be > 0 (or 0 for the scene's probe.radius_m)");
    }
  }
  for (std::size_t k = 0; k < s.electrodes.size(); ++k) {
    const auto& e = s.electrodes[k];
    const std::string key = electrode_label(s, k);
    switch (e.shape) {
      case pvdf::Electrode::Shape::rectangle:
        if (!finite_point(e.center_m)) fail(s, key + ".center_m holds a non-finite coordinate");
        if (!finite_positive(e.size_m[0]) || !finite_positive(e.size_m[1])) {
          fail(s, key + ".size_m = [" + fmt(e.size_m[0]) + ", " + fmt(e.size_m[1]) + "] must hold two sizes > 0");
        }
        if (!std::isfinite(e.angle_rad)) fail(s, key + ".angle_deg is not finite");
        break;
      case pvdf::Electrode::Shape::circle:
        if (!finite_point(e.center_m)) fail(s, key + ".center_m holds a non-finite coordinate");
        if (!finite_positive(e.radius_m)) fail(s, key + ".radius_m = " + fmt(e.radius_m) + " must be > 0");
        break;
      case pvdf::Electrode::Shape::polygon: {
        if (e.vertices_m.size() < 3) fail(s, key + ".vertices_m needs at least 3 points");
        for (const auto& p : e.vertices_m) {
          if (!finite_point(p)) fail(s, key + ".vertices_m holds a non-finite coordinate");
        }
        for (std::size_t i = 0; i < e.vertices_m.size(); ++i) {
          const auto& a = e.vertices_m[i];
          const auto& b = e.vertices_m[(i + 1) % e.vertices_m.size()];
          if (a == b) fail(s, key + ".vertices_m repeats vertex " + std::to_string(i) + "; remove the duplicate point");
        }
        const auto bad = planar::first_self_intersection(e.vertices_m);
        if (bad[0] >= 0) {
          fail(s, key + ".vertices_m is self-intersecting (edge " + std::to_string(bad[0]) + " meets edge " +
                      std::to_string(bad[1]) + "); list the vertices in order around a simple outline");
        }
        if (!(std::abs(planar::signed_area(e.vertices_m)) > 0)) {
          fail(s, key + ".vertices_m encloses zero area; give at least three non-collinear points");
        }
        break;
      }
    }
  }
}

using pvdf::RimRelation;
using pvdf::rim_relation;

}  // namespace

void validate_geometry(const pvdf::Scene& s, const std::vector<std::array<double, 2>>& extras) {
  check_sizes(s);
  const auto sizes = target_sizes_m(s);
  const double size_min = sizes[0];
  const double clearance = 0.5 * size_min;
  const std::string clearance_text = fmt(clearance) + " m (half the finest mesh size " + fmt(size_min) + " m)";

  for (std::size_t k = 0; k < s.electrodes.size(); ++k) {
    const auto& e = s.electrodes[k];
    const std::string key = electrode_label(s, k);
    const double feature = electrode_feature_size_m(e);
    if (feature < size_min) {
      fail(s, key + ": its size " + fmt(feature) + " m (" +
                  (e.shape == pvdf::Electrode::Shape::rectangle ? "smaller side"
                   : e.shape == pvdf::Electrode::Shape::circle  ? "diameter"
                                                                : "4*area/perimeter") +
                  ") is smaller than the finest mesh size " + fmt(size_min) +
                  " m; enlarge the electrode or set a smaller mesh.size_min_m");
    }
    const RimRelation rel = rim_relation(s.membrane.outline, e);
    if (rel.kind == RimRelation::Kind::outside) {
      fail(s, key + " lies outside the film; move its centre/vertices inside the clamped outline");
    }
    if (rel.kind == RimRelation::Kind::crossing) {
      fail(s, key + " crosses or touches the rim; move it inward or shrink it (electrodes lie inside the film)");
    }
    if (rel.clearance_m < clearance) {
      fail(s, key + " touches the rim: its outline comes within " + fmt(rel.clearance_m) +
                  " m of it; keep at least " + clearance_text + " clear, or set a smaller mesh.size_min_m");
    }
  }
  for (std::size_t a = 0; a < s.electrodes.size(); ++a) {
    const planar::Region ra = electrode_region(s.electrodes[a]);
    for (std::size_t b = a + 1; b < s.electrodes.size(); ++b) {
      const planar::Region rb = electrode_region(s.electrodes[b]);
      if (planar::regions_overlap(ra, rb)) {
        fail(s, electrode_label(s, b) + " overlaps " + electrode_label(s, a) +
                    "; electrodes must be disjoint (each is the overlap of a top and bottom electrode)");
      }
      const double gap = planar::boundary_distance(ra, rb);
      if (gap < clearance) {
        fail(s, electrode_label(s, b) + " touches " + electrode_label(s, a) + ": gap " + fmt(gap) +
                    " m; keep at least " + clearance_text + " between electrodes");
      }
    }
  }
  auto check_footprint = [&](const std::array<double, 2>& c, double r, const std::string& key, const std::string& fix) {
    if (!finite_point(c)) fail(s, key + " position is not finite");
    const double inside = s.membrane.outline.inside_distance_m(c);
    if (inside <= 0) {
      fail(s, key + ": the probe centre [" + fmt(c[0]) + ", " + fmt(c[1]) + "] m lies outside the film; " + fix);
    }
    if (inside - r < 0) {
      fail(s, key + ": the probe footprint (centre [" + fmt(c[0]) + ", " + fmt(c[1]) + "] m, radius " + fmt(r) +
                  " m) reaches " + fmt(r - inside) + " m outside the film; " + fix);
    }
  };
  for (std::size_t i = 0; i < s.loads.size(); ++i) {
    const auto& l = s.loads[i];
    if (l.kind != pvdf::Load::Kind::probe) continue;
    const double r = l.radius_m > 0 ? l.radius_m : s.probe.radius_m;
    check_footprint(l.position_m, r, "loads[" + std::to_string(i) + "]",
                    "move loads[" + std::to_string(i) + "].position_m inward or use a smaller " +
                        (l.radius_m > 0 ? "loads[" + std::to_string(i) + "].radius_m" : std::string("probe.radius_m")));
  }
  for (std::size_t i = 0; i < extras.size(); ++i) {
    check_footprint(extras[i], s.probe.radius_m, "extra probe position " + std::to_string(i),
                    "keep probe positions at least probe.radius_m inside the rim");
  }
}

}  // namespace detail

std::array<double, 2> target_sizes_m(const pvdf::Scene& scene) {
  double size_min = 0.5 * scene.probe.radius_m;
  for (const auto& l : scene.loads) {
    if (l.kind == pvdf::Load::Kind::probe && l.radius_m > 0) size_min = std::min(size_min, 0.5 * l.radius_m);
  }
  for (const auto& e : scene.electrodes) {
    size_min = std::min(size_min, 0.25 * detail::electrode_feature_size_m(e));
  }
  const double radius = scene.membrane.outline.characteristic_radius_m();
  double size_max = radius / 8;
  size_min = std::min(size_min, size_max);
  if (scene.mesh.size_min_m > 0) size_min = scene.mesh.size_min_m;
  if (scene.mesh.size_max_m > 0) {
    size_max = scene.mesh.size_max_m;
    if (!(scene.mesh.size_min_m > 0)) size_min = std::min(size_min, size_max);
  }
  size_max = std::max(size_max, size_min);
  return {size_min, size_max};
}

void validate_geometry(const pvdf::Scene& scene) { detail::validate_geometry(scene, {}); }

// A .msh file from elsewhere (or from another scene) must fit the scene it is solved with: the
// solver takes the film, material, electrodes and loads from the scene and only the cells from the
// mesh, so a mesh of another film would silently solve another problem.
void check_mesh_fits_scene(const pvdf::Scene& scene, const FilmMesh& mesh, const std::string& source) {
  using detail::fmt;
  if (mesh.quads.empty()) throw pvdf::InputError(source + ": holds no quadrilaterals; write the mesh with pvdfkit mesh");
  if (mesh.rim_edges.empty()) {
    throw pvdf::InputError(source + ": its physical curve \"rim\" holds no edges; the clamped rim must be a group of "
                           "boundary lines (docs/mesh.md)");
  }
  for (std::size_t i = 0; i < mesh.quads.size(); ++i) {
    const auto& q = mesh.quads[i];
    const double sj = scaled_jacobian({mesh.vertices[q[0]], mesh.vertices[q[1]], mesh.vertices[q[2]], mesh.vertices[q[3]]});
    if (!(sj > 0)) {
      throw pvdf::InputError(source + ": quadrilateral " + std::to_string(i) + " is degenerate or self-crossing (scaled "
                             "Jacobian " + fmt(sj) + " <= 0); fix or remesh it (pvdfkit mesh)");
    }
  }
  const auto& outline = scene.membrane.outline;
  const double radius = outline.characteristic_radius_m();
  for (const auto& v : mesh.vertices) {
    if (!std::isfinite(v[0]) || !std::isfinite(v[1]) || outline.inside_distance_m({v[0], v[1]}) < -1e-3 * radius) {
      throw pvdf::InputError(source + ": vertex (" + fmt(v[0]) + ", " + fmt(v[1]) + ") m lies outside the film of " +
                             scene.source + "; the mesh must be of this scene's film, in metres");
    }
  }
  double area = 0;
  for (std::uint8_t id = 0; id <= mesh.electrode_names.size(); ++id) area += material_area_m2(mesh, id);
  const double nominal = outline.area_m2();
  if (!(std::abs(area - nominal) <= 0.05 * nominal)) {
    throw pvdf::InputError(source + ": meshes " + fmt(area) + " m^2 but the film of " + scene.source + " has " +
                           fmt(nominal) + " m^2 (more than 5 % apart); mesh this scene with pvdfkit mesh");
  }
  if (mesh.electrode_names.empty()) return;
  std::string expected;
  for (const auto& e : scene.electrodes) expected += (expected.empty() ? "" : ", ") + e.name;
  std::string found;
  for (const auto& n : mesh.electrode_names) found += (found.empty() ? "" : ", ") + pvdf::escape_control_bytes(n);
  if (found != expected) {
    throw pvdf::InputError(source + ": electrode groups [" + found + "] (in tag order) are not the electrodes [" +
                           expected + "] of " + scene.source + "; mesh this scene with pvdfkit mesh");
  }
}

}  // namespace pvdf::mesh
