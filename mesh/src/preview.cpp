// Preview of a film mesh (PNG, SVG or PDF by extension): the whole film and a zoom on the electrodes, cell edges drawn,
// electrodes filled in their own colours with a legend, probe footprints outlined, axes in mm.
#include "pvdf/core/constants.hpp"
#include "pvdf/plot/plot.hpp"
#include "pvdf/mesh/mesher.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

namespace pvdf::mesh {

namespace {

constexpr double mm = 1e3;

void draw(pvdf::plot::Axes& ax, const pvdf::Scene& scene, const FilmMesh& mesh, double edge_width_px) {
  const pvdf::plot::Color film_fill{235, 235, 235};
  const pvdf::plot::Color edge{90, 90, 90};
  std::vector<bool> labelled(mesh.electrode_names.size() + 1, false);
  // Film first, electrodes on top, so the legend lists electrodes in order after "film".
  for (int pass = 0; pass < 2; ++pass) {
    for (std::size_t i = 0; i < mesh.quads.size(); ++i) {
      const std::uint8_t id = mesh.material_ids[i];
      const bool electrode = id != film_material_id && id <= mesh.electrode_names.size();
      if (electrode != (pass == 1)) continue;
      std::vector<std::array<double, 2>> corners;
      for (unsigned int v : mesh.quads[i]) corners.push_back({mesh.vertices[v][0] * mm, mesh.vertices[v][1] * mm});
      std::string label;
      if (id < labelled.size() && !labelled[id]) {
        labelled[id] = true;
        label = electrode ? "electrode " + mesh.electrode_names[id - 1] : "film";
      }
      ax.polygon(corners, electrode ? pvdf::plot::cycle_color(id - 1) : film_fill, edge, edge_width_px, label);
    }
  }
  bool probe_labelled = false;
  for (const auto& l : scene.loads) {
    if (l.kind != pvdf::Load::Kind::probe) continue;
    const double r = (l.radius_m > 0 ? l.radius_m : scene.probe.radius_m) * mm;
    std::vector<double> x, y;
    for (int k = 0; k <= 96; ++k) {
      const double t = 2 * pi * k / 96;
      x.push_back(l.position_m[0] * mm + r * std::cos(t));
      y.push_back(l.position_m[1] * mm + r * std::sin(t));
    }
    ax.line(x, y, probe_labelled ? "" : "probe footprint", pvdf::plot::Color{200, 0, 0},
            pvdf::plot::LineStyle::solid, pvdf::plot::Marker::none, 2.0);
    probe_labelled = true;
  }
  ax.xlabel("x (mm)").ylabel("y (mm)").equal_aspect().legend("outside below");
}

}  // namespace

void write_preview_png(const pvdf::Scene& scene, const FilmMesh& mesh, const std::string& path) {
  MeshReport report;
  measure_quality(mesh, report);
  pvdf::plot::Figure figure(1800, 900, 1, 2);
  char title[240];
  std::snprintf(title, sizeof title,
                "Film mesh of %s: %zu quads, %zu vertices, min scaled Jacobian %.2f, worst aspect ratio %.1f",
                std::filesystem::path(scene.source).filename().string().c_str(), report.n_cells, report.n_vertices, report.min_scaled_jacobian,
                report.max_aspect_ratio);
  figure.suptitle(title);
  auto& whole = figure.axes(0, 0);
  draw(whole, scene, mesh, 0.6);
  whole.title("whole film");
  // Zoom: the box around electrodes and probe footprints, with a margin.
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  auto grow = [&](double x, double y, double r) {
    x0 = std::min(x0, x - r);
    x1 = std::max(x1, x + r);
    y0 = std::min(y0, y - r);
    y1 = std::max(y1, y + r);
  };
  for (const auto& e : scene.electrodes) {
    for (const auto& p : e.outline(32)) grow(p[0], p[1], 0);
  }
  for (const auto& l : scene.loads) {
    if (l.kind == pvdf::Load::Kind::probe) {
      grow(l.position_m[0], l.position_m[1], l.radius_m > 0 ? l.radius_m : scene.probe.radius_m);
    }
  }
  auto& zoom = figure.axes(0, 1);
  draw(zoom, scene, mesh, 0.8);
  if (x0 < x1) {
    const double margin = 0.15 * std::max(x1 - x0, y1 - y0);
    const double cx = 0.5 * (x0 + x1), cy = 0.5 * (y0 + y1);
    const double half = 0.5 * std::max(x1 - x0, y1 - y0) + margin;
    zoom.xlim((cx - half) * mm, (cx + half) * mm).ylim((cy - half) * mm, (cy + half) * mm);
  }
  zoom.title("electrodes and probe footprints");
  figure.save(path);
}

}  // namespace pvdf::mesh
