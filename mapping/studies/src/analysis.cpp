// Charge against distance along rays (seed 001 eq. 6, Fig. 7) and map against measurement (Fig. 12).
#include "pvdf/mapping/analysis.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace pvdf::mapping {

namespace {
constexpr double nan_value = std::numeric_limits<double>::quiet_NaN();

double median_of(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}
}  // namespace

double map_draw_angle_rad(const ChargeMap& map) {
  const auto scene = nlohmann::json::parse(map.scene_json, nullptr, false);
  if (scene.is_discarded() || !scene.is_object()) return 0.0;
  if (scene.contains("material") && scene["material"].is_object() && scene["material"].contains("draw_angle_deg") &&
      scene["material"]["draw_angle_deg"].is_number()) {
    return scene["material"]["draw_angle_deg"].get<double>() * pi / 180.0;
  }
  if (scene.contains("synthetic_model") && scene["synthetic_model"].is_object() &&
      scene["synthetic_model"].contains("draw_angle_rad") && scene["synthetic_model"]["draw_angle_rad"].is_number()) {
    return scene["synthetic_model"]["draw_angle_rad"].get<double>();
  }
  return 0.0;
}

// Ordinary least squares of ln y on ln(x/x_ref): the straight line of a log-log plot (Fig. 7).
PowerLawFit fit_power_law(const std::vector<double>& x, const std::vector<double>& y, double x_ref) {
  if (x.size() != y.size()) throw InputError("power-law fit: " + std::to_string(x.size()) + " x values but " +
                                             std::to_string(y.size()) + " y values");
  if (!(x_ref > 0)) throw InputError("power-law fit: reference x " + std::to_string(x_ref) + " must be > 0");
  std::vector<double> lx, ly;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (x[i] > 0 && y[i] > 0 && std::isfinite(x[i]) && std::isfinite(y[i])) {
      lx.push_back(std::log(x[i] / x_ref));
      ly.push_back(std::log(y[i]));
    }
  }
  const std::size_t n = lx.size();
  if (n < 2) throw InputError("power-law fit: " + std::to_string(n) + " usable points (x > 0, y > 0); need at least 2");
  double mx = 0, my = 0;
  for (std::size_t i = 0; i < n; ++i) {
    mx += lx[i];
    my += ly[i];
  }
  mx /= double(n);
  my /= double(n);
  double sxx = 0, sxy = 0, syy = 0;
  for (std::size_t i = 0; i < n; ++i) {
    sxx += (lx[i] - mx) * (lx[i] - mx);
    sxy += (lx[i] - mx) * (ly[i] - my);
    syy += (ly[i] - my) * (ly[i] - my);
  }
  if (!(sxx > 1e-300)) throw InputError("power-law fit: all usable x values are equal; need at least 2 distinct");
  PowerLawFit f;
  f.n_used = int(n);
  f.C2 = sxy / sxx;
  const double a = my - f.C2 * mx;
  f.C1 = std::exp(a);
  double ss_res = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double r = ly[i] - (a + f.C2 * lx[i]);
    ss_res += r * r;
    f.max_relative_deviation = std::max(f.max_relative_deviation, std::abs(std::expm1(-r)));
  }
  // A perfectly flat line (syy = 0) is fitted exactly: R² = 1.
  f.r_squared = syy > 0 ? 1.0 - ss_res / syy : 1.0;
  return f;
}

