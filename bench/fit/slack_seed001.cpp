// The seed-001 film made slack (docs/fem-vs-experiment.md §6.1): direct solves of the presses of the
// observations file at a given pre-tension N0 < 0, large-rotation membrane with bending kept and the
// tension-field residual stiffness ε (the combination that converges on strongly slack films), on the
// first mesh (no refinement; the printed estimate says how far that mesh is from converged).
// Usage: slack_seed001 [N0_N_per_m = -2800] [eps = 1e-3]
#include "pvdf/core/scene.hpp"
#include "pvdf/fem/solver.hpp"

#include <cstdio>
#include <cstdlib>

int main(int argc, char** argv) {
  const double n0 = argc > 1 ? std::atof(argv[1]) : -2800.0;
  const double eps = argc > 2 ? std::atof(argv[2]) : 1e-3;
  pvdf::Scene scene = pvdf::load_scene(std::string(PVDF_SOURCE_DIR) + "/examples/scenes/seed001.json");
  scene.membrane.pretension_N_per_m = n0;
  pvdf::fem::Options o;
  o.model = pvdf::fem::Model::large_rotation;
  o.include_bending = true;
  o.max_refinements = 0;
  o.tension_field_residual_stiffness = eps;
  std::printf("seed-001 film, N0 = %g N/m, residual stiffness %g, d31 %.2f pC/N\n", n0, eps,
              scene.material.d31_C_per_N * 1e12);
  const double presses[4][2] = {{0, 0}, {0.006, 0.006}, {0.00466, -0.005}, {-0.00466, -0.005}};
  for (const auto& p : presses) {
    const auto r = pvdf::fem::solve(pvdf::with_probe_load(scene, p[0], p[1], 1.0), o);
    std::printf("press (%5.2f, %5.2f) mm: %s, %zu DOFs, %d load steps, %.1f s, w = %.3f mm, estimate %.3f, "
                "wrinkled %.3f, slack %.3f, charges",
                p[0] * 1e3, p[1] * 1e3, pvdf::fem::status_name(r.summary.status).c_str(), r.summary.n_dofs,
                r.summary.load_steps, r.summary.wall_s, r.deflection_at_load_m * 1e3,
                r.summary.estimated_relative_error, r.wrinkled_area_fraction, r.slack_area_fraction);
    for (const auto& e : r.electrodes) std::printf(" %s %.2f", e.name.c_str(), e.charge_C * 1e12);
    std::printf(" pC\n");
    std::fflush(stdout);
  }
  return 0;
}
