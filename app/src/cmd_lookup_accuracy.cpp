// `pvdfkit lookup-accuracy`: on a given charge map, the lookup against the seed-001 triangulation —
// median position error against charge noise and locates per second — by Monte Carlo presses
// whose true charges are the map's own interpolant (the study is pvdf::mapping::lookup_accuracy;
// this command parses the flags, prints the table and draws the figure).
#include "command.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/mapping/map_io.hpp"
#include "pvdf/plot/plot.hpp"
#include "pvdf/mapping/lookup_accuracy.hpp"
#include "pvdf/mapping/map.hpp"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <vector>

namespace {

struct CompareOptions {
  std::string map_path;
  long long presses = 500;
  double radius_m = 0.015;
  std::string noise = "0.01e-12,0.03e-12,0.1e-12,0.3e-12,1e-12";
  std::string plot_path;
  bool json = false;
  unsigned seed = 1;
};

int run_compare(const CompareOptions& o) {
  using namespace pvdf::mapping;
  const ChargeMap map = read_map(o.map_path);
  LookupAccuracyOptions study_options;
  study_options.noise_C = pvdf::parse_number_list(o.noise, "--noise-C");
  for (double s : study_options.noise_C) {
    if (!(s > 0)) throw pvdf::InputError("--noise-C " + pvdf::format_g(s) + ": every level must be > 0 (C)");
  }
  study_options.n_presses = static_cast<std::size_t>(o.presses);
  study_options.radius_m = o.radius_m;
  study_options.seed = o.seed;

  // The table is printed row by row as the noise levels finish.
  const auto print_row = [&o](const LookupAccuracy& study) {
    if (o.json) return;
    if (study.rows.size() == 1) {
      std::printf("%zu presses within %.1f mm, %.3g-%.3g N (truth: the map's interpolant)\n", study.n_presses,
                  o.radius_m * 1e3, study.min_force_N, study.max_force_N);
      std::printf("%10s %16s %16s %16s %16s %12s %12s %12s\n", "noise_pC", "lookup_F_known", "reported_sigma",
                  "lookup_F_free", "triangulation", "ambiguous_%", "lookup_/s", "triang_/s");
    }
    const LookupAccuracyRow& r = study.rows.back();
    const double amb = 100.0 * r.n_ambiguous / double(study.n_presses);
    std::printf("%10.3g %13.4f mm %13.4f mm %13.4f mm %13.4f mm %12.1f %12.0f %12.0f\n", r.noise_C * 1e12,
                r.median_error_force_known_m * 1e3, r.median_sigma_force_known_m * 1e3,
                r.median_error_force_unknown_m * 1e3, r.median_error_triangulation_m * 1e3, amb, r.lookup_per_cpu_s,
                r.triangulation_per_cpu_s);
  };
  const LookupAccuracy study = lookup_accuracy(map, study_options, print_row);
  if (study.n_presses < study_options.min_presses)
    throw pvdf::InputError(o.map_path + ": fewer than 10 mapped positions within --radius-m " + pvdf::format_g(o.radius_m) +
                           " m of the centre; give a radius inside the map");

  if (o.json) {
    nlohmann::json rows = nlohmann::json::array();
    for (const LookupAccuracyRow& r : study.rows) {
      const double amb = 100.0 * r.n_ambiguous / double(study.n_presses);
      rows.push_back({{"noise_C", r.noise_C}, {"median_error_force_known_m", r.median_error_force_known_m},
                      {"median_sigma_force_known_m", r.median_sigma_force_known_m},
                      {"median_error_force_unknown_m", r.median_error_force_unknown_m},
                      {"median_error_triangulation_m", r.median_error_triangulation_m},
                      {"ambiguous_fraction", amb / 100}, {"lookup_per_cpu_s", r.lookup_per_cpu_s},
                      {"triangulation_per_cpu_s", r.triangulation_per_cpu_s}});
    }
    std::cout << nlohmann::json{{"map", o.map_path}, {"presses", study.n_presses}, {"rows", rows}}.dump(2) << '\n';
  }
  if (!o.plot_path.empty()) {
    std::vector<double> noise_pC, e_known, s_known, e_free, e_tri;
    for (const LookupAccuracyRow& r : study.rows) {
      noise_pC.push_back(r.noise_C * 1e12);
      e_known.push_back(r.median_error_force_known_m * 1e3);
      s_known.push_back(r.median_sigma_force_known_m * 1e3);
      e_free.push_back(r.median_error_force_unknown_m * 1e3);
      e_tri.push_back(r.median_error_triangulation_m * 1e3);
    }
    pvdf::plot::Figure fig(1000, 700);
    fig.axes()
        .line(noise_pC, e_known, "lookup, force known (median error)", std::nullopt, pvdf::plot::LineStyle::solid,
              pvdf::plot::Marker::circle)
        .line(noise_pC, s_known, "lookup, force known (median reported 1σ)", std::nullopt,
              pvdf::plot::LineStyle::dashed)
        .line(noise_pC, e_free, "lookup, force unknown (nearest reported answer)", std::nullopt,
              pvdf::plot::LineStyle::solid, pvdf::plot::Marker::square)
        .line(noise_pC, e_tri, "triangulation (seed 001 eq. 6), force known", std::nullopt, pvdf::plot::LineStyle::solid,
              pvdf::plot::Marker::triangle)
        .log_x()
        .log_y()
        .title("Position error against charge noise: " + std::filesystem::path(o.map_path).filename().string())
        .xlabel("1σ charge noise per electrode (pC)")
        .ylabel("median position error (mm)")
        .grid_lines()
        .legend("upper left");
    fig.save(o.plot_path);
    if (!o.json) std::printf("plot written to %s\n", o.plot_path.c_str());
  }
  return pvdf::exit_code::success;
}

}  // namespace

PVDF_COMMAND(62, [](CLI::App& root) {
  auto* sub = root.add_subcommand("lookup-accuracy",
                                  "On a charge map: lookup against the seed-001 triangulation, position error "
                                  "against charge noise and speed (Monte Carlo; docs/lookup.md)");
  auto o = std::make_shared<CompareOptions>();
  sub->add_option("MAP", o->map_path, "Charge map (HDF5 from `pvdfkit map`, `synthetic-map` or `calibrate`)")->required();
  sub->add_option("--presses", o->presses, "Random presses per noise level (default 500)")
      ->check(pvdf::app::integer_in(10, 1000000));
  sub->add_option("--radius-m", o->radius_m, "Presses within this distance of the film centre (m) (default 0.015)")
      ->check(pvdf::app::number_in(0, 10, "m", true));
  sub->add_option("--noise-C", o->noise, "1-sigma charge noise levels per electrode N1,N2,... (C) (default 1e-14,3e-14,1e-13,3e-13,1e-12)");
  sub->add_option("--seed", o->seed, "Random seed (default 1)");
  sub->add_option("--plot", o->plot_path, "Figure of median position error against noise (.png, .svg or .pdf)")
      ->check(pvdf::app::figure_file());
  sub->add_flag("--json", o->json, "Print the table as JSON");
  return pvdf::app::Subcommand{sub, [o] { return run_compare(*o); }};
});
