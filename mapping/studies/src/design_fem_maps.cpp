// The FEM map source of a design study (pvdf/mapping/design_fem_maps.hpp); moved from
// app/src/cmd_design.cpp (map_options, planned_positions, make_map).
#include "pvdf/mapping/design_fem_maps.hpp"

#include "maps_progress.hpp"

#include "pvdf/core/io.hpp"
#include "pvdf/core/progress.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/mapping/generate.hpp"

#include <cctype>
#include <cstdio>
#include <memory>

namespace pvdf::mapping {

namespace {

/// The label as a file name: letters, digits and ".-=" kept, anything else "_".
std::string slug(const std::string& text) {
  std::string s;
  for (char c : text) s += (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' || c == '=') ? c : '_';
  return s;
}

/// The map engine's settings for one candidate's map at `spacing_m`.
MapOptions map_options(const DesignCandidate& c, const DesignFemMaps& settings, double spacing_m) {
  MapOptions mo;
  mo.spacing_m = spacing_m;
  mo.forces_N = {settings.force_N};  // one level: other forces by the F^(2/3) law (docs/design.md §1)
  mo.tolerance = settings.tolerance;
  mo.threads = settings.threads;
  mo.description = "pvdfkit design preview of " + c.label;
  return mo;
}

/// The candidate's FEM map, written to settings.maps_dir; map number `index` of `progress`.
void make_fem_map(DesignCandidate& c, const DesignFemMaps& settings, double spacing_m, MapsProgress& progress,
                  std::size_t index) {
  const pvdf::Scene scene = pvdf::parse_scene(*c.scene, c.source);
  MapOptions mo = map_options(c, settings, spacing_m);
  mo.progress = progress.for_map(index);
  mo.time_left = progress.time_left_for_map(index);
  mo.common_seconds_per_position = progress.common_cost_for_map(index);
  mo.time_left_now = progress.time_left_now_for_map(index);
  progress.start_map(index);
  MapReport report;
  c.map = generate_map(scene, mo, &report);
  pvdf::make_directories(settings.maps_dir);
  c.map_file = settings.maps_dir + "/" + slug(c.label) + "_" + pvdf::format_printf("%.2gmm", spacing_m * 1e3) + ".h5";
  write_generated_map(c.map_file, c.map, report.provenance);
  progress.note("map " + c.label + ": " + std::to_string(report.n_solved) + " FEM solves in " +
                pvdf::format_duration(report.wall_s) + " (model " + report.model + ", estimated charge error " +
                pvdf::format_printf("%.2g", report.estimated_relative_error) + "), written to " + c.map_file);
  if (report.n_failed > 0 && settings.warn) {
    settings.warn(c.label + ": " + std::to_string(report.n_failed) + " map points did not converge (left out)");
  }
  c.map_source = "fem";
}

}  // namespace

DesignMapSource fem_design_maps(const DesignFemMaps& settings) {
  // One progress per phase, made when the phase begins (its clock starts there).
  auto progress = std::make_shared<std::unique_ptr<MapsProgress>>();
  DesignMapSource maps;
  maps.begin_phase = [settings, progress](const std::string& phase, const std::vector<const DesignCandidate*>& candidates,
                                          double spacing_m) {
    std::vector<std::size_t> planned;
    for (const DesignCandidate* c : candidates) {
      planned.push_back(planned_positions(pvdf::parse_scene(*c->scene, c->source), map_options(*c, settings, spacing_m)));
    }
    const std::string label = settings.progress_label.empty() ? "design: " + phase + " maps, positions" : settings.progress_label;
    progress->reset();  // the previous phase's bar is gone before the next one starts
    *progress = std::make_unique<MapsProgress>(label, std::move(planned), settings.quiet, phase, settings.memory);
  };
  maps.make_map = [settings, progress](DesignCandidate& c, double spacing_m, std::size_t index) {
    make_fem_map(c, settings, spacing_m, **progress, index);
  };
  maps.end_phase = [progress] {
    (*progress)->finish();
  };
  return maps;
}

}  // namespace pvdf::mapping