RayAnalysis analyse_rays(const ChargeMap& map, const MapInterpolant& interpolant, const RayOptions& o) {
  if (!(o.d_min_m > 0)) throw InputError("rays: d_min_m = " + std::to_string(o.d_min_m) + " must be > 0 (m)");
  if (!(o.d_max_m > o.d_min_m)) {
    throw InputError("rays: d_max_m = " + std::to_string(o.d_max_m) + " must be > d_min_m = " + std::to_string(o.d_min_m));
  }
  if (!(o.angle_step_deg > 0 && o.angle_step_deg <= 360)) {
    throw InputError("rays: angle step " + std::to_string(o.angle_step_deg) + " deg must be in (0, 360], e.g. 10");
  }
  if (o.n_samples < 2) throw InputError("rays: n_samples = " + std::to_string(o.n_samples) + " must be >= 2");
  if (o.min_points < 2) throw InputError("rays: min_points = " + std::to_string(o.min_points) + " must be >= 2");
  if (!(o.force_N > 0) || !std::isfinite(o.force_N)) {
    throw InputError("rays: force " + std::to_string(o.force_N) + " N must be > 0");
  }
  RayAnalysis a;
  a.options = o;
  a.draw_angle_rad = map_draw_angle_rad(map);
  const double log_force = std::log(o.force_N);
  std::vector<double> betas = o.beta_deg;
  if (betas.empty()) {
    for (int m = 0; m * o.angle_step_deg < 360.0 - 1e-9; ++m) betas.push_back(m * o.angle_step_deg);
  }
  for (double b : betas) {
    if (!std::isfinite(b)) throw InputError("rays: a ray angle is not finite; give angles in degrees, e.g. 45,65,85");
  }
  std::array<double, max_electrodes> q{};
  for (std::size_t k = 0; k < map.ne(); ++k) {
    RayElectrodeSummary s;
    s.name = map.electrode_names[k];
    std::vector<double> exponents;
    s.min_r_squared = 1.0;
    for (const double beta_deg : betas) {
      RayChargeFit r;
      r.electrode = k;
      r.beta_deg = beta_deg;
      const double theta = a.draw_angle_rad + beta_deg * pi / 180.0;
      const double ux = std::cos(theta), uy = std::sin(theta);
      for (int i = 0; i < o.n_samples; ++i) {
        const double d = o.d_min_m * std::pow(o.d_max_m / o.d_min_m, double(i) / double(o.n_samples - 1));
        const double x = map.electrode_centers_m[k][0] + d * ux, y = map.electrode_centers_m[k][1] + d * uy;
        if (!interpolant.evaluate(x, y, log_force, q.data(), nullptr)) continue;
        r.d_m.push_back(d);
        r.charge_C.push_back(q[k]);
        if (q[k] > 0) ++r.n_used;
        else ++r.n_nonpositive;
      }
      if (r.n_used < o.min_points) {
        r.reason = std::to_string(r.n_used) + " usable samples (inside the map, Q > 0; " + std::to_string(r.n_nonpositive) +
                   " with Q <= 0), need " + std::to_string(o.min_points);
      } else {
        const PowerLawFit f = fit_power_law(r.d_m, r.charge_C, 1e-3);
        r.fitted = true;
        r.C1_C = f.C1;
        r.C2 = f.C2;
        r.r_squared = f.r_squared;
        r.max_relative_deviation = f.max_relative_deviation;
        exponents.push_back(-f.C2);
        s.min_r_squared = std::min(s.min_r_squared, f.r_squared);
        s.n_in_paper_range += (-f.C2 >= paper_exponent_min && -f.C2 <= paper_exponent_max);
      }
      a.rays.push_back(std::move(r));
      ++s.n_rays;
    }
    s.n_fitted = int(exponents.size());
    if (!exponents.empty()) {
      s.min_decay_exponent = *std::min_element(exponents.begin(), exponents.end());
      s.max_decay_exponent = *std::max_element(exponents.begin(), exponents.end());
      s.median_decay_exponent = median_of(exponents);
    } else {
      s.min_r_squared = 0;
    }
    a.electrodes.push_back(s);
  }
  return a;
}

std::vector<MeasuredPress> read_measured_csv(const std::string& path, const std::vector<std::string>& names) {
  return read_measurements(path, names);
}

double charge_difference_pct(double measured_C, double predicted_C, double floor_C) {
  if (!(std::abs(predicted_C) >= floor_C) || predicted_C == 0 || !std::isfinite(measured_C)) return nan_value;
  return 100.0 * (measured_C - predicted_C) / predicted_C;
}

std::vector<double> comparison_floor_C(const CompareOptions& options, const std::vector<double>& noise_C) {
  std::vector<double> floor_C(noise_C.size(), options.min_map_charge_C);
  if (!(options.min_map_charge_C > 0)) {
    for (std::size_t k = 0; k < noise_C.size(); ++k) floor_C[k] = 3.0 * noise_C[k];
  }
  return floor_C;
}

