// `pvdfkit solve`: deflection, membrane forces and electrode charges of the clamped film under
// probe and pressure loads (pvdf::fem; docs/fem.md). Exit 3 when the solve does not converge.
#include "command.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/core/scene_geometry.hpp"
#include "pvdf/fem/result_json.hpp"
#include "pvdf/core/resources.hpp"
#include "pvdf/fem/solver.hpp"
#include "pvdf/mesh/mesher.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>

#include <unistd.h>

namespace {

struct SolveOptions {
  std::string scene_path;
  std::vector<std::string> loads;
  std::vector<std::string> samples;
  std::string model;
  double tolerance = 0;
  std::string vtu_dir;
  std::string mesh_path;
  bool json = false;
  bool verbose = false;
  int max_refinements = -1;
  std::string refinement = "goal";
};


/// `--load`: the probe loads that replace the scene's, each checked with the rules of loads[].
void apply_load_flags(const SolveOptions& o, pvdf::Scene& scene) {
  if (o.loads.empty()) return;
  scene.loads.clear();
  for (const auto& text : o.loads) {
    const auto v = pvdf::parse_number_list(text, "--load X_M,Y_M,F_N", 3);
    // The rules of the scene's loads[]: 1e-9 <= force_N <= 1e4, the footprint clear of the rim.
    if (!(v[2] >= 1e-9 && v[2] <= 1e4)) {
      throw pvdf::InputError("--load " + pvdf::quote_cell(text) + ": force " + pvdf::format_g(v[2]) +
                             " N must lie in [1e-9, 1e4] N (a probe pushes the film; the rule of loads[].force_N)");
    }
    const std::string unresolved = pvdf::force_resolution_problem(scene, v[2]);
    if (!unresolved.empty()) throw pvdf::InputError("--load " + pvdf::quote_cell(text) + ": " + unresolved);
    const std::string problem = pvdf::probe_footprint_problem(scene, {v[0], v[1]}, scene.probe.radius_m);
    if (!problem.empty()) throw pvdf::InputError("--load " + pvdf::escape_control_bytes(text) + ": " + problem);
    pvdf::Load l;
    l.kind = pvdf::Load::Kind::probe;
    l.position_m = {v[0], v[1]};
    l.force_N = v[2];
    scene.loads.push_back(l);
  }
}

/// The solver options: the scene's, overridden by the flags (each checked where it is parsed).
pvdf::fem::Options solver_options(const SolveOptions& o, const pvdf::Scene& scene) {
  pvdf::fem::Options options = pvdf::fem::options_from_scene(scene);
  if (!o.model.empty()) options.model = pvdf::fem::parse_model(o.model, "--model");
  if (o.tolerance != 0) options.tolerance = o.tolerance;  // checked where parsed
  if (o.max_refinements >= 0) options.max_refinements = o.max_refinements;
  if (o.refinement != "goal" && o.refinement != "kelly") {
    throw pvdf::InputError("--refinement '" + pvdf::escape_control_bytes(o.refinement) + "' is not a refinement; use goal or kelly");
  }
  options.refinement = o.refinement == "kelly" ? pvdf::fem::Refinement::kelly : pvdf::fem::Refinement::goal;
  for (const auto& text : o.samples) {
    const auto v = pvdf::parse_number_list(text, "--sample X_M,Y_M", 2);
    if (!scene.membrane.outline.contains({v[0], v[1]})) {
      throw pvdf::InputError("--sample " + pvdf::escape_control_bytes(text) + ": the point lies outside the film; give a point inside the clamped outline");
    }
    options.sample_points_m.push_back({v[0], v[1]});
  }
  options.vtu_directory = o.vtu_dir;
  options.verbose = o.verbose;
  return options;
}

/// While alive, standard output (file descriptor 1, where the solver prints its Newton lines)
/// goes to standard error: `solve --json --verbose` keeps stdout for the JSON alone.
class StdoutToStderr {
 public:
  StdoutToStderr() {
    std::fflush(stdout);
    saved_ = ::dup(STDOUT_FILENO);
    if (saved_ >= 0) ::dup2(STDERR_FILENO, STDOUT_FILENO);
  }
  ~StdoutToStderr() {
    std::fflush(stdout);
    if (saved_ < 0) return;
    ::dup2(saved_, STDOUT_FILENO);
    ::close(saved_);
  }
  StdoutToStderr(const StdoutToStderr&) = delete;
  StdoutToStderr& operator=(const StdoutToStderr&) = delete;

