// Accuracy of pvdf::fem against the independent axisymmetric oracle (tests/fem/oracles) on the
// models a user actually gets: the large-rotation membrane that `auto` picks at 1 N on a seed-001
// film, bending together with membrane action from 25 µm (bending negligible) to 2 mm (bending
// dominant), pretension (with the closed form of Lee et al. 2008 as a loose cross-check), and the
// electrode charge against an independent integration of the oracle's fields. Each output is
// accepted by the rule of oracle_compare.hpp: error on the finer of two nested meshes ≤ the change
// between them (a tolerance from the FEM's own convergence, not tuned). Lines starting "ORACLE"
// are the table of docs/fem.md ("Verification against oracles").
#include "pvdf/core/constants.hpp"

#include "oracle_compare.hpp"

#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <cstdio>

using namespace pvdf::fem::testing;
namespace oracles = pvdf::fem::oracles;

namespace {

using pvdf::pi;
constexpr double a = 0.045, E = 2e9, nu = 0.3, c = 1e-3;

pvdf::fem::Options membrane_mesh(pvdf::fem::Model model, bool bending, int level) {
  pvdf::fem::Options o;
  o.model = model;
  o.include_bending = bending;
  o.adaptive = false;
  o.coarse_size_m = a / 3;
  o.probe_size_m = c;
  o.initial_global_refinements = level;
  return o;
}

void report(const char* test, const std::string& output, double fine_error, double mesh_change) {
  std::printf("ORACLE %-28s %-28s error %.2e  mesh change %.2e\n", test, output.c_str(), fine_error, mesh_change);
}

/// Compares centre deflection, w and N_r (and N_θ) along the ray on two nested meshes.
double compare_ray(const char* test, const pvdf::Scene& s, const oracles::AxisymmetricSolution& oracle,
                 pvdf::fem::Options coarse_options, const std::vector<double>& radii, double floor_rel = 2e-4) {
  pvdf::fem::Options fine_options = coarse_options;
  ++fine_options.initial_global_refinements;
  const RaySamples coarse = solve_on_ray(s, coarse_options, radii);
  const RaySamples fine = solve_on_ray(s, fine_options, radii);
  INFO(test << ": coarse " << coarse.status << ", fine " << fine.status);
  REQUIRE(coarse.usable);
  REQUIRE(fine.usable);
  std::printf("ORACLE %-28s meshes %zu / %zu dofs, %.1f / %.1f s\n", test, coarse.n_dofs, fine.n_dofs, coarse.wall_s,
              fine.wall_s);
  auto one = [&](const std::string& what, double c0, double c1, double o) {
    const double e = check_converges_to(std::string(test) + " " + what, c0, c1, o, floor_rel);
    report(test, what, e, std::abs(c1 - c0) / std::abs(o));
  };
  one("w(0)", coarse.centre_deflection_m, fine.centre_deflection_m, oracle.centre_deflection_m());
  const double w0_error = std::abs(fine.centre_deflection_m - oracle.centre_deflection_m());
  for (std::size_t i = 0; i < radii.size(); ++i) {
    const std::string at = "(" + std::to_string(static_cast<int>(std::lround(radii[i] * 1e4)) / 10.0).substr(0, 4) + " mm)";
    one("N_r" + at, coarse.Nr_N_per_m[i], fine.Nr_N_per_m[i], oracle.radial_force_N_per_m(radii[i]));
    one("w" + at, coarse.w_m[i], fine.w_m[i], oracle.deflection_m(radii[i]));
  }
  return w0_error;
}

}  // namespace

