// `pvdfkit mesh`: meshes a scene's film with Gmsh (quads, electrodes and probe footprints as
// mesh edges), writes the .msh and a PNG preview, and prints the quality report.
#include "command.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/mesh/mesher.hpp"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <iostream>
#include <memory>

namespace {

struct MeshCommandOptions {
  std::string scene_path;
  std::string output_path = "film.msh";
  std::string preview_path;  // default: output with .png
  bool no_preview = false;
  double size_factor = 1.0;
  bool json = false;
  bool verbose = false;
};

std::string default_preview_path(const std::string& msh) {
  const auto slash = msh.find_last_of('/');
  const auto dot = msh.find_last_of('.');
  if (dot != std::string::npos && (slash == std::string::npos || dot > slash)) return msh.substr(0, dot) + ".png";
  return msh + ".png";
}

int run_mesh(const MeshCommandOptions& o) {
  const pvdf::Scene scene = o.scene_path.empty() ? pvdf::default_scene() : pvdf::load_scene(o.scene_path);
  for (const auto& w : scene.warnings) pvdf::app::warn(w);
  // Every output path is checked before Gmsh runs: no .msh is left when the preview cannot be written.
  if (!o.no_preview) {
    pvdf::app::check_output_file(o.preview_path.empty() ? default_preview_path(o.output_path) : o.preview_path, "--preview");
  }
  pvdf::mesh::MeshParameters parameters;
  parameters.size_factor = o.size_factor;
  parameters.verbose = o.verbose;
  pvdf::mesh::MeshReport report;
  const pvdf::mesh::FilmMesh mesh = pvdf::mesh::write_msh(scene, o.output_path, parameters, &report);
  for (const auto& note : report.notes) pvdf::app::warn(note);
  std::string preview;
  if (!o.no_preview) {
    preview = o.preview_path.empty() ? default_preview_path(o.output_path) : o.preview_path;
    pvdf::mesh::write_preview_png(scene, mesh, preview);
  }
  if (o.json) {
    nlohmann::json j = {{"scene", scene.source},
                        {"msh", o.output_path},
                        {"n_cells", report.n_cells},
                        {"n_vertices", report.n_vertices},
                        {"edge_min_m", report.size_min_m},
                        {"edge_max_m", report.size_max_m},
                        {"target_size_min_m", report.target_size_min_m},
                        {"target_size_max_m", report.target_size_max_m},
                        {"min_scaled_jacobian", report.min_scaled_jacobian},
                        {"max_aspect_ratio", report.max_aspect_ratio},
                        {"n_probes_embedded", report.n_probes_embedded},
                        {"gmsh_configuration", report.algorithm},
                        {"n_attempts", report.n_attempts},
                        {"notes", report.notes},
                        {"wall_s", report.wall_s},
                        {"electrodes", mesh.electrode_names}};
    if (!preview.empty()) j["preview_png"] = preview;
    std::cout << j.dump(2) << '\n';
  } else {
    std::printf("mesh of %s written to %s\n", scene.source.c_str(), o.output_path.c_str());
    std::printf("  %zu quadrilaterals, %zu vertices, %zu electrodes, %zu probe footprints embedded\n", report.n_cells,
                report.n_vertices, mesh.electrode_names.size(), report.n_probes_embedded);
    std::printf("  edge length %.4g .. %.4g mm (target sizes %.4g .. %.4g mm)\n", report.size_min_m * 1e3,
                report.size_max_m * 1e3, report.target_size_min_m * 1e3, report.target_size_max_m * 1e3);
    std::printf("  minimum scaled Jacobian %.3f (threshold %.3f), worst aspect ratio %.2f\n",
                report.min_scaled_jacobian, scene.mesh.min_scaled_jacobian, report.max_aspect_ratio);
    std::printf("  meshed in %.3f s by Gmsh (%s, attempt %zu)\n", report.wall_s, report.algorithm.c_str(),
                report.n_attempts);
    if (!preview.empty()) std::printf("preview written to %s\n", preview.c_str());
  }
  return pvdf::exit_code::success;
}

}  // namespace

PVDF_COMMAND(20, [](CLI::App& root) {
  auto* sub = root.add_subcommand(
      "mesh", "Mesh a scene's film with Gmsh: quads, electrodes and probe footprints as mesh edges; writes .msh + PNG");
  auto o = std::make_shared<MeshCommandOptions>();
  sub->add_option("SCENE", o->scene_path, "Scene file (JSON, docs/scene.md) (default the built-in seed-001 scene)");
  sub->add_option("-o,--output", o->output_path, "Gmsh .msh file to write (format 4.1, metres) (default film.msh)")
      ->check(pvdf::app::output_file());
  sub->add_option("--preview", o->preview_path, "Preview figure (.png, .svg or .pdf) (default the output with .png)")
      ->check(pvdf::app::figure_file());
  sub->add_flag("--no-preview", o->no_preview, "Do not write the PNG preview");
  sub->add_option("--size-factor", o->size_factor, "Multiply the scene's mesh sizes (0.5 = about 4x the cells) (default 1)")
      ->check(pvdf::app::number_in(pvdf::mesh::size_factor_min, pvdf::mesh::size_factor_max));
  sub->add_flag("--json", o->json, "Print the quality report as JSON");
  sub->add_flag("--verbose", o->verbose, "Show Gmsh's own log");
  return pvdf::app::Subcommand{sub, [o] { return run_mesh(*o); }};
});
