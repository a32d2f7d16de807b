// `pvdfkit fit SCENE measured.csv [--params NAME,...] -o fitted.json [--json] [--plot FILE.png]`:
// fits the film's effective physics to bench data on FEM predictions (docs/fem-vs-experiment.md).
#include "command.hpp"
#include "pvdf/core/resources.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/progress.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/fit/fit.hpp"
#include "pvdf/fit/report.hpp"

#include <nlohmann/json.hpp>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <sstream>

namespace {

struct FitCliOptions {
  std::string scene_path, measured_path, output_path, plot_path, params, start, residual_stiffness;
  bool json = false, verbose = false, quiet = false, params_given = false;
  double tolerance = 0;
  int max_iterations = 40;
};

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    const auto a = item.find_first_not_of(' '), b = item.find_last_not_of(' ');
    if (a != std::string::npos) out.push_back(item.substr(a, b - a + 1));
  }
  return out;
}

/// Refuses an empty item in a comma list (`--params E_scale,,`): split() would drop it silently.
void check_no_empty_item(const std::string& text, const std::string& flag) {
  std::stringstream ss(text + ",");
  std::string item;
  while (std::getline(ss, item, ',')) {
    if (item.find_first_not_of(' ') == std::string::npos) {
      throw pvdf::InputError(flag + " " + pvdf::quote_cell(text) + ": has an empty item; separate the names by single commas");
    }
  }
}

std::map<std::string, double> parse_start(const std::string& text) {
  std::map<std::string, double> out;
  if (!text.empty()) check_no_empty_item(text, "--start");
  for (const auto& item : split(text)) {
    const auto eq = item.find('=');
    double v = 0;
    if (eq == std::string::npos || !pvdf::parse_finite(item.substr(eq + 1), v)) {
      throw pvdf::InputError("--start: '" + item + "' must be NAME=VALUE with a finite number, e.g. E_scale=0.02");
    }
    const std::string name = item.substr(0, eq);
    // Plausible starting values: a factor beyond 1e3 on the stiffness or a gain, or a piezo
    // constant beyond 1e-9 C/N (50 x any piezo polymer), is a typo or a unit slip, not a start.
    const bool factor = name == "E_scale" || name.rfind("gain_", 0) == 0;
    if (factor && !(v >= 1e-3 && v <= 1e3)) {
      throw pvdf::InputError("--start: " + pvdf::quote_cell(item) + ": " + name + " must lie in [1e-3, 1e3] (a factor on the scene's value)");
    }
    if ((name == "d31_C_per_N" || name == "d32_C_per_N") && !(std::abs(v) <= 1e-9)) {
      throw pvdf::InputError("--start: " + pvdf::quote_cell(item) + ": |" + name + "| must be <= 1e-9 C/N (PVDF: ~2e-11; is the unit pC/N?)");
    }
    out[name] = v;
  }
  return out;
}

void print_text(const pvdf::fit::FitResult& r, const pvdf::fit::MeasuredTable& m) {
  std::printf("fit of %s: %s (%d iterations, %zu FEM solves on %zu sweep meshes, %.1f s)\n", m.source.c_str(),
              pvdf::fit::status_name(r.status).c_str(), r.iterations, r.fem.n_solves, r.fem.n_sweeps, r.wall_s);
  std::printf("chi2 %.4g -> %.4g, %d degrees of freedom, reduced chi2 %.4g%s\n", r.chi2_start, r.chi2,
              r.degrees_of_freedom, r.reduced_chi2, r.sigmas_given ? "" : " (no sigma columns: relative sigmas)");
  std::printf("%-20s %14s %14s %14s %s\n", "parameter", "start", "value", "1-sigma", "");
  for (const auto& p : r.parameters) {
    std::printf("%-20s %14.6g %14.6g %14.3g %s\n", p.name.c_str(), p.start, p.value, p.sigma,
                p.at_bound ? "(at bound)" : (p.determined ? "" : "(NOT DETERMINED)"));
  }
  std::printf("correlation (column-scaled condition number %.3g):\n", r.condition_number);
  for (std::size_t a = 0; a < r.correlation.size(); ++a) {
    std::printf("  %-20s", r.parameters[a].name.c_str());
    for (double c : r.correlation[a]) std::printf(" %8.4f", c);
    std::printf("\n");
  }
  std::printf("residuals: %5s %-16s %12s %12s %12s %12s %8s\n", "line", "column", "measured", "sigma", "FEM start",
              "FEM fit", "(F-m)/s");
  for (const auto& o : r.observations) {
    std::printf("           %5zu %-16s %12.5g %12.3g %12.5g %12.5g %8.2f\n", o.line, o.column.c_str(), o.measured, o.sigma,
                o.predicted_start, o.predicted, o.normalized_residual);
  }
  const auto& s = r.fem.reference_setup;
  std::printf("FEM: %s%s, %zu DOFs, estimated charge error %.3g %%, deflection error %.3g %% (not in the intervals)\n",
              pvdf::fem::model_name(s.model).c_str(), s.include_bending ? " with bending" : " (bending neglected)",
              s.n_dofs, 100 * s.estimated_relative_error, 100 * s.estimated_deflection_relative_error);
  if (r.fem.residual_stiffness > 0) {
    std::printf("FEM: tension-field residual stiffness %g (slack-film stresses biased by about %g x |N0|)\n",
                r.fem.residual_stiffness, r.fem.residual_stiffness);
  }
}

