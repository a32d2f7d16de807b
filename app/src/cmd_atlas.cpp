// `pvdfkit atlas`: the charge-density atlas of a scene's film (docs/atlas.md) — one FEM probe
// sweep over the map grid that keeps, per press, the moments of the charge density over a regular
// grid of square cells, from which `pvdfkit map SCENE --atlas FILE` integrates any electrode layout.
#include "command.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/progress.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/mapping/atlas.hpp"
#include "pvdf/mapping/atlas_report.hpp"

#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>

namespace {

// Set by SIGINT/SIGTERM: the sweep stops after the presses in flight and keeps its checkpoint.
std::atomic<bool> interrupted{false};
extern "C" void on_atlas_interrupt(int) { interrupted.store(true); }

struct AtlasCommandOptions {
  std::string scene_path;
  std::string output;
  double spacing_m = 0.002;
  std::string forces = "1";
  double tolerance = 0;
  double cell_m = 0.001;
  double fe_size_m = 0;
  double rim_margin_m = 0;
  double keep_out_m = 0.001;
  int threads = 0;
  int setup_checks = 3;
  std::string checkpoint;
  bool no_checkpoint = false;
  bool no_resume = false;
  std::size_t stop_after = 0;
  bool json = false;
  bool quiet = false;
};

int run_atlas(const AtlasCommandOptions& o) {
  const pvdf::Scene scene = pvdf::load_scene(o.scene_path);
  for (const auto& w : scene.warnings) pvdf::app::warn(w);
  pvdf::mapping::AtlasOptions options;
  options.spacing_m = o.spacing_m;
  options.forces_N = pvdf::app::parse_force_levels(o.forces, "--forces-N");
  options.tolerance = o.tolerance;
  options.cell_m = o.cell_m;
  options.fe_size_m = o.fe_size_m;
  if (o.rim_margin_m != 0 && o.rim_margin_m < 2 * scene.probe.radius_m) {
    throw pvdf::InputError("--rim-margin-m " + pvdf::format_g(o.rim_margin_m) + " must be 0 (default) or >= " +
                           pvdf::format_g(2 * scene.probe.radius_m) + " m, two probe radii");
  }
  options.rim_margin_m = o.rim_margin_m;
  options.keep_out_m = o.keep_out_m;
  options.threads = o.threads;
  options.n_setup_checks = o.setup_checks;
  options.description = "pvdfkit atlas " + o.scene_path;
  if (!o.no_checkpoint) {
    options.checkpoint_path = o.checkpoint.empty() ? o.output + ".checkpoint" : o.checkpoint;
    // The default OUTPUT.checkpoint is derived: checked as an output here (main checked the flags).
    if (o.checkpoint.empty()) pvdf::app::check_output_file(options.checkpoint_path, "--checkpoint");
  }
  options.resume = !o.no_resume;
  options.stop_after_positions = o.stop_after;
  options.cancel = &interrupted;
  std::signal(SIGINT, on_atlas_interrupt);
  std::signal(SIGTERM, on_atlas_interrupt);
  std::unique_ptr<pvdf::Progress> bar;
  if (!o.quiet) {
    options.progress = [&bar](std::size_t done, std::size_t total) {
      if (!bar) bar = std::make_unique<pvdf::Progress>("atlas", total);
      bar->update(done);
    };
  }
  pvdf::app::OutputLock lock(o.output, "-o/--output");
  std::optional<pvdf::app::OutputLock> checkpoint_lock;
  if (!o.no_checkpoint && !o.checkpoint.empty()) checkpoint_lock.emplace(o.checkpoint, "--checkpoint");
  pvdf::mapping::AtlasReport report;
  const pvdf::mapping::ChargeAtlas atlas = pvdf::mapping::generate_atlas(scene, options, &report);
  if (bar) bar->finish();
  if (report.stopped_early) {
    const std::string why = interrupted ? std::string("interrupted") :
                                          "stopped after " + std::to_string(o.stop_after) + " positions (--stop-after-positions)";
    if (options.checkpoint_path.empty()) {
      std::cerr << "error: " << why << "; no checkpoint (--no-checkpoint), no atlas written\n";
    } else {
      std::cerr << "error: " << why << "; the checkpoint " << options.checkpoint_path
                << " holds the completed rows: rerun the same command to resume\n";
    }
    return interrupted ? 130 : pvdf::exit_code::numerical;
  }
  pvdf::mapping::write_atlas(o.output, atlas);
  if (!options.checkpoint_path.empty()) std::remove(options.checkpoint_path.c_str());
  if (o.json) {
    std::cout << pvdf::mapping::atlas_report_json(report, atlas, o.output).dump(2) << '\n';
  } else {
    std::printf("%s: %zu positions x %zu force levels, %zu x %zu atlas cells of %g mm\n", o.output.c_str(), report.n_positions,
                atlas.nf(), atlas.grid.nx, atlas.grid.ny, 1e3 * atlas.grid.cell_m);
    std::printf("model %s: %s\n", atlas.model.c_str(), atlas.model_reason.c_str());
    std::printf("%zu positions solved, the others mirror images (x -> -x: %s, y -> -y: %s)\n", report.n_solved_positions,
                report.mirror_x ? "yes" : "no", report.mirror_y ? "yes" : "no");
    std::printf("FE mesh: %zu DOFs, cells of %g mm over the whole film; largest per-press estimate %.2g %% "
                "(%zu presses above the tolerance %g)\n",
                atlas.n_dofs, 1e3 * atlas.fe_size_m, 100 * report.estimated_relative_error, report.n_tolerance_not_met,
                atlas.tolerance);
    std::printf("served: electrodes at least %g mm inside the clamp; %zu presses solved again by the rim model\n",
                1e3 * atlas.keep_out_m, report.n_rim_solves);
    if (report.n_resumed_positions > 0)
      std::printf("%zu positions taken from the checkpoint, %zu solved now\n", report.n_resumed_positions,
                  report.n_solved_positions - report.n_resumed_positions);
    std::printf("%d thread(s), setup %.1f s, %.1f s in all\n", report.threads, report.setup_s, report.wall_s);
  }
  if (report.n_failed > 0) {
    std::cerr << "error: " << report.n_failed << " press(es) did not converge and are marked not_converged in " << o.output
              << " (first: " << report.first_failure << ")\n";
    return pvdf::exit_code::numerical;
  }
  return pvdf::exit_code::success;
}

}  // namespace

