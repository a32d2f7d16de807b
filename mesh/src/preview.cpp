// PNG preview of a film mesh: cell edges, electrodes filled in their own colours with a legend,
// probe footprints outlined, axes in millimetres.
#include "pvdf/core/plot.hpp"
#include "pvdf/mesh/mesher.hpp"

#include <cmath>

namespace pvdf::mesh {

void write_preview_png(const pvdf::Scene& scene, const FilmMesh& mesh, const std::string& path) {
  constexpr double mm = 1e3;
  pvdf::plot::Figure figure(1000, 950);
  auto& ax = figure.axes();
  const pvdf::plot::Color film_fill{235, 235, 235};
  const pvdf::plot::Color edge{90, 90, 90};
  std::vector<bool> labelled(mesh.electrode_names.size() + 1, false);
  for (std::size_t i = 0; i < mesh.quads.size(); ++i) {
    std::vector<std::array<double, 2>> corners;
    for (unsigned int v : mesh.quads[i]) corners.push_back({mesh.vertices[v][0] * mm, mesh.vertices[v][1] * mm});
    const std::uint8_t id = mesh.material_ids[i];
    const bool electrode = id != film_material_id && id <= mesh.electrode_names.size();
    std::string label;
    if (id < labelled.size() && !labelled[id]) {
      labelled[id] = true;
      label = electrode ? "electrode " + mesh.electrode_names[id - 1] : "film";
    }
    const pvdf::plot::Color fill = electrode ? pvdf::plot::cycle_color(id - 1) : film_fill;
    ax.polygon(corners, fill, edge, 0.6, label);
  }
  // Probe footprints of the scene's loads.
  bool probe_labelled = false;
  for (const auto& l : scene.loads) {
    if (l.kind != pvdf::Load::Kind::probe) continue;
    const double r = (l.radius_m > 0 ? l.radius_m : scene.probe.radius_m) * mm;
    std::vector<double> x, y;
    for (int k = 0; k <= 96; ++k) {
      const double t = 2 * 3.14159265358979323846 * k / 96;
      x.push_back(l.position_m[0] * mm + r * std::cos(t));
      y.push_back(l.position_m[1] * mm + r * std::sin(t));
    }
    ax.line(x, y, probe_labelled ? "" : "probe footprint", pvdf::plot::Color{200, 0, 0},
            pvdf::plot::LineStyle::solid, pvdf::plot::Marker::none, 2.0);
    probe_labelled = true;
  }
  MeshReport report;
  measure_quality(mesh, report);
  char title[200];
  std::snprintf(title, sizeof title, "Film mesh: %zu quads, %zu vertices, min scaled Jacobian %.2f", report.n_cells,
                report.n_vertices, report.min_scaled_jacobian);
  ax.title(title).xlabel("x (mm)").ylabel("y (mm)").equal_aspect().legend("upper right");
  figure.save_png(path);
}

}  // namespace pvdf::mesh
