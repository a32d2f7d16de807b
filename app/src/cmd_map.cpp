// `pvdfkit map`: the charge map of a scene — every grid position × force level → the charge of
// every electrode (FEM probe sweep; docs/map-generation.md). Runs unchanged under
// `mpirun -np N`; resumes from its checkpoint; exit 3 when any point failed (map still written).
#include "command.hpp"
#include "pvdf/core/resources.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/progress.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/core/scene_geometry.hpp"
#include "pvdf/fem/solver.hpp"
#include "pvdf/mapping/ambiguity.hpp"
#include "pvdf/mapping/ramp.hpp"
#include "pvdf/mapping/generate.hpp"
#include "pvdf/mapping/map_report.hpp"
#include "pvdf/mapping/atlas.hpp"
#include "pvdf/mapping/map_io.hpp"
#include "pvdf/mesh/mesher.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <iostream>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>

namespace {

using namespace pvdf::mapping;

// Set by SIGINT/SIGTERM: the generation stops after the current solves and keeps its checkpoint.
std::atomic<bool> interrupted{false};

/// Largest map (positions x force levels) `pvdfkit map` starts: ~25 bytes per point and electrode
/// in memory, and days of solves beyond it.
constexpr double max_map_points = 2e6;
extern "C" void on_interrupt(int) { interrupted.store(true); }

struct MapCommandOptions {
  std::string scene_path;
  std::string output;
  double spacing_m = 0.002;
  std::string placement = "uniform";
  int adaptive_levels = 2;
  std::string forces = "1";
  std::string region;
  double rim_margin_m = 0;
  std::string model = "auto";
  double tolerance = 0;
  int threads = 0;
  std::string checkpoint;
  bool no_checkpoint = false;
  bool no_resume = false;
  bool no_symmetry = false;
  bool no_force_scaling = false;
  int scaling_check_stride = 4;
  int setup_checks = 3;
  std::string rim_model = "by-estimate";
  std::string direct_solves = "by-estimate";
  std::string probe_refinement = "footprint";
  std::string noise;
  bool json = false;
  bool force_mpi = false;
  std::size_t stop_after = 0;
  bool quiet = false;
  std::string mesh_path;
  std::string atlas_path;
  std::vector<std::string> solve_flags_given;  // flags of the FEM sweep given together with --atlas
};

/// The generator's options from the command's flags, each flag checked against its rule before any
/// work starts: forces, region, the size of the map, the checkpoint path, the rim margin and noise.
MapOptions map_options(const MapCommandOptions& o, const pvdf::Scene& scene) {
  MapOptions options;
  options.spacing_m = o.spacing_m;
  if (o.placement == "adaptive") options.placement = pvdf::mapping::Placement::adaptive;
  else if (o.placement == "uniform") options.placement = pvdf::mapping::Placement::uniform;
  else throw pvdf::InputError("--placement " + pvdf::escape_control_bytes(o.placement) + ": use adaptive or uniform");
  if (o.adaptive_levels < 1 || o.adaptive_levels > 5) {
    throw pvdf::InputError("--adaptive-levels " + std::to_string(o.adaptive_levels) +
                           " must lie in 1..5 (the coarse level is 2^levels x --spacing-m)");
  }
  options.adaptive_levels = o.adaptive_levels;
  options.forces_N = pvdf::app::parse_force_levels(o.forces, "--forces-N");
  double area_m2 = scene.membrane.outline.area_m2();
  if (!o.region.empty()) {
    const auto r = pvdf::parse_number_list(o.region, "--region XMIN,XMAX,YMIN,YMAX (m)", 4);
    if (!(r[0] < r[1] && r[2] < r[3])) {
      throw pvdf::InputError("--region " + pvdf::quote_cell(o.region) + ": needs XMIN < XMAX and YMIN < YMAX (m)");
    }
    // A region far beyond the film maps nothing (and its node count would overflow): refused,
    // with the likely cause when the numbers are the film's size in millimetres.
    const double half_size_m = scene.membrane.outline.characteristic_radius_m();
    for (const double v : r) {
      if (std::abs(v) > 2 * half_size_m) {
        const bool looks_like_mm = std::abs(r[0]) / 1e3 <= 2 * half_size_m && std::abs(r[1]) / 1e3 <= 2 * half_size_m &&
                                   std::abs(r[2]) / 1e3 <= 2 * half_size_m && std::abs(r[3]) / 1e3 <= 2 * half_size_m;
        throw pvdf::InputError(
            "--region " + pvdf::quote_cell(o.region) + ": " + pvdf::format_g(v) + " m lies beyond the film (half-size " +
            pvdf::format_g(half_size_m) + " m)" +
            (looks_like_mm ? "; these look like mm: the unit is metres, e.g. --region " + pvdf::format_g(r[0] / 1e3) + "," +
                                 pvdf::format_g(r[1] / 1e3) + "," + pvdf::format_g(r[2] / 1e3) + "," + pvdf::format_g(r[3] / 1e3)
                           : "; give XMIN,XMAX,YMIN,YMAX in metres within the film"));
      }
    }
    options.region_m = std::array<double, 4>{r[0], r[1], r[2], r[3]};
    area_m2 = std::min(area_m2, (r[1] - r[0]) * (r[3] - r[2]));
  }
  // Bound the work before it starts: positions x force levels x electrodes are held in memory.
  const double n_positions = area_m2 / (o.spacing_m * o.spacing_m);
  if (n_positions * static_cast<double>(options.forces_N.size()) > max_map_points) {
    throw pvdf::InputError("--spacing-m " + pvdf::format_g(o.spacing_m) + ": the map would hold about " +
                           pvdf::format_g(n_positions) + " positions x " + std::to_string(options.forces_N.size()) +
                           " force levels, more than the limit " + pvdf::format_g(max_map_points) +
                           " points; use a larger --spacing-m or a smaller --region");
  }
  if (!o.no_checkpoint) {
    // The default checkpoint OUTPUT.checkpoint is derived: checked as an output here (the flags
    // were checked by main, including --checkpoint against -o and the inputs).
    pvdf::app::check_output_file(o.checkpoint.empty() ? o.output + ".checkpoint" : o.checkpoint, "--checkpoint");
  }
  if (o.rim_margin_m != 0 && o.rim_margin_m < 2 * scene.probe.radius_m) {
    throw pvdf::InputError("--rim-margin-m " + pvdf::format_g(o.rim_margin_m) + " must be 0 (default) or >= " +
                           pvdf::format_g(2 * scene.probe.radius_m) +
                           " m, two probe radii: a footprint must stay one probe radius clear of the rim (docs/scene.md)");
  }
  options.rim_margin_m = o.rim_margin_m;
  if (!o.model.empty()) pvdf::fem::parse_model(o.model, "--model");  // refused here, naming the flag
  options.model = o.model;
  options.tolerance = o.tolerance;
  options.threads = o.threads;
  options.use_symmetry = !o.no_symmetry;
  options.use_force_scaling = !o.no_force_scaling;
  options.scaling_check_stride = o.scaling_check_stride;
  options.n_setup_checks = o.setup_checks;
  options.rim_model = pvdf::mapping::parse_rim_model(o.rim_model, "--rim-model");
  options.direct_solves = pvdf::mapping::parse_direct_solves(o.direct_solves, "--direct-solves");
  options.probe_refinement = pvdf::mapping::parse_probe_refinement(o.probe_refinement, "--probe-refinement");
  if (!o.noise.empty()) {
    options.noise_C = pvdf::parse_number_list(o.noise, "--noise-C");
    if (options.noise_C.size() != scene.electrodes.size()) {
      std::string order;
      for (const auto& e : scene.electrodes) order += (order.empty() ? "" : ",") + e.name;
      throw pvdf::InputError("--noise-C " + pvdf::quote_cell(o.noise) + ": " + std::to_string(options.noise_C.size()) +
                             " values for " + std::to_string(scene.electrodes.size()) +
                             " electrodes; give one per electrode in the scene's order " + order);
    }
    for (const double n : options.noise_C) {
      if (!(n > 0 && n < 1e-6)) {
        throw pvdf::InputError("--noise-C " + pvdf::escape_control_bytes(o.noise) + ": " + pvdf::format_g(n) +
                               " must lie in (0, 1e-6) C (a 1-sigma charge noise)");
      }
    }
  }
  return options;
}

/// The `--json` summary: counts, model, estimates, timings.
void print_map_json(const MapCommandOptions& o, const ChargeMap& map, const MapReport& report) {
  nlohmann::json j = pvdf::mapping::map_report_json(report, map);
  j["output"] = o.output;
  j["mesh"] = o.mesh_path.empty() ? std::string("built-in") : o.mesh_path;
  j["peak_resident_bytes"] = pvdf::peak_resident_bytes();  // this process (rank 0 under MPI), so far
  std::cout << j.dump(2) << '\n';
}

/// The text summary; for a three-electrode map without failures also the share of the film three
/// charges leave ambiguous with the force unknown, and the remedies.
void print_map_text(const MapCommandOptions& o, const ChargeMap& map, const MapReport& report) {
  std::printf("%s: %zu x %zu grid, %zu positions x %zu force levels = %zu points\n", o.output.c_str(), map.nx(),
              map.ny(), report.n_positions, map.nf(), report.n_points);
  std::printf("solved %zu, scaled %zu (checks %zu, failed %zu, worst %.3g), mirrored %zu, resumed %zu, failed %zu\n",
              report.n_solved, report.n_scaled, report.n_scaling_checks, report.n_scaling_checks_failed,
              report.max_scaling_check_error, report.n_mirrored, report.n_resumed, report.n_failed);
  if (report.n_scaling_checks > 0 && report.n_scaled == 0 && report.n_scaling_checks_failed > 0) {
    // Say what "scaled 0" cost: every level was solved because the membrane law missed the tolerance.
    std::printf("force scaling (Q ~ F^(2/3), w ~ F^(1/3) from the largest level) not used: %zu of %zu checks off by up to "
                "%.3g %% (pre-tension or bending breaks the membrane law), so every force level was solved\n",
                report.n_scaling_checks_failed, report.n_scaling_checks, 100 * report.max_scaling_check_error);
  }
  std::printf("model %s: %s\n", report.model.c_str(), report.model_reason.c_str());
  std::printf("estimated error (largest per-node estimate): charge %.2g %%, deflection at the load %.2g %%; "
              "%zu points above the tolerance (tolerance_not_met)\n",
              100 * map.estimated_relative_error, 100 * map.estimated_deflection_relative_error,
              report.n_tolerance_not_met);
  const pvdf::mapping::LookupErrorSummary& total = report.lookup_total_relative_error;
  if (std::isfinite(total.max)) {
    std::printf("total error a lookup on this map carries (node estimate and the error between nodes and force levels, "
                "docs/lookup.md section 1.10), relative to a press's largest charge: median %.3g %%, 90 %% of the "
                "presses below %.3g %%, at most %.3g %%\n",
                100 * total.median, 100 * total.p90, 100 * total.max);
  }
  if (report.placement == "adaptive") {
    std::printf("adaptive placement:");
    for (std::size_t l = 0; l < report.level_solves.size(); ++l) {
      std::printf(" %g mm: %zu positions, %zu solves;", 1e3 * report.level_spacing_m[l], report.level_positions[l], report.level_solves[l]);
    }
    std::printf(" %zu points interpolated; stated total error (node + between nodes + between levels) at most %.2g %%\n",
                report.n_interpolated, 100 * map.estimated_total_relative_error);
  }
  std::printf("rim model (bending, rim-graded mesh, %zu DOFs): %zu points\n", report.rim_n_dofs, report.n_rim_model);
  std::printf("direct adaptive solves (own mesh, as `solve` at that press) where the sweep missed the tolerance: %zu points "
              "(%zu solves, %.1f s)\n", report.n_direct, report.direct_solves, report.direct_s);
  std::printf("symmetry: %s\n", report.symmetry_reason.c_str());
  std::printf("%d rank(s) x %d thread(s), %.1f s, %.3g s per solved position and core\n", report.ranks,
              report.threads, report.wall_s, report.per_position_s);
  if (map.ne() == 3 && report.n_failed == 0) {
    try {
      // How much of the film three charges leave ambiguous with the force unknown, and the remedies.
      const pvdf::mapping::AmbiguityShare a = pvdf::mapping::ambiguity_share(map);
      std::printf("ambiguity at %g N (%zu nodes): more than one press fits the charges at %.0f %% of the film with the force "
                  "unknown (range %g-%g N); remedies: a force reading (--force-N) %.0f %%, the force known within +-25 %% "
                  "(--force-range-N) %.0f %%, a fourth electrode (pvdfkit design quantifies it; docs/lookup.md section 2)\n",
                  a.force_N, a.nodes, 100 * a.force_unknown, a.min_force_N, a.max_force_N, 100 * a.force_known,
                  100 * a.force_within_25);
      if (map.nf() >= 2) {
        // Whether a press's loading curve separates the candidates (docs/lookup.md section 2, "Force ramps"):
        // only where the map's charge direction turns with the force (pretension, bending).
        const pvdf::mapping::RampAmbiguity r = pvdf::mapping::ramp_ambiguity_share(map);
        std::printf("force ramp (%d samples from %g to %g N, the map's noise, %zu nodes): ambiguous %.0f %% at the peak, "
                    "%.0f %% after the ramp test (%.0f %% with as many samples held at the peak); the map is taken as "
                    "exact, so its own error must be below the noise for this to hold\n",
                    pvdf::mapping::RampOptions{}.n_samples, pvdf::mapping::RampOptions{}.ramp_start * r.peak_force_N,
                    r.peak_force_N, r.nodes, 100 * r.ambiguous_at_peak, 100 * r.ambiguous_after_ramp,
                    100 * r.ambiguous_after_hold);
      }
    } catch (const pvdf::InputError& e) {
      // A map on which nothing can be located (no usable cell) has no ambiguity to report.
      std::printf("ambiguity: not computed (%s)\n", e.what());
    }
  }
}

/// `map SCENE --atlas FILE`: the scene's electrodes integrated over the atlas (docs/atlas.md §4),
/// no solve; the atlas decides the grid, the forces and the FEM settings.
int run_map_from_atlas(const MapCommandOptions& o) {
  if (!o.solve_flags_given.empty()) {
    throw pvdf::InputError(o.solve_flags_given.front() + " with --atlas " + o.atlas_path +
                           ": the atlas fixes the grid, forces and FEM settings; drop the flag or make another atlas");
  }
  const pvdf::Scene scene = pvdf::load_scene(o.scene_path);
  for (const auto& w : scene.warnings) pvdf::app::warn(w);
  const auto t0 = std::chrono::steady_clock::now();
  const pvdf::mapping::ChargeAtlas atlas = pvdf::mapping::read_atlas(o.atlas_path);
  pvdf::mapping::ChargeMap map = pvdf::mapping::map_from_atlas(atlas, scene, o.atlas_path);
  if (!o.noise.empty()) map.noise_C = map_options(o, scene).noise_C;
  pvdf::app::OutputLock output_lock(o.output, "-o/--output");
  std::size_t n_tolerance_not_met = 0;
  const std::vector<std::uint8_t> flags = pvdf::mapping::atlas_map_provenance(map, &n_tolerance_not_met);
  write_generated_map(o.output, map, flags, {});
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::size_t ok = 0, failed = 0;
  for (const auto st : map.status) {
    ok += st == std::uint8_t(PointStatus::ok);
    failed += st == std::uint8_t(PointStatus::not_converged);
  }
  if (o.json) {
    nlohmann::json j;
    j["output"] = o.output;
    j["atlas"] = o.atlas_path;
    j["nx"] = map.nx();
    j["ny"] = map.ny();
    j["forces_N"] = map.forces_N;
    j["n_points"] = ok + failed;
    j["n_failed"] = failed;
    j["model"] = map.model;
    j["tolerance"] = map.tolerance;
    j["estimated_relative_error"] = map.estimated_relative_error;
    j["n_tolerance_not_met"] = n_tolerance_not_met;
    j["wall_s"] = wall_s;
    std::cout << j.dump(2) << '\n';
  } else {
    std::printf("%s: %zu x %zu grid x %zu force levels from the atlas %s (%zu points, %zu not converged in the atlas)\n",
                o.output.c_str(), map.nx(), map.ny(), map.nf(), o.atlas_path.c_str(), ok + failed, failed);
    std::printf("estimated error (largest per node, FE + atlas integration): %.2g %% of the press's largest charge; "
                "%zu points above the tolerance %.2g %% (tolerance_not_met in /provenance); %.2f s\n",
                100 * map.estimated_relative_error, n_tolerance_not_met, 100 * map.tolerance, wall_s);
  }
  return failed > 0 ? pvdf::exit_code::numerical : pvdf::exit_code::success;
}

int run_map(const MapCommandOptions& o) {
  if (!o.atlas_path.empty()) return run_map_from_atlas(o);
  // MPI only when launched by mpirun (or asked for): a plain run needs no MPI runtime.
  std::optional<MpiSession> mpi;
  if (o.force_mpi || MpiSession::launched_by_mpirun()) mpi.emplace();
  const int rank = mpi ? mpi->rank() : 0;

  pvdf::Scene scene = pvdf::load_scene(o.scene_path);
  if (rank == 0) {
    for (const auto& w : scene.warnings) pvdf::app::warn(w);
  }
  MapOptions options = map_options(o, scene);
  for (const double f : options.forces_N) {  // each level must deflect this film beyond rounding
    const std::string unresolved = pvdf::force_resolution_problem(scene, f);
    if (!unresolved.empty()) throw pvdf::InputError("--forces-N " + pvdf::quote_cell(o.forces) + ": " + unresolved);
  }
  if (!o.no_checkpoint) options.checkpoint_path = o.checkpoint.empty() ? o.output + ".checkpoint" : o.checkpoint;
  options.resume = !o.no_resume;
  options.distributed = mpi.has_value();
  options.stop_after_positions = o.stop_after;
  options.cancel = &interrupted;
  std::signal(SIGINT, on_interrupt);
  std::signal(SIGTERM, on_interrupt);
  options.description = "pvdfkit map " + o.scene_path;
  if (!o.mesh_path.empty()) {
    auto mesh = std::make_shared<pvdf::mesh::FilmMesh>(pvdf::mesh::read_msh(o.mesh_path));
    pvdf::mesh::check_mesh_fits_scene(scene, *mesh, o.mesh_path);
    options.mesh = std::move(mesh);
    options.description += " --mesh " + o.mesh_path;
  }

  std::mutex live_mutex;            // guards live, held while it is called
  std::function<double()> live;     // the generator's time left as of now (MapOptions::time_left_now)
  std::unique_ptr<pvdf::Progress> bar;  // destroyed first: its heartbeat stops before live goes
  if (rank == 0 && !o.quiet) {
    // From the start: the setup (mesh, check solves) says "starting" with its elapsed time, and
    // the first line after it has the positions to do and the setup's ETA (generate_map reports
    // 0 of the total before the first row).
    bar = std::make_unique<pvdf::Progress>("map", 0);
    options.progress = [&bar](std::size_t done, std::size_t total) {
      bar->set_total(total);  // adaptive placement learns each level's solves when it gets there
      bar->update(done);
    };
    // The generator's own estimate of its time left (each position's cost predicted from its
    // distance to the clamp, pvdf::ItemCostEta) replaces the bar's items-over-rate ETA, which
    // is wrong early on: the positions near the clamp cost several times those in the middle.
    options.time_left = [&bar](double seconds_left) { bar->set_eta_s(seconds_left); };
    // ... and is asked again before each line, so that rows in flight count as they run. The
    // heartbeat calls it under live_mutex, which the generator's withdrawal (at its end) waits for.
    bar->set_refresh([&] {
      std::lock_guard<std::mutex> lock(live_mutex);
      if (live) bar->set_eta_s(live());
    });
    options.time_left_now = [&](std::function<double()> seconds_left_now) {
      std::lock_guard<std::mutex> lock(live_mutex);
      live = std::move(seconds_left_now);
    };
  }
  // One writer per output: a second `map` to the same file (or checkpoint) refuses at once.
  std::optional<pvdf::app::OutputLock> output_lock, checkpoint_lock;
  if (rank == 0) {
    output_lock.emplace(o.output, "-o/--output");
    if (!o.no_checkpoint && !o.checkpoint.empty()) checkpoint_lock.emplace(o.checkpoint, "--checkpoint");
  }
  MapReport report;
  const ChargeMap map = generate_map(scene, options, &report);
  if (bar) bar->finish();
  if (rank != 0) return report.n_failed > 0 || report.stopped_early ? pvdf::exit_code::numerical : pvdf::exit_code::success;

  if (report.stopped_early) {
    const std::string why = interrupted ? std::string("interrupted") :
                                          "stopped after " + std::to_string(o.stop_after) + " positions (--stop-after-positions)";
    if (options.checkpoint_path.empty()) {
      std::cerr << "error: " << why << "; no checkpoint (--no-checkpoint), no map written\n";
    } else {
      std::cerr << "error: " << why << "; the checkpoint " << options.checkpoint_path
                << " holds the completed rows: rerun the same command to resume\n";
    }
    return interrupted ? 130 : pvdf::exit_code::numerical;
  }
  if (report.n_failed == 0 &&
      std::none_of(map.charge_C.begin(), map.charge_C.end(), [](double q) { return std::isfinite(q) && q != 0; })) {
    // A map whose every charge is zero locates nothing: not written, a reported outcome.
    std::cerr << "error: every charge of the map is zero (model " << report.model
              << "): nothing could be located with it, so no map was written to " << o.output
              << "; linear kinematics leave no net charge on a flat film (no stretching): use --model auto\n";
    return pvdf::exit_code::numerical;
  }
  write_generated_map(o.output, map, report.provenance, report.node_model);
  remove_checkpoint_files(options.checkpoint_path);

  if (o.json) {
    print_map_json(o, map, report);
  } else {
    print_map_text(o, map, report);
  }
  if (report.n_failed > 0) {
    std::cerr << "error: " << report.n_failed << " map point(s) did not converge and are marked not_converged in "
              << o.output << " (first: " << report.first_failure << ")\n";
    return pvdf::exit_code::numerical;
  }
  return pvdf::exit_code::success;
}

}  // namespace