int run_fit(const FitCliOptions& o) {
  const pvdf::Scene scene = pvdf::load_scene(o.scene_path);
  std::vector<std::string> names;
  for (const auto& e : scene.electrodes) names.push_back(e.name);
  pvdf::check_csv_file(o.measured_path, "MEASURED");  // rows, header and cells, before anything is read
  const pvdf::fit::MeasuredTable measured = pvdf::fit::read_measured(o.measured_path, names);
  pvdf::fit::check_measured_for_fit(measured, o.measured_path);
  pvdf::fit::FitOptions fo;
  if (o.params_given && !o.params.empty()) check_no_empty_item(o.params, "--params");
  fo.parameters = split(o.params);
  if (o.params_given && fo.parameters.empty()) {
    throw pvdf::InputError("--params '" + pvdf::quote_cell(o.params) + "' names no parameter; give NAME,... or omit "
                           "--params for the default");
  }
  fo.start = parse_start(o.start);
  {  // names refused here, naming the flag (the library checks the values)
    const std::vector<std::string> known = pvdf::fit::parameter_names(scene);
    std::string list;
    for (const auto& k : known) list += (list.empty() ? "" : ",") + k;
    const auto check = [&](const std::string& flag, const std::string& n) {
      if (std::find(known.begin(), known.end(), n) == known.end()) {
        throw pvdf::InputError(flag + ": '" + pvdf::escape_control_bytes(n) + "' is not a parameter of this scene; choose from " + list);
      }
    };
    for (const auto& n : fo.parameters) check("--params", n);
    for (const auto& kv : fo.start) check("--start", kv.first);
  }
  if (o.max_iterations < 1) throw pvdf::InputError("--max-iterations " + std::to_string(o.max_iterations) + " must be >= 1");
  fo.max_iterations = o.max_iterations;
  if (o.tolerance != 0) {
    if (!(o.tolerance >= 1e-6 && o.tolerance <= 0.5)) {
      throw pvdf::InputError("--tolerance " + std::to_string(o.tolerance) + " must be in [1e-6, 0.5]");
    }
    fo.predictor.use_scene_model = false;
    fo.predictor.sweep.solver = pvdf::fem::options_from_scene(scene);
    fo.predictor.sweep.solver.tolerance = o.tolerance;
  }
  if (!o.residual_stiffness.empty()) {
    double eps = 0;
    if (!pvdf::parse_finite(o.residual_stiffness, eps) || !(eps >= 0 && eps < 1)) {
      throw pvdf::InputError("--residual-stiffness '" + pvdf::escape_control_bytes(o.residual_stiffness) +
                             "' must be a number in [0, 1) (0 = the exact relaxed law; 1e-3 for strongly slack films)");
    }
    fo.predictor.sweep.solver.tension_field_residual_stiffness = eps;
  }
  // Progress on stderr (none with --quiet): per batch of FEM solves a bar with ETA on a terminal,
  // plain lines with ETA in a log (pvdf::Progress); the line of each Levenberg-Marquardt
  // iteration on a terminal or with --verbose, and in a log at most one per
  // Progress::line_interval_s() (an iteration line is the fit's pulse when batches are short).
  const bool tty = isatty(STDERR_FILENO) != 0;
  std::shared_ptr<pvdf::Progress> bar;
  if (!o.quiet) {
    fo.predictor.progress = [&bar](std::size_t done, std::size_t total) {
      if (done == 1) bar = std::make_shared<pvdf::Progress>("fit: FEM solves", total);
      if (bar) bar->update(done);
      if (bar && done == total) {
        bar->finish();
        bar.reset();
      }
    };
  }
  if (!o.quiet || o.verbose) {
    const bool every_line = tty || o.verbose;
    const double interval_s = pvdf::Progress::line_interval_s();
    auto last_line = std::make_shared<std::chrono::steady_clock::time_point>(std::chrono::steady_clock::now());
    fo.log = [every_line, interval_s, last_line](const std::string& line) {
      const auto now = std::chrono::steady_clock::now();
      if (!every_line && std::chrono::duration<double>(now - *last_line).count() < interval_s) return;
      *last_line = now;
      std::cerr << line << '\n';
    };
  }

  const pvdf::fit::FitResult r = pvdf::fit::fit_film(scene, measured, fo);
  const bool usable = r.status == pvdf::fit::FitStatus::converged;
  if (!o.plot_path.empty() && !r.observations.empty()) pvdf::fit::write_fit_png(r, measured, scene, o.plot_path);
  if (o.json) {
    nlohmann::json j = pvdf::fit::to_json(r, measured);
    j["peak_resident_bytes"] = pvdf::peak_resident_bytes();  // this process, so far (getrusage)
    j["scene"] = o.scene_path;
    j["fitted_scene"] = usable ? nlohmann::json(o.output_path) : nlohmann::json(nullptr);
    std::cout << j.dump(2) << '\n';
  } else if (!r.observations.empty()) {
    print_text(r, measured);
  }
  for (const auto& w : r.warnings) pvdf::app::warn(w);
  if (!usable) {
    std::cerr << "error: fit " << pvdf::fit::status_name(r.status) << ": " << r.message
              << "; no fitted scene written\n";
    return pvdf::exit_code::numerical;
  }
  nlohmann::json out = pvdf::scene_to_json(r.fitted_scene);
  std::ostringstream desc;
  desc << "fitted by pvdfkit fit to " << o.measured_path << " from " << o.scene_path << ":";
  for (const auto& p : r.parameters) desc << ' ' << p.name << " = " << p.value << " +- " << p.sigma << ';';
  desc << " electrode gains are not scene keys (see the fit report)";
  out["description"] = desc.str();
  pvdf::write_file_atomically(o.output_path, [&](std::ostream& os) { os << out.dump(2) << '\n'; });
  if (!o.json) {
    std::printf("fitted scene written to %s%s\n", o.output_path.c_str(),
                o.plot_path.empty() ? "" : (", figure to " + o.plot_path).c_str());
  }
  return pvdf::exit_code::success;
}

}  // namespace

