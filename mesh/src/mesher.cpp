// Scene → Gmsh (OpenCASCADE kernel) → all-quad FilmMesh. The geometry is built in units of the
// film's characteristic radius so that Gmsh's absolute tolerances mean the same for a 1 mm and a
// 1 m film; coordinates are scaled back to metres on extraction (and on writing .msh files).
#include "pvdf/mesh/mesher.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "scene_geometry.hpp"

#include <gmsh.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <unordered_map>

namespace pvdf::mesh {

namespace {

/// Reorders a quad's vertices counter-clockwise (deal.II's orientation) when Gmsh gave them clockwise.
void make_counter_clockwise(std::array<unsigned int, 4>& quad, const std::vector<std::array<double, 2>>& vertices) {
  double area2 = 0;
  for (int c = 0; c < 4; ++c) {
    const auto& p = vertices[quad[c]];
    const auto& r = vertices[quad[(c + 1) % 4]];
    area2 += p[0] * r[1] - r[0] * p[1];
  }
  if (area2 < 0) std::swap(quad[1], quad[3]);
}

/// An estimate of the quadrilateral count before meshing, to refuse runaway requests: the far
/// field at size_max, plus a graded band (sizes growing by mesh.growth per ring) along every
/// electrode outline and embedded probe circle, times the ~5 quads Gmsh's recombination and
/// subdivision make per triangle-sized cell (seed 001: estimate 2300, Gmsh 2472).
double estimated_cells(const pvdf::Scene& scene, const std::array<double, 2>& sizes_m, std::size_t n_extras) {
  const double h_min = sizes_m[0], h_max = sizes_m[1];
  const double g = scene.mesh.growth;
  double perimeter = 0;
  for (const auto& e : scene.electrodes) {
    perimeter += e.shape == pvdf::Electrode::Shape::circle ? 2 * pi * e.radius_m : planar::perimeter(e.outline());
  }
  for (const auto& l : scene.loads) {
    if (l.kind == pvdf::Load::Kind::probe) perimeter += 2 * pi * (l.radius_m > 0 ? l.radius_m : scene.probe.radius_m);
  }
  perimeter += static_cast<double>(n_extras) * 2 * pi * scene.probe.radius_m;
  const double far = scene.membrane.outline.area_m2() / (h_max * h_max);
  const double bands = perimeter / h_min * g / (g - 1);
  return 5 * (far + bands);
}

/// Gmsh is a process-wide singleton: initialized on first use, finalized once at exit, and
/// used by one thread at a time.
class GmshSession {
 public:
  static GmshSession& instance() {
    static GmshSession session;
    return session;
  }
  std::mutex& mutex() { return mutex_; }
  GmshSession(const GmshSession&) = delete;
  GmshSession& operator=(const GmshSession&) = delete;

