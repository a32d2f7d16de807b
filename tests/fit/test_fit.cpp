// pvdf::fit against known films: the exact (E_scale, N0, F) rescaling the predictor relies on,
// its derivatives against finite differences of independent predictions, parameter recovery
// with coverage of the reported 1-σ intervals, and the E_scale/gain degeneracy of a pure membrane.
#include "pvdf/core/scene.hpp"
#include "pvdf/fem/solver.hpp"
#include "pvdf/fit/fit.hpp"
#include "pvdf/fit/predictor.hpp"
#include "axisymmetric_plate.hpp"  // tests/fem/oracles: the independent tension-field oracle

#include "../test_sigma_scale.hpp"

#include <catch2/catch.hpp>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>

namespace {

using namespace pvdf::fit;

pvdf::Scene film() { return pvdf::load_scene(PVDF_FIT_TEST_DIR "/film.json"); }

/// 3 positions × 3 forces: the force dependence separates pre-tension from stiffness.
std::vector<Press> presses() {
  std::vector<Press> p;
  for (double f : {0.2, 0.5, 1.0})
    for (auto xy : {std::array<double, 2>{0.0, 0.0}, {0.004, 0.002}, {-0.003, -0.006}}) p.push_back({xy[0], xy[1], f});
  return p;
}

/// A measured table with the given values (deflection + 3 charges per press) and sigmas.
MeasuredTable table(const std::vector<Press>& ps, const std::vector<std::vector<double>>& values,
                    const std::vector<std::vector<double>>& sigmas, bool with_deflection = true) {
  MeasuredTable m;
  m.source = "synthetic";
  for (std::size_t i = 0; i < ps.size(); ++i) {
    m.line.push_back(i + 2);
    m.x_m.push_back(ps[i].x_m);
    m.y_m.push_back(ps[i].y_m);
    m.force_N.push_back(ps[i].force_N);
  }
  const char* names[] = {"deflection_m", "charge_A_C", "charge_B_C", "charge_C_C"};
  for (int c = with_deflection ? 0 : 1; c < 4; ++c) {
    ObservedColumn o;
    o.name = names[c];
    o.electrode = c - 1;
    o.has_sigma = !sigmas.empty();
    for (std::size_t i = 0; i < ps.size(); ++i) {
      o.value.push_back(values[i][c]);
      if (o.has_sigma) o.sigma.push_back(sigmas[i][c]);
    }
    m.observed.push_back(o);
  }
  return m;
}

/// Noise-free observations [press][deflection, QA, QB, QC] of a film.
std::vector<std::vector<double>> observe(Predictor& p, double T, double E, double d31, double d32) {
  const auto r = p.predict({T, E});
  std::vector<std::vector<double>> out;
  for (const auto& x : r) {
    const auto q = charges_C(x, p.electrode_areas_m2(), p.scene().membrane.thickness_m, d31, d32, {1, 1, 1});
    out.push_back({x.deflection_m, q[0], q[1], q[2]});
  }
  return out;
}

}  // namespace