PVDF_COMMAND(67, [](CLI::App& root) {
  auto* sub = root.add_subcommand(
      "fit", "Fit the film's pre-tension, stiffness scale, piezo constants and electrode gains to bench data on FEM "
             "predictions, with 1-sigma intervals and identifiability (docs/fem-vs-experiment.md)");
  auto o = std::make_shared<FitCliOptions>();
  sub->add_option("SCENE", o->scene_path, "Scene file (JSON, docs/scene.md) of the sensor: the starting values")->required();
  sub->add_option("MEASURED", o->measured_path,
                  "CSV: x_m,y_m,force_N and any of deflection_m, charge_<electrode>_C, with optional sigma_<column>")
      ->required();
  sub->add_option("--params", o->params,
                  "Parameters to fit, comma-separated: pretension_N_per_m, E_scale, d31_C_per_N, d32_C_per_N, "
                  "gain_<electrode> (default E_scale if deflections are given, d31_C_per_N if charges are)")
      ->each([o](const std::string&) { o->params_given = true; });
  sub->add_option("-o,--output", o->output_path, "Fitted scene (JSON, same format as SCENE)")
      ->required()
      ->check(pvdf::app::output_file());
  sub->add_flag("--json", o->json, "Print the result as JSON (keys in docs/fem-vs-experiment.md)");
  sub->add_option("--plot", o->plot_path, "Figure (.png, .svg or .pdf): measured against FEM before and after the fit")
      ->check(pvdf::app::figure_file());
  sub->add_option("--start", o->start, "Starting values NAME=VALUE,... (default the scene's, E_scale 1, gains 1)");
  sub->add_option("--tolerance", o->tolerance, "Requested relative error of the FEM predictions on the sweep mesh (default the scene's model.tolerance)")
      ->check(pvdf::app::number_in(1e-8, 0.5, "(the rule of the scene key model.tolerance), e.g. 0.01"));
  sub->add_option("--max-iterations", o->max_iterations, "Levenberg-Marquardt iterations (default 40)")
      ->check(pvdf::app::integer_in(1, 10000));
  sub->add_option("--residual-stiffness", o->residual_stiffness,
                  "Tension-field residual stiffness EPS in [0, 1) for slack films (negative pretension_N_per_m): the "
                  "membrane energy (1-EPS) W_relaxed + EPS W_elastic, with bending kept; 1e-3 lets strongly slack films "
                  "converge, biasing their membrane forces by about EPS x |N0|; docs/fem.md 3.3 (default 0: the exact relaxed law)")
      ->type_name("EPS");
  sub->add_flag("--verbose", o->verbose, "One line per iteration on stderr even when it is not a terminal "
                                         "(otherwise at most one each 10 s there)");
  sub->add_flag("--quiet", o->quiet, "No progress on stderr (warnings and errors are still reported)");
  return pvdf::app::Subcommand{sub, [o] {
    try {
      return run_fit(*o);
    } catch (const pvdf::InputError& e) {
      // The library names its options; on the command line they are flags.
      std::string what = e.what();
      for (const auto& [from, to] : {std::pair<std::string, std::string>{"FitOptions::start", "--start"},
                                     {"FitOptions::parameters", "--params"}}) {
        for (auto at = what.find(from); at != std::string::npos; at = what.find(from, at + to.size())) what.replace(at, from.size(), to);
      }
      throw pvdf::InputError(what);
    }
  }};
});