 private:
  GmshSession() {
    gmsh::initialize(0, nullptr, false);
    gmsh::option::setNumber("General.Terminal", 0);
  }
  ~GmshSession() {
    try {
      gmsh::finalize();
    } catch (...) {
      // Nothing sensible to do at exit.
    }
  }
  std::mutex mutex_;
};

std::string gmsh_error_text() {
  std::string e;
  try {
    gmsh::logger::getLastError(e);
  } catch (...) {
  }
  return e.empty() ? "unknown Gmsh error" : e;
}

/// Runs a Gmsh call sequence, turning Gmsh's exceptions (it throws std::string) into
/// pvdf::NumericalError.
void guarded(const std::string& what, const std::function<void()>& f) {
  try {
    f();
  } catch (const pvdf::InputError&) {
    throw;
  } catch (const pvdf::NumericalError&) {
    throw;
  } catch (const std::string& s) {
    throw pvdf::NumericalError("Gmsh failed while " + what + ": " + s);
  } catch (const std::exception& e) {
    throw pvdf::NumericalError("Gmsh failed while " + what + ": " + e.what());
  } catch (...) {
    throw pvdf::NumericalError("Gmsh failed while " + what + ": " + gmsh_error_text());
  }
}

int add_polygon(const std::vector<std::array<double, 2>>& vertices, double scale) {
  std::vector<int> points, lines;
  for (const auto& v : vertices) points.push_back(gmsh::model::occ::addPoint(v[0] * scale, v[1] * scale, 0));
  for (std::size_t i = 0; i < points.size(); ++i) {
    lines.push_back(gmsh::model::occ::addLine(points[i], points[(i + 1) % points.size()]));
  }
  const int loop = gmsh::model::occ::addCurveLoop(lines);
  return gmsh::model::occ::addPlaneSurface({loop});
}

int add_film(const pvdf::FilmOutline& o, double scale) {
  switch (o.shape) {
    case pvdf::FilmOutline::Shape::circle: return gmsh::model::occ::addDisk(0, 0, 0, o.radius_m * scale, o.radius_m * scale);
    case pvdf::FilmOutline::Shape::rectangle: {
      const double hx = 0.5 * o.size_m[0], hy = 0.5 * o.size_m[1];
      return add_polygon({{-hx, -hy}, {hx, -hy}, {hx, hy}, {-hx, hy}}, scale);
    }
    case pvdf::FilmOutline::Shape::ellipse: {
      const double a = o.semi_axes_m[0] * scale, b = o.semi_axes_m[1] * scale;
      if (a >= b) return gmsh::model::occ::addDisk(0, 0, 0, a, b);
      // OpenCASCADE wants the major radius along x: build it along x and turn it.
      const int tag = gmsh::model::occ::addDisk(0, 0, 0, b, a);
      gmsh::model::occ::rotate({{2, tag}}, 0, 0, 0, 0, 0, 1, pi / 2);
      return tag;
    }
    case pvdf::FilmOutline::Shape::polygon: return add_polygon(o.vertices_m, scale);
  }
  return -1;
}

int add_electrode(const pvdf::Electrode& e, double scale) {
  if (e.shape == pvdf::Electrode::Shape::circle) {
    return gmsh::model::occ::addDisk(e.center_m[0] * scale, e.center_m[1] * scale, 0, e.radius_m * scale,
                                     e.radius_m * scale);
  }
  return add_polygon(e.outline(), scale);
}

/// Runs one Gmsh geometry call for the scene entity `label`; a Gmsh refusal (e.g. "Could not
/// create line" for two vertices closer than its tolerance) becomes an InputError naming it.
int named(const pvdf::Scene& scene, const std::string& label, const std::function<int()>& f) {
  std::string why;
  try {
    return f();
  } catch (const std::string& e) {
    why = e;
  } catch (const std::exception& e) {
    why = e.what();
  } catch (...) {
    why = gmsh_error_text();
  }
  throw pvdf::InputError(scene.source + ": " + label + ": Gmsh could not build its outline (" +
                         pvdf::escape_control_bytes(why) +
                         "); two of its vertices nearly coincide or an edge is too short: remove the short edge");
}

struct Model {
  FilmMesh mesh;
  bool accepted = false;            ///< quality at or above the threshold
  double min_scaled_jacobian = 0;   ///< of `mesh`
  std::string algorithm;            ///< Gmsh configuration that made `mesh`
  std::size_t n_attempts = 0;
  std::string failures;             ///< why earlier configurations were not accepted
  std::vector<std::string> notes;
  std::size_t n_probes_embedded = 0;
  double scale_m = 1;  ///< metres per model unit
};

/// Gmsh options of every attempt: quiet, one thread, all-quad by recombination, sizes from the
/// field set by set_size_field (at most `size_max`, model units).
void set_gmsh_options(const MeshParameters& params, double size_max) {
  gmsh::option::setNumber("General.Terminal", params.verbose ? 1 : 0);
  gmsh::option::setNumber("General.Verbosity", params.verbose ? 5 : 0);
  gmsh::option::setNumber("General.NumThreads", 1);
  gmsh::option::setNumber("Geometry.OCCBooleanPreserveNumbering", 1);
  // Triangles recombined into quads and subdivided to an all-quad mesh (the algorithms are
  // chosen per attempt below; Gmsh 4.8's quad algorithm 8 can crash here, docs/mesh.md).
  gmsh::option::setNumber("Mesh.RecombineAll", 1);
  gmsh::option::setNumber("Mesh.SubdivisionAlgorithm", 0);
  gmsh::option::setNumber("Mesh.ElementOrder", 1);
  gmsh::option::setNumber("Mesh.MeshSizeFromPoints", 0);
  gmsh::option::setNumber("Mesh.MeshSizeFromCurvature", 0);
  // Extending the boundary sizes inward avoids the cap triangles (two edges on a small circle)
  // whose subdivision gives near-flat quads (scaled Jacobian ~0.2 at the probe circle).
  gmsh::option::setNumber("Mesh.MeshSizeExtendFromBoundary", 1);
  gmsh::option::setNumber("Mesh.MeshSizeMin", 0);
  gmsh::option::setNumber("Mesh.MeshSizeMax", size_max);
  gmsh::option::setNumber("Mesh.ScalingFactor", 1);
  gmsh::option::setNumber("Mesh.SaveAll", 0);
}

/// The model's faces and curves after the boolean fragment of the film with the electrodes and
/// the embedded probe disks.
struct Geometry {
  std::vector<int> rim_curves, inner_curves;
  std::map<int, int> face_material;  ///< face tag -> material id
};

/// Builds the film, electrodes and probe disks (model units: metres × s), fragments them and
/// adds the physical groups (docs/mesh.md).
Geometry build_geometry(const pvdf::Scene& scene, const std::vector<detail::Footprint>& footprints, double s,
                        Model& model) {
  Geometry geometry;
  const std::size_t n_el = scene.electrodes.size();
  std::vector<int>& rim_curves = geometry.rim_curves;
  std::vector<int>& inner_curves = geometry.inner_curves;
  std::map<int, int>& face_material = geometry.face_material;
  guarded("building the geometry", [&] {
    const int film = named(scene, "membrane (the film outline)", [&] { return add_film(scene.membrane.outline, s); });
    gmsh::vectorpair tools;
    for (std::size_t k = 0; k < n_el; ++k) {
      tools.push_back({2, named(scene, detail::electrode_label(scene, k), [&] { return add_electrode(scene.electrodes[k], s); })});
    }
    std::vector<std::size_t> embedded;
    for (std::size_t i = 0; i < footprints.size(); ++i) {
      const auto& f = footprints[i];
      if (!f.embed) {
        model.notes.push_back(f.note);
        continue;
      }
      tools.push_back({2, gmsh::model::occ::addDisk(f.center_m[0] * s, f.center_m[1] * s, 0, f.radius_m * s,
                                                    f.radius_m * s)});
      embedded.push_back(i);
    }
    model.n_probes_embedded = embedded.size();
    gmsh::vectorpair out;
    std::vector<gmsh::vectorpair> map;
    if (!tools.empty()) {
      gmsh::model::occ::fragment({{2, film}}, tools, out, map);
    } else {
      out = {{2, film}};
      map = {out};
    }
    gmsh::model::occ::synchronize();
    if (map.size() != 1 + tools.size()) throw pvdf::NumericalError("Gmsh fragment returned an unexpected map");
    for (const auto& dt : out) face_material[dt.second] = film_material_id;
    for (std::size_t k = 0; k < n_el; ++k) {
      if (map[1 + k].empty()) {
        throw pvdf::NumericalError("electrode " + scene.electrodes[k].name + " vanished in the Gmsh boolean fragment");
      }
      for (const auto& dt : map[1 + k]) face_material[dt.second] = electrode_material_id(k);
    }
    // The rim: the boundary of the union of all faces.
    gmsh::vectorpair all_faces, rim;
    for (const auto& fm : face_material) all_faces.push_back({2, fm.first});
    gmsh::model::getBoundary(all_faces, rim, true, false, false);
    std::set<int> rim_set;
    for (const auto& dt : rim) rim_set.insert(std::abs(dt.second));
    rim_curves.assign(rim_set.begin(), rim_set.end());
    gmsh::vectorpair curves;
    gmsh::model::getEntities(curves, 1);
    for (const auto& dt : curves) {
      if (!rim_set.count(dt.second)) inner_curves.push_back(dt.second);
    }
    // Physical groups: tag = deal.II id + msh_tag_offset (Gmsh reserves 0).
    std::vector<int> film_faces;
    std::vector<std::vector<int>> electrode_faces(n_el);
    for (const auto& fm : face_material) {
      if (fm.second == film_material_id) {
        film_faces.push_back(fm.first);
      } else {
        electrode_faces[fm.second - 1].push_back(fm.first);
      }
    }
    if (!film_faces.empty()) {
      gmsh::model::addPhysicalGroup(2, film_faces, film_material_id + msh_tag_offset);
      gmsh::model::setPhysicalName(2, film_material_id + msh_tag_offset, "film");
    }
    for (std::size_t k = 0; k < n_el; ++k) {
      const int tag = electrode_material_id(k) + msh_tag_offset;
      gmsh::model::addPhysicalGroup(2, electrode_faces[k], tag);
      gmsh::model::setPhysicalName(2, tag, scene.electrodes[k].name);
    }
    gmsh::model::addPhysicalGroup(1, rim_curves, rim_boundary_id + msh_tag_offset);
    gmsh::model::setPhysicalName(1, rim_boundary_id + msh_tag_offset, "rim");
    for (std::size_t j = 0; j < embedded.size(); ++j) {
      gmsh::vectorpair disk_faces = map[1 + n_el + j], disk_boundary;
      gmsh::model::getBoundary(disk_faces, disk_boundary, true, false, false);
      std::vector<int> tags;
      for (const auto& dt : disk_boundary) tags.push_back(std::abs(dt.second));
      const int tag = msh_probe_tag_base + static_cast<int>(j);
      gmsh::model::addPhysicalGroup(1, tags, tag);
      gmsh::model::setPhysicalName(1, tag, "probe_" + std::to_string(j));
    }
  });
  return geometry;
}

// Size field: fine (size_min) on electrode outlines and probe circles, growing linearly at
// rate (growth - 1) with distance up to size_max — each element about `growth` times its
// neighbour nearer the feature.
void set_size_field(const pvdf::Scene& scene, const std::vector<detail::Footprint>& footprints,
                    const std::vector<int>& inner_curves, double s, double size_min, double size_max) {
  guarded("setting the mesh size field", [&] {
    if (inner_curves.empty()) {
      gmsh::option::setNumber("Mesh.MeshSizeMax", size_max);
      return;
    }
    double longest = 0;
    for (const auto& e : scene.electrodes) {
      longest = std::max(longest, planar::perimeter(e.outline(64)));
    }
    for (const auto& f : footprints) longest = std::max(longest, 2 * pi * f.radius_m);
    const double points = std::clamp(std::ceil(longest * s / size_min), 20.0, 400.0);
    const int distance = gmsh::model::mesh::field::add("Distance");
    gmsh::model::mesh::field::setNumbers(distance, "CurvesList",
                                         std::vector<double>(inner_curves.begin(), inner_curves.end()));
    gmsh::model::mesh::field::setNumber(distance, "NumPointsPerCurve", points);
    const int threshold = gmsh::model::mesh::field::add("Threshold");
    gmsh::model::mesh::field::setNumber(threshold, "InField", distance);
    gmsh::model::mesh::field::setNumber(threshold, "SizeMin", size_min);
    gmsh::model::mesh::field::setNumber(threshold, "SizeMax", size_max);
    gmsh::model::mesh::field::setNumber(threshold, "DistMin", 0);
    gmsh::model::mesh::field::setNumber(threshold, "DistMax", (size_max - size_min) / (scene.mesh.growth - 1));
    gmsh::model::mesh::field::setAsBackgroundMesh(threshold);
  });
}

/// Extraction: vertices (metres), quads counter-clockwise, material ids, rim edges.
FilmMesh extract_mesh(const Geometry& geometry, double length_m) {
  const std::vector<int>& rim_curves = geometry.rim_curves;
  const std::map<int, int>& face_material = geometry.face_material;
  FilmMesh mesh;
  guarded("reading the mesh back", [&] {
    std::vector<std::size_t> node_tags;
    std::vector<double> coords, parametric;
    gmsh::model::mesh::getNodes(node_tags, coords, parametric, -1, -1, false, false);
    std::unordered_map<std::size_t, unsigned int> index;
    index.reserve(node_tags.size());
    std::vector<std::size_t> order(node_tags.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return node_tags[a] < node_tags[b]; });
    for (std::size_t i : order) {
      index[node_tags[i]] = static_cast<unsigned int>(mesh.vertices.size());
      mesh.vertices.push_back({coords[3 * i] * length_m, coords[3 * i + 1] * length_m});
    }
    std::size_t n_other = 0;
    for (const auto& fm : face_material) {
      std::vector<int> types;
      std::vector<std::vector<std::size_t>> element_tags, element_nodes;
      gmsh::model::mesh::getElements(types, element_tags, element_nodes, 2, fm.first);
      for (std::size_t t = 0; t < types.size(); ++t) {
        if (types[t] != 3) {  // 3 = 4-node quadrangle
          n_other += element_tags[t].size();
          continue;
        }
        const auto& nodes = element_nodes[t];
        for (std::size_t q = 0; q + 3 < nodes.size(); q += 4) {
          std::array<unsigned int, 4> quad{index.at(nodes[q]), index.at(nodes[q + 1]), index.at(nodes[q + 2]),
                                           index.at(nodes[q + 3])};
          make_counter_clockwise(quad, mesh.vertices);
          mesh.quads.push_back(quad);
          mesh.material_ids.push_back(static_cast<std::uint8_t>(fm.second));
        }
      }
    }
    if (n_other > 0) {
      throw pvdf::NumericalError("Gmsh left " + std::to_string(n_other) +
                                 " non-quadrilateral elements after recombination; the fem needs quads only");
    }
    for (int curve : rim_curves) {
      std::vector<int> types;
      std::vector<std::vector<std::size_t>> element_tags, element_nodes;
      gmsh::model::mesh::getElements(types, element_tags, element_nodes, 1, curve);
      for (std::size_t t = 0; t < types.size(); ++t) {
        if (types[t] != 1) continue;  // 1 = 2-node line
        const auto& nodes = element_nodes[t];
        for (std::size_t q = 0; q + 1 < nodes.size(); q += 2) {
          mesh.rim_edges.push_back({index.at(nodes[q]), index.at(nodes[q + 1])});
        }
      }
    }
  });
  return mesh;
}

// Meshing: the first configuration that gives an all-quad mesh above the quality threshold
// wins; the others are fall-backs for geometries where it fails (a fixed order, so the
// result stays deterministic).
void mesh_with_fallbacks(const pvdf::Scene& scene, const Geometry& geometry, double length_m,
                         double min_scaled_jacobian, Model& model) {
  struct Configuration {
    int algorithm, recombination;
    const char* name;
  };
  const Configuration configurations[] = {
      {6, 2, "Frontal-Delaunay + simple full-quad"},
      {5, 2, "Delaunay + simple full-quad"},
      {6, 3, "Frontal-Delaunay + Blossom full-quad"},
      {1, 2, "MeshAdapt + simple full-quad"},
  };
  std::string failures;
  bool have_best = false;
  for (const auto& c : configurations) {
    ++model.n_attempts;
    std::string failure;
    try {
      guarded("meshing", [&] {
        gmsh::option::setNumber("Mesh.Algorithm", c.algorithm);
        gmsh::option::setNumber("Mesh.RecombinationAlgorithm", c.recombination);
        gmsh::model::mesh::clear();
        gmsh::model::mesh::generate(2);
      });
      FilmMesh candidate = extract_mesh(geometry, length_m);
      MeshReport quality;
      measure_quality(candidate, quality);
      if (!have_best || quality.min_scaled_jacobian > model.min_scaled_jacobian) {
        model.mesh = std::move(candidate);
        model.min_scaled_jacobian = quality.min_scaled_jacobian;
        model.algorithm = c.name;
        have_best = true;
      }
      if (quality.min_scaled_jacobian >= min_scaled_jacobian) {
        model.accepted = true;
        // The loaded Gmsh model must be the accepted one (write_msh writes it).
        if (model.algorithm != c.name) throw pvdf::NumericalError("internal: accepted mesh is not the loaded one");
        break;
      }
      failure = "worst scaled Jacobian " + detail::fmt(quality.min_scaled_jacobian);
    } catch (const pvdf::NumericalError& e) {
      failure = e.what();
    }
    failures += std::string(failures.empty() ? "" : "; ") + c.name + ": " + failure;
  }
  model.failures = failures;
  if (!have_best) throw pvdf::NumericalError("Gmsh could not make an all-quad mesh of " + scene.source + " (" + failures + ")");
}

/// Builds and meshes the scene in the current Gmsh session (lock held by the caller), and
/// extracts the FilmMesh. Leaves the meshed model loaded for the caller (e.g. to write it).
Model mesh_scene(const pvdf::Scene& scene, const MeshParameters& params,
                 const std::vector<std::array<double, 2>>& extras, const std::array<double, 2>& sizes_m,
                 double min_scaled_jacobian) {
  Model model;
  const double length_m = scene.membrane.outline.characteristic_radius_m();
  model.scale_m = length_m;
  const double s = 1.0 / length_m;
  const double size_min = sizes_m[0] * s, size_max = sizes_m[1] * s;
  const auto footprints = detail::probe_footprints(scene, extras, sizes_m[0]);

  gmsh::clear();
  gmsh::model::add("pvdf_film");
  set_gmsh_options(params, size_max);
  const Geometry geometry = build_geometry(scene, footprints, s, model);
  set_size_field(scene, footprints, geometry.inner_curves, s, size_min, size_max);
  mesh_with_fallbacks(scene, geometry, length_m, min_scaled_jacobian, model);
  FilmMesh& mesh = model.mesh;
  for (const auto& e : scene.electrodes) mesh.electrode_names.push_back(e.name);
  const auto& o = scene.membrane.outline;
  if (o.shape == pvdf::FilmOutline::Shape::circle) {
    mesh.rim_shape = FilmMesh::RimShape::circle;
    mesh.rim_radius_m = o.radius_m;
  } else if (o.shape == pvdf::FilmOutline::Shape::ellipse) {
    mesh.rim_shape = FilmMesh::RimShape::ellipse;
    mesh.rim_semi_axes_m = o.semi_axes_m;
  }
  mesh.rim_center_m = {0, 0};
  return model;
}

/// The shared front end of build_film_mesh and write_msh: validate, mesh, measure, refuse bad
/// quality; `after` runs with the Gmsh model still loaded (lock held).
FilmMesh run(const pvdf::Scene& scene, const MeshParameters& params, MeshReport* report,
             const std::vector<std::array<double, 2>>& extras, const std::function<void(const Model&)>& after) {
  const auto start = std::chrono::steady_clock::now();
  if (!(params.size_factor >= size_factor_min && params.size_factor <= size_factor_max)) {
    throw pvdf::InputError("mesh size factor = " + detail::fmt(params.size_factor) + " must lie in [" +
                           detail::fmt(size_factor_min) + ", " + detail::fmt(size_factor_max) + "]");
  }
  detail::validate_geometry(scene, extras);
  auto sizes = target_sizes_m(scene);
  sizes[0] *= params.size_factor;
  sizes[1] *= params.size_factor;
  const double n_estimated = estimated_cells(scene, sizes, extras.size());
  if (n_estimated > max_cells) {
    throw pvdf::InputError(scene.source + ": the mesh would have about " + detail::fmt(n_estimated) +
                           " quadrilaterals (sizes " + detail::fmt(sizes[0]) + " .. " + detail::fmt(sizes[1]) +
                           " m), more than the limit " + detail::fmt(max_cells) +
                           "; raise mesh.size_min_m / mesh.size_max_m or the size factor");
  }

  GmshSession& session = GmshSession::instance();
  std::lock_guard<std::mutex> lock(session.mutex());
  Model model = mesh_scene(scene, params, extras, sizes, scene.mesh.min_scaled_jacobian);

  MeshReport r;
  r.target_size_min_m = sizes[0];
  r.target_size_max_m = sizes[1];
  measure_quality(model.mesh, r);
  r.n_probes_embedded = model.n_probes_embedded;
  r.notes = model.notes;
  r.algorithm = model.algorithm;
  r.n_attempts = model.n_attempts;
  if (!model.accepted || !(r.min_scaled_jacobian >= scene.mesh.min_scaled_jacobian)) {
    r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (report) *report = r;
    throw pvdf::NumericalError(scene.source + ": the mesh's worst element has scaled Jacobian " +
                               detail::fmt(r.min_scaled_jacobian) + " < mesh.min_scaled_jacobian = " +
                               detail::fmt(scene.mesh.min_scaled_jacobian) +
                               " (best of " + std::to_string(model.n_attempts) + " Gmsh configurations: " +
                               model.failures + "); the mesh is refused. Move outlines that nearly touch apart, "
                               "or change mesh.size_min_m / mesh.growth (or the mesh size factor)");
  }
  if (after) after(model);
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (report) *report = r;
  return std::move(model.mesh);
}

}  // namespace