TEST_CASE("large-rotation probe membrane (the auto choice at 1 N) against the Green-Lagrange oracle",
          "[fem][oracle][large-rotation]") {
  const pvdf::Scene s = centred_probe_scene(a, 25e-6, E, nu, 1.0, c);
  const auto oracle = oracles::solve_axisymmetric(oracle_problem(s, false, oracles::Kinematics::green_lagrange));
  REQUIRE(oracle.converged);
  // What `auto` picks here (the model is checked, not assumed): large rotation without bending.
  {
    pvdf::fem::Options o = membrane_mesh(pvdf::fem::Model::automatic, true, 0);
    const auto r = pvdf::fem::solve(s, o);
    REQUIRE(pvdf::fem::usable(r.summary.status));
    INFO(r.summary.model_reason);
    CHECK(r.summary.model == pvdf::fem::Model::large_rotation);
    CHECK(r.summary.model_reason.find("bending neglected") != std::string::npos);
  }
  const double w0_error = compare_ray("large-rotation 25um 1N", s, oracle,
                                     membrane_mesh(pvdf::fem::Model::large_rotation, false, 0), {3e-3, 10e-3, 30e-3, 44e-3});
  // The test can tell the kinematics apart: the FEM centre deflection is closer to the Green–Lagrange
  // oracle than the von Kármán oracle is (they differ by ~4e-5 at 1 N on this film).
  const auto vk = oracles::solve_axisymmetric(oracle_problem(s, false, oracles::Kinematics::von_karman));
  REQUIRE(vk.converged);
  const double kinematics_gap = std::abs(vk.centre_deflection_m() - oracle.centre_deflection_m());
  std::printf("ORACLE large-rotation: |w0 FEM - GL| = %.2e m, |w0 vK - GL| = %.2e m\n", w0_error, kinematics_gap);
  CHECK(w0_error < kinematics_gap);
}

TEST_CASE("bending + membrane against the von Karman oracle with bending, 100 um to 2 mm",
          "[fem][oracle][bending]") {
  // F = 1 N on a 2 mm probe: w/h from ~10 (membrane-dominated) to ~0.01 (linear plate). At 25 µm the
  // 0.2 mm rim boundary layer is not resolved by uniformly refined meshes (docs/fem.md, verification):
  // the thin film is covered by the membrane test above, where bending is negligible.
  const double probe = 2e-3;
  // n = 200 oracle elements: the default 400 stalls in the first load step for h ≥ 1 mm (the oracle
  // reports that as not converged); 200 and 400 agree to 1e-8 where both converge.
  const oracles::AxisymmetricOptions grid{200};
  for (double h : {100e-6, 400e-6, 2e-3}) {
    const pvdf::Scene s = centred_probe_scene(a, h, E, nu, 1.0, probe);
    const auto with = oracles::solve_axisymmetric(oracle_problem(s, true, oracles::Kinematics::von_karman), grid);
    const auto without = oracles::solve_axisymmetric(oracle_problem(s, false, oracles::Kinematics::von_karman), grid);
    REQUIRE(with.converged);
    REQUIRE(without.converged);
    const double share = 1 - with.centre_deflection_m() / without.centre_deflection_m();
    std::printf("ORACLE bending h = %g m: w/h = %.3g, bending lowers w(0) by %.3g %%\n", h,
                with.centre_deflection_m() / h, 100 * share);
    pvdf::fem::Options o;
    o.model = pvdf::fem::Model::von_karman;
    o.adaptive = false;
    o.coarse_size_m = a / 3;
    o.probe_size_m = probe / 2;
    // The acceptance rule needs two meshes one uniform refinement apart; the default rim grading
    // (docs/fem.md §6.1) would grade the coarse one only (the fine one's rim cells are already
    // small enough), so it is off here. With it, at 100 µm: w(0) 9e-5 off the oracle instead of 8e-4.
    o.grade_rim_for_bending = false;
    const std::string name = "vK+bending h=" + std::to_string(static_cast<int>(std::lround(h * 1e6))) + "um";
    compare_ray(name.c_str(), s, with, o, {5e-3, 20e-3});
  }
}

