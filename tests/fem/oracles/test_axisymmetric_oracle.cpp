// The axisymmetric oracle against independent truths: Hencky's series (membrane, pressure), the
// linear plate and tensioned-membrane closed forms (tiny loads), the exact membrane scaling and
// energy identity, vertical equilibrium, and grid convergence to the 1e-5 target.
#include <catch2/catch.hpp>

#include "axisymmetric_plate.hpp"
#include "hencky.hpp"
#include "linear_plate.hpp"
#include "membrane_scaling.hpp"

using namespace pvdf::fem::oracles;

namespace {
AxisymmetricProblem seed001_probe() {
  AxisymmetricProblem p;  // a = 45 mm, h = 25 µm, E = 2 GPa, ν = 0.3, 1 N on a 1 mm disk
  return p;
}
double rel(double x, double ref) { return std::abs(x - ref) / std::abs(ref); }
}  // namespace

TEST_CASE("membrane under uniform pressure matches Hencky's series to 1e-6", "[oracle][membrane]") {
  AxisymmetricProblem p = seed001_probe();
  p.load_radius_m = p.radius_m;
  p.force_N = 0.7;
  const double q = p.force_N / (M_PI * p.radius_m * p.radius_m);
  const auto s = solve_axisymmetric(p, {160});
  REQUIRE(s.converged);
  const HenckySeries H = hencky_series(p.poisson_ratio);
  const double a = p.radius_m, h = p.thickness_m, E = p.youngs_modulus_Pa;
  CHECK(rel(s.centre_deflection_m(), H.centre_deflection_m(q, a, h, E)) < 1e-6);
  for (double r : {0.0, 0.3 * a, 0.8 * a, a}) {
    CHECK(rel(s.deflection_m(r) + 1e-3 * H.centre_deflection_m(q, a, h, E),
              H.deflection_m(r, q, a, h, E) + 1e-3 * H.centre_deflection_m(q, a, h, E)) < 1e-6);
    CHECK(rel(s.radial_force_N_per_m(r), H.radial_force_N_per_m(r, q, a, h, E)) < 1e-6);
    CHECK(rel(s.hoop_force_N_per_m(r), H.hoop_force_N_per_m(r, q, a, h, E)) < 1e-6);
  }
  // Vertical equilibrium across circles: the load inside r is F r²/a².
  for (double r : {0.25 * a, 0.5 * a, a}) CHECK(s.vertical_force_N(r) == Approx(p.force_N * r * r / (a * a)).epsilon(1e-6));
  // Energy identity of the pure membrane: U = p V / 4.
  CHECK(s.strain_energy_J == Approx(membrane_strain_energy_J(s.load_work_J)).epsilon(1e-9));
}

TEST_CASE("probe-loaded membrane: grid convergence to 1e-5 in centre deflection and N_r", "[oracle][membrane]") {
  const AxisymmetricProblem p = seed001_probe();
  const auto coarse = solve_axisymmetric(p, {100});
  const auto mid = solve_axisymmetric(p, {200});
  const auto fine = solve_axisymmetric(p, {400});
  REQUIRE((coarse.converged && mid.converged && fine.converged));
  CHECK(rel(mid.centre_deflection_m(), fine.centre_deflection_m()) < 1e-8);
  for (double r : {0.0, 0.5e-3, 1e-3, 2e-3, 10e-3, 30e-3, 45e-3}) {
    CHECK(rel(mid.radial_force_N_per_m(r), fine.radial_force_N_per_m(r)) < 1e-5);
    CHECK(rel(mid.hoop_force_N_per_m(r), fine.hoop_force_N_per_m(r)) < 1e-5);
  }
  // The error shrinks with refinement (coarse-mid difference larger than mid-fine).
  const double r = 10e-3;
  CHECK(std::abs(coarse.radial_force_N_per_m(r) - fine.radial_force_N_per_m(r)) >
        std::abs(mid.radial_force_N_per_m(r) - fine.radial_force_N_per_m(r)));
  // Known value: a 1 N probe deflects this film by about 3.3 mm.
  CHECK(fine.centre_deflection_m() == Approx(3.26e-3).epsilon(0.01));
  for (double rr : {2e-3, 20e-3, 45e-3}) CHECK(fine.vertical_force_N(rr) == Approx(1.0).epsilon(1e-5));
}

TEST_CASE("pure membrane obeys w ~ F^(1/3), N ~ F^(2/3) and U = F*delta/4", "[oracle][membrane][scaling]") {
  AxisymmetricProblem p = seed001_probe();
  const auto s1 = solve_axisymmetric(p, {120});
  p.force_N = 8.0;
  const auto s8 = solve_axisymmetric(p, {120});
  REQUIRE((s1.converged && s8.converged));
  CHECK(s8.centre_deflection_m() == Approx(membrane_scaled_deflection_m(s1.centre_deflection_m(), 1, 8)).epsilon(1e-9));
  CHECK(s8.radial_force_N_per_m(5e-3) ==
        Approx(membrane_scaled_force(s1.radial_force_N_per_m(5e-3), 1, 8)).epsilon(1e-8));
  CHECK(s1.strain_energy_J == Approx(0.25 * s1.load_work_J).epsilon(1e-9));
  // The load work is F times the mean deflection over the footprint, a little below F·w(0).
  CHECK(s1.load_work_J < 1.0 * s1.centre_deflection_m());
  CHECK(s1.load_work_J > 0.9 * s1.centre_deflection_m());
}

