// `pvdfkit compare SCENE measured.csv`: measured charges (and deflections) against FEM solves at
// the measured presses themselves, warm-started on one prepared mesh — no map, no interpolation
// error. The comparison is the library's (pvdf::mapping::compare_with_fem); here its progress,
// text, JSON and CSV.
#include "compare_scene.hpp"

#include "command.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/progress.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/mapping/analysis.hpp"
#include "pvdf/mapping/compare_fem.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/pictures.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>

namespace pvdf::app {

namespace {

nlohmann::json number_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

}  // namespace

namespace {

/// The library's comparison (mapping::compare_with_fem) under the names the printers below use.
struct SceneComparison {
  std::vector<std::string> names;
  pvdf::mapping::Comparison c;
  std::vector<double> w_meas, w_fem;
  pvdf::fem::SweepSetup setup;
};

SceneComparison compare_with_fem(const pvdf::Scene& scene, const std::string& measured_path, double min_charge_C,
                                 bool quiet) {
  // Progress on stderr (none with --quiet): the sweep setup ("starting"), then the solves.
  std::unique_ptr<pvdf::Progress> bar;
  std::function<void(std::size_t, std::size_t)> progress;
  if (!quiet) {
    bar = std::make_unique<pvdf::Progress>("compare: FEM solves", 0);
    progress = [&bar](std::size_t done, std::size_t total) {
      bar->set_total(total);
      bar->update(done);
    };
  }
  pvdf::mapping::FemComparison r = pvdf::mapping::compare_with_fem(scene, measured_path, min_charge_C, progress);
  if (bar) bar->finish();
  return {std::move(r.electrode_names), std::move(r.comparison), std::move(r.deflection_measured_m),
          std::move(r.deflection_fem_m), r.setup};
}

/// `--report`: one CSV row per press, measured and FEM values side by side.
void write_comparison_csv(const SceneComparison& r, const std::string& report_path) {
  const auto& names = r.names;
  const std::size_t ne = names.size(), n = r.c.presses.size();
  pvdf::write_file_atomically(report_path, [&](std::ostream& out) {
    out.precision(10);
    out << "line,x_m,y_m,force_N,deflection_measured_m,deflection_fem_m";
    for (const auto& nm : names) out << ",charge_" << nm << "_measured_C,charge_" << nm << "_fem_C,difference_" << nm << "_pct";
    out << '\n';
    for (std::size_t i = 0; i < n; ++i) {
      const auto& p = r.c.presses[i];
      out << p.measured.line << ',' << p.measured.x_m << ',' << p.measured.y_m << ',' << p.measured.force_N << ','
          << r.w_meas[i] << ',' << r.w_fem[i];
      for (std::size_t k = 0; k < ne; ++k)
        out << ',' << p.measured.charge_C[k] << ',' << p.map_charge_C[k] << ',' << p.difference_pct[k];
      out << '\n';
    }
  });
}

void print_comparison_json(const SceneComparison& r, const std::string& scene_path, const std::string& measured_path) {
  const auto& names = r.names;
  const auto& c = r.c;
  const auto& setup = r.setup;
  const std::size_t ne = names.size(), n = c.presses.size();
  nlohmann::json j = pvdf::mapping::comparison_summary_json(c);
  j["scene"] = scene_path;
  j["measured"] = measured_path;
  j["model"] = pvdf::fem::model_name(setup.model);
  j["estimated_charge_relative_error"] = setup.estimated_relative_error;
  j["estimated_deflection_relative_error"] = setup.estimated_deflection_relative_error;
  j["difference_definition"] = "100 * (Q_measured - Q_fem) / Q_fem, per press and electrode";
  j["presses"] = nlohmann::json::array();
  for (std::size_t i = 0; i < n; ++i) {
    const auto& p = c.presses[i];
    nlohmann::json e = {{"line", p.measured.line}, {"x_m", p.measured.x_m}, {"y_m", p.measured.y_m},
                        {"force_N", p.measured.force_N}, {"deflection_measured_m", number_or_null(r.w_meas[i])},
                        {"deflection_fem_m", r.w_fem[i]}};
    for (std::size_t k = 0; k < ne; ++k) {
      e["charge_" + names[k] + "_measured_C"] = number_or_null(p.measured.charge_C[k]);
      e["charge_" + names[k] + "_fem_C"] = p.map_charge_C[k];
      e["difference_" + names[k] + "_pct"] = number_or_null(p.difference_pct[k]);
    }
    j["presses"].push_back(e);
  }
  std::cout << j.dump(2) << '\n';
}

void print_comparison_text(const SceneComparison& r, const std::string& scene_path, const std::string& measured_path) {
  const auto& names = r.names;
  const auto& c = r.c;
  const auto& setup = r.setup;
  const std::size_t ne = names.size(), n = c.presses.size();
  std::printf("%s against FEM solves of %s at the measured presses (%s, estimated charge error %.2g %%); "
              "difference = 100 (Q_measured - Q_fem) / Q_fem\n",
              measured_path.c_str(), scene_path.c_str(), pvdf::fem::model_name(setup.model).c_str(),
              100 * setup.estimated_relative_error);
  std::printf("%5s %9s %9s %7s %9s %9s", "line", "x_mm", "y_mm", "F_N", "w_meas_mm", "w_fem_mm");
  for (const auto& nm : names) std::printf(" %10s %10s %8s", (nm + "_meas_pC").c_str(), (nm + "_fem_pC").c_str(), (nm + "_%").c_str());
  std::printf("\n");
  for (std::size_t i = 0; i < n; ++i) {
    const auto& p = c.presses[i];
    std::printf("%5zu %9.3f %9.3f %7.3g", p.measured.line, p.measured.x_m * 1e3, p.measured.y_m * 1e3, p.measured.force_N);
    // a deflection the CSV does not give (or the FEM did not reach) is "-", never "nan"
    for (const double w : {r.w_meas[i], r.w_fem[i]}) {
      if (std::isfinite(w)) std::printf(" %9.4g", w * 1e3);
      else std::printf(" %9s", "-");
    }
    for (std::size_t k = 0; k < ne; ++k) {
      std::printf(" %10.4g %10.4g", p.measured.charge_C[k] * 1e12, p.map_charge_C[k] * 1e12);
      if (std::isfinite(p.difference_pct[k])) std::printf(" %8.2f", p.difference_pct[k]);
      else std::printf(" %8s", "-");
    }
    std::printf("\n");
  }
  std::printf("per electrode: mean |difference|, mean signed difference, rms, max |difference| (%%)\n");
  for (const auto& s : c.electrodes) {
    std::printf("  %-8s n %3d  mean|d| %7.2f  mean %+7.2f  rms %7.2f  max %7.2f\n", s.name.c_str(), s.n_compared,
                s.mean_abs_difference_pct, s.mean_difference_pct, s.rms_difference_pct, s.max_abs_difference_pct);
  }
  std::printf("all: mean |difference| %.2f %% over %d values (seed 001: %.0f %%)\n", c.mean_abs_difference_pct,
              c.n_compared_values, pvdf::mapping::paper_mean_difference_pct);
}

}  // namespace

int run_compare_scene(const std::string& scene_path, const std::string& measured_path, bool json,
                      const std::string& plot_path, const std::string& report_path, double min_charge_C, bool quiet) {
  const pvdf::Scene scene = pvdf::load_scene(scene_path);
  const SceneComparison r = compare_with_fem(scene, measured_path, min_charge_C, quiet);
  if (!report_path.empty()) write_comparison_csv(r, report_path);
  if (json) {
    print_comparison_json(r, scene_path, measured_path);
  } else {
    print_comparison_text(r, scene_path, measured_path);
  }
  if (!plot_path.empty() && r.c.n_compared_values > 0) {
    pvdf::mapping::write_comparison_png(r.c, plot_path);
    if (!json) std::printf("plot written to %s\n", plot_path.c_str());
  }
  if (!report_path.empty() && !json) std::printf("report written to %s\n", report_path.c_str());
  bool any_deflection = false;
  for (double w : r.w_meas) any_deflection = any_deflection || std::isfinite(w);
  if (r.c.n_compared_values == 0 && !any_deflection) {
    std::cerr << "error: " << measured_path << ": nothing to compare (no charge or deflection column)\n";
    return pvdf::exit_code::numerical;
  }
  return pvdf::exit_code::success;
}

}  // namespace pvdf::app
