// `pvdfkit rays`: charge against distance along rays from each electrode of a charge map, with
// the power-law fit Q = C1(β)·d^C2 of seed 001 eq. 6 per ray (Fig. 7); docs/seed001-reproduction.md.
#include "command.hpp"
#include "map_checks.hpp"

#include "pvdf/core/constants.hpp"
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
#include <iostream>
#include <memory>
#include <ostream>

namespace {

struct RaysOptions {
  std::string map_path;
  double force_N = 1.0;
  double angle_step_deg = 10.0;
  double d_min_m = 3e-3, d_max_m = 20e-3;
  int n_samples = 24;
  int min_points = 6;
  bool json = false;
  std::string csv_path;
  std::string plot_path;
  std::string electrode;
  std::string plot_angles = "0,10,20,30,40,50,60,70,80,90";
  std::string measured_path;
  double angle_tolerance_deg = 2.0;
};

using namespace pvdf::mapping;

/// Bound the work before reading the map: rays x samples per electrode.
void check_ray_flags(const RaysOptions& o) {
  if (!(o.d_max_m > o.d_min_m)) {
    throw pvdf::InputError("--d-max-m " + pvdf::format_g(o.d_max_m) + " must exceed --d-min-m " + pvdf::format_g(o.d_min_m));
  }
  if (o.min_points > o.n_samples) {
    throw pvdf::InputError("--min-points " + std::to_string(o.min_points) + " exceeds --n-samples " +
                           std::to_string(o.n_samples) + "; no ray could be fitted");
  }
  const double n_rays = std::ceil(360.0 / o.angle_step_deg);
  if (n_rays * o.n_samples > 1e7) {
    throw pvdf::InputError("--angle-step-deg " + pvdf::format_g(o.angle_step_deg) + " with --n-samples " +
                           std::to_string(o.n_samples) + " asks for " + pvdf::format_g(n_rays * o.n_samples) +
                           " samples per electrode, more than the limit 1e7; use a larger step or fewer samples");
  }
}

/// What `--plot` draws: the electrode, the ray angles and the measured presses (optional).
struct RayPlotChoice {
  std::size_t electrode = 0;
  std::vector<double> angles_deg;
  std::vector<MeasuredPress> measured;
};

/// The plot choices, validated before the (cheap but not free) analysis.
RayPlotChoice ray_plot_choice(const RaysOptions& o, const ChargeMap& map) {
  RayPlotChoice plot;
  // Checked with or without --plot: a bad list is a mistake either way.
  plot.angles_deg = pvdf::parse_number_list(o.plot_angles, "--plot-angles-deg");
  for (const double a : plot.angles_deg) {
    if (!(std::abs(a) <= 360)) {
      throw pvdf::InputError("--plot-angles-deg " + pvdf::quote_cell(o.plot_angles) + ": " + pvdf::format_g(a) +
                             " must lie in [-360, 360] deg");
    }
  }
  if (!o.plot_path.empty()) {
    std::string name = o.electrode;
    if (name.empty()) {  // seed 001 Fig. 7 shows electrode B
      name = map.electrode_names.front();
      for (const auto& n : map.electrode_names) {
        if (n == "B") name = n;
      }
    }
    bool found = false;
    for (std::size_t k = 0; k < map.ne(); ++k) {
      if (map.electrode_names[k] == name) {
        plot.electrode = k;
        found = true;
      }
    }
    if (!found) {
      std::string names;
      for (const auto& n : map.electrode_names) names += (names.empty() ? "" : ",") + n;
      throw pvdf::InputError("--electrode " + name + ": not an electrode of " + o.map_path + " (it has " + names + ")");
    }
    if (!o.measured_path.empty()) {
      pvdf::check_csv_file(o.measured_path, "--measured");
      plot.measured = read_measured_csv(o.measured_path, map.electrode_names);
      pvdf::app::warn_if_map_too_coarse(map, plot.measured);  // the same rule as `compare MAP`
    }
  } else if (!o.measured_path.empty() || !o.electrode.empty()) {
    throw pvdf::InputError("--measured and --electrode choose what --plot draws; give --plot FILE.png (or .svg, .pdf) too");
  }
  return plot;
}

/// `--csv`: one row per ray.
void write_rays_csv(const std::string& path, const ChargeMap& map, const RayAnalysis& a) {
  pvdf::write_file_atomically(path, [&](std::ostream& out) {
    out.precision(10);
    out << "electrode,beta_deg,fitted,C1_C,C2,decay_exponent,r_squared,n_used,n_nonpositive,max_relative_deviation\n";
    for (const auto& r : a.rays) {
      out << map.electrode_names[r.electrode] << ',' << r.beta_deg << ',' << int(r.fitted) << ',';
      if (r.fitted) {
        out << r.C1_C << ',' << r.C2 << ',' << -r.C2 << ',' << r.r_squared << ',';
      } else {
        out << "nan,nan,nan,nan,";
      }
      out << r.n_used << ',' << r.n_nonpositive << ',' << (r.fitted ? r.max_relative_deviation : std::nan("")) << '\n';
    }
  });
}

void print_rays_json(const RaysOptions& o, const ChargeMap& map, const RayOptions& ro, const RayAnalysis& a) {
  nlohmann::json j;
  j["map"] = o.map_path;
  j["model"] = map.model;
  j["force_N"] = ro.force_N;
  j["d_min_m"] = ro.d_min_m;
  j["d_max_m"] = ro.d_max_m;
  j["n_samples"] = ro.n_samples;
  j["angle_step_deg"] = ro.angle_step_deg;
  j["draw_angle_deg"] = a.draw_angle_rad * 180.0 / pvdf::pi;
  j["law"] = "Q = C1 * (d / 1 mm)^C2, least squares in ln Q against ln d";
  j["paper_decay_exponent_range"] = {paper_exponent_min, paper_exponent_max};
  j["rays"] = nlohmann::json::array();
  for (const auto& r : a.rays) {
    nlohmann::json e = {{"electrode", map.electrode_names[r.electrode]}, {"beta_deg", r.beta_deg}, {"fitted", r.fitted},
                        {"n_used", r.n_used}, {"n_nonpositive", r.n_nonpositive}};
    if (r.fitted) {
      e["C1_C"] = r.C1_C;
      e["C2"] = r.C2;
      e["decay_exponent"] = -r.C2;
      e["r_squared"] = r.r_squared;
      e["max_relative_deviation"] = r.max_relative_deviation;
    } else {
      e["reason"] = r.reason;
    }
    j["rays"].push_back(e);
  }
  j["electrodes"] = nlohmann::json::array();
  for (const auto& s : a.electrodes) {
    nlohmann::json e = {{"name", s.name}, {"n_rays", s.n_rays}, {"n_fitted", s.n_fitted},
                        {"n_in_paper_range", s.n_in_paper_range}};
    if (s.n_fitted > 0) {
      e["min_decay_exponent"] = s.min_decay_exponent;
      e["median_decay_exponent"] = s.median_decay_exponent;
      e["max_decay_exponent"] = s.max_decay_exponent;
      e["min_r_squared"] = s.min_r_squared;
    }
    j["electrodes"].push_back(e);
  }
  std::cout << j.dump(2) << '\n';
}

void print_rays_text(const RaysOptions& o, const ChargeMap& map, const RayOptions& ro, const RayAnalysis& a) {
  std::printf("%s (%s map): Q = C1 (d / 1 mm)^C2 along rays at %.3g N, d = %.3g .. %.3g mm, %d samples per ray "
              "(log-spaced), beta from the draw direction\n",
              o.map_path.c_str(), map.model.c_str(), ro.force_N, ro.d_min_m * 1e3, ro.d_max_m * 1e3, ro.n_samples);
  std::printf("%-9s %8s %12s %9s %9s %4s %10s\n", "electrode", "beta_deg", "C1_pC", "C2", "R2", "n", "max_dev_%");
  for (const auto& r : a.rays) {
    if (r.fitted) {
      std::printf("%-9s %8.1f %12.5g %9.4f %9.5f %4d %10.3g\n", map.electrode_names[r.electrode].c_str(), r.beta_deg,
                  r.C1_C * 1e12, r.C2, r.r_squared, r.n_used, 100 * r.max_relative_deviation);
    } else {
      std::printf("%-9s %8.1f   not fitted: %s\n", map.electrode_names[r.electrode].c_str(), r.beta_deg, r.reason.c_str());
    }
  }
  std::printf("decay exponent -C2 per electrode (seed 001: %.2f .. %.2f):\n", paper_exponent_min, paper_exponent_max);
  for (const auto& s : a.electrodes) {
    if (s.n_fitted == 0) {
      std::printf("  %-8s no ray fitted (of %d)\n", s.name.c_str(), s.n_rays);
      continue;
    }
    std::printf("  %-8s min %.3f  median %.3f  max %.3f; %d of %d fitted rays in the paper's range; min R2 %.4f\n",
                s.name.c_str(), s.min_decay_exponent, s.median_decay_exponent, s.max_decay_exponent, s.n_in_paper_range,
                s.n_fitted, s.min_r_squared);
  }
}

int run_rays(const RaysOptions& o) {
  check_ray_flags(o);
  const ChargeMap map = read_map(o.map_path);
  const MapInterpolant interpolant(map);
  RayOptions ro;
  ro.force_N = o.force_N;
  ro.angle_step_deg = o.angle_step_deg;
  ro.d_min_m = o.d_min_m;
  ro.d_max_m = o.d_max_m;
  ro.n_samples = o.n_samples;
  ro.min_points = o.min_points;
  const RayPlotChoice plot = ray_plot_choice(o, map);

  const RayAnalysis a = analyse_rays(map, interpolant, ro);

  if (!o.csv_path.empty()) write_rays_csv(o.csv_path, map, a);
  if (o.json) {
    print_rays_json(o, map, ro, a);
  } else {
    print_rays_text(o, map, ro, a);
  }
  if (!o.plot_path.empty()) {
    // The drawn rays need not be on the table's step (Fig. 12 uses 45°, 65°, 85°).
    RayOptions po = ro;
    po.beta_deg = plot.angles_deg;
    const RayAnalysis drawn = analyse_rays(map, interpolant, po);
    write_rays_png(drawn, map, plot.electrode, plot.angles_deg, plot.measured.empty() ? nullptr : &plot.measured,
                   o.angle_tolerance_deg, o.plot_path);
    if (!o.json) std::printf("plot written to %s\n", o.plot_path.c_str());
  }
  if (!o.csv_path.empty() && !o.json) std::printf("table written to %s\n", o.csv_path.c_str());
  int fitted = 0;
  for (const auto& s : a.electrodes) fitted += s.n_fitted;
  if (fitted == 0) {
    std::cerr << "error: " << o.map_path << ": no ray could be fitted (too few samples inside the map with Q > 0); "
              << "try a smaller --d-max-m or a map with a smaller rim margin\n";
    return pvdf::exit_code::numerical;
  }
  return pvdf::exit_code::success;
}

}  // namespace