FilmMesh build_film_mesh(const pvdf::Scene& scene, const MeshParameters& parameters, MeshReport* report,
                         const std::vector<std::array<double, 2>>& extra_probe_positions_m) {
  return run(scene, parameters, report, extra_probe_positions_m, {});
}

FilmMesh build_film_mesh(const pvdf::Scene& scene, MeshReport* report,
                         const std::vector<std::array<double, 2>>& extra_probe_positions_m) {
  return build_film_mesh(scene, MeshParameters{}, report, extra_probe_positions_m);
}

FilmMesh write_msh(const pvdf::Scene& scene, const std::string& path, const MeshParameters& parameters,
                   MeshReport* report) {
  return run(scene, parameters, report, {}, [&](const Model& model) {
    guarded("writing " + path, [&] {
      if (scene.mesh.order == 2) {
        // Second-order (9-node) quads: the rim nodes lie on the exact curve.
        gmsh::model::mesh::setOrder(2);
      }
      gmsh::option::setNumber("Mesh.MshFileVersion", 4.1);
      gmsh::option::setNumber("Mesh.Binary", 0);
      gmsh::option::setNumber("Mesh.ScalingFactor", model.scale_m);
      pvdf::write_path_atomically(path, [&](const std::string& tmp) {
        // Gmsh picks the format from the extension.
        const std::string tmp_msh = tmp + ".msh";
        try {
          gmsh::write(tmp_msh);
        } catch (...) {
          std::remove(tmp_msh.c_str());
          throw;
        }
        if (std::rename(tmp_msh.c_str(), tmp.c_str()) != 0) {
          std::remove(tmp_msh.c_str());
          throw pvdf::InputError("cannot write " + path + " (rename of the temporary file failed)");
        }
      });
      gmsh::option::setNumber("Mesh.ScalingFactor", 1);
    });
  });
}