TEST_CASE("the predictor's rescaling equals a direct solve of the rescaled film, and its derivatives match differences",
          "[fit]") {
  const pvdf::Scene s = film();
  const std::vector<Press> ps{{0.003, 0.001, 0.6}, {-0.002, -0.005, 0.3}};
  const double T = 12.0, E = 0.4;
  // Rescaled: base material at N0/E and F/E, forces times E.
  Predictor scaled(s, ps);
  const auto r = scaled.predict({T, E}, {true, true});
  // Direct: the film's own stiffness and pre-tension (a separate predictor and mesh setup).
  Predictor direct(apply_parameters(s, T, E, 6.5e-12, 0.65e-12), ps);
  const auto d = direct.predict({T, 1.0});
  for (std::size_t i = 0; i < ps.size(); ++i) {
    CHECK(r[i].deflection_m == Approx(d[i].deflection_m).epsilon(1e-6));
    for (std::size_t k = 0; k < 3; ++k)
      for (int c = 0; c < 2; ++c)
        CHECK(r[i].force_basis_N_per_m[k][c] == Approx(d[i].force_basis_N_per_m[k][c]).epsilon(1e-5));
  }
  // Derivatives against central differences of predictions (the predictor's own are one-sided
  // differences in the rescaled variables, combined by the chain rule).
  const double hT = 0.05, hE = 0.002;
  const auto tp = scaled.predict({T + hT, E}), tm = scaled.predict({T - hT, E});
  const auto ep = scaled.predict({T, E + hE}), em = scaled.predict({T, E - hE});
  for (std::size_t i = 0; i < ps.size(); ++i) {
    const double dwdT = (tp[i].deflection_m - tm[i].deflection_m) / (2 * hT);
    const double dwdE = (ep[i].deflection_m - em[i].deflection_m) / (2 * hE);
    CHECK(r[i].d_deflection[0] == Approx(dwdT).epsilon(2e-3));
    CHECK(r[i].d_deflection[1] == Approx(dwdE).epsilon(2e-3));
    for (std::size_t k = 0; k < 3; ++k) {
      const double dndT = (tp[i].force_basis_N_per_m[k][0] - tm[i].force_basis_N_per_m[k][0]) / (2 * hT);
      const double dndE = (ep[i].force_basis_N_per_m[k][0] - em[i].force_basis_N_per_m[k][0]) / (2 * hE);
      CHECK(r[i].d_force_basis[0][k][0] == Approx(dndT).epsilon(5e-3).margin(1e-6));
      CHECK(r[i].d_force_basis[1][k][0] == Approx(dndE).epsilon(5e-3).margin(1e-6));
    }
  }
}

TEST_CASE("the sweep charges equal adaptive direct solves at the presses (no interpolation)", "[fit]") {
  const pvdf::Scene s = film();
  const std::vector<Press> ps{{0.004, 0.002, 1.0}, {-0.003, -0.006, 0.5}};
  Predictor p(s, ps);
  const auto r = p.predict({0.0, 1.0});
  for (std::size_t i = 0; i < ps.size(); ++i) {
    pvdf::fem::Options o = pvdf::fem::options_from_scene(s);
    o.tolerance = 0.005;
    o.max_refinements = 3;
    const auto d = pvdf::fem::solve(pvdf::with_probe_load(s, ps[i].x_m, ps[i].y_m, ps[i].force_N), o);
    REQUIRE(pvdf::fem::usable(d.summary.status));
    const auto q = charges_C(r[i], p.electrode_areas_m2(), s.membrane.thickness_m, s.material.d31_C_per_N,
                             s.material.d32_C_per_N, {1, 1, 1});
    double scale = 0;
    for (const auto& e : d.electrodes) scale = std::max(scale, std::abs(e.charge_C));
    for (std::size_t k = 0; k < 3; ++k) CHECK(std::abs(q[k] - d.electrodes[k].charge_C) < 0.03 * scale);
    CHECK(r[i].deflection_m == Approx(d.deflection_at_load_m).epsilon(0.03));
  }
}

