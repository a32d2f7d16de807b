// atlas_report_json (pvdf/mapping/atlas_report.hpp): the report of an atlas generation as JSON, for
// the command and the Python package alike.
#include "pvdf/mapping/atlas_report.hpp"

namespace pvdf::mapping {

nlohmann::json atlas_report_json(const AtlasReport& report, const ChargeAtlas& atlas, const std::string& output) {
  nlohmann::json j;
  j["output"] = output;
  j["n_positions"] = report.n_positions;
  j["n_points"] = report.n_points;
  j["n_solved_positions"] = report.n_solved_positions;
  j["n_resumed_positions"] = report.n_resumed_positions;
  j["mirror_x"] = report.mirror_x;
  j["mirror_y"] = report.mirror_y;
  j["n_failed"] = report.n_failed;
  j["n_tolerance_not_met"] = report.n_tolerance_not_met;
  j["estimated_relative_error"] = report.estimated_relative_error;
  j["model"] = atlas.model;
  j["model_reason"] = atlas.model_reason;
  j["tolerance"] = atlas.tolerance;
  j["n_dofs"] = atlas.n_dofs;
  j["fe_size_m"] = atlas.fe_size_m;
  j["keep_out_m"] = atlas.keep_out_m;
  j["n_rim_solves"] = report.n_rim_solves;
  j["cell_m"] = atlas.grid.cell_m;
  j["n_cells"] = atlas.n_cells();
  j["spacing_m"] = atlas.spacing_m;
  j["forces_N"] = atlas.forces_N;
  j["threads"] = report.threads;
  j["setup_s"] = report.setup_s;
  j["wall_s"] = report.wall_s;
  if (!report.first_failure.empty()) j["first_failure"] = report.first_failure;
  return j;
}

}  // namespace pvdf::mapping
