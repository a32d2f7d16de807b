// The numbers behind docs/fem-vs-paper.md: seed 001 eq. 7 evaluated as printed, what load it
// really describes, and what the independent axisymmetric oracle (tests/fem/oracles) says for the
// seed-001 film (isotropic stand-in E = 2 GPa, ν = 0.3, as in the paper's own check).
//
// Run:  build/bench/fem/fem_paper_numbers        (prints a markdown table; ~1 s for the oracle part,
//       then, when pvdf::fem is built, pvdfkit's solves of the seed-001 scene with bending: minutes)
#include "axisymmetric_plate.hpp"
#include "hencky.hpp"
#include "linear_plate.hpp"
#include "membrane_scaling.hpp"

#ifdef PVDF_BENCH_HAVE_FEM
#include "pvdf/core/constants.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/fem/solver.hpp"
#endif

#include <cmath>
#include <cstdio>
#include <functional>

using namespace pvdf::fem::oracles;

namespace {
constexpr double E = 2e9, nu = 0.3, a = 45e-3, h = 25e-6, c = 1e-3, pi = pvdf::pi;

// Seed 001 eq. 7 as printed: P = 4Eh/(R(1−ν)) · (3−ν)/4 · (U/R)³  (P comes out in Pa).
double eq7_pressure(double U) { return 4 * E * h / (a * (1 - nu)) * (3 - nu) / 4 * std::pow(U / a, 3); }
double eq7_deflection(double P) { return a * std::cbrt(P / (4 * E * h / (a * (1 - nu)) * (3 - nu) / 4)); }

AxisymmetricSolution solve(double force, double load_radius, Kinematics kin, bool bending) {
  AxisymmetricProblem p;
  p.radius_m = a;
  p.thickness_m = h;
  p.youngs_modulus_Pa = E;
  p.poisson_ratio = nu;
  p.force_N = force;
  p.load_radius_m = load_radius;
  p.kinematics = kin;
  p.bending = bending;
  return solve_axisymmetric(p, {bending ? 300 : 200});
}

// Probe force whose oracle centre deflection is `target` (secant on log F, Green–Lagrange membrane).
double force_for_deflection(double target, Kinematics kin) {
  auto f = [&](double logF) { return std::log(solve(std::exp(logF), c, kin, false).centre_deflection_m() / target); };
  double x0 = 3 * std::log(target / 3.2586e-3), x1 = x0 + 0.05;
  double f0 = f(x0), f1 = f(x1);
  for (int it = 0; it < 30 && std::abs(f1) > 1e-12; ++it) {
    const double x2 = x1 - f1 * (x1 - x0) / (f1 - f0);
    x0 = x1;
    f0 = f1;
    x1 = x2;
    f1 = f(x1);
  }
  return std::exp(x1);
}
}  // namespace

