// The tension-field (wrinkling) membrane of pvdf::fem against the independent axisymmetric
// tension-field oracle (tests/fem/oracles: Hermite-cubic energy minimiser with the relaxed law in
// principal axes): a centred probe on a slack film — centre deflection, N_r, and the radius beyond
// which the hoop force vanishes (through the wrinkled share of the area, (a² − r_w²)/a²). Accepted
// by the nested-mesh rule of oracle_compare.hpp. Also: where nothing wrinkles the relaxed model is
// the ordinary membrane; the relaxed tangent against finite differences of the residual; the hard
// forces (1e-6 N, 20 N) converge or fail with a status, never NaN.
#include "oracle_compare.hpp"
#include "tension_field.hpp"  // fem/src: the law itself (pure C++, compiled into this test)

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdio>
#include <random>

using namespace pvdf::fem::testing;
using pvdf::fem::detail::MembraneState;
using pvdf::fem::detail::relaxed_membrane;
namespace oracles = pvdf::fem::oracles;

namespace {

constexpr double a = 0.045, E = 2e9, nu = 0.3, c = 1e-3, h = 25e-6;

pvdf::fem::Options membrane_mesh(pvdf::fem::Model model, int level) {
  pvdf::fem::Options o;
  o.model = model;
  o.include_bending = false;
  o.adaptive = false;
  o.coarse_size_m = a / 3;
  o.probe_size_m = c;
  o.initial_global_refinements = level;
  return o;
}

/// r_w from the wrinkled area share (the hoop force vanishes on r_w < r < a).
double wrinkle_radius(double wrinkled_area_fraction) { return a * std::sqrt(std::max(0.0, 1 - wrinkled_area_fraction)); }

/// The axisymmetric tension-field oracle (von Kármán, 200 radial elements) of a centred-probe scene.
oracles::AxisymmetricSolution slack_oracle(const pvdf::Scene& s) {
  oracles::AxisymmetricProblem p = oracle_problem(s, false, oracles::Kinematics::von_karman);
  p.tension_field = true;
  return oracles::solve_axisymmetric(p, {200});
}

}  // namespace

TEST_CASE("tension field: slack film under a centred probe against the axisymmetric oracle",
          "[fem][oracle][tension-field]") {
  // N0 = −700 N/m: stress-free radius 45.45 mm (natural strain 1e-2); 1 N.
  const double n0 = -700, F = 1.0;
  pvdf::Scene s = centred_probe_scene(a, h, E, nu, F, c, n0);
  const auto oracle = slack_oracle(s);
  REQUIRE(oracle.converged);
  const auto zones = oracle.wrinkled_intervals_m();
  REQUIRE(zones.size() == 1);
  const double r_w = zones[0].first;
  const std::vector<double> radii{5e-3, 10e-3, 20e-3, 35e-3};
  pvdf::fem::Options coarse_o = membrane_mesh(pvdf::fem::Model::von_karman, 0), fine_o = coarse_o;
  ++fine_o.initial_global_refinements;
  double wf[2] = {0, 0};
  RaySamples rays[2];
  for (int i = 0; i < 2; ++i) {
    pvdf::fem::Options o = i == 0 ? coarse_o : fine_o;
    for (double r : radii) o.sample_points_m.push_back({r * std::cos(ray_angle_rad), r * std::sin(ray_angle_rad)});
    const auto res = pvdf::fem::solve(s, o);
    INFO(pvdf::fem::status_name(res.summary.status) << ": " << res.summary.message);
    REQUIRE(pvdf::fem::usable(res.summary.status));
    wf[i] = res.wrinkled_area_fraction;
    rays[i].centre_deflection_m = res.deflection_at_load_m;
    for (const auto& sm : res.samples) {
      rays[i].w_m.push_back(sm.w_m);
      rays[i].Nr_N_per_m.push_back(sm.membrane_force.polar[0]);
      rays[i].Nt_N_per_m.push_back(sm.membrane_force.polar[1]);
    }
    std::printf("TENSION-FIELD FEM level %d: %zu dofs, %.1f s, w(0) = %.4f mm, wrinkled %.4f, slack %.4f\n", i,
                res.summary.n_dofs, res.summary.wall_s, res.deflection_at_load_m * 1e3, res.wrinkled_area_fraction,
                res.slack_area_fraction);
  }
  std::printf("TENSION-FIELD oracle: w(0) = %.4f mm, r_w = %.3f mm; FEM r_w = %.3f / %.3f mm\n",
              oracle.centre_deflection_m() * 1e3, r_w * 1e3, wrinkle_radius(wf[0]) * 1e3, wrinkle_radius(wf[1]) * 1e3);
  check_converges_to("w(0)", rays[0].centre_deflection_m, rays[1].centre_deflection_m, oracle.centre_deflection_m());
  for (std::size_t i = 0; i < radii.size(); ++i) {
    INFO("r = " << radii[i]);
    check_converges_to("N_r", rays[0].Nr_N_per_m[i], rays[1].Nr_N_per_m[i], oracle.radial_force_N_per_m(radii[i]),
                       1e-3);
    check_converges_to("w", rays[0].w_m[i], rays[1].w_m[i], oracle.deflection_m(radii[i]), 1e-3);
  }
  // The hoop force vanishes beyond r_w: the wrinkled share of the area, compared as a radius. The
  // wrinkled/taut boundary is resolved to the cell containing it, so the floor is a cell size.
  check_converges_to("r_w", wrinkle_radius(wf[0]), wrinkle_radius(wf[1]), r_w, 0.02);
  // Samples in the wrinkled zone: hoop force zero (to round-off of the relaxed law), inside it positive.
  for (std::size_t i = 0; i < radii.size(); ++i) {
    INFO("r = " << radii[i] << " N_t = " << rays[1].Nt_N_per_m[i]);
    if (radii[i] > 1.1 * r_w) CHECK(std::abs(rays[1].Nt_N_per_m[i]) < 1e-6 * rays[1].Nr_N_per_m[i]);
    if (radii[i] < 0.9 * r_w) CHECK(rays[1].Nt_N_per_m[i] > 0);
  }
}