 private:
  int saved_ = -1;
};

/// The solve, on the built-in mesh or on `--mesh`: the first solve on the file's cells exactly as
/// written (what `pvdfkit mesh` previewed), then the same output-driven refinement as on the
/// built-in mesh (docs/mesh.md, "Solving on a .msh"). A sample point the library cannot place is
/// reported against the flag that gave it.
pvdf::fem::Result solve_scene(const SolveOptions& o, const pvdf::Scene& scene, pvdf::fem::Options options,
                              std::size_t& mesh_file_cells) {
  try {
    if (!o.mesh_path.empty()) {
      const pvdf::mesh::FilmMesh mesh = pvdf::mesh::read_msh(o.mesh_path);
      pvdf::mesh::check_mesh_fits_scene(scene, mesh, o.mesh_path);
      mesh_file_cells = mesh.n_cells();
      options.grade_given_mesh = false;
      return pvdf::fem::solve(scene, mesh, options);
    }
    return pvdf::fem::solve(scene, options);
  } catch (const pvdf::InputError& e) {
    const std::string what = e.what();
    if (what.rfind("sample point ", 0) == 0) throw pvdf::InputError("--sample: " + what);
    throw;
  }
}

void print_solve_json(const SolveOptions& o, const pvdf::fem::Result& r, std::size_t mesh_file_cells) {
  nlohmann::json j = pvdf::fem::result_json(r);
  j["peak_resident_bytes"] = pvdf::peak_resident_bytes();  // this process, so far (getrusage)
  j["mesh"] = o.mesh_path.empty() ? nlohmann::json("built-in") : nlohmann::json(o.mesh_path);
  if (!o.mesh_path.empty()) j["mesh_file_cells"] = mesh_file_cells;
  std::cout << j.dump(2) << '\n';
}

void print_solve_text(const SolveOptions& o, const pvdf::Scene& scene, const pvdf::fem::Result& r,
                      std::size_t mesh_file_cells) {
  const auto& s = r.summary;
  const bool ok = pvdf::fem::usable(s.status);
  std::printf("%s: %s (%s)\n", scene.source.c_str(), pvdf::fem::status_name(s.status).c_str(), s.message.c_str());
  std::printf("model %s: %s\n", pvdf::fem::model_name(s.model).c_str(), s.model_reason.c_str());
  if (!o.mesh_path.empty()) std::printf("mesh %s: %zu cells as read, refined from there\n", o.mesh_path.c_str(), mesh_file_cells);
  std::printf("%zu DOFs, %zu cells, %d Newton iterations, %d load steps, %d refinements, %.3f s wall, %.3f CPU-s "
              "(assembly %.3f s, linear solves %.3f s, setup %.3f s)\n",
              s.n_dofs, s.n_cells, s.newton_iterations, s.load_steps, s.refinement_cycles, s.wall_s, s.cpu_s,
              s.assembly_s, s.linear_solve_s, s.setup_s);
  std::printf("estimated relative error %.3g = discretization %.3g + model %.3g (%s)\n", s.estimated_relative_error,
              s.estimated_discretization_error, s.estimated_model_error, s.error_estimator.c_str());
  if (!ok) return;
  std::printf("max deflection %.4f mm, deflection at load %.4f mm, rim reaction %.6g N\n",
              r.max_deflection_m * 1e3, r.deflection_at_load_m * 1e3, r.rim_reaction_N);
  if (r.wrinkled_area_fraction > 0 || r.slack_area_fraction > 0)
    std::printf("wrinkled %.1f %% of the film, slack %.1f %% (tension-field membrane)\n",
                100 * r.wrinkled_area_fraction, 100 * r.slack_area_fraction);
  for (const auto& e : r.electrodes) {
    const auto& n = e.mean_membrane_force_material_N_per_m;
    std::printf("electrode %-8s N11 %10.4f  N22 %10.4f  N12 %10.4f N/m  charge %.4g pC\n", e.name.c_str(), n[0],
                n[1], n[2], e.charge_C * 1e12);
  }
  for (const auto& p : r.samples) {
    const auto& n = p.membrane_force.global;
    std::printf("sample (%.4g, %.4g) mm: w %.5f mm  Nxx %.4f  Nyy %.4f  Nxy %.4f N/m\n", p.x_m * 1e3, p.y_m * 1e3,
                p.w_m * 1e3, n[0], n[1], n[2]);
  }
  for (const auto& f : r.vtu_files) std::printf("wrote %s\n", f.c_str());
}

int run_solve(const SolveOptions& o) {
  pvdf::Scene scene = pvdf::load_scene(o.scene_path);
  for (const auto& w : scene.warnings) pvdf::app::warn(w);
  apply_load_flags(o, scene);
  const pvdf::fem::Options options = solver_options(o, scene);
  std::size_t mesh_file_cells = 0;
  std::optional<StdoutToStderr> progress_to_stderr;
  if (o.json && o.verbose) progress_to_stderr.emplace();  // stdout carries the JSON alone
  pvdf::fem::Result r = solve_scene(o, scene, options, mesh_file_cells);
  progress_to_stderr.reset();
  const auto& s = r.summary;
  const bool ok = pvdf::fem::usable(s.status);

  if (o.json) {
    print_solve_json(o, r, mesh_file_cells);
  } else {
    print_solve_text(o, scene, r, mesh_file_cells);
  }
  if (!ok) {
    std::cerr << "error: " << scene.source << ": the film solve did not converge (" << pvdf::fem::status_name(s.status)
              << "): " << s.message << "\n";
    return pvdf::exit_code::numerical;
  }
  return pvdf::exit_code::success;
}

}  // namespace