int main() {
  const HenckySeries H = hencky_series(nu);
  const double D = flexural_rigidity_Nm(E, h, nu);
  const double p_probe = 1.0 / (pi * c * c);    // 1 N on the 2 mm-diameter probe
  const double p_spread = 1.0 / (pi * a * a);   // 1 N spread over the whole film
  std::printf("# seed 001 eq. 7 and the 1 N probe, film a = 45 mm, h = 25 um, E = 2 GPa, nu = 0.3\n\n");
  std::printf("Hencky series (recomputed): b0 = %.6f, K(0.3) = %.5f; eq. 7 as a Hencky-type law has K_eq7 = "
              "((1-nu)/(3-nu))^(1/3) = %.5f\n\n",
              H.b[0], H.K, std::cbrt((1 - nu) / (3 - nu)));
  std::printf("| quantity | value |\n|---|---|\n");
  std::printf("| eq. 7 as printed, P = 3e5 Pa -> U | %.2f mm |\n", 1e3 * eq7_deflection(3e5));
  std::printf("| eq. 7 pressure for U = 18.5 mm | %.3g Pa |\n", eq7_pressure(18.5e-3));
  std::printf("| 1 N / probe area pi (1 mm)^2 | %.3g Pa |\n", p_probe);
  std::printf("| total force of 3e5 Pa on the whole film (pi a^2) | %.0f N |\n", 3e5 * pi * a * a);
  std::printf("| Hencky w0, p = 3e5 Pa on the whole film | %.2f mm |\n", 1e3 * H.centre_deflection_m(3e5, a, h, E));
  const double w_3e5_vk = solve(3e5 * pi * a * a, a, Kinematics::von_karman, false).centre_deflection_m();
  const double w_3e5_gl = solve(3e5 * pi * a * a, a, Kinematics::green_lagrange, false).centre_deflection_m();
  std::printf("| oracle w0, p = 3e5 Pa on the whole film, von Karman / Green-Lagrange | %.2f / %.2f mm |\n",
              1e3 * w_3e5_vk, 1e3 * w_3e5_gl);
  std::printf("| 1 N spread over the whole film: p | %.1f Pa |\n", p_spread);
  std::printf("| ... eq. 7 -> U | %.3f mm |\n", 1e3 * eq7_deflection(p_spread));
  std::printf("| ... Hencky -> w0 | %.4f mm |\n", 1e3 * H.centre_deflection_m(p_spread, a, h, E));
  std::printf("| ... oracle (von Karman membrane) -> w0 | %.4f mm |\n",
              1e3 * solve(1.0, a, Kinematics::von_karman, false).centre_deflection_m());
  const auto probe_vk = solve(1.0, c, Kinematics::von_karman, false);
  const auto probe_gl = solve(1.0, c, Kinematics::green_lagrange, false);
  const auto probe_bend = solve(1.0, c, Kinematics::von_karman, true);
  std::printf("| 1 N probe on r < 1 mm, oracle membrane, von Karman | %.4f mm |\n", 1e3 * probe_vk.centre_deflection_m());
  std::printf("| ... Green-Lagrange | %.4f mm |\n", 1e3 * probe_gl.centre_deflection_m());
  std::printf("| ... von Karman + bending (clamped plate) | %.4f mm |\n", 1e3 * probe_bend.centre_deflection_m());
  std::printf("| ... slope at the probe edge w'(1 mm) | %.3f (%.1f deg) |\n", -probe_vk.slope(c),
              std::atan(-probe_vk.slope(c)) * 180 / pi);
  std::printf("| ... chord angle atan(w0/a) | %.2f deg |\n", std::atan(probe_vk.centre_deflection_m() / a) * 180 / pi);
  std::printf("| ... N_r at the electrode radius 10 mm / N_theta | %.1f / %.1f N/m |\n",
              probe_vk.radial_force_N_per_m(10e-3), probe_vk.hoop_force_N_per_m(10e-3));
  std::printf("| linear clamped plate, 1 N on r < 1 mm (SHELL63 without stress stiffening) | %.2f m |\n",
              clamped_plate_disk_load_deflection_m(0.0, 1.0, c, a, D));
  std::printf("| thickness for which that linear plate gives 19.5 mm | %.0f um |\n",
              1e6 * h * std::cbrt(clamped_plate_disk_load_deflection_m(0.0, 1.0, c, a, D) / 19.5e-3));
  std::printf("| cone of half-angle 15 deg over R = 45 mm: R tan 15 deg | %.2f mm |\n", 1e3 * a * std::tan(15 * pi / 180));
  std::printf("| probe force for w0 = 12 mm, membrane scaling F ~ w^3 | %.1f N |\n",
              std::pow(12e-3 / probe_vk.centre_deflection_m(), 3));
  std::printf("| ... Green-Lagrange oracle | %.1f N |\n", force_for_deflection(12e-3, Kinematics::green_lagrange));
  std::printf("| probe force for w0 = 19.5 mm, membrane scaling | %.0f N |\n",
              std::pow(19.5e-3 / probe_vk.centre_deflection_m(), 3));
  std::printf("| ... Green-Lagrange oracle | %.0f N |\n", force_for_deflection(19.5e-3, Kinematics::green_lagrange));
  std::printf("| strain energy / (F w_mean), 1 N probe, membrane (exact 1/4) | %.6f |\n",
              probe_vk.strain_energy_J / probe_vk.load_work_J);
#ifdef PVDF_BENCH_HAVE_FEM
  // pvdfkit with the scene's own model options (automatic kinematics, bending, 1 % tolerance).
  for (const bool isotropic : {true, false}) {
    pvdf::Scene scene = pvdf::default_scene();
    if (isotropic) {
      scene.material.E1_Pa = scene.material.E2_Pa = E;
      scene.material.nu12 = nu;
      scene.material.G12_Pa = E / (2 * (1 + nu));
      scene.material.isotropic = true;
    }
    // The scene's options first (automatic kinematics), then large rotation + bending explicitly.
    for (const bool automatic : {true, false}) {
      pvdf::fem::Options options = pvdf::fem::options_from_scene(scene);
      if (!automatic) options.model = pvdf::fem::Model::large_rotation;
      const auto res = pvdf::fem::solve(scene, options);
      const char* film = isotropic ? "isotropic E = 2 GPa, nu = 0.3" : "seed-001 orthotropic (Table 1, reciprocal nu21)";
      if (!pvdf::fem::usable(res.summary.status)) {
        std::printf("| pvdfkit, 1 N probe, %s film, model %s | %s: %s |\n", film, automatic ? "auto" : "large-rotation",
                    pvdf::fem::status_name(res.summary.status).c_str(), res.summary.message.c_str());
        continue;
      }
      std::printf("| pvdfkit, 1 N probe, %s film, model %s (used %s, with bending, est. error %.1e) | %.4f mm |\n", film,
                  automatic ? "auto" : "large-rotation", pvdf::fem::model_name(res.summary.model).c_str(),
                  res.summary.estimated_relative_error, 1e3 * std::abs(res.deflection_at_load_m));
      if (!res.electrodes.empty())
        std::printf("| ... electrode A mean [N11, N22, N12] | [%.1f, %.1f, %.1f] N/m |\n",
                    res.electrodes[0].mean_membrane_force_material_N_per_m[0],
                    res.electrodes[0].mean_membrane_force_material_N_per_m[1],
                    res.electrodes[0].mean_membrane_force_material_N_per_m[2]);
    }
  }
#endif
  return 0;
}