PVDF_COMMAND(64, [](CLI::App& root) {
  auto* sub = root.add_subcommand(
      "rays",
      "Charge against distance along rays from each electrode of a map, with the power-law fit Q = C1*d^C2 per "
      "angle (seed 001 eq. 6, Fig. 7)");
  auto o = std::make_shared<RaysOptions>();
  sub->add_option("MAP", o->map_path, "Charge map (HDF5 from `pvdfkit map`, `synthetic-map` or `calibrate`)")->required();
  sub->add_option("--force-N", o->force_N, "Force of the press (N) (default 1, seed 001)")
      ->check(pvdf::app::number_in(0, 1e4, "N", true));
  sub->add_option("--angle-step-deg", o->angle_step_deg, "Angle between rays (deg) (default 10, seed 001 Fig. 3)")
      ->check(pvdf::app::number_in(0.01, 360, "deg"));
  sub->add_option("--d-min-m", o->d_min_m, "First sample distance from the electrode centre (m) (default 0.003)")
      ->check(pvdf::app::number_in(0, 10, "m", true));
  sub->add_option("--d-max-m", o->d_max_m, "Last sample distance (m); rays leaving the map stop earlier (default 0.02)")
      ->check(pvdf::app::number_in(0, 10, "m", true));
  sub->add_option("--n-samples", o->n_samples, "Samples per ray, equally spaced in ln d (default 24)")
      ->check(pvdf::app::integer_in(2, 100000));
  sub->add_option("--min-points", o->min_points, "Fewer usable samples (in the map, charge > 0) and the ray is not fitted (default 6)")
      ->check(pvdf::app::integer_in(2, 100000, "(a power-law fit needs two points)"));
  sub->add_flag("--json", o->json, "Print the fit table and the per-electrode summary as JSON");
  sub->add_option("--csv", o->csv_path, "Write the fit table as CSV (electrode,beta_deg,fitted,C1_C,C2,...)")
      ->check(pvdf::app::output_file());
  sub->add_option("--plot", o->plot_path, "Figure like seed 001 Fig. 7 (.png, .svg or .pdf): Q(d) and the fits of one electrode, log-log")
      ->check(pvdf::app::figure_file());
  sub->add_option("--electrode", o->electrode, "Electrode drawn by --plot (default B if the map has one, else the first)");
  sub->add_option("--plot-angles-deg", o->plot_angles, "Rays drawn by --plot, e.g. 45,65,85 (default 0,10,...,90)");
  sub->add_option("--measured", o->measured_path, "Add measured presses on the drawn rays to --plot (CSV as for `compare`; Fig. 12)");
  sub->add_option("--angle-tolerance-deg", o->angle_tolerance_deg, "A measured press is on a ray within this bearing (deg) (default 2)")
      ->check(pvdf::app::number_in(0, 180, "deg", true));
  return pvdf::app::Subcommand{sub, [o] { return run_rays(*o); }};
});