namespace {

using pvdf::testing::test_sigma_scale;  // tests/test_sigma_scale.hpp

/// What a coverage study counts: per parameter the repetitions within 2σ of the truth, over all
/// parameters and repetitions the estimates within 1σ, and the mean of z² = ((value − truth)/σ)².
struct Coverage {
  std::array<int, 3> within_2sigma{0, 0, 0};
  int within_1sigma = 0;
  int n = 0;
  double mean_z2 = 0;
};

/// Coverage study: a known film (pre-tension T of either sign, E_scale E, d31), data from a finer
/// sweep mesh + 2 % noise, 20 seeded fits started at (T_start, E_start, the scene's d31).
/// `eps`: the tension-field residual stiffness of both predictors (the fit's slack path).
Coverage coverage(double T, double E, double d31, double T_start, double E_start, const char* label,
                            double eps = 0) {
  const pvdf::Scene s = film();
  const auto ps = presses();
  const double d32 = s.material.d32_C_per_N;
  // The data come from a finer sweep mesh (tolerance 0.005: cells half the size, finer grading)
  // than the fit's (the scene's 0.04), so the fit does not see its own discretization.
  PredictorOptions fine;
  fine.use_scene_model = false;
  fine.sweep.solver = pvdf::fem::options_from_scene(s);
  fine.sweep.solver.tolerance = 0.005;
  fine.sweep.n_setup_checks = 0;
  fine.sweep.solver.tension_field_residual_stiffness = eps;
  Predictor truth(s, ps, fine);
  const auto clean = observe(truth, T, E, d31, d32);

  PredictorOptions coarse;
  coarse.sweep.solver.tension_field_residual_stiffness = eps;
  Predictor model(s, ps, coarse);
  std::mt19937 rng(20261124);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double rel = 0.02;  // 2 % of every value, 1 sigma
  Coverage cov;
  const double scale = test_sigma_scale();
  double sum_z2 = 0;
  const int reps = 20;
  const auto t0 = std::chrono::steady_clock::now();
  for (int rep = 0; rep < reps; ++rep) {
    std::vector<std::vector<double>> noisy = clean, sig = clean;
    for (std::size_t i = 0; i < clean.size(); ++i) {
      for (std::size_t c = 0; c < 4; ++c) {
        sig[i][c] = rel * std::abs(clean[i][c]);
        noisy[i][c] = clean[i][c] + sig[i][c] * normal(rng);
      }
    }
    FitOptions fo;
    fo.parameters = {"pretension_N_per_m", "E_scale", "d31_C_per_N"};
    // Started away from the truth (the fit must travel), but not so far that 20 repetitions take minutes.
    fo.start = {{"pretension_N_per_m", T_start}, {"E_scale", E_start}};
    const FitResult r = fit_film(model, table(ps, noisy, sig), fo);
    INFO(label << " repetition " << rep << ": " << r.message);
    REQUIRE(r.status == FitStatus::converged);
    const double truth_values[3] = {T, E, d31};
    for (int j = 0; j < 3; ++j) {
      const auto& p = r.parameters[j];
      const double sigma = scale * p.sigma;
      REQUIRE(sigma > 0);
      const double z = (p.value - truth_values[j]) / sigma;
      REQUIRE(std::isfinite(z));
      if (std::abs(z) <= 2) ++cov.within_2sigma[j];
      if (std::abs(z) <= 1) ++cov.within_1sigma;
      sum_z2 += z * z;
      ++cov.n;
      if (rep == 0) std::printf("  %s = %.5g +- %.3g (true %.5g)\n", p.name.c_str(), p.value, p.sigma, truth_values[j]);
    }
    if (rep == 0)
      std::printf("  %d iterations; FEM so far: %zu solves (%.1f s), %zu sweep meshes (%.1f s)\n", r.iterations,
                  r.fem.n_solves, r.fem.solve_s, r.fem.n_sweeps, r.fem.setup_s);
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  cov.mean_z2 = sum_z2 / cov.n;
  std::printf("%s (sigma x %g): coverage of the 2-sigma intervals over %d repetitions: pretension %d, E_scale %d, "
              "d31 %d; within 1 sigma %d of %d; mean z^2 %.3f (%.1f s)\n",
              label, scale, reps, cov.within_2sigma[0], cov.within_2sigma[1], cov.within_2sigma[2], cov.within_1sigma,
              cov.n, cov.mean_z2, wall);
  return cov;
}

/// The two-sided bands (docs/testing.md, "Coverage tests"): ≥ 17 of 20 within 2σ per parameter
/// (too small a σ fails here), 1σ share of all 60 estimates in [0.45, 0.88] (σ × 2 gives 0.954, σ × 0.5
/// gives 0.383), mean z² in [0.4, 2.2] (1 for the right σ, 0.25 for σ × 2, 4 for σ × 0.5).
void check_two_sided(const Coverage& c) {
  for (int j = 0; j < 3; ++j) CHECK(c.within_2sigma[j] >= 17);
  const double share_1sigma = double(c.within_1sigma) / c.n;
  CHECK(share_1sigma >= 0.45);
  CHECK(share_1sigma <= 0.88);
  CHECK(c.mean_z2 >= 0.4);
  CHECK(c.mean_z2 <= 2.2);
}

}  // namespace

TEST_CASE("a known film (pre-tension, stiffness, d31): the fit's sigma is neither too small nor too large (two-sided coverage)",
          "[fit][.coverage]") {
  check_two_sided(coverage(20.0, 0.5, 5.0e-12, 10.0, 0.7, "pre-tensioned film"));
}

TEST_CASE("a known SLACK film (negative pre-tension, stiffness, d31) is recovered within 2 sigma in >= 17 of 20",
          "[fit][.coverage-slack]") {
  // N0 = −150 N/m on the 25 µm seed-001 film: held flat it would be compressed by 150 N/m, a natural
  // strain of about 2e-3 (stress-free radius 30.06 mm); at E_scale 0.5 the fit's rescaled slack is −300.
  check_two_sided(coverage(-150.0, 0.5, 5.0e-12, -80.0, 0.7, "slack film"));
}

TEST_CASE("a known SLACK film is recovered within 2 sigma in >= 17 of 20 on the residual-stiffness path (1e-3)",
          "[fit][.coverage-slack-residual]") {
  // The same film and data as above, with the fit's strongly-slack settings: residual stiffness 1e-3
  // (in the data's finer model too) and bending kept.
  check_two_sided(coverage(-150.0, 0.5, 5.0e-12, -80.0, 0.7, "slack film, residual stiffness 1e-3", 1e-3));
}

TEST_CASE("charges alone cannot separate E_scale from the gains on a pure membrane: flagged, with the condition number",
          "[fit]") {
  const pvdf::Scene s = film();
  const auto ps = presses();
  Predictor truth(s, ps);
  auto clean = observe(truth, 0.0, 0.6, 6.5e-12, 0.65e-12);
  std::vector<std::vector<double>> sig = clean;
  for (auto& row : sig)
    for (auto& v : row) v = 0.02 * std::abs(v);
  FitOptions fo;
  // Q_k = gain_k · E^(1/3) · (a function of position) for a pure membrane without pre-tension:
  // only the products gain_k·E^(1/3) are seen.
  fo.parameters = {"E_scale", "gain_A", "gain_B", "gain_C"};
  const FitResult r = fit_film(truth, table(ps, clean, sig, false), fo);
  CHECK(r.status == FitStatus::ill_conditioned);
  for (const char* name : {"E_scale", "gain_A", "gain_B", "gain_C", "condition number"})
    CHECK(r.message.find(name) != std::string::npos);
  REQUIRE(r.parameters.size() == 4);
  for (const auto& p : r.parameters) CHECK_FALSE(p.determined);
  CHECK(std::abs(r.correlation[0][1]) > 0.999);
  std::printf("E_scale and gains from charges alone: condition number %.3g, correlation E/gain_A %.8f\n",
              r.condition_number, r.correlation[0][1]);
  // With the deflection the same two parameters are determined.
  const FitResult w = fit_film(truth, table(ps, clean, sig, true), fo);
  CHECK(w.status == FitStatus::converged);
  CHECK(w.parameters[0].value == Approx(0.6).epsilon(1e-3));
}

namespace {

/// A strongly slack isotropic film for the residual-stiffness path: 30 mm radius, 25 µm, E = 2 GPa,
/// ν = 0.3, 1 mm probe, one 2 mm electrode R at (8, 0) mm; N0 is set per prediction.
pvdf::Scene slack_oracle_film() {
  pvdf::Scene s = pvdf::default_scene();
  s.source = "slack oracle film";
  s.membrane.outline.shape = pvdf::FilmOutline::Shape::circle;
  s.membrane.outline.radius_m = 0.03;
  s.membrane.thickness_m = 25e-6;
  s.membrane.pretension_N_per_m = 0;
  s.material.isotropic = true;
  s.material.E1_Pa = s.material.E2_Pa = 2e9;
  s.material.nu12 = 0.3;
  s.material.G12_Pa = 2e9 / 2.6;
  s.material.draw_angle_rad = 0;
  pvdf::Electrode e;
  e.name = "R";
  e.center_m = {0.008, 0.0};
  e.size_m = {0.002, 0.002};
  s.electrodes = {e};
  s.probe.radius_m = 0.001;
  s.loads.clear();
  s.model.tolerance = 0.02;
  return s;
}

/// The oracle's mean membrane force over the square electrode in x–y axes [N11, N22] (N/m):
/// N_r, N_θ of the axisymmetric tension-field membrane rotated and averaged on a 20 × 20 grid.
std::array<double, 2> oracle_mean_force(const pvdf::fem::oracles::AxisymmetricSolution& o, const pvdf::Electrode& e) {
  std::array<double, 2> sum{0, 0};
  const int n = 20;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double x = e.center_m[0] + e.size_m[0] * ((i + 0.5) / n - 0.5);
      const double y = e.center_m[1] + e.size_m[1] * ((j + 0.5) / n - 0.5);
      const double r = std::hypot(x, y), c2 = x * x / (r * r), s2 = y * y / (r * r);
      const double nr = o.radial_force_N_per_m(r), nt = o.hoop_force_N_per_m(r);
      sum[0] += nr * c2 + nt * s2;
      sum[1] += nr * s2 + nt * c2;
    }
  return {sum[0] / (n * n), sum[1] / (n * n)};
}

}  // namespace