FilmMesh write_msh(const pvdf::Scene& scene, const std::string& path, MeshReport* report) {
  return write_msh(scene, path, MeshParameters{}, report);
}

namespace {

/// Refuses anything but a readable file named .msh whose first line is $MeshFormat.
void check_msh_file(const std::string& path) {
  // Gmsh picks its reader by extension and would run any other text as a .geo script (which can
  // call the shell): only files named .msh that start like one are handed to it.
  const std::string shown = pvdf::escape_control_bytes(path);
  const auto dot = path.find_last_of("./");
  std::string extension = dot == std::string::npos || path[dot] != '.' ? "" : path.substr(dot);
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (extension != ".msh") throw pvdf::InputError(shown + ": a mesh file must be a Gmsh .msh file (name ending in .msh)");
  std::ifstream probe(path, std::ios::binary);
  std::string first;
  if (!probe || !std::getline(probe, first)) throw pvdf::InputError(shown + ": cannot read the mesh file; check the path");
  if (!first.empty() && first.back() == '\r') first.pop_back();
  if (first != "$MeshFormat") {
    throw pvdf::InputError(shown + ": is not a Gmsh mesh file (its first line is not $MeshFormat); write it with "
                           "pvdfkit mesh or Gmsh");
  }
}

/// A rim whose vertices all lie at one distance from the origin is a circle of that radius.
void detect_circular_rim(FilmMesh& mesh) {
  double r_min = 1e300, r_max = 0;
  for (const auto& e : mesh.rim_edges) {
    for (unsigned int v : e) {
      const double r = std::hypot(mesh.vertices[v][0], mesh.vertices[v][1]);
      r_min = std::min(r_min, r);
      r_max = std::max(r_max, r);
    }
  }
  if (!mesh.rim_edges.empty() && r_max > 0 && (r_max - r_min) < 1e-9 * r_max) {
    mesh.rim_shape = FilmMesh::RimShape::circle;
    mesh.rim_radius_m = 0.5 * (r_min + r_max);
  }
}

}  // namespace

