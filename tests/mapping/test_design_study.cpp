// The study steps that moved out of the command (docs/structure.md "app/ parses, prints and writes
// files"): the design study's run (which maps, at which spacing, refined in rank order), its
// ranking, winners to refine and JSON, the rule for presses a map's spacing cannot resolve, and the
// force level a picture shows. Oracles: summaries and maps built by hand, a recording map source.
#include "pvdf/core/error.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/mapping/map_io.hpp"
#include "pvdf/mapping/analysis.hpp"
#include "pvdf/mapping/design_study.hpp"
#include "pvdf/mapping/pictures.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <set>

using namespace pvdf::mapping;

namespace {

DesignCandidate candidate(const std::string& label, double usable, bool with_scene) {
  DesignCandidate c;
  c.label = label;
  c.source = label + (with_scene ? ".json" : ".h5");
  if (with_scene) c.scene = nlohmann::json::object();
  c.map_source = with_scene ? "synthetic" : "file";
  if (!with_scene) c.map_file = c.source;
  c.summary.usable_fraction = usable;
  return c;
}

}  // namespace

TEST_CASE("rank_candidates is rank_designs over candidates; winners_to_refine skips ready maps", "[design_study]") {
  const std::vector<DesignCandidate> all = {candidate("a", 0.2, true), candidate("b", 0.5, false),
                                            candidate("c", 0.4, true), candidate("d", 0.4, true)};
  const auto ranked = rank_candidates(all);
  REQUIRE(ranked.size() == 4);
  CHECK(ranked[0]->label == "b");
  CHECK(ranked[1]->label == "c");  // equal to d: the order given
  CHECK(ranked[2]->label == "d");
  CHECK(ranked[3]->label == "a");
  const auto subset = rank_candidates(std::vector<const DesignCandidate*>{&all[3], &all[2]});
  CHECK(subset[0]->label == "d");  // stable: equal layouts keep the order given
  const auto winners = winners_to_refine(ranked, 2);
  REQUIRE(winners.size() == 2);
  CHECK(winners[0]->label == "c");  // b is a ready map: not refined
  CHECK(winners[1]->label == "d");
  CHECK(winners_to_refine(ranked, 0).empty());
  CHECK(winners_to_refine(ranked, 10).size() == 3);
}

TEST_CASE("design_study_json holds the settings, every layout with its rank and the best", "[design_study]") {
  std::vector<DesignCandidate> all = {candidate("a", 0.2, true), candidate("b", 0.5, false)};
  DesignOptions d;
  d.noise_C = {5e-14};
  DesignStudyReport r;
  r.preview_spacing_m = 0.003;
  r.ranked = rank_candidates(all);
  nlohmann::json j = design_study_json(d, r);
  const std::set<std::string> keys = {"synthetic", "noise_C", "target_m", "force_N", "force_range_N", "force_known",
                                      "adc_bits", "preview_spacing_m", "layouts", "best", "figures"};
  std::set<std::string> got;
  for (const auto& item : j.items()) got.insert(item.key());
  CHECK(got == keys);
  CHECK(j["best"] == "b");
  REQUIRE(j["layouts"].size() == 2);
  CHECK(j["layouts"][0]["rank"] == 1);
  CHECK(j["layouts"][0]["map_file"] == "b.h5");
  CHECK(j["layouts"][1]["label"] == "a");
  CHECK_FALSE(j["layouts"][1].contains("map_file"));  // no file for a synthetic map
  CHECK(j["layouts"][1]["refined"] == false);

  // With refined winners: `refined` appears and the best is the first of them.
  DesignCandidate fine = all[0];
  fine.refined = true;
  fine.summary.usable_fraction = 0.9;
  std::vector<DesignCandidate> refined = {fine};
  r.ranked_refined = rank_candidates(refined);
  r.sweep = SceneSweep{"membrane.pretension_N_per_m", {0, 5}};
  j = design_study_json(d, r);
  CHECK(j["best"] == "a");
  REQUIRE(j["refined"].size() == 1);
  CHECK(j["refined"][0]["refined"] == true);
  CHECK(j["vary"]["key"] == "membrane.pretension_N_per_m");
}

TEST_CASE("presses_map_cannot_resolve: closer than twice the spacing to an electrode centre", "[design_study]") {
  ChargeMap map;
  map.x_m = {-0.002, -0.001, 0.0, 0.001, 0.002};
  map.y_m = {-0.004, -0.002, 0.0, 0.002, 0.004};  // h = 2 mm, the larger step
  map.electrode_names = {"A", "B"};
  map.electrode_centers_m = {{0.0, 0.0}, {0.010, 0.0}};
  std::vector<MeasuredPress> presses(3);
  presses[0].x_m = 0.0039;  // 3.9 mm from A: within 2h = 4 mm
  presses[0].line = 7;
  presses[1].x_m = 0.005;  // 5 mm from both: resolved
  presses[1].line = 8;
  presses[2].x_m = 0.0085;  // 1.5 mm from B
  presses[2].line = 9;
  const auto u = presses_map_cannot_resolve(map, presses);
  REQUIRE(u.size() == 2);
  CHECK(u[0].line == 7);
  CHECK(u[0].electrode == 0);
  CHECK(u[0].distance_m == Approx(0.0039));
  CHECK(u[0].spacing_m == Approx(0.002));
  CHECK(u[1].line == 9);
  CHECK(u[1].electrode == 1);
  map.x_m = {0.0};  // under 2 x 2 nodes: no spacing, no warning
  CHECK(presses_map_cannot_resolve(map, presses).empty());
}