TEST_CASE("tension field: identical to the ordinary membrane where nothing wrinkles", "[fem][tension-field]") {
  // Pretension 10 N/m, 1 N: taut everywhere (the oracle says so too).
  pvdf::Scene s = centred_probe_scene(a, h, E, nu, 1.0, c, 10.0);
  pvdf::fem::Options o = membrane_mesh(pvdf::fem::Model::large_rotation, 0);
  o.sample_points_m = {{10e-3, 3e-3}, {-20e-3, 5e-3}};
  const auto plain = pvdf::fem::solve(s, o);
  s.membrane.tension_field = true;
  const auto relaxed = pvdf::fem::solve(s, o);
  REQUIRE(pvdf::fem::usable(plain.summary.status));
  REQUIRE(pvdf::fem::usable(relaxed.summary.status));
  CHECK(relaxed.wrinkled_area_fraction == 0.0);
  CHECK(relaxed.slack_area_fraction == 0.0);
  CHECK(relaxed.deflection_at_load_m == Approx(plain.deflection_at_load_m).epsilon(1e-8));
  for (std::size_t i = 0; i < 2; ++i)
    for (int k = 0; k < 3; ++k) {
      const double ref = plain.samples[i].membrane_force.global[k];
      CHECK(relaxed.samples[i].membrane_force.global[k] == Approx(ref).epsilon(1e-7).margin(1e-9));
    }
}