FilmMesh read_msh(const std::string& path) {
  check_msh_file(path);
  GmshSession& session = GmshSession::instance();
  std::lock_guard<std::mutex> lock(session.mutex());
  FilmMesh mesh;
  try {
    gmsh::clear();
    gmsh::option::setNumber("General.Terminal", 0);
    gmsh::open(path);
  } catch (...) {
    throw pvdf::InputError(path + ": Gmsh cannot read it as a mesh (" + gmsh_error_text() + ")");
  }
  guarded("reading " + path, [&] {
    gmsh::vectorpair groups;
    gmsh::model::getPhysicalGroups(groups);
    int rim_tag = -1;
    std::vector<std::pair<int, std::string>> surfaces;  // (tag, name)
    for (const auto& g : groups) {
      std::string name;
      gmsh::model::getPhysicalName(g.first, g.second, name);
      if (g.first == 1 && name == "rim") rim_tag = g.second;
      if (g.first == 2) surfaces.push_back({g.second, name});
    }
    if (rim_tag < 0) throw pvdf::InputError(path + ": has no physical curve named \"rim\"; write it with pvdfkit mesh");
    std::sort(surfaces.begin(), surfaces.end());
    std::vector<std::size_t> node_tags;
    std::vector<double> coords, parametric;
    gmsh::model::mesh::getNodes(node_tags, coords, parametric, -1, -1, false, false);
    std::unordered_map<std::size_t, std::size_t> position;
    for (std::size_t i = 0; i < node_tags.size(); ++i) position[node_tags[i]] = i;
    // First pass: elements by group; second: number the corner nodes in tag order.
    struct RawQuad {
      std::array<std::size_t, 4> tags;
      std::uint8_t material;
    };
    std::vector<RawQuad> raw;
    std::vector<std::array<std::size_t, 2>> raw_rim;
    std::uint8_t next_electrode = 1;
    for (const auto& [tag, name] : surfaces) {
      std::uint8_t material = film_material_id;
      if (name != "film") {
        material = next_electrode++;
        mesh.electrode_names.push_back(name);
      }
      std::vector<int> entities;
      gmsh::model::getEntitiesForPhysicalGroup(2, tag, entities);
      for (int entity : entities) {
        std::vector<int> types;
        std::vector<std::vector<std::size_t>> element_tags, element_nodes;
        gmsh::model::mesh::getElements(types, element_tags, element_nodes, 2, entity);
        for (std::size_t t = 0; t < types.size(); ++t) {
          const std::size_t per = types[t] == 3 ? 4 : types[t] == 16 ? 8 : types[t] == 10 ? 9 : 0;
          if (per == 0) {
            throw pvdf::InputError(path + ": surface \"" + name + "\" holds Gmsh elements of type " +
                                   std::to_string(types[t]) + "; only quadrilaterals (types 3, 10, 16) are accepted");
          }
          const auto& nodes = element_nodes[t];
          for (std::size_t q = 0; q + per <= nodes.size(); q += per) {
            raw.push_back({{nodes[q], nodes[q + 1], nodes[q + 2], nodes[q + 3]}, material});
          }
        }
      }
    }
    std::vector<int> rim_entities;
    gmsh::model::getEntitiesForPhysicalGroup(1, rim_tag, rim_entities);
    for (int entity : rim_entities) {
      std::vector<int> types;
      std::vector<std::vector<std::size_t>> element_tags, element_nodes;
      gmsh::model::mesh::getElements(types, element_tags, element_nodes, 1, entity);
      for (std::size_t t = 0; t < types.size(); ++t) {
        const std::size_t per = types[t] == 1 ? 2 : types[t] == 8 ? 3 : 0;
        if (per == 0) continue;
        const auto& nodes = element_nodes[t];
        for (std::size_t q = 0; q + per <= nodes.size(); q += per) raw_rim.push_back({nodes[q], nodes[q + 1]});
      }
    }
    if (raw.empty()) throw pvdf::InputError(path + ": holds no quadrilaterals in named physical surfaces");
    std::vector<std::size_t> corner_tags;
    for (const auto& q : raw) corner_tags.insert(corner_tags.end(), q.tags.begin(), q.tags.end());
    std::sort(corner_tags.begin(), corner_tags.end());
    corner_tags.erase(std::unique(corner_tags.begin(), corner_tags.end()), corner_tags.end());
    std::unordered_map<std::size_t, unsigned int> index;
    for (std::size_t tag : corner_tags) {
      const auto it = position.find(tag);
      if (it == position.end()) throw pvdf::InputError(path + ": an element refers to a missing node");
      index[tag] = static_cast<unsigned int>(mesh.vertices.size());
      mesh.vertices.push_back({coords[3 * it->second], coords[3 * it->second + 1]});
    }
    for (const auto& q : raw) {
      std::array<unsigned int, 4> quad{index.at(q.tags[0]), index.at(q.tags[1]), index.at(q.tags[2]),
                                       index.at(q.tags[3])};
      make_counter_clockwise(quad, mesh.vertices);
      mesh.quads.push_back(quad);
      mesh.material_ids.push_back(q.material);
    }
    for (const auto& e : raw_rim) {
      const auto a = index.find(e[0]), b = index.find(e[1]);
      if (a == index.end() || b == index.end()) throw pvdf::InputError(path + ": a rim edge is not on a quadrilateral");
      mesh.rim_edges.push_back({a->second, b->second});
    }
    detect_circular_rim(mesh);
  });
  gmsh::clear();
  return mesh;
}

}  // namespace pvdf::mesh