TEST_CASE("tiny loads with bending reproduce the linear clamped plate closed forms", "[oracle][plate]") {
  AxisymmetricProblem p = seed001_probe();
  p.bending = true;
  p.force_N = 1e-10;  // w0 ≈ 6e-5 h: membrane action ~ (w/h)² ≈ 1e-8
  const double D = flexural_rigidity_Nm(p.youngs_modulus_Pa, p.thickness_m, p.poisson_ratio);
  SECTION("disk load") {
    const auto s = solve_axisymmetric(p, {200});
    REQUIRE(s.converged);
    for (double r : {0.0, 0.5e-3, 1e-3, 5e-3, 30e-3})
      CHECK(rel(s.deflection_m(r),
                clamped_plate_disk_load_deflection_m(r, p.force_N, p.load_radius_m, p.radius_m, D)) < 1e-5);
    CHECK(s.strain_energy_J == Approx(linear_strain_energy_J(s.load_work_J)).epsilon(1e-5));
  }
  SECTION("uniform pressure") {
    p.load_radius_m = p.radius_m;
    const auto s = solve_axisymmetric(p, {200});
    REQUIRE(s.converged);
    const double q = p.force_N / (M_PI * p.radius_m * p.radius_m);
    for (double r : {0.0, 10e-3, 30e-3})
      CHECK(rel(s.deflection_m(r), clamped_plate_pressure_deflection_m(r, q, p.radius_m, D)) < 1e-5);
  }
}

TEST_CASE("linear plate closed forms are consistent with each other", "[oracle][plate]") {
  const double a = 45e-3, D = 2.9e-6, P = 1e-6;
  // c = a: the disk load is the uniform pressure.
  for (double r : {0.0, 10e-3, 44e-3})
    CHECK(clamped_plate_disk_load_deflection_m(r, P, a, a, D) ==
          Approx(clamped_plate_pressure_deflection_m(r, P / (M_PI * a * a), a, D)).epsilon(1e-12));
  // c → 0: the point-load centre deflection P a²/(16πD).
  CHECK(clamped_plate_disk_load_deflection_m(0.0, P, 1e-7, a, D) == Approx(P * a * a / (16 * M_PI * D)).epsilon(1e-9));
  // Continuity at r = c.
  const double c = 2e-3;
  CHECK(clamped_plate_disk_load_deflection_m(c * (1 - 1e-12), P, c, a, D) ==
        Approx(clamped_plate_disk_load_deflection_m(c * (1 + 1e-12), P, c, a, D)).epsilon(1e-9));
}

TEST_CASE("a dominant pretension gives the linear tensioned membrane", "[oracle][pretension]") {
  AxisymmetricProblem p = seed001_probe();
  p.pretension_N_per_m = 100.0;
  p.force_N = 1e-6;  // w ≈ 1e-9 m: the nonlinear stiffening is negligible against N0
  const auto s = solve_axisymmetric(p, {200});
  REQUIRE(s.converged);
  for (double r : {0.0, 0.5e-3, 1e-3, 5e-3, 30e-3})
    CHECK(rel(s.deflection_m(r), tensioned_membrane_disk_load_deflection_m(r, p.force_N, p.load_radius_m,
                                                                           p.radius_m, p.pretension_N_per_m)) < 1e-5);
  // With pretension the membrane scaling breaks: U/L is 1/2 (linear), not 1/4.
  CHECK(s.strain_energy_J == Approx(0.5 * s.load_work_J).epsilon(1e-4));
}

TEST_CASE("bending and Green-Lagrange corrections are small, signed and vanish as they should",
          "[oracle][kinematics]") {
  AxisymmetricProblem p = seed001_probe();
  const auto vk = solve_axisymmetric(p, {200});
  p.kinematics = Kinematics::green_lagrange;
  const auto gl = solve_axisymmetric(p, {200});
  p.kinematics = Kinematics::von_karman;
  p.bending = true;
  const auto bend = solve_axisymmetric(p, {200});
  REQUIRE((vk.converged && gl.converged && bend.converged));
  // Both stiffen the film a little at 1 N (relative changes between 1e-6 and 1e-2).
  const double d_gl = rel(gl.centre_deflection_m(), vk.centre_deflection_m());
  const double d_bend = rel(bend.centre_deflection_m(), vk.centre_deflection_m());
  CHECK(gl.centre_deflection_m() < vk.centre_deflection_m());
  CHECK(bend.centre_deflection_m() < vk.centre_deflection_m());
  CHECK((d_gl > 1e-6 && d_gl < 1e-2));
  CHECK((d_bend > 1e-5 && d_bend < 1e-2));
  // Bending energy makes U/L rise above 1/4; both still balance the load.
  CHECK(bend.strain_energy_J / bend.load_work_J > 0.25 + 1e-6);
  CHECK(gl.vertical_force_N(20e-3) == Approx(1.0).epsilon(1e-5));
  CHECK(bend.vertical_force_N(20e-3) == Approx(1.0).epsilon(1e-5));
  // The Green–Lagrange correction is a strain-order effect: it shrinks like F^(2/3).
  p.bending = false;
  p.force_N = 1e-3;
  const auto vk_small = solve_axisymmetric(p, {200});
  p.kinematics = Kinematics::green_lagrange;
  const auto gl_small = solve_axisymmetric(p, {200});
  REQUIRE((vk_small.converged && gl_small.converged));
  const double d_small = rel(gl_small.centre_deflection_m(), vk_small.centre_deflection_m());
  CHECK(d_gl / d_small == Approx(100.0).epsilon(0.1));
}
