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

