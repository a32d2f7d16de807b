// `pvdfkit solve --model auto` near the clamped rim of the seed-001 film. Near the rim bending
// changes the charges by percents (2.2 % at (28, 28) mm with bending against without, docs/fem.md);
// the a-priori rule, calibrated on a centred probe, drops bending there. The adjoint-weighted
// estimate of bending's effect must see it: `auto` keeps bending, and the JSON says why with the
// numbers; the clamp's layer is then a boundary condition (docs/fem.md §3.4: no rim graded to the
// 0.2 mm layer, JSON "clamp_layer") and the answer is within the tolerance of a converged
// rim-graded reference solved on a mesh built another way (tests/fem/data/auto_rim_reference.json,
// with the command that made it), with an estimate within [0.5, 3] of that difference.
#include "../app/cli_runner.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <fstream>
#include <cmath>
#include <cstdio>
#include <string>

using pvdf::test::run_pvdfkit;

namespace {

nlohmann::json solve_json(const std::string& args) {
  const auto r = run_pvdfkit("solve " + std::string(PVDF_SOURCE_DIR) + "/examples/scenes/seed001.json --json " + args);
  INFO(args << "\n" << r.err);
  REQUIRE(r.exit_code == 0);
  return nlohmann::json::parse(r.out);
}

}  // namespace

TEST_CASE("solve --model auto near the rim of seed 001 keeps bending by its estimated effect", "[fem][cli][rim][slow]") {
  std::ifstream in(PVDF_AUTO_RIM_REFERENCE);
  REQUIRE(in.good());
  const nlohmann::json reference = nlohmann::json::parse(in);
  REQUIRE(reference.at("probes").size() == 2);
  for (const auto& probe : reference.at("probes")) {
    char load[96];
    std::snprintf(load, sizeof load, "%.6g,%.6g,%.6g", probe.at("x_m").get<double>(), probe.at("y_m").get<double>(),
                  probe.at("force_N").get<double>());
    const auto aut = solve_json(std::string("--load ") + load + " --model auto");
    REQUIRE(aut.at("status") == "converged");
    for (const char* key : {"estimated_discretization_error", "estimated_model_error", "estimated_relative_error",
                            "error_estimator", "model_reason"}) {
      INFO(key);
      REQUIRE(aut.contains(key));
    }
    const double disc = aut.at("estimated_discretization_error").get<double>();
    const double model = aut.at("estimated_model_error").get<double>();
    CHECK(aut.at("estimated_relative_error").get<double>() == Approx(disc + model).epsilon(1e-12));
    const std::string reason = aut.at("model_reason").get<std::string>();
    INFO(load << ": model_reason " << reason);
    CHECK_THAT(reason, Catch::Contains("bending kept: adjoint-weighted estimate of its effect"));
    CHECK_THAT(aut.at("error_estimator").get<std::string>(), Catch::Contains("dual-weighted residual"));
    for (const auto& e : aut.at("electrodes")) {
      CHECK(e.contains("charge_error_C"));
      CHECK(e.at("charge_error_C").get<double>() > 0);
    }
    // Accuracy: every charge within the tolerance of the reference (relative to the largest), and
    // the difference within what the estimate allows (3x, the effectivity band's upper end, plus
    // the reference's own 0.1 %).
    const auto& q_ref = probe.at("charge_C");
    REQUIRE(aut.at("electrodes").size() == q_ref.size());
    double scale = 0, diff = 0;
    for (std::size_t k = 0; k < q_ref.size(); ++k) {
      scale = std::max(scale, std::abs(q_ref[k].get<double>()));
      diff = std::max(diff, std::abs(aut.at("electrodes")[k].at("charge_C").get<double>() - q_ref[k].get<double>()));
    }
    const double tolerance = 0.01;  // the scene's
    INFO(load << ": charges " << diff / scale << " off the reference, estimate " << disc + model);
    CHECK(diff / scale <= tolerance);
    CHECK(diff / scale <= 3 * (disc + model) + 1e-3);
    const auto& clamp = aut.at("clamp_layer");
    CHECK(clamp.at("treatment") == "boundary-condition");
    CHECK(aut.at("n_dofs").get<std::size_t>() < 40000);  // no rim graded to l_b (126 k DOFs that way)
    const double clamp_estimate = clamp.at("estimated_error").get<double>();
    CHECK(clamp_estimate / (diff / scale) >= 0.5);  // NaN fails both
    CHECK(clamp_estimate / (diff / scale) <= 3.0);
    std::printf("RIM %s: clamp layer %s, correction %.3e, estimate %.3e (estimate / difference %.2f), l_b %.3f mm, "
                "%d passes\n",
                load, clamp.at("treatment").get<std::string>().c_str(), clamp.at("correction").get<double>(),
                clamp_estimate, clamp_estimate / (diff / scale), clamp.at("width_m").get<double>() * 1e3,
                clamp.at("passes").get<int>());
    std::printf("RIM %s: %.3f %% off the converged reference\n", load, 100 * diff / scale);
    std::printf("RIM %s: auto %s, %zu dofs, %.1f s, estimate %.2e (discretization %.2e + model %.2e)\n  model_reason: %s\n",
                load, aut.at("model").get<std::string>().c_str(), aut.at("n_dofs").get<std::size_t>(),
                aut.at("wall_s").get<double>(), disc + model, disc, model, reason.c_str());
  }
}