TEST_CASE("tension field: the relaxed law (stress = dW/de, exact tangent; isotropic = the oracle's law)",
          "[fem][tension-field]") {
  // An orthotropic, sheared stiffness (N/m) and the isotropic one of the oracle's film.
  const double Eh = E * h, A = Eh / (1 - nu * nu);
  const double iso[3][3] = {{A, A * nu, 0}, {A * nu, A, 0}, {0, 0, A * (1 - nu) / 2}};
  const double ortho[3][3] = {{6e4, 1.5e4, 3e3}, {1.5e4, 4e4, -2e3}, {3e3, -2e3, 1.5e4}};
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> uni(-1e-3, 1e-3);
  int n_state[3] = {0, 0, 0}, n_checked = 0, n_bad_tangent = 0;
  for (const auto* C : {iso, ortho}) {
    for (int t = 0; t < 3000; ++t) {
      const std::array<double, 3> e{uni(rng), uni(rng), uni(rng)};
      const auto L = relaxed_membrane(C, e, true);
      ++n_state[static_cast<int>(L.state)];
      const double d = 1e-10;
      bool same_state = true;
      double dW[3], dS[3][3];
      for (int j = 0; j < 3; ++j) {
        auto ep = e, em = e;
        ep[j] += d;
        em[j] -= d;
        const auto Lp = relaxed_membrane(C, ep, false), Lm = relaxed_membrane(C, em, false);
        same_state = same_state && Lp.state == L.state && Lm.state == L.state;
        dW[j] = (Lp.W - Lm.W) / (2 * d);
        for (int i = 0; i < 3; ++i) dS[i][j] = (Lp.S[i] - Lm.S[i]) / (2 * d);
      }
      if (!same_state) continue;  // a state boundary within ±d (W is C¹ there, not C²)
      ++n_checked;
      for (int j = 0; j < 3; ++j) CHECK(std::abs(dW[j] - L.S[j]) < 1e-6 * (1 + std::abs(L.S[j])));
      double worst = 0;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) worst = std::max(worst, std::abs(dS[i][j] - L.D[i][j]) / C[0][0]);
      if (worst > 1e-3) ++n_bad_tangent;
      // Wrinkled: uniaxial tension (one principal force zero, the other positive).
      if (L.state == MembraneState::wrinkled) {
        const double det = L.S[0] * L.S[1] - L.S[2] * L.S[2];
        CHECK(std::abs(det) < 1e-9 * (L.S[0] + L.S[1]) * (L.S[0] + L.S[1]));
        CHECK(L.S[0] + L.S[1] > 0);
      }
      // The isotropic law in principal strain axes against the oracle's four-state law.
      if (C == iso) {
        const double m = 0.5 * (e[0] + e[1]), r = std::hypot(0.5 * (e[0] - e[1]), 0.5 * e[2]);
        const auto O = oracles::detail::relaxed_law(m + r, m - r, nu);  // forces per E·h
        CHECK(L.W == Approx(O.W * Eh).epsilon(1e-9).margin(1e-15));
        const double s_max = 0.5 * (L.S[0] + L.S[1]) + std::hypot(0.5 * (L.S[0] - L.S[1]), L.S[2]);
        const double s_min = 0.5 * (L.S[0] + L.S[1]) - std::hypot(0.5 * (L.S[0] - L.S[1]), L.S[2]);
        CHECK(s_max == Approx(std::max(O.Nr, O.Nt) * Eh).epsilon(1e-8).margin(1e-9));
        CHECK(s_min == Approx(std::min(O.Nr, O.Nt) * Eh).epsilon(1e-8).margin(1e-9));
      }
    }
  }
  INFO("taut " << n_state[0] << ", wrinkled " << n_state[1] << ", slack " << n_state[2] << "; checked " << n_checked
               << ", tangent off by > 1e-3 C11: " << n_bad_tangent);
  CHECK(n_state[0] > 500);
  CHECK(n_state[1] > 500);
  CHECK(n_state[2] > 500);
  CHECK(n_bad_tangent <= n_checked / 1000);  // the θ-search's round-off near degenerate directions
}

TEST_CASE("tension field: assembled tangent against finite differences of the residual", "[fem][tension-field]") {
  // A pre-tensioned orthotropic film (seed-001 material) with the relaxed law in a
  // random smooth state. (In states with taut/wrinkled boundaries the residual has kinks, where a
  // finite difference is not a derivative: the law's test above covers those states pointwise.)
  pvdf::Scene s = pvdf::default_scene();
  s.membrane.pretension_N_per_m = 30;
  s.membrane.tension_field = true;
  pvdf::fem::Options o;
  o.model = pvdf::fem::Model::large_rotation;
  o.include_bending = false;
  const auto check = pvdf::fem::check_jacobian(s, o, 2e-3, 3, 7);
  CHECK(check.max_relative_difference < 1e-5);
}

TEST_CASE("tension field: a slack film at 1e-6 N and 20 N converges or fails with a status, never NaN",
          "[fem][tension-field][hard]") {
  for (double F : {1e-6, 20.0}) {
    pvdf::Scene s = centred_probe_scene(a, h, E, nu, F, c, -700);
    pvdf::fem::Options o = membrane_mesh(pvdf::fem::Model::large_rotation, 0);
    o.verbose = std::getenv("PVDF_TF_VERBOSE") != nullptr;
    const auto r = pvdf::fem::solve(s, o);
    INFO("F = " << F << ": " << pvdf::fem::status_name(r.summary.status) << " " << r.summary.message);
    std::printf("TENSION-FIELD hard case F = %g N: %s, w(0) = %.4f mm, wrinkled %.3f, %d load steps, %.1f s\n", F,
                pvdf::fem::status_name(r.summary.status).c_str(), r.deflection_at_load_m * 1e3,
                r.wrinkled_area_fraction, r.summary.load_steps, r.summary.wall_s);
    if (!pvdf::fem::usable(r.summary.status)) {
      CHECK_FALSE(r.summary.message.empty());
      continue;
    }
    CHECK(std::isfinite(r.deflection_at_load_m));
    CHECK(r.deflection_at_load_m > 0);
    if (F > 1) {
      // Against the oracle (same kinematics: Green–Lagrange).
      oracles::AxisymmetricProblem p = oracle_problem(s, false, oracles::Kinematics::green_lagrange);
      p.tension_field = true;
      const auto oracle = oracles::solve_axisymmetric(p, {200});
      REQUIRE(oracle.converged);
      std::printf("TENSION-FIELD hard case F = %g N: oracle w(0) = %.4f mm\n", F, oracle.centre_deflection_m() * 1e3);
      CHECK(r.deflection_at_load_m == Approx(oracle.centre_deflection_m()).epsilon(0.01));
    } else {
      // Vanishing force: the elastic strains vanish, and the slack film hangs as the inextensible cone
      // whose generators have the stress-free length (1 + s)(a − c) from the probe's edge to the rim:
      // w(0) → (a − c)·√((1 + s)² − 1), s = |N0|(1 − ν)/(E h).
      const double s_nat = 700 * (1 - nu) / (E * h);
      const double cone = (a - c) * std::sqrt((1 + s_nat) * (1 + s_nat) - 1);
      std::printf("TENSION-FIELD hard case F = %g N: inextensible cone w(0) = %.4f mm\n", F, cone * 1e3);
      CHECK(r.deflection_at_load_m == Approx(cone).epsilon(0.02));
    }
  }
}