PVDF_COMMAND(36, [](CLI::App& root) {
  auto* sub = root.add_subcommand("atlas", "Charge-density atlas of a film: one FEM probe sweep from which `map --atlas` "
                                           "gives the charge map of any electrode layout without a solve (docs/atlas.md)");
  auto o = std::make_shared<AtlasCommandOptions>();
  sub->add_option("SCENE", o->scene_path, "Scene file (JSON, docs/scene.md); its electrodes and loads are ignored")->required();
  sub->add_option("-o,--output", o->output, "Atlas file to write (HDF5, docs/atlas.md)")
      ->required()
      ->check(pvdf::app::output_file());
  sub->add_option("--spacing-m", o->spacing_m, "Probe grid spacing (m); nodes at multiples of it, as `map` (default 0.002)")
      ->check(pvdf::app::number_in(1e-5, 0.1, "m (the unit is metres: 2 mm is 0.002)"));
  sub->add_option("--forces-N", o->forces, "Force levels F1,F2,... in N, each in [1e-9, 1e4], distinct (default 1)");
  sub->add_option("--tolerance", o->tolerance, "Requested relative charge error (default: scene, 0.01)")
      ->check(pvdf::app::number_in(1e-8, 0.5, "(the rule of the scene key model.tolerance), e.g. 0.01"));
  sub->add_option("--cell-m", o->cell_m, "Side of the square atlas cells (m) (default 0.001)")
      ->check(pvdf::app::number_in(1e-5, 0.05, "m (1 mm is 0.001)"));
  sub->add_option("--fe-size-m", o->fe_size_m,
                  "FE cell size over the whole film (m) (default 0: min(--cell-m, probe diameter), smaller for tolerances below 0.01)")
      ->check(pvdf::app::number_in(0, 0.05, "m"));
  sub->add_option("--rim-margin-m", o->rim_margin_m, "No probe centres closer than this to the rim (m) (default 0: 2 x probe radius)")
      ->check(pvdf::app::number_in(0, 1, "m"));
  sub->add_option("--keep-out-m", o->keep_out_m,
                  "Electrodes are served at least this far inside the clamp (m); `map --atlas` refuses layouts reaching "
                  "closer (default 0.001, as the design's --clamp-margin-m; 0 = anywhere)")
      ->check(pvdf::app::number_in(0, 0.1, "m (1 mm is 0.001)"));
  sub->add_option("--threads", o->threads, "Worker threads (default 0: the cores)")->check(pvdf::app::integer_in(0, 1024));
  sub->add_option("--setup-checks", o->setup_checks,
                  "Probe positions at which the setup evaluates its error estimate to size the mesh, 0-3 (default 3)")
      ->check(pvdf::app::integer_in(0, 3));
  sub->add_option("--checkpoint", o->checkpoint,
                  "Checkpoint file: the completed rows, every 30 s and when stopped (default OUTPUT.checkpoint; resumed when it exists)")
      ->check(pvdf::app::output_file());
  sub->add_flag("--no-checkpoint", o->no_checkpoint, "Write no checkpoint");
  sub->add_flag("--no-resume", o->no_resume, "Ignore an existing checkpoint (start afresh)");
  sub->add_option("--stop-after-positions", o->stop_after,
                  "Testing: stop as if killed after N solved positions (checkpoint kept, no atlas written)")
      ->check(pvdf::app::integer_in(1, 1000000000));
  sub->add_flag("--json", o->json, "Print a JSON summary (counts, model, estimate, timings)");
  sub->add_flag("--quiet", o->quiet, "No progress bar");
  return pvdf::app::Subcommand{sub, [o] { return run_atlas(*o); }};
});
