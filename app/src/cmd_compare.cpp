// `pvdfkit compare MAP measured.csv`: FEM charge map against measured charges — per-press and
// mean % difference per electrode, like seed 001 Fig. 12 ("an average difference of 18 %").
#include "command.hpp"
#include "map_checks.hpp"
#ifdef PVDF_HAVE_FIT
#include "compare_scene.hpp"
#endif

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/mapping/analysis.hpp"
#include "pvdf/mapping/interpolant.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/map_io.hpp"
#include "pvdf/mapping/pictures.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <ostream>

namespace {

struct CompareCliOptions {
  std::string map_path;
  std::string measured_path;
  bool json = false, quiet = false;
  std::string plot_path;
  std::string report_path;
  double min_map_charge_C = 0;
};

nlohmann::json number_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

int run_compare(const CompareCliOptions& o) {
  using namespace pvdf::mapping;
  // The CSV is checked whole before any solve: rows, header, cells (fit and compare load it all).
  pvdf::check_csv_file(o.measured_path, "MEASURED");
#ifdef PVDF_HAVE_FIT
  if (pvdf::app::is_scene_file(o.map_path))  // a scene: FEM solves at the presses (compare_scene.cpp)
    return pvdf::app::run_compare_scene(o.map_path, o.measured_path, o.json, o.plot_path, o.report_path,
                                           o.min_map_charge_C, o.quiet);
#endif
  const ChargeMap map = read_map(o.map_path);
  const MapInterpolant interpolant(map);
  const auto measured = read_measured_csv(o.measured_path, map.electrode_names);
  pvdf::app::check_measured_plausible(measured, o.measured_path, map.electrode_names);
#ifdef PVDF_HAVE_FIT
  pvdf::app::warn_if_map_too_coarse(map, measured);
#endif
  CompareOptions co;
  co.min_map_charge_C = o.min_map_charge_C;
  const Comparison c = compare_with_map(map, interpolant, measured, co);
  const std::size_t ne = map.ne();

  if (!o.report_path.empty()) {
    pvdf::write_file_atomically(o.report_path, [&](std::ostream& out) {
      out.precision(10);
      out << "line,x_m,y_m,force_N,in_map,force_extrapolated";
      for (const auto& n : map.electrode_names) {
        out << ",charge_" << n << "_measured_C,charge_" << n << "_map_C,difference_" << n << "_pct";
      }
      out << '\n';
      for (const auto& p : c.presses) {
        out << p.measured.line << ',' << p.measured.x_m << ',' << p.measured.y_m << ',' << p.measured.force_N << ','
            << int(p.in_map) << ',' << int(p.force_extrapolated);
        for (std::size_t k = 0; k < ne; ++k) {
          out << ',' << p.measured.charge_C[k] << ',' << p.map_charge_C[k] << ',' << p.difference_pct[k];
        }
        out << '\n';
      }
    });
  }
  if (o.json) {
    nlohmann::json j = comparison_summary_json(c);
    j["map"] = o.map_path;
    j["measured"] = o.measured_path;
    j["model"] = map.model;
    j["difference_definition"] = "100 * (Q_measured - Q_map) / Q_map, per press and electrode";
    j["n_in_map"] = c.n_in_map;
    j["n_outside_map"] = c.n_outside;
    j["n_force_extrapolated"] = c.n_force_extrapolated;
    j["presses"] = nlohmann::json::array();
    for (const auto& p : c.presses) {
      nlohmann::json e = {{"line", p.measured.line}, {"x_m", p.measured.x_m}, {"y_m", p.measured.y_m},
                          {"force_N", p.measured.force_N}, {"in_map", p.in_map},
                          {"force_extrapolated", p.force_extrapolated}};
      for (std::size_t k = 0; k < ne; ++k) {
        const auto& n = map.electrode_names[k];
        e["charge_" + n + "_measured_C"] = p.measured.charge_C[k];
        e["charge_" + n + "_map_C"] = number_or_null(p.map_charge_C[k]);
        e["difference_" + n + "_pct"] = number_or_null(p.difference_pct[k]);
      }
      j["presses"].push_back(e);
    }
    std::cout << j.dump(2) << '\n';
  } else {
    std::printf("%s against %s (%s map); difference = 100 (Q_measured - Q_map) / Q_map\n", o.measured_path.c_str(),
                o.map_path.c_str(), map.model.c_str());
    std::printf("%5s %9s %9s %7s", "line", "x_mm", "y_mm", "F_N");
    for (const auto& n : map.electrode_names) std::printf(" %10s %10s %8s", (n + "_meas_pC").c_str(), (n + "_map_pC").c_str(), (n + "_%").c_str());
    std::printf("\n");
    for (const auto& p : c.presses) {
      std::printf("%5zu %9.3f %9.3f %7.3g", p.measured.line, p.measured.x_m * 1e3, p.measured.y_m * 1e3, p.measured.force_N);
      if (!p.in_map) {
        std::printf("   outside the map: not compared\n");
        continue;
      }
      for (std::size_t k = 0; k < ne; ++k) {
        std::printf(" %10.4g %10.4g", p.measured.charge_C[k] * 1e12, p.map_charge_C[k] * 1e12);
        if (std::isfinite(p.difference_pct[k])) std::printf(" %8.2f", p.difference_pct[k]);
        else std::printf(" %8s", "-");
      }
      std::printf("%s\n", p.force_extrapolated ? "  (force outside the map's levels: F^(2/3) scaling)" : "");
    }
    std::printf("per electrode: mean |difference|, mean signed difference, rms, max |difference| (%%)\n");
    for (const auto& s : c.electrodes) {
      std::printf("  %-8s n %3d  mean|d| %7.2f  mean %+7.2f  rms %7.2f  max %7.2f\n", s.name.c_str(), s.n_compared,
                  s.mean_abs_difference_pct, s.mean_difference_pct, s.rms_difference_pct, s.max_abs_difference_pct);
    }
    std::printf("all: mean |difference| %.2f %% over %d values (seed 001: %.0f %%); %d of %d presses outside the map\n",
                c.mean_abs_difference_pct, c.n_compared_values, paper_mean_difference_pct, c.n_outside, c.n_presses);
  }
  if (!o.plot_path.empty() && c.n_compared_values > 0) {
    write_comparison_png(c, o.plot_path, std::filesystem::path(o.measured_path).filename().string());
    if (!o.json) std::printf("plot written to %s\n", o.plot_path.c_str());
  }
  if (!o.report_path.empty() && !o.json) std::printf("report written to %s\n", o.report_path.c_str());
  if (c.n_compared_values == 0) {
    std::cerr << "error: " << o.measured_path << ": no press could be compared (" << c.n_outside << " of " << c.n_presses
              << " outside the map; the others below the charge floor)\n";
    return pvdf::exit_code::numerical;
  }
  return pvdf::exit_code::success;
}

}  // namespace

