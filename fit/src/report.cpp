// JSON and PNG reports of a fit.
#include "pvdf/fit/report.hpp"

#include "pvdf/core/io.hpp"
#include "pvdf/plot/plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace pvdf::fit {

namespace {

nlohmann::json number_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

}  // namespace

nlohmann::json to_json(const FitResult& r, const MeasuredTable& m) {
  nlohmann::json j;
  j["measured"] = m.source;
  j["status"] = status_name(r.status);
  j["message"] = r.message;
  j["iterations"] = r.iterations;
  j["sigmas_given"] = r.sigmas_given;
  j["chi2_start"] = r.chi2_start;
  j["chi2"] = r.chi2;
  j["degrees_of_freedom"] = r.degrees_of_freedom;
  j["reduced_chi2"] = number_or_null(r.reduced_chi2);
  j["relative_sigma_estimated"] = r.sigmas_given ? nlohmann::json(nullptr) : nlohmann::json(r.relative_sigma_estimated);
  j["condition_number"] = number_or_null(r.condition_number);
  j["parameters"] = nlohmann::json::array();
  for (const auto& p : r.parameters) {
    j["parameters"].push_back({{"name", p.name},
                               {"start", p.start},
                               {"value", p.value},
                               {"sigma", number_or_null(p.sigma)},
                               {"at_bound", p.at_bound},
                               {"determined", p.determined},
                               {"warning", p.warning}});
  }
  nlohmann::json corr = nlohmann::json::array();
  for (const auto& row : r.correlation) {
    nlohmann::json jr = nlohmann::json::array();
    for (double c : row) jr.push_back(number_or_null(c));
    corr.push_back(jr);
  }
  j["correlation"] = corr;
  j["film"] = {{"pretension_N_per_m", r.pretension_N_per_m},
               {"E_scale", r.E_scale},
               {"d31_C_per_N", r.d31_C_per_N},
               {"d32_C_per_N", r.d32_C_per_N}};
  nlohmann::json gains = nlohmann::json::object();
  for (std::size_t k = 0; k < r.gains.size() && k < r.fitted_scene.electrodes.size(); ++k)
    gains[r.fitted_scene.electrodes[k].name] = r.gains[k];
  j["film"]["gains"] = gains;
  j["warnings"] = r.warnings;
  j["observations"] = nlohmann::json::array();
  for (const auto& o : r.observations) {
    j["observations"].push_back({{"line", o.line},
                                 {"x_m", m.x_m[o.row]},
                                 {"y_m", m.y_m[o.row]},
                                 {"force_N", m.force_N[o.row]},
                                 {"column", o.column},
                                 {"measured", o.measured},
                                 {"sigma", o.sigma},
                                 {"predicted_start", o.predicted_start},
                                 {"predicted", o.predicted},
                                 {"normalized_residual", o.normalized_residual}});
  }
  const auto& s = r.fem.reference_setup;
  j["fem"] = {{"model", fem::model_name(s.model)},
              {"include_bending", s.include_bending},
              {"residual_stiffness", r.fem.residual_stiffness},
              {"n_dofs", s.n_dofs},
              {"estimated_charge_relative_error", s.estimated_relative_error},
              {"estimated_deflection_relative_error", s.estimated_deflection_relative_error},
              {"n_solves", r.fem.n_solves},
              {"n_sweeps", r.fem.n_sweeps},
              {"setup_s", r.fem.setup_s},
              {"solve_s", r.fem.solve_s}};
  j["wall_s"] = r.wall_s;
  return j;
}