TEST_CASE("tension field: residual stiffness and the pretension-stepping path against the oracle",
          "[fem][oracle][tension-field][residual-stiffness]") {
  // The slack film of the first test case (N0 = −700 N/m, 1 N, von Kármán): with the residual stiffness
  // ε the relaxed law keeps ε·C where wrinkled or slack, so the solve takes the pretension-stepping
  // path; its answers differ from the exact relaxed law by O(ε·|N0|/N): bounded here against the
  // oracle at ε = 1e-3 and 1e-4, and shrinking with ε.
  const double n0 = -700, F = 1.0;
  pvdf::Scene s = centred_probe_scene(a, h, E, nu, F, c, n0);
  const auto oracle = slack_oracle(s);
  REQUIRE(oracle.converged);
  const double w_oracle = oracle.centre_deflection_m(), r_sample = 10e-3;
  const double nr_oracle = oracle.radial_force_N_per_m(r_sample);
  double err_w[2] = {0, 0}, err_nr[2] = {0, 0};
  int k = 0;
  for (double eps : {1e-3, 1e-4}) {
    pvdf::fem::Options o = membrane_mesh(pvdf::fem::Model::von_karman, 1);
    o.tension_field_residual_stiffness = eps;
    o.sample_points_m = {{r_sample * std::cos(ray_angle_rad), r_sample * std::sin(ray_angle_rad)}};
    const auto r = pvdf::fem::solve(s, o);
    INFO("eps = " << eps << ": " << pvdf::fem::status_name(r.summary.status) << " " << r.summary.message);
    REQUIRE(r.summary.status == pvdf::fem::Status::converged);
    REQUIRE(std::isfinite(r.deflection_at_load_m));
    err_w[k] = r.deflection_at_load_m / w_oracle - 1;
    err_nr[k] = r.samples.at(0).membrane_force.polar[0] / nr_oracle - 1;
    std::printf("TENSION-FIELD eps = %g: w(0) = %.4f mm (oracle %.4f, %+.2e), N_r(10 mm) = %.4f N/m (oracle %.4f, "
                "%+.2e), N_t = %.3e N/m, %d load steps, %.1f s\n",
                eps, r.deflection_at_load_m * 1e3, w_oracle * 1e3, err_w[k], r.samples[0].membrane_force.polar[0],
                nr_oracle, err_nr[k], r.samples[0].membrane_force.polar[1], r.summary.load_steps, r.summary.wall_s);
    // The residual stress ε·C·e in the wrinkled zone: compressive hoop force of order ε·|N0|.
    CHECK(std::abs(r.samples[0].membrane_force.polar[1]) < 2 * eps * std::abs(n0));
    ++k;
  }
  // Bounded: the level-1 mesh alone is within 1e-4 (first test case); ε adds at most 1e-3 at ε = 1e-3.
  CHECK(std::abs(err_w[0]) < 1e-3);
  CHECK(std::abs(err_nr[0]) < 1e-2);
  // Vanishing: ε = 1e-4 is closer to the oracle than ε = 1e-3 (or both at the mesh's floor). The
  // floor of N_r on this mesh: 2.4e-3 at ε = 1e-4 (unchanged since the check was written). Since r21
  // ε = 1e-3 ends below it (−2.0e-4, was +7.0e-3): where the exact tangent is indefinite Newton takes
  // the convexified one (newton.cpp) and ends at a minimum of the ε-energy, no longer at a saddle.
  CHECK(std::abs(err_w[1]) < std::max(std::abs(err_w[0]), 2e-4));
  CHECK(std::abs(err_nr[1]) < std::max(std::abs(err_nr[0]), 2.5e-3));
}
