// The design study of `pvdfkit design` (docs/design.md) as library steps: its candidate layouts,
// their maps and evaluation, their ranking, the winners to refine, and its JSON (run_design_study
// does them in order). The command reads the files, chooses the map source (FEM maps:
// design_fem_maps.hpp), draws the figures and prints; everything it decides is here.
#pragma once

#include "pvdf/mapping/design.hpp"
#include "pvdf/mapping/map.hpp"

#include <nlohmann/json.hpp>

#include <cstddef>
#include <cstdint>
#include <functional>
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

/// A ready map (read from `path`) as a candidate labelled `label`: map source "file", series -1.
DesignCandidate ready_map_candidate(const std::string& path, const std::string& label, ChargeMap map);

/// The candidate's DesignSummary from its map (evaluate_design), marked synthetic when its map is
/// the synthetic stand-in.
void evaluate_candidate(DesignCandidate& candidate, const DesignOptions& options);

/// The best of the unrefined candidates of sweep series `series` by ranks_before (the first of
/// equals), or null when the series has none.
const DesignCandidate* best_in_series(const std::vector<DesignCandidate>& candidates, int series);

/// Where a study's maps come from. A phase ("preview", "refined", "verify") makes the maps of its
/// candidates in order: begin_phase (optional) sees them all first (e.g. for a progress total),
/// make_map sets one candidate's `map`, `map_source` and (for a written map) `map_file`, and
/// end_phase (optional) closes the phase. synthetic_design_maps here; FEM maps in design_fem_maps.hpp.
struct DesignMapSource {
  std::function<void(const std::string& phase, const std::vector<const DesignCandidate*>& candidates, double spacing_m)>
      begin_phase;
  /// Map number `index` (0-based) of the phase, at grid spacing `spacing_m` (m).
  std::function<void(DesignCandidate& candidate, double spacing_m, std::size_t index)> make_map;
  std::function<void()> end_phase;
};

/// The synthetic stand-in (synthetic_map_for_scene at one force level `force_N`, noise 0.05 pC) as
/// a study's map source: instant, labelled "synthetic".
DesignMapSource synthetic_design_maps(double force_N);

/// One phase of maps: each candidate with a scene gets its map from `maps` at `spacing_m`, and
/// every candidate (a ready map too) is evaluated, in order.
void map_and_evaluate(const std::string& phase, const std::vector<DesignCandidate*>& candidates, double spacing_m,
                      const DesignMapSource& maps, const DesignOptions& options);

/// The process's resident memory after each block of map positions (design.json's `memory`).
struct MemorySample {
  std::string phase;
  std::size_t positions = 0;  ///< positions solved in the phase so far
  std::uint64_t resident_bytes = 0;
};

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

/// The settings of a design study (run_design_study).
struct DesignStudyOptions {
  DesignOptions analysis;        ///< how each layout is evaluated
  double spacing_m = 0.001;      ///< grid spacing of the preview maps (m), > 0
  int refine_best = 0;           ///< the best this many layouts with a scene get a finer map and are ranked again
  double refine_spacing_m = 0;   ///< grid spacing of the refined maps (m); 0: half spacing_m
};

/// A design study's candidates and what it found. `report` points into `candidates` and `refined`,
/// so the study moves but is not copied.
struct DesignStudy {
  std::vector<DesignCandidate> candidates;  ///< the previews, in the order given
  std::vector<DesignCandidate> refined;     ///< the refined winners, in the order refined
  DesignStudyReport report;                 ///< rankings, `synthetic`, `preview_spacing_m` (the caller adds sweep, figures)
  /// True when some preview can locate a press (DesignStatus::ok); false means every layout is singular.
  bool any_can_locate() const;

  DesignStudy() = default;
  DesignStudy(DesignStudy&&) = default;
  DesignStudy& operator=(DesignStudy&&) = default;
  DesignStudy(const DesignStudy&) = delete;
  DesignStudy& operator=(const DesignStudy&) = delete;
};

/// The design study (docs/design.md): each candidate's preview map (map_and_evaluate, phase
/// "preview"), its evaluation and the ranking; then the first `refine_best` ranked layouts with a
/// scene recomputed at `refine_spacing_m` (phase "refined") and ranked again. Ready maps are
/// evaluated as given. Throws what `maps` throws (InputError for a map it cannot make).
DesignStudy run_design_study(std::vector<DesignCandidate> candidates, const DesignStudyOptions& options,
                             const DesignMapSource& maps);

/// The study as JSON: the analysis settings, `layouts` (and `refined`), `best`, `vary`, `figures`.
nlohmann::json design_study_json(const DesignOptions& options, const DesignStudyReport& report);

}  // namespace pvdf::mapping