TEST_CASE("with the residual stiffness the predictor solves strongly slack films like the tension-field oracle",
          "[fit][slack-residual]") {
  // N0 = −2000 and −1800 N/m on a 30 mm film (natural strain 2.8 % and 2.5 %), a centred 1 N press: the
  // fit's path with ε = 1e-3 (bending kept; the second N0 on its own sweep, started from the first's
  // state as the fit steps, with the cold continuation behind it) against the independent axisymmetric tension-field membrane (Green–Lagrange, no bending,
  // no ε). Allowed: the ε bias of the membrane forces, 2·ε·|N0| (docs/fem.md §3.3), plus 3 % for the
  // sweep mesh (tolerance 2 %) and bending, which the oracle leaves out (boundary layer
  // sqrt(D/N)/a ≈ 2 % at the rim).
  namespace oracles = pvdf::fem::oracles;
  const pvdf::Scene s = slack_oracle_film();
  const double eps = 1e-3;
  PredictorOptions po;
  po.sweep.solver.tension_field_residual_stiffness = eps;
  po.parallel = false;
  po.sweep.n_setup_checks = 1;  // the centre: the one press solved
  const auto t0 = std::chrono::steady_clock::now();
  Predictor p(s, {{0.0, 0.0, 1.0}}, po);
  CHECK(p.stats().reference_setup.include_bending);
  CHECK(p.stats().reference_setup.model == pvdf::fem::Model::large_rotation);
  for (double n0 : {-2000.0, -1800.0}) {
    const auto r = p.predict({n0, 1.0});
    REQUIRE(r.size() == 1);
    oracles::AxisymmetricProblem op;
    op.radius_m = 0.03;
    op.thickness_m = 25e-6;
    op.youngs_modulus_Pa = 2e9;
    op.poisson_ratio = 0.3;
    op.force_N = 1.0;
    op.load_radius_m = 0.001;
    op.pretension_N_per_m = n0;
    op.tension_field = true;
    op.kinematics = oracles::Kinematics::green_lagrange;
    const auto o = oracles::solve_axisymmetric(op, {400});
    INFO("oracle: " << o.message);
    REQUIRE(o.converged);
    const auto n_oracle = oracle_mean_force(o, s.electrodes[0]);
    const auto& n_fem = r[0].force_basis_N_per_m.at(0);
    std::printf("SLACK eps %g, N0 %g N/m: w(0) %.4f mm (oracle %.4f, %+.2e); electrode R N11 %.3f (oracle %.3f), "
                "N22 %.3f (oracle %.3f) N/m; %.1f s so far, %zu solves\n",
                eps, n0, r[0].deflection_m * 1e3, o.centre_deflection_m() * 1e3,
                r[0].deflection_m / o.centre_deflection_m() - 1, n_fem[0], n_oracle[0], n_fem[1], n_oracle[1],
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), p.stats().n_solves);
    CHECK(r[0].deflection_m == Approx(o.centre_deflection_m()).epsilon(0.03));
    const double bias = 2 * eps * std::abs(n0);
    for (int c = 0; c < 2; ++c) CHECK(std::abs(n_fem[c] - n_oracle[c]) <= bias + 0.03 * std::abs(n_oracle[0]));
  }
}