void summarize_comparison(Comparison& c, const std::vector<std::string>& electrode_names) {
  const std::size_t ne = electrode_names.size();
  c.electrodes.assign(ne, {});
  c.n_compared_values = 0;
  double sum_abs = 0, sum = 0;
  for (std::size_t k = 0; k < ne; ++k) {
    CompareElectrodeSummary& s = c.electrodes[k];
    s.name = electrode_names[k];
    double sa = 0, ss = 0, s2 = 0;
    for (const auto& p : c.presses) {
      if (k >= p.difference_pct.size() || !std::isfinite(p.difference_pct[k])) continue;
      const double d = p.difference_pct[k];
      ++s.n_compared;
      sa += std::abs(d);
      ss += d;
      s2 += d * d;
      s.max_abs_difference_pct = std::max(s.max_abs_difference_pct, std::abs(d));
    }
    if (s.n_compared > 0) {
      s.mean_abs_difference_pct = sa / s.n_compared;
      s.mean_difference_pct = ss / s.n_compared;
      s.rms_difference_pct = std::sqrt(s2 / s.n_compared);
    }
    sum_abs += sa;
    sum += ss;
    c.n_compared_values += s.n_compared;
  }
  c.mean_abs_difference_pct = c.n_compared_values > 0 ? sum_abs / c.n_compared_values : 0.0;
  c.mean_difference_pct = c.n_compared_values > 0 ? sum / c.n_compared_values : 0.0;
}

Comparison compare_with_map(const ChargeMap& map, const MapInterpolant& interpolant,
                            const std::vector<MeasuredPress>& measured, const CompareOptions& options) {
  const std::size_t ne = map.ne();
  const std::vector<double> floor_C = comparison_floor_C(options, map.noise_C);
  Comparison c;
  c.n_presses = int(measured.size());
  std::array<double, max_electrodes> q{};
  for (const auto& m : measured) {
    if (m.charge_C.size() != ne) {
      throw InputError("compare: a measured press (line " + std::to_string(m.line) + ") has " +
                       std::to_string(m.charge_C.size()) + " charges but the map has " + std::to_string(ne) + " electrodes");
    }
    ComparedPress p;
    p.measured = m;
    p.map_charge_C.assign(ne, nan_value);
    p.difference_pct.assign(ne, nan_value);
    p.in_map = interpolant.evaluate(m.x_m, m.y_m, std::log(m.force_N), q.data(), nullptr);
    if (p.in_map) {
      ++c.n_in_map;
      const double lf = std::log(m.force_N);
      p.force_extrapolated = lf < interpolant.min_log_force() - 1e-12 || lf > interpolant.max_log_force() + 1e-12;
      c.n_force_extrapolated += p.force_extrapolated;
      for (std::size_t k = 0; k < ne; ++k) {
        p.map_charge_C[k] = q[k];
        p.difference_pct[k] = charge_difference_pct(m.charge_C[k], q[k], floor_C[k]);
      }
    } else {
      ++c.n_outside;
    }
    c.presses.push_back(std::move(p));
  }
  summarize_comparison(c, map.electrode_names);
  return c;
}

std::vector<UnresolvedPress> presses_map_cannot_resolve(const ChargeMap& map, const std::vector<MeasuredPress>& presses) {
  std::vector<UnresolvedPress> out;
  if (map.nx() < 2 || map.ny() < 2) return out;
  const double h = std::max(map.x_m[1] - map.x_m[0], map.y_m[1] - map.y_m[0]);
  for (const auto& p : presses) {
    for (std::size_t k = 0; k < map.ne(); ++k) {
      const double d = std::hypot(p.x_m - map.electrode_centers_m[k][0], p.y_m - map.electrode_centers_m[k][1]);
      if (d < 2 * h) {
        out.push_back({p.line, k, d, h});
        break;
      }
    }
  }
  return out;
}

nlohmann::json comparison_summary_json(const Comparison& c) {
  nlohmann::json j;
  j["n_presses"] = c.n_presses;
  j["n_compared_values"] = c.n_compared_values;
  j["mean_abs_difference_pct"] = c.mean_abs_difference_pct;
  j["mean_difference_pct"] = c.mean_difference_pct;
  j["paper_mean_difference_pct"] = paper_mean_difference_pct;
  j["electrodes"] = nlohmann::json::array();
  for (const auto& s : c.electrodes) {
    j["electrodes"].push_back({{"name", s.name},
                               {"n_compared", s.n_compared},
                               {"mean_abs_difference_pct", s.mean_abs_difference_pct},
                               {"mean_difference_pct", s.mean_difference_pct},
                               {"rms_difference_pct", s.rms_difference_pct},
                               {"max_abs_difference_pct", s.max_abs_difference_pct}});
  }
  return j;
}

}  // namespace pvdf::mapping