PVDF_COMMAND(66, [](CLI::App& root) {
  auto* sub = root.add_subcommand(
      "compare",
      "FEM charge map against measured charges: per-press and mean % difference per electrode (seed 001 Fig. 12)");
  auto o = std::make_shared<CompareCliOptions>();
  sub->add_option("MAP", o->map_path, "Charge map (HDF5 from `pvdfkit map`, `synthetic-map` or `calibrate`; its calibration is not "
                                       "applied), or a scene file (JSON: FEM solves at the measured presses)")->required();
  sub->add_option("MEASURED", o->measured_path,
                  "CSV with columns x_m,y_m,force_N and charge_<name>_C per electrode of the map (docs/seed001-reproduction.md)")
      ->required();
  sub->add_flag("--json", o->json, "Print the comparison as JSON (summary, per electrode, per press)");
  sub->add_option("--plot", o->plot_path, "Figure (.png, .svg or .pdf): CSV against map charge, and % difference per press")
      ->check(pvdf::app::figure_file());
  sub->add_option("-o,--report", o->report_path, "Write the per-press report as CSV")->check(pvdf::app::output_file());
  sub->add_option("--min-map-charge-C", o->min_map_charge_C,
                  "Map (or, with a scene, FEM) charges smaller than this are not compared as a percentage (C) "
                  "(default 3 x the map's 1-sigma charge noise; with a scene 3 x 0.05 pC)")
      ->check(pvdf::app::number_in(0, 1e-3, "C"));
  sub->add_flag("--quiet", o->quiet, "A scene: no progress of its FEM solves on stderr (warnings and errors are still reported)");
  return pvdf::app::Subcommand{sub, [o] { return run_compare(*o); }};
});