TEST_CASE("with the residual stiffness a press far from the solved one is reached by a walk, to the cold solve's equilibrium",
          "[fit][slack-residual]") {
  // The slack film's cone moves with the probe, so Newton from a state 20 mm away does not converge;
  // the sweep walks the probe there (warm solves in short steps). The walk must end on the
  // equilibrium a cold solve (the continuation from the flat film) finds at that press.
  pvdf::Scene s = slack_oracle_film();
  s.membrane.pretension_N_per_m = -2000;
  pvdf::fem::SweepOptions so;
  so.solver.model = pvdf::fem::Model::large_rotation;
  so.solver.include_bending = true;
  so.solver.tension_field_residual_stiffness = 1e-3;
  so.solver.tolerance = 0.02;
  so.forces_N = {1.0};
  so.estimate_errors = false;
  so.n_setup_checks = 0;
  pvdf::fem::ProbeSweep reference(s, so);
  const auto cold = reference.solve(0.018, -0.008, 1.0);
  REQUIRE(pvdf::fem::usable(cold.status));
  // Newton capped at 12 iterations per solve, fewer than the direct warm start needs (24 measured):
  // only the walk can get there warm. Same options otherwise, hence the same mesh.
  so.solver.max_newton_iterations = 12;
  pvdf::fem::ProbeSweep sweep(s, so);
  REQUIRE(sweep.setup().n_dofs == reference.setup().n_dofs);
  pvdf::fem::SweepState centre, walked;
  const auto c = reference.solve(0, 0, 1.0, nullptr, &centre);
  REQUIRE(pvdf::fem::usable(c.status));
  const auto w = sweep.solve(0.018, -0.008, 1.0, &centre, &walked);
  INFO(w.message);
  REQUIRE(pvdf::fem::usable(w.status));
  CHECK(w.warm_started);
  std::printf("SLACK walk to (18, -8) mm: %d Newton iterations, %.1f s, w %.5f mm; cold: %d iterations, %.1f s, w %.5f mm; "
              "electrode R %.6g / %.6g pC\n",
              w.newton_iterations, w.wall_s, w.deflection_at_load_m * 1e3, cold.newton_iterations, cold.wall_s,
              cold.deflection_at_load_m * 1e3, w.charge_C.at(0) * 1e12, cold.charge_C.at(0) * 1e12);
  CHECK(w.deflection_at_load_m == Approx(cold.deflection_at_load_m).epsilon(1e-6));
  CHECK(w.charge_C.at(0) == Approx(cold.charge_C.at(0)).epsilon(1e-5));
}