TEST_CASE("picture_force_N: the level asked for, else the one nearest 1 N in ratio", "[design_study]") {
  ChargeMap map;
  map.forces_N = {0.25, 0.5, 2.0, 4.0};
  CHECK(picture_force_N(map, 3.0) == 3.0);
  CHECK(picture_force_N(map, 0) == 0.5);  // 0.5 and 2 tie in ratio: the first
  map.forces_N = {0.25, 1.5, 4.0};
  CHECK(picture_force_N(map, 0) == 1.5);
  map.forces_N = {8.0};
  CHECK(picture_force_N(map, -1) == 8.0);
}

TEST_CASE("comparison_summary_json: the keys compare MAP and compare SCENE share", "[design_study]") {
  Comparison c;
  ComparedPress p;
  p.measured.charge_C = {1.1e-12, 2.0e-12};
  p.map_charge_C = {1.0e-12, 2.0e-12};
  p.difference_pct = {10.0, std::numeric_limits<double>::quiet_NaN()};  // the second below the floor
  c.presses = {p};
  summarize_comparison(c, {"A", "B"});
  c.n_presses = 1;
  const nlohmann::json j = comparison_summary_json(c);
  CHECK(j["n_presses"] == 1);
  CHECK(j["n_compared_values"] == 1);
  CHECK(j["mean_abs_difference_pct"].get<double>() == Approx(10.0));
  CHECK(j["paper_mean_difference_pct"].get<double>() == paper_mean_difference_pct);
  REQUIRE(j["electrodes"].size() == 2);
  CHECK(j["electrodes"][0]["name"] == "A");
  CHECK(j["electrodes"][0]["n_compared"] == 1);
  CHECK(j["electrodes"][1]["n_compared"] == 0);
  CHECK(j.size() == 6);
}

TEST_CASE("run_design_study: previews from the map source, ready maps as given, the winners refined", "[design_study]") {
  const std::string scenes = std::string(PVDF_SOURCE_DIR) + "/examples/scenes/";
  std::vector<DesignCandidate> all;
  for (const char* name : {"seed001", "four-electrodes-45deg"}) {
    const std::string path = scenes + name + ".json";
    for (auto& c : scene_candidates(pvdf::load_scene(path).original, path, name, int(all.size()), std::nullopt)) {
      all.push_back(std::move(c));
    }
  }
  const std::string map_path = std::string(PVDF_SOURCE_DIR) + "/tests/mapping/data/seed001_4mm.h5";
  all.push_back(ready_map_candidate(map_path, "ready", read_map(map_path)));

  // The synthetic source, with each call recorded: the study decides which maps, at which spacing.
  const DesignMapSource synthetic = synthetic_design_maps(1.0);
  std::vector<std::string> calls;
  DesignMapSource maps;
  maps.begin_phase = [&calls](const std::string& phase, const std::vector<const DesignCandidate*>& c, double) {
    calls.push_back("begin " + phase + " " + std::to_string(c.size()));
  };
  maps.make_map = [&](DesignCandidate& c, double spacing_m, std::size_t index) {
    calls.push_back(c.label + " " + std::to_string(index) + " " + std::to_string(int(std::lround(spacing_m * 1e4))));
    synthetic.make_map(c, spacing_m, index);
  };
  DesignStudyOptions options;
  options.spacing_m = 0.002;
  options.refine_best = 2;
  const DesignStudy study = run_design_study(std::move(all), options, maps);

  REQUIRE(study.candidates.size() == 3);
  CHECK(study.candidates[2].map_source == "file");  // a ready map is evaluated as read, never remade
  REQUIRE(study.report.ranked.size() == 3);
  const auto ranked = rank_candidates(study.candidates);
  for (std::size_t i = 0; i < ranked.size(); ++i) CHECK(study.report.ranked[i] == ranked[i]);
  // The two best layouts with a scene, refined at half the spacing, in rank order.
  const auto winners = winners_to_refine(study.report.ranked, 2);
  REQUIRE(study.refined.size() == 2);
  const std::vector<std::string> expected = {"begin preview 2",
                                             "seed001 0 20",
                                             "four-electrodes-45deg 1 20",
                                             "begin refined 2",
                                             winners[0]->label + " 0 10",
                                             winners[1]->label + " 1 10"};
  CHECK(calls == expected);
  for (const auto& r : study.refined) {
    CHECK(r.refined);
    CHECK(r.summary.spacing_m == Approx(0.001));
    CHECK(r.summary.synthetic);
  }
  CHECK(study.report.ranked_refined.size() == 2);
  CHECK(&study.report.best() == study.report.ranked_refined.front());
  CHECK(study.report.synthetic);
  CHECK(study.report.preview_spacing_m == 0.002);
  CHECK(study.any_can_locate());
  // best_in_series: the series' best unrefined candidate by ranks_before.
  CHECK(best_in_series(study.candidates, 0) == &study.candidates[0]);
  CHECK(best_in_series(study.candidates, 5) == nullptr);
}
