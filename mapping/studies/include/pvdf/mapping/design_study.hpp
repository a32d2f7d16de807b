// The design study of `pvdfkit design` (docs/design.md) as library steps: its candidate layouts,
// their ranking, the winners to refine, and its JSON. The command reads the files, makes the maps
// (FEM, synthetic or read), draws the figures and prints; everything it decides is here.
#pragma once

#include "pvdf/mapping/design.hpp"
#include "pvdf/mapping/map.hpp"

#include <nlohmann/json.hpp>

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace pvdf::mapping {

/// One candidate layout of a design study and what its evaluation found.
struct DesignCandidate {
  std::string label;                    ///< shown in tables and plots
  std::string source;                   ///< scene or map file
  std::optional<nlohmann::json> scene;  ///< null for a ready map
  std::string sweep_key;                ///< the swept scene key (empty: no sweep)
  double sweep_value = 0;
  int series = 0;               ///< which scene of the study (sweep curves); -1 for a ready map
  std::string map_source;       ///< "fem" | "synthetic" | "file" | "atlas"
  std::string map_file;         ///< written or read map (empty for synthetic)
  ChargeMap map;
  DesignSummary summary;
  bool refined = false;
};

/// The candidates of one scene (its original JSON, read from `path`): the scene itself labelled
/// `name`, or with a sweep one per value, labelled "name KEY=VALUE" (set_scene_key's, which throws
/// InputError for a key the scene cannot take).
std::vector<DesignCandidate> scene_candidates(const nlohmann::json& scene, const std::string& path,
                                              const std::string& name, int series,
                                              const std::optional<SceneSweep>& sweep);

/// True when two layouts have the same synthetic stand-in (synthetic_model_for_scene: centres, draw
/// angle, charge scale, d32/d31, film radius), so a sweep between them scores the same synthetically.
bool same_synthetic_stand_in(const DesignCandidate& a, const DesignCandidate& b);

/// The candidates best first by rank_designs (stable: equal layouts keep their order).
std::vector<const DesignCandidate*> rank_candidates(const std::vector<DesignCandidate>& candidates);
/// The same rule over pointers (a subset of candidates): `candidates` best first.
std::vector<const DesignCandidate*> rank_candidates(const std::vector<const DesignCandidate*>& candidates);

/// The winners a refinement recomputes: the first `n` of `ranked` that have a scene (a ready map
/// cannot be refined).
std::vector<const DesignCandidate*> winners_to_refine(const std::vector<const DesignCandidate*>& ranked, int n);

/// A candidate as one entry of the study's `layouts` (or `refined`): design_summary_json plus its
/// rank (1 = best), label, source, map source and file, the swept key and value, and `refined`.
nlohmann::json design_candidate_json(const DesignCandidate& candidate, int rank);

/// What the study found, as `pvdfkit design --json` prints it (the command adds its memory keys).
struct DesignStudyReport {
  bool synthetic = false;    ///< any candidate evaluated on a synthetic stand-in
  double preview_spacing_m = 0;
  std::vector<const DesignCandidate*> ranked;          ///< the previews, best first
  std::vector<const DesignCandidate*> ranked_refined;  ///< the refined winners, best first (may be empty)
  std::optional<SceneSweep> sweep;
  std::vector<std::string> figures;                    ///< files written
  /// The best layout: the first refined winner, else the first preview.
  const DesignCandidate& best() const { return ranked_refined.empty() ? *ranked.front() : *ranked_refined.front(); }
};

/// The study as JSON: the analysis settings, `layouts` (and `refined`), `best`, `vary`, `figures`.
nlohmann::json design_study_json(const DesignOptions& options, const DesignStudyReport& report);

}  // namespace pvdf::mapping