PVDF_COMMAND(35, [](CLI::App& root) {
  auto* sub = root.add_subcommand("map", "Charge map: the charge of every electrode for a probe pressed at every grid "
                                         "position and force level (FEM; runs under mpirun -np N)");
  auto o = std::make_shared<MapCommandOptions>();
  sub->add_option("SCENE", o->scene_path, "Scene file (JSON, docs/scene.md)")->required();
  sub->add_option("-o,--output", o->output, "Map file to write (HDF5, docs/mapping.md)")
      ->required()
      ->check(pvdf::app::output_file());
  sub->add_option("--spacing-m", o->spacing_m, "Grid spacing (m); nodes at multiples of it (default 0.002)")
      ->check(pvdf::app::number_in(1e-5, 0.1, "m (the unit is metres: 2 mm is 0.002)"));
  sub->add_option("--placement", o->placement,
                  "uniform (default): every node solved; adaptive: solves placed where the interpolant's estimated "
                  "error needs them, down to --spacing-m, every node storing its total error (opt-in: its estimate is "
                  "about 4x cautious in the median today, in the [0.5, 3] band at 37-79 % of presses; docs/map-generation.md section 10)");
  sub->add_option("--adaptive-levels", o->adaptive_levels,
                  "Adaptive placement: the coarse level is 2^N x --spacing-m, N in 1..5 (default 2)");
  sub->add_option("--forces-N", o->forces, "Force levels F1,F2,... in N, each in [1e-9, 1e4], distinct (default 1)");
  sub->add_option("--region", o->region, "Map only XMIN,XMAX,YMIN,YMAX, m (default the whole film)");
  sub->add_option("--rim-margin-m", o->rim_margin_m, "No probe centres closer than this to the rim (m; 0 = 2 x probe radius)")
      ->check(pvdf::app::number_in(0, 1, "m"));
  sub->add_option("--model", o->model, "Kinematics: auto|linear|von-karman|large-rotation (default auto)");
  sub->add_option("--tolerance", o->tolerance, "Requested relative charge error (default: scene, 0.01)")
      ->check(pvdf::app::number_in(1e-8, 0.5, "(the rule of the scene key model.tolerance), e.g. 0.01"));
  sub->add_option("--threads", o->threads, "Threads per process (0 = cores / ranks)")
      ->check(pvdf::app::integer_in(0, 1024));
  sub->add_option("--checkpoint", o->checkpoint, "Checkpoint file (default OUTPUT.checkpoint; resumed when it exists)")
      ->check(pvdf::app::output_file());
  sub->add_flag("--no-checkpoint", o->no_checkpoint, "Write no checkpoint");
  sub->add_flag("--no-resume", o->no_resume, "Ignore an existing checkpoint (start afresh)");
  sub->add_flag("--no-symmetry", o->no_symmetry, "Solve every position even when the scene is mirror-symmetric");
  sub->add_flag("--no-force-scaling", o->no_force_scaling, "Solve every force level (no Q ~ F^(2/3) shortcut)");
  sub->add_option("--scaling-check-stride", o->scaling_check_stride,
                  "Force-scaling check positions every N grid steps (default 4)")
      ->check(pvdf::app::integer_in(1, 1000));
  sub->add_option("--setup-checks", o->setup_checks,
                  "Probe positions at which the setup evaluates its error estimate to size the mesh, 0-3 (default 3)")
      ->check(pvdf::app::integer_in(0, 3));
  sub->add_option("--rim-model", o->rim_model,
                  "Where bending on a rim-graded mesh solves a node: by-estimate (default), never, always");
  sub->add_option("--direct-solves", o->direct_solves,
                  "Nodes still above the tolerance after the sweep: by-estimate (default: solved again on their own "
                  "adaptive mesh), never (kept, flagged tolerance_not_met)");
  sub->add_option("--probe-refinement", o->probe_refinement,
                  "Mesh of each probe solve: footprint (default: the sweep mesh refined around the probe's footprint), "
                  "none (the sweep mesh alone: faster, footprint error unseen by the estimate)");
  sub->add_option("--noise-C", o->noise, "1-sigma charge noise per electrode N1,N2,..., C (default 5e-14 each)");
  sub->add_option("--mesh", o->mesh_path,
                  "Start the sweep mesh from this Gmsh mesh (.msh from `pvdfkit mesh`, physical groups of docs/mesh.md); "
                  "it is refined to the sweep's sizes, never coarsened");
  sub->add_option("--atlas", o->atlas_path,
                  "Integrate the scene's electrodes over this charge-density atlas (`pvdfkit atlas`, docs/atlas.md) "
                  "instead of solving: seconds; the atlas fixes grid, forces and FEM settings");
  sub->add_flag("--json", o->json, "Print a JSON summary (counts, model, timings)");
  sub->add_flag("--quiet", o->quiet, "No progress bar");
  sub->add_flag("--mpi", o->force_mpi, "Initialize MPI even when not started by mpirun (singleton)");
  sub->add_option("--stop-after-positions", o->stop_after,
                  "Testing: stop as if killed after N solved positions (checkpoint kept, no map written)")
      ->check(pvdf::app::integer_in(1, 1000000000));
  return pvdf::app::Subcommand{sub, [o, sub] {
    for (const char* flag : {"--spacing-m", "--placement", "--adaptive-levels", "--forces-N", "--region", "--rim-margin-m",
                             "--model", "--tolerance", "--mesh", "--rim-model", "--direct-solves", "--probe-refinement"})
      if (sub->count(flag) > 0) o->solve_flags_given.push_back(flag);
    return run_map(*o);
  }};
});
