// Analytic membrane-like charge model and maps sampled from it.
#include "pvdf/mapping/synthetic.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/membrane_scaling.hpp"
#include "pvdf/version.hpp"

#include <nlohmann/json.hpp>

#include <cmath>

namespace pvdf::mapping {

double SyntheticModel::charge_C(double x_m, double y_m, double force_N, std::size_t k) const {
  const double c = std::cos(draw_angle_rad), s = std::sin(draw_angle_rad);
  const double dx = x_m - centers_m[k][0], dy = y_m - centers_m[k][1];
  const double u = c * dx + s * dy, v = -s * dx + c * dy;
  const double a = std::sqrt(anisotropy);
  const double rho2 = (u / a) * (u / a) + (v * a) * (v * a);
  const double R = film_radius_m;
  const double rim = 1.0 - rim_strength * (x_m * x_m + y_m * y_m) / (R * R);
  const double c2 = core_m * core_m;
  const double piezo = (u * u + d32_over_d31 * v * v + 0.5 * (1.0 + d32_over_d31) * c2) / (u * u + v * v + c2);
  return scale_C * std::pow(force_N, force_exponent + force_skew * x_m / R) * rim * piezo *
         std::pow(rho2 + c2, -0.5 * exponent);
}

ChargeMap build_synthetic_map(const SyntheticModel& model, double spacing_m, double rim_margin_m,
                              const std::vector<double>& forces_N, double noise_C) {
  if (!(spacing_m > 0)) throw InputError("synthetic map: spacing_m must be > 0");
  ChargeMap m;
  const double R = model.film_radius_m;
  const int half = int(std::ceil(R / spacing_m - 1e-9));
  for (int i = -half; i <= half; ++i) m.x_m.push_back(i * spacing_m);
  m.y_m = m.x_m;
  m.forces_N = forces_N;
  m.electrode_names = model.names;
  m.electrode_centers_m = model.centers_m;
  m.noise_C.assign(model.n_electrodes(), noise_C);
  m.model = "synthetic-analytic";
  m.tolerance = 0.0;
  m.rim_margin_m = rim_margin_m;
  m.description = "analytic membrane-like charge model (pvdf::mapping::SyntheticModel), not an FEM result";
  nlohmann::json scene = {{"name", "synthetic"},
                          {"membrane", {{"shape", "circle"}, {"radius_m", R}}},
                          {"synthetic_model",
                           {{"scale_C", model.scale_C}, {"core_m", model.core_m}, {"exponent", model.exponent},
                            {"anisotropy", model.anisotropy}, {"draw_angle_rad", model.draw_angle_rad},
                            {"force_exponent", model.force_exponent}, {"force_skew", model.force_skew},
                            {"d32_over_d31", model.d32_over_d31}, {"rim_strength", model.rim_strength}}}};
  for (std::size_t k = 0; k < model.n_electrodes(); ++k) {
    scene["electrodes"].push_back({{"name", model.names[k]}, {"center_m", {model.centers_m[k][0], model.centers_m[k][1]}}});
  }
  m.scene_json = scene.dump();
  m.pvdfkit_version = pvdf::version_string;
  m.mask.assign(m.nx() * m.ny(), 0);
  for (std::size_t j = 0; j < m.ny(); ++j) {
    for (std::size_t i = 0; i < m.nx(); ++i) {
      const double r = std::hypot(m.x_m[i], m.y_m[j]);
      m.mask[j * m.nx() + i] = r <= R - rim_margin_m ? 1 : 0;
    }
  }
  m.allocate();
  for (std::size_t f = 0; f < m.nf(); ++f) {
    for (std::size_t j = 0; j < m.ny(); ++j) {
      for (std::size_t i = 0; i < m.nx(); ++i) {
        const std::size_t p = m.point(f, j, i);
        if (!m.mask[j * m.nx() + i]) {
          m.status[p] = std::uint8_t(PointStatus::outside);
          continue;
        }
        m.status[p] = std::uint8_t(PointStatus::ok);
        // A membrane-like deflection under the probe: w ∝ F^(1/3) (pure-membrane scaling), zero at the rim.
        const double r = std::hypot(m.x_m[i], m.y_m[j]);
        m.deflection_at_load_m[p] = -3.3e-3 * pvdf::membrane_deflection_factor(m.forces_N[f]) * (1.0 - r * r / (R * R));
        for (std::size_t k = 0; k < m.ne(); ++k) {
          m.charge_C[p * m.ne() + k] = model.charge_C(m.x_m[i], m.y_m[j], m.forces_N[f], k);
        }
      }
    }
  }
  return m;
}

}  // namespace pvdf::mapping