PVDF_COMMAND(30, [](CLI::App& root) {
  auto* sub = root.add_subcommand("solve", "Deflection, membrane forces and electrode charges of the clamped film "
                                           "under probe loads (nonlinear membrane-plate FEM)");
  auto o = std::make_shared<SolveOptions>();
  sub->add_option("SCENE", o->scene_path, "Scene file (JSON, docs/scene.md)")->required();
  sub->add_option("--load", o->loads, "Probe load X_M,Y_M,F_N (repeatable; replaces the scene's loads)");
  sub->add_option("--sample", o->samples, "Evaluate the fields at X_M,Y_M (repeatable)");
  sub->add_option("--model", o->model, "Kinematics: auto|linear|von-karman|large-rotation (default: scene)");
  sub->add_option("--tolerance", o->tolerance, "Requested relative error of the outputs (default: scene, 0.01)")
      ->check(pvdf::app::number_in(1e-8, 0.5, "(the rule of the scene key model.tolerance), e.g. 0.01"));
  sub->add_option("--max-refinements", o->max_refinements, "Cap on adaptive refinement cycles (default: scene)")
      ->check(pvdf::app::integer_in(0, 20, "(the rule of the scene key model.max_refinements)"));
  sub->add_option("--refinement", o->refinement,
                  "Adaptive refinement indicators: goal (adjoint-weighted residual of the outputs) or kelly (default goal)");
  sub->add_option("--vtu", o->vtu_dir, "Write VTU files (one per mesh) and film.pvd into this folder")
      ->check(pvdf::app::output_folder());
  sub->add_option("--mesh", o->mesh_path,
                  "Solve on this Gmsh mesh (.msh from `pvdfkit mesh`, or any quad mesh with the physical groups of "
                  "docs/mesh.md) instead of the built-in one; the first solve uses its cells as they are");
  sub->add_flag("--json", o->json, "Print one JSON object (status, model, n_dofs, electrodes, samples, ...)");
  sub->add_flag("--verbose", o->verbose, "Print Newton progress");
  return pvdf::app::Subcommand{sub, [o] { return run_solve(*o); }};
});
