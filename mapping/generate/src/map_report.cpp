// map_report_json (pvdf/mapping/map_report.hpp): the report of a map generation as JSON, for the
// command and the Python package alike.
#include "pvdf/mapping/map_report.hpp"

#include <cmath>
#include <string>

namespace pvdf::mapping {

nlohmann::json map_report_json(const MapReport& report, const ChargeMap& map) {
  nlohmann::json j;
  j["n_positions"] = report.n_positions;
  j["n_points"] = report.n_points;
  j["n_solved"] = report.n_solved;
  j["n_scaled"] = report.n_scaled;
  j["n_mirrored"] = report.n_mirrored;
  j["n_resumed"] = report.n_resumed;
  j["n_failed"] = report.n_failed;
  j["n_scaling_checks"] = report.n_scaling_checks;
  j["n_scaling_checks_failed"] = report.n_scaling_checks_failed;
  j["max_scaling_check_error"] = report.max_scaling_check_error;
  j["mirror_x"] = report.mirror_x;
  j["mirror_y"] = report.mirror_y;
  j["symmetry_reason"] = report.symmetry_reason;
  j["model"] = report.model;
  j["model_reason"] = report.model_reason;
  j["tolerance"] = map.tolerance;
  j["estimated_relative_error"] = report.estimated_relative_error;
  // Unknown (NaN) is written as null, never as a number.
  const double w_error = map.estimated_deflection_relative_error;
  j["estimated_deflection_relative_error"] = std::isfinite(w_error) ? nlohmann::json(w_error) : nlohmann::json(nullptr);
  j["n_tolerance_not_met"] = report.n_tolerance_not_met;
  j["n_rim_model"] = report.n_rim_model;
  j["rim_solves"] = report.rim_solves;
  j["rim_s"] = report.rim_s;
  j["n_clamp_layer"] = report.n_clamp_layer;
  j["clamp_layer_solves"] = report.clamp_layer_solves;
  j["clamp_layer_s"] = report.clamp_layer_s;
  j["clamp_layer_condition"] = report.clamp_layer_condition;
  j["estimate_s"] = report.estimate_s;
  j["probe_size_m"] = report.probe_size_m;
  j["probe_mesh_s"] = report.probe_mesh_s;
  j["probe_mesh_dofs"] = report.probe_mesh_dofs;
  j["n_direct"] = report.n_direct;
  j["direct_solves"] = report.direct_solves;
  j["direct_s"] = report.direct_s;
  j["rim_n_dofs"] = report.rim_n_dofs;
  j["n_dofs"] = report.n_dofs;
  j["ranks"] = report.ranks;
  j["threads"] = report.threads;
  j["placement"] = report.placement;
  if (report.placement == "adaptive") {
    nlohmann::json levels = nlohmann::json::array();
    for (std::size_t l = 0; l < report.level_solves.size(); ++l) {
      levels.push_back({{"spacing_m", report.level_spacing_m[l]}, {"positions", report.level_positions[l]},
                        {"solves", report.level_solves[l]}});
    }
    j["levels"] = levels;
    j["n_interpolated"] = report.n_interpolated;
    j["placement_s"] = report.placement_s;
  }
  const double total_error = map.estimated_total_relative_error;
  j["estimated_total_relative_error"] = std::isfinite(total_error) ? nlohmann::json(total_error) : nlohmann::json(nullptr);
  const auto number_or_null = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  j["lookup_total_relative_error"] = number_or_null(report.lookup_total_relative_error.max);
  j["lookup_total_relative_error_median"] = number_or_null(report.lookup_total_relative_error.median);
  j["lookup_total_relative_error_p90"] = number_or_null(report.lookup_total_relative_error.p90);
  j["solve_cpu_s"] = report.solve_cpu_s;
  const std::size_t solves = report.n_solved;  // FEM solves of this run (resumed points are not counted)
  j["cpu_s_per_solve"] = solves > 0 ? nlohmann::json(report.solve_cpu_s / double(solves)) : nlohmann::json(nullptr);
  j["estimate_share"] = report.solve_cpu_s > 0 ? nlohmann::json(report.estimate_s / report.solve_cpu_s) : nlohmann::json(nullptr);
  j["wall_s"] = report.wall_s;
  j["per_position_s"] = report.per_position_s;
  j["nx"] = map.nx();
  j["ny"] = map.ny();
  j["forces_N"] = map.forces_N;
  j["rim_margin_m"] = map.rim_margin_m;
  j["checkpoint_hash"] = report.checkpoint_hash;
  if (!report.first_failure.empty()) j["first_failure"] = report.first_failure;
  return j;
}

}  // namespace pvdf::mapping