void write_fit_png(const FitResult& r, const MeasuredTable& m, const pvdf::Scene& scene, const std::string& path) {
  using plot::Color;
  using plot::LineStyle;
  using plot::Marker;
  plot::Figure fig(1500, 1150, 2, 2);
  auto& a = fig.axes(0, 0);
  auto& b = fig.axes(0, 1);
  auto& c = fig.axes(1, 0);
  auto& d = fig.axes(1, 1);
  const Color grey{150, 150, 150};
  const std::size_t ne = scene.electrodes.size();
  bool any_charge = false, any_deflection = false;
  double lo = std::numeric_limits<double>::infinity(), hi = 0;
  double dlo = std::numeric_limits<double>::infinity(), dhi = 0;
  for (std::size_t k = 0; k < ne; ++k) {
    std::vector<double> meas, err, start, fit, idx_fit, pct_start, pct_fit, dist, dist_err;
    for (std::size_t n = 0; n < r.observations.size(); ++n) {
      const auto& o = r.observations[n];
      if (o.electrode != static_cast<int>(k)) continue;
      any_charge = true;
      meas.push_back(o.measured * 1e12);
      err.push_back(o.sigma * 1e12);
      start.push_back(o.predicted_start * 1e12);
      fit.push_back(o.predicted * 1e12);
      idx_fit.push_back(double(n + 1));
      pct_start.push_back(100 * (o.measured - o.predicted_start) / o.predicted_start);
      pct_fit.push_back(100 * (o.measured - o.predicted) / o.predicted);
      const auto& e = scene.electrodes[k];
      dist.push_back(1e3 * std::hypot(m.x_m[o.row] - e.center_m[0], m.y_m[o.row] - e.center_m[1]));
      for (double v : {meas.back(), start.back(), fit.back()})
        if (v > 0) lo = std::min(lo, v), hi = std::max(hi, v);
      if (dist.back() > 0) dlo = std::min(dlo, dist.back()), dhi = std::max(dhi, dist.back());
    }
    if (meas.empty()) continue;
    const Color col = plot::cycle_color(k);
    const std::string name = scene.electrodes[k].name;
    a.scatter(start, meas, k == 0 ? "before (start values)" : "", grey, Marker::cross, 8);
    a.error_bars(fit, meas, err, col);
    a.scatter(fit, meas, name + " after fit", col, Marker::circle, 7);
    b.scatter(idx_fit, pct_start, k == 0 ? "before" : "", grey, Marker::cross, 8);
    b.scatter(idx_fit, pct_fit, name + " after", col, Marker::circle, 7);
    c.error_bars(dist, meas, err, col);
    c.scatter(dist, meas, name + " measured", col, Marker::circle, 7);
    c.scatter(dist, fit, name + " fitted FEM", col, Marker::plus, 11);
    c.scatter(dist, start, k == 0 ? "FEM before" : "", grey, Marker::cross, 8);
  }
  if (any_charge && hi > 0) {
    const double x0 = lo / 1.5, x1 = hi * 1.5;
    a.line({x0, x1}, {x0, x1}, "measured = predicted", Color{0, 0, 0});
    a.xlim(x0, x1).ylim(x0, x1).log_x().log_y();
    c.ylim(x0, x1).log_y();
    if (dhi > 0) c.xlim(std::max(0.5, dlo / 1.3), dhi * 1.3).log_x();
  }
  a.title("Charges: measured against FEM").xlabel("FEM charge (pC)").ylabel("measured charge (pC), ±1σ").grid_lines().legend("upper left");
  b.hline(0.0, Color{0, 0, 0}, LineStyle::solid)
      .title(pvdf::format_printf("Difference per value (reduced χ² %.3g after the fit)", r.reduced_chi2))
      .xlabel("observation number (row × column order)")
      .integer_x()
      .ylabel("100·(measured − FEM)/FEM (%)")
      .grid_lines()
      .legend("best");
  c.title("Charge against distance from each electrode (Fig. 12 style)")
      .xlabel("distance from the electrode centre (mm)")
      .ylabel("charge (pC)")
      .grid_lines()
      .legend("upper right");
  // (d) deflection per press, or normalized residuals.
  std::vector<double> di, dm, de, ds, df;
  for (const auto& o : r.observations) {
    if (o.electrode >= 0) continue;
    any_deflection = true;
    di.push_back(double(o.row + 1));
    dm.push_back(o.measured * 1e3);
    de.push_back(o.sigma * 1e3);
    ds.push_back(o.predicted_start * 1e3);
    df.push_back(o.predicted * 1e3);
  }
  if (any_deflection) {
    d.error_bars(di, dm, de, Color{0, 0, 0});
    d.scatter(di, dm, "measured ±1σ", Color{0, 0, 0}, Marker::circle, 8);
    d.scatter(di, ds, "FEM before", grey, Marker::cross, 10);
    d.scatter(di, df, "FEM after fit", plot::cycle_color(3), Marker::square, 9);
    double top = 0;
    for (const auto* v : {&dm, &ds, &df})
      for (double x : *v) top = std::max(top, x);
    for (std::size_t i = 0; i < dm.size(); ++i) top = std::max(top, dm[i] + de[i]);
    // x spans the presses that have a deflection (one row apart at the ends), not every data
    // row: one measured deflection is one point in the middle of the panel.
    const double first = *std::min_element(di.begin(), di.end()), last = *std::max_element(di.begin(), di.end());
    d.ylim(0, 1.15 * top).xlim(first - 1, last + 1);
    d.integer_x().title("Deflection under the probe").xlabel("press (data row)").ylabel("deflection (mm)").grid_lines().legend("upper right");
  } else {
    std::vector<double> idx, res;
    for (std::size_t n = 0; n < r.observations.size(); ++n) {
      idx.push_back(double(n + 1));
      res.push_back(r.observations[n].normalized_residual);
    }
    d.scatter(idx, res, "after fit", plot::cycle_color(0), Marker::circle, 7);
    d.hline(2, grey, LineStyle::dashed, "±2σ").hline(-2, grey, LineStyle::dashed);
    d.integer_x().title("Normalized residuals (FEM − measured)/σ").xlabel("observation number").ylabel("residual / σ").grid_lines().legend("upper right");
  }
  std::string title = "Fit " + status_name(r.status) + ":";
  for (const auto& p : r.parameters) {
    char buf[160];
    const bool piezo = p.name.size() > 8 && p.name.compare(p.name.size() - 8, 8, "_C_per_N") == 0;  // shown in pC/N
    if (piezo) std::snprintf(buf, sizeof buf, "  %s = %.4g ± %.2g pC/N", p.name.substr(0, p.name.size() - 8).c_str(), p.value * 1e12, p.sigma * 1e12);
    else std::snprintf(buf, sizeof buf, "  %s = %.4g ± %.2g", p.name.c_str(), p.value, p.sigma);
    title += buf;
  }
  fig.suptitle(title);
  fig.save_png(path);
}

}  // namespace pvdf::fit
