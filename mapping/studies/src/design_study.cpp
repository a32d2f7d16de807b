// The design study's candidates, maps and evaluation, ranking, winners and JSON
// (pvdf/mapping/design_study.hpp); moved from app/src/cmd_design.cpp so that the command only
// parses, reads, draws and prints.
#include "pvdf/mapping/design_study.hpp"

#include "pvdf/core/scene.hpp"

#include <cstdio>

namespace pvdf::mapping {

std::vector<DesignCandidate> scene_candidates(const nlohmann::json& scene, const std::string& path,
                                              const std::string& name, int series,
                                              const std::optional<SceneSweep>& sweep) {
  std::vector<DesignCandidate> out;
  if (!sweep) {
    DesignCandidate c;
    c.label = name;
    c.source = path;
    c.scene = scene;
    c.series = series;
    out.push_back(std::move(c));
    return out;
  }
  for (double v : sweep->values) {
    DesignCandidate c;
    char value[32];
    std::snprintf(value, sizeof value, "%.4g", v);
    c.label = name + " " + sweep->key + "=" + value;
    c.source = path;
    c.scene = set_scene_key(scene, sweep->key, v, path);
    c.sweep_key = sweep->key;
    c.sweep_value = v;
    c.series = series;
    out.push_back(std::move(c));
  }
  return out;
}

bool same_synthetic_stand_in(const DesignCandidate& a, const DesignCandidate& b) {
  const auto m0 = synthetic_model_for_scene(pvdf::parse_scene(*a.scene, a.source));
  const auto m1 = synthetic_model_for_scene(pvdf::parse_scene(*b.scene, b.source));
  return m0.centers_m == m1.centers_m && m0.draw_angle_rad == m1.draw_angle_rad && m0.scale_C == m1.scale_C &&
         m0.d32_over_d31 == m1.d32_over_d31 && m0.film_radius_m == m1.film_radius_m;
}

std::vector<const DesignCandidate*> rank_candidates(const std::vector<const DesignCandidate*>& candidates) {
  std::vector<DesignSummary> summaries;
  for (const DesignCandidate* c : candidates) summaries.push_back(c->summary);
  std::vector<const DesignCandidate*> ranked;
  for (std::size_t i : rank_designs(summaries)) ranked.push_back(candidates[i]);
  return ranked;
}

std::vector<const DesignCandidate*> rank_candidates(const std::vector<DesignCandidate>& candidates) {
  std::vector<const DesignCandidate*> all;
  for (const auto& c : candidates) all.push_back(&c);
  return rank_candidates(all);
}

std::vector<const DesignCandidate*> winners_to_refine(const std::vector<const DesignCandidate*>& ranked, int n) {
  std::vector<const DesignCandidate*> out;
  for (const DesignCandidate* c : ranked) {
    if (int(out.size()) >= n) break;
    if (c->scene) out.push_back(c);
  }
  return out;
}

DesignCandidate ready_map_candidate(const std::string& path, const std::string& label, ChargeMap map) {
  DesignCandidate c;
  c.label = label;
  c.source = path;
  c.map_source = "file";
  c.map_file = path;
  c.map = std::move(map);
  c.series = -1;
  return c;
}

void evaluate_candidate(DesignCandidate& c, const DesignOptions& options) {
  c.summary = evaluate_design(c.map, options);
  if (c.map_source == "synthetic") c.summary.synthetic = true;
}

const DesignCandidate* best_in_series(const std::vector<DesignCandidate>& candidates, int series) {
  const DesignCandidate* best = nullptr;
  for (const auto& c : candidates) {
    if (c.series != series || c.refined) continue;
    if (!best || ranks_before(c.summary, best->summary)) best = &c;
  }
  return best;
}

DesignMapSource synthetic_design_maps(double force_N) {
  DesignMapSource maps;
  maps.make_map = [force_N](DesignCandidate& c, double spacing_m, std::size_t) {
    c.map = synthetic_map_for_scene(pvdf::parse_scene(*c.scene, c.source), spacing_m, force_N, 5e-14);
    c.map_source = "synthetic";
  };
  return maps;
}

void map_and_evaluate(const std::string& phase, const std::vector<DesignCandidate*>& candidates, double spacing_m,
                      const DesignMapSource& maps, const DesignOptions& options) {
  std::vector<const DesignCandidate*> with_scene;
  for (const DesignCandidate* c : candidates) {
    if (c->scene) with_scene.push_back(c);
  }
  if (maps.begin_phase) maps.begin_phase(phase, with_scene, spacing_m);
  std::size_t index = 0;
  for (DesignCandidate* c : candidates) {
    if (c->scene) maps.make_map(*c, spacing_m, index++);
    evaluate_candidate(*c, options);
  }
  if (maps.end_phase) maps.end_phase();
}

bool DesignStudy::any_can_locate() const {
  for (const auto& c : candidates) {
    if (c.summary.status == DesignStatus::ok) return true;
  }
  return false;
}

DesignStudy run_design_study(std::vector<DesignCandidate> candidates, const DesignStudyOptions& options,
                             const DesignMapSource& maps) {
  DesignStudy study;
  study.candidates = std::move(candidates);
  // Step 1: the previews, evaluated and ranked.
  std::vector<DesignCandidate*> previews;
  for (auto& c : study.candidates) previews.push_back(&c);
  map_and_evaluate("preview", previews, options.spacing_m, maps, options.analysis);
  study.report.ranked = rank_candidates(study.candidates);

  // Step 2: the winners at a finer spacing, ranked again. `refined` is sized first: the report
  // points into it.
  if (options.refine_best > 0) {
    const double fine = options.refine_spacing_m > 0 ? options.refine_spacing_m : options.spacing_m / 2;
    for (const DesignCandidate* c : winners_to_refine(study.report.ranked, options.refine_best)) {
      study.refined.push_back(*c);
      study.refined.back().refined = true;
    }
    std::vector<DesignCandidate*> to_refine;
    for (auto& r : study.refined) to_refine.push_back(&r);
    map_and_evaluate("refined", to_refine, fine, maps, options.analysis);
  }
  study.report.ranked_refined = rank_candidates(study.refined);

  for (const auto& c : study.candidates) study.report.synthetic |= c.summary.synthetic;
  study.report.preview_spacing_m = options.spacing_m;
  return study;
}

nlohmann::json design_candidate_json(const DesignCandidate& c, int rank) {
  nlohmann::json j = design_summary_json(c.summary);
  j["rank"] = rank;
  j["label"] = c.label;
  j["source"] = c.source;
  j["map_source"] = c.map_source;
  if (!c.map_file.empty()) j["map_file"] = c.map_file;
  if (!c.sweep_key.empty()) {
    j["vary_key"] = c.sweep_key;
    j["vary_value"] = c.sweep_value;
  }
  j["refined"] = c.refined;
  return j;
}

nlohmann::json design_study_json(const DesignOptions& d, const DesignStudyReport& r) {
  nlohmann::json j;
  j["synthetic"] = r.synthetic;
  j["noise_C"] = d.noise_C;
  j["target_m"] = d.target_m;
  j["force_N"] = d.force_N;
  j["force_range_N"] = {d.min_force_N, d.max_force_N};
  j["force_known"] = d.force_known;
  j["adc_bits"] = d.adc_bits;
  j["preview_spacing_m"] = r.preview_spacing_m;
  j["layouts"] = nlohmann::json::array();
  for (std::size_t i = 0; i < r.ranked.size(); ++i) j["layouts"].push_back(design_candidate_json(*r.ranked[i], int(i) + 1));
  if (!r.ranked_refined.empty()) {
    j["refined"] = nlohmann::json::array();
    for (std::size_t i = 0; i < r.ranked_refined.size(); ++i) {
      j["refined"].push_back(design_candidate_json(*r.ranked_refined[i], int(i) + 1));
    }
  }
  j["best"] = r.best().label;
  if (r.sweep) j["vary"] = {{"key", r.sweep->key}, {"values", r.sweep->values}};
  j["figures"] = r.figures;
  return j;
}

}  // namespace pvdf::mapping