// A refinement cycle whose warm re-solve fails falls back to a solve from the flat film. Until r18
// that fallback left the clamp-layer condition's held rim values behind (a new mesh has none), so
// the answer was the plain clamp's under the condition's name and estimate: at (−35.97, 18.98) mm
// on seed 001, 1 N, 2.6 % off while stating 0.61 %. Now the passes run again, and where they fail
// the solve takes the reference path (rim graded). Reference: the whole-film audit's bending-kept
// solve there (bench/mapping/data/seed001_whole_film_refs.json: `solve --tolerance 0.002 --model
// large-rotation`, rim graded, its own estimate 0.16 %; pvdfkit's own rim-graded path at a 5× tighter
// tolerance, so this test holds the fallback's honesty, not the plate model's accuracy, which the
// CalculiX references of test_fem_ccx_clamp hold). ~50 CPU-s, 1.7 GB.
TEST_CASE("solve near the clamp: a failed re-solve after refinement is not returned as the condition's answer",
          "[fem][cli][rim][slow]") {
  std::ifstream in(PVDF_WHOLE_FILM_REFERENCES);
  REQUIRE(in.good());
  const nlohmann::json refs = nlohmann::json::parse(in);
  const char* key = "-0.035971703313195165,0.018983313460726205,1.0,0.002,large-rotation";
  REQUIRE(refs.contains(key));
  const auto& q_ref = refs.at(key).at("charge_C");
  const auto aut = solve_json("--load -0.035971703313195165,0.018983313460726205,1");
  REQUIRE(aut.at("status") == "converged");
  REQUIRE(aut.at("electrodes").size() == q_ref.size());
  double scale = 0, diff = 0;
  for (std::size_t k = 0; k < q_ref.size(); ++k) {
    scale = std::max(scale, std::abs(q_ref[k].get<double>()));
    diff = std::max(diff, std::abs(aut.at("electrodes")[k].at("charge_C").get<double>() - q_ref[k].get<double>()));
  }
  const double stated = aut.at("estimated_relative_error").get<double>();
  INFO("charges " << diff / scale << " off the reference, stated " << stated << ", clamp layer "
                  << aut.at("clamp_layer").dump() << "\nmodel_reason: " << aut.at("model_reason").get<std::string>());
  CHECK(diff / scale <= 0.01);               // the scene's tolerance
  CHECK(stated / (diff / scale) >= 0.5);     // NaN fails
  CHECK(stated <= 0.01);
  std::printf("EDGE (-35.97, 18.98) mm: %.3f %% off the audit reference, stated %.3f %%, clamp layer %s, %zu dofs\n",
              100 * diff / scale, 100 * stated, aut.at("clamp_layer").at("treatment").get<std::string>().c_str(),
              aut.at("n_dofs").get<std::size_t>());
}
