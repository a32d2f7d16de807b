// The JSON form of a solve's result (pvdf/fem/result_json.hpp).
#include "pvdf/fem/result_json.hpp"

namespace pvdf::fem {
namespace {

nlohmann::json triple(const std::array<double, 3>& a) { return nlohmann::json::array({a[0], a[1], a[2]}); }

nlohmann::json electrodes_json(const std::vector<ElectrodeResult>& electrodes) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& e : electrodes) {
    out.push_back({{"name", e.name},
                   {"area_m2", e.area_m2},
                   {"mean_membrane_force_material_N_per_m", triple(e.mean_membrane_force_material_N_per_m)},
                   {"mean_membrane_force_global_N_per_m", triple(e.mean_membrane_force_global_N_per_m)},
                   {"charge_C", e.charge_C},
                   {"charge_error_C", e.charge_error_C}});
  }
  return out;
}

nlohmann::json samples_json(const std::vector<SampleResult>& samples) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& p : samples) {
    out.push_back({{"x_m", p.x_m},
                   {"y_m", p.y_m},
                   {"w_m", p.w_m},
                   {"ux_m", p.ux_m},
                   {"uy_m", p.uy_m},
                   {"membrane_force_global_N_per_m", triple(p.membrane_force.global)},
                   {"membrane_force_material_N_per_m", triple(p.membrane_force.material)},
                   {"membrane_force_polar_N_per_m", triple(p.membrane_force.polar)},
                   {"charge_density_C_per_m2", p.charge_density_C_per_m2}});
  }
  return out;
}

}  // namespace

nlohmann::json result_json(const Result& r) {
  const Summary& s = r.summary;
  nlohmann::json j;
  j["status"] = status_name(s.status);
  j["message"] = s.message;
  j["model"] = model_name(s.model);
  j["model_reason"] = s.model_reason;
  j["n_dofs"] = s.n_dofs;
  j["n_cells"] = s.n_cells;
  j["newton_iterations"] = s.newton_iterations;
  j["load_steps"] = s.load_steps;
  j["refinement_cycles"] = s.refinement_cycles;
  j["wall_s"] = s.wall_s;
  j["cpu_s"] = s.cpu_s;
  j["time_breakdown_s"] = {{"setup", s.setup_s}, {"assembly", s.assembly_s}, {"linear_solve", s.linear_solve_s}};
  j["estimated_relative_error"] = s.estimated_relative_error;
  j["estimated_discretization_error"] = s.estimated_discretization_error;
  j["estimated_model_error"] = s.estimated_model_error;
  j["error_estimator"] = s.error_estimator;
  j["clamp_layer"] = {{"treatment", s.clamp_layer},
                      {"estimated_error", s.estimated_clamp_layer_error},
                      {"correction", s.clamp_layer_correction},
                      {"width_m", s.clamp_layer_width_m},
                      {"passes", s.clamp_layer_passes}};
  j["stress_measure"] = "second Piola-Kirchhoff membrane resultant (N/m), undeformed axes";
  if (!usable(s.status)) return j;
  j["max_deflection_m"] = r.max_deflection_m;
  j["deflection_at_load_m"] = r.deflection_at_load_m;
  j["rim_reaction_N"] = r.rim_reaction_N;
  j["strain_energy_J"] = r.strain_energy_J;
  j["wrinkled_area_fraction"] = r.wrinkled_area_fraction;  // tension-field membrane (slack films)
  j["slack_area_fraction"] = r.slack_area_fraction;
  j["loads"] = nlohmann::json::array();
  for (const auto& l : r.loads) {
    j["loads"].push_back({{"x_m", l.x_m}, {"y_m", l.y_m}, {"force_N", l.force_N}, {"deflection_m", l.deflection_m}});
  }
  j["electrodes"] = electrodes_json(r.electrodes);
  j["samples"] = samples_json(r.samples);
  if (!r.vtu_files.empty()) j["vtu_files"] = r.vtu_files;
  return j;
}

}  // namespace pvdf::fem