TEST_CASE("pretension against the tensioned-membrane oracle, and Lee et al. 2008 as a cross-check",
          "[fem][oracle][pretension]") {
  for (double n0 : {10.0, 100.0}) {
    const pvdf::Scene s = centred_probe_scene(a, 25e-6, E, nu, 1.0, c, n0);
    const auto oracle = oracles::solve_axisymmetric(oracle_problem(s, false, oracles::Kinematics::green_lagrange));
    REQUIRE(oracle.converged);
    const std::string name = "pretension " + std::to_string(static_cast<int>(n0)) + " N/m";
    compare_ray(name.c_str(), s, oracle, membrane_mesh(pvdf::fem::Model::large_rotation, false, 0), {5e-3, 20e-3});
    // Lee et al., "Measurement of the elastic properties and intrinsic strength of monolayer
    // graphene", Science 321 (2008): F ≈ σ0 π δ + E h q³ δ³ / a², q = 1/(1.05 − 0.15ν − 0.16ν²). Its
    // pretension term is a fit for their tip-to-hole ratio: the exact linear tensioned membrane under
    // a disk load has F = 2π σ0 δ/(ln(a/c) + ½) (linear_plate.hpp), which for a/c = 45 is 0.46 of
    // σ0 π δ. So only a loose cross-check of the oracle's δ: within 25 % (the cubic term dominates
    // at 10 N/m, the linear one weighs more at 100 N/m).
    const double q = 1 / (1.05 - 0.15 * nu - 0.16 * nu * nu), delta = oracle.centre_deflection_m();
    const double F_lee = n0 * pi * delta + E * 25e-6 * q * q * q * delta * delta * delta / (a * a);
    std::printf("ORACLE pretension %g N/m: Lee et al. force at the oracle's deflection %.4f N (applied 1 N)\n", n0, F_lee);
    CHECK(F_lee == Approx(1.0).epsilon(0.25));
  }
}

// The charge law (docs/charge-model.md): Q = ∫_S (d31 N11 + d32 N22)/h dA, N in the film's material
// axes; the oracle's N_r(r), N_θ(r) are integrated over each electrode square by
// oracle_electrode_charge (oracle_compare.hpp), independently of the FEM's quadrature.
TEST_CASE("electrode charge (sign and magnitude) against the integrated oracle fields", "[fem][oracle][charge]") {
  pvdf::Scene s = centred_probe_scene(a, 25e-6, E, nu, 1.0, c);
  const pvdf::Scene seed = pvdf::default_scene();
  s.electrodes = seed.electrodes;     // A, B, C: 2 × 2 mm at 10 mm from the centre
  s.material.draw_angle_rad = 0.5;    // oblique draw: N11 and N22 both differ from N_r and N_θ
  s.material.d31_C_per_N = 6.5e-12;
  s.material.d32_C_per_N = 0.65e-12;
  const auto oracle = oracles::solve_axisymmetric(oracle_problem(s, false, oracles::Kinematics::green_lagrange));
  REQUIRE(oracle.converged);
  auto oracle_charge = [&](const pvdf::Electrode& el) { return oracle_electrode_charge(oracle, s, el); };
  pvdf::fem::Options o = membrane_mesh(pvdf::fem::Model::large_rotation, false, 0);
  // 1 mm cells on the electrodes: with 2 mm the uniform-refinement change (5e-5) understated the
  // error (3e-4) for electrode A and the rule below failed, rightly.
  o.electrode_size_m = 1e-3;
  const auto coarse = pvdf::fem::solve(s, o);
  ++o.initial_global_refinements;
  const auto fine = pvdf::fem::solve(s, o);
  REQUIRE(pvdf::fem::usable(coarse.summary.status));
  REQUIRE(pvdf::fem::usable(fine.summary.status));
  std::printf("ORACLE charge: meshes %zu / %zu dofs, %.1f / %.1f s\n", coarse.summary.n_dofs, fine.summary.n_dofs,
              coarse.summary.wall_s, fine.summary.wall_s);
  for (std::size_t k = 0; k < s.electrodes.size(); ++k) {
    const double q_oracle = oracle_charge(s.electrodes[k]);
    CHECK(q_oracle > 0);  // a stretched film with d31, d32 > 0 collects positive charge (sign by d31)
    CHECK(fine.electrodes[k].charge_C > 0);
    const std::string what = "charge " + s.electrodes[k].name;
    const double e = check_converges_to(what, coarse.electrodes[k].charge_C, fine.electrodes[k].charge_C, q_oracle);
    std::printf("ORACLE charge %s: FEM %.4f pC, oracle %.4f pC\n", s.electrodes[k].name.c_str(),
                fine.electrodes[k].charge_C * 1e12, q_oracle * 1e12);
    report("charge", what, e, std::abs(fine.electrodes[k].charge_C - coarse.electrodes[k].charge_C) / q_oracle);
  }
}
