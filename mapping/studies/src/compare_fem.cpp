// Measured presses against FEM solves at the same presses (pvdf/mapping/compare_fem.hpp); moved
// from app/src/compare_scene.cpp (compare_with_fem) so that the command only parses and prints.
#include "pvdf/mapping/compare_fem.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/fit/measured.hpp"
#include "pvdf/fit/predictor.hpp"
#include "pvdf/mapping/map.hpp"

#include <limits>

namespace pvdf::mapping {

FemComparison compare_with_fem(const pvdf::Scene& scene, const std::string& measured_path, double min_charge_C,
                               const std::function<void(std::size_t, std::size_t)>& progress) {
  constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();
  FemComparison out;
  std::vector<std::string>& names = out.electrode_names;
  for (const auto& e : scene.electrodes) names.push_back(e.name);
  const fit::MeasuredTable m = fit::read_measured(measured_path, names);
  const std::size_t ne = names.size(), n = m.n_rows();
  std::vector<fit::Press> presses;
  for (std::size_t i = 0; i < n; ++i) {
    if (!scene.membrane.outline.contains({m.x_m[i], m.y_m[i]}, scene.probe.radius_m)) {
      throw pvdf::InputError(measured_path + ":" + std::to_string(m.line[i]) +
                             ": press is not inside the film at least a probe radius from the rim; fix or remove the row");
    }
    presses.push_back({m.x_m[i], m.y_m[i], m.force_N[i]});
  }
  fit::PredictorOptions options;
  options.progress = progress;
  fit::Predictor predictor(scene, presses, options);
  const auto responses = predictor.predict({scene.membrane.pretension_N_per_m, 1.0});
  const std::vector<double> gains(ne, 1.0);

  Comparison& c = out.comparison;
  out.deflection_measured_m.assign(n, nan_value);
  out.deflection_fem_m.assign(n, nan_value);
  std::vector<std::vector<double>> measured_q(n, std::vector<double>(ne, nan_value));
  for (const auto& col : m.observed) {
    for (std::size_t i = 0; i < n; ++i) {
      if (col.electrode < 0) out.deflection_measured_m[i] = col.value[i];
      else measured_q[i][col.electrode] = col.value[i];
    }
  }
  CompareOptions co;
  co.min_map_charge_C = min_charge_C;
  const std::vector<double> floor_C = comparison_floor_C(co, std::vector<double>(ne, default_noise_C));
  for (std::size_t i = 0; i < n; ++i) {
    ComparedPress p;
    p.measured.x_m = m.x_m[i];
    p.measured.y_m = m.y_m[i];
    p.measured.force_N = m.force_N[i];
    p.measured.line = m.line[i];
    p.measured.charge_C = measured_q[i];
    p.in_map = true;
    p.map_charge_C = fit::charges_C(responses[i], predictor.electrode_areas_m2(), scene.membrane.thickness_m,
                                    scene.material.d31_C_per_N, scene.material.d32_C_per_N, gains);
    p.difference_pct.assign(ne, nan_value);
    for (std::size_t k = 0; k < ne; ++k)
      p.difference_pct[k] = charge_difference_pct(measured_q[i][k], p.map_charge_C[k], floor_C[k]);
    out.deflection_fem_m[i] = responses[i].deflection_m;
    c.presses.push_back(p);
  }
  summarize_comparison(c, names);
  c.n_presses = c.n_in_map = static_cast<int>(n);
  out.setup = predictor.stats().reference_setup;
  return out;
}

}  // namespace pvdf::mapping
