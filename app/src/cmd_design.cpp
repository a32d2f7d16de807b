// `pvdfkit design`: compare candidate sensor layouts before fabrication. Each layout's
// charge map (FEM preview, synthetic stand-in, or a ready map file) → Cramér–Rao error maps,
// ambiguity, sensitivity, dynamic range, dead zones → a ranking, side-by-side PNG maps, and for
// a sweep of one scene key the figure of merit against the swept value. docs/design.md. The
// layout search (--optimize) is cmd_design_optimize.cpp; what both share, cmd_design.hpp.
#include "cmd_design.hpp"
#include "command.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/mapping/map_io.hpp"
#include "pvdf/plot/plot.hpp"
#include "pvdf/core/resources.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/mapping/design.hpp"
#include "pvdf/mapping/map.hpp"
#ifdef PVDF_HAVE_MAP_GENERATION
#include "pvdf/mapping/design_fem_maps.hpp"
#endif

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <limits>
#include <memory>
#include <optional>

namespace pvdf::app::design {

using namespace pvdf::mapping;

std::string stem(const std::string& path) {
  std::string s = path.substr(path.find_last_of('/') + 1);
  const std::size_t dot = s.rfind('.');
  return dot == std::string::npos || dot == 0 ? s : s.substr(0, dot);
}

/// mm with "unbounded" for +∞ (never "inf" or "nan" as a result).
std::string mm(double m) { return std::isfinite(m) ? pvdf::format_printf(m < 1e-4 ? "%.4f mm" : "%.3g mm", m * 1e3) : "unbounded"; }
std::string pct(double f) { return std::isfinite(f) ? pvdf::format_printf("%.1f %%", 100 * f) : "unbounded"; }

// ---------------------------------------------------------------------------------------------
// Maps: the source the flags choose (the study itself is mapping::run_design_study)

DesignMapSource design_maps(const DesignCommandOptions& o, std::vector<MemorySample>* memory,
                            const std::string& progress_label) {
  if (o.synthetic) return synthetic_design_maps(o.force_N);
#ifdef PVDF_HAVE_MAP_GENERATION
  DesignFemMaps fem;
  fem.force_N = o.force_N;
  fem.tolerance = o.tolerance;
  fem.threads = o.threads;
  fem.maps_dir = o.out_dir + "/maps";
  fem.quiet = o.quiet;
  fem.progress_label = progress_label;
  fem.memory = memory;
  fem.warn = [](const std::string& message) { pvdf::app::warn(message); };
  return fem_design_maps(fem);
#else
  (void)memory;
  (void)progress_label;
  DesignMapSource maps;
  maps.make_map = [](DesignCandidate&, double, std::size_t) {
    throw pvdf::InputError("this pvdfkit was built without FEM map generation (PVDF_WITH_FEM=OFF): use --synthetic for "
                           "a preview, or --map MAP.h5 with a map from another build");
  };
  return maps;
#endif
}

// ---------------------------------------------------------------------------------------------
// Text and JSON

void print_table(const std::vector<const Candidate*>& ranked, const std::string& title) {
  std::printf("\n%s\n", title.c_str());
  std::printf("%4s  %-34s %8s %9s %12s %11s %10s %10s %7s %8s %9s %7s  %s\n", "rank", "layout", "usable", "coverage",
              "median σpos", "p90 σpos", "median σF", "ambiguous", "dead", "singular", "FS (pC)", "LSB/σ", "map");
  int rank = 0;
  for (const Candidate* c : ranked) {
    const auto& s = c->summary;
    std::string label = c->label;
    if (label.size() > 34) label = label.substr(0, 31) + "...";
    std::printf("%4d  %-34s %8s %9s %12s %11s %10s %10s %7s %8s %9.3g %7.2g  %s %.2g mm%s\n", ++rank, label.c_str(),
                pct(s.usable_fraction).c_str(), pct(s.coverage).c_str(), mm(s.median_sigma_pos_m).c_str(),
                mm(s.p90_sigma_pos_m).c_str(), pct(s.median_sigma_force_rel).c_str(), pct(s.ambiguous_fraction).c_str(),
                pct(s.dead_fraction).c_str(), pct(s.singular_fraction).c_str(), s.full_scale_C * 1e12, s.lsb_over_noise,
                c->map_source.c_str(), s.spacing_m * 1e3, s.status == DesignStatus::ok ? "" : "  UNABLE TO LOCATE");
  }
}

void print_details(const Candidate& c) {
  const auto& s = c.summary;
  std::printf("  %s: %s", c.label.c_str(), design_status_name(s.status).c_str());
  if (!s.status_reason.empty()) std::printf(" (%s)", s.status_reason.c_str());
  std::printf("; model %s, tolerance %.3g, %zu of %zu mapped nodes evaluated; silent ambiguity %s; saturated at %.3g N: %s; "
              "an electrode below 1 LSB at %.3g N: %s\n",
              s.model.c_str(), s.tolerance, s.n_evaluated, s.n_mapped, pct(s.silent_ambiguous_fraction).c_str(),
              s.max_force_N, pct(s.saturated_fraction).c_str(), s.min_force_N, pct(s.below_lsb_fraction).c_str());
  std::printf("    median σpos with the force known: %s\n", mm(s.median_sigma_pos_known_force_m).c_str());
  for (const auto& e : s.electrodes) {
    std::printf("    %-6s sensitivity %s pC/N on its centre, median %.3g pC/N over the film; max %.4g pC at %.3g N; "
                "noise %.3g pC (with quantization %.3g pC)\n",
                e.name.c_str(),
                std::isfinite(e.sensitivity_at_center_C_per_N) ? pvdf::format_printf("%.3g", e.sensitivity_at_center_C_per_N * 1e12).c_str()
                                                                 : "n/a",
                e.median_sensitivity_C_per_N * 1e12, e.max_charge_C * 1e12, s.max_force_N, e.noise_C * 1e12,
                e.effective_noise_C * 1e12);
  }
}

// ---------------------------------------------------------------------------------------------
// Figures

std::vector<std::array<double, 2>> outline_mm(const pvdf::FilmOutline& o) {
  std::vector<std::array<double, 2>> v;
  using pvdf::pi;
  switch (o.shape) {
    case pvdf::FilmOutline::Shape::circle:
    case pvdf::FilmOutline::Shape::ellipse: {
      const double a = o.shape == pvdf::FilmOutline::Shape::circle ? o.radius_m : o.semi_axes_m[0];
      const double b = o.shape == pvdf::FilmOutline::Shape::circle ? o.radius_m : o.semi_axes_m[1];
      for (int i = 0; i < 128; ++i) v.push_back({1e3 * a * std::cos(2 * pi * i / 128), 1e3 * b * std::sin(2 * pi * i / 128)});
      break;
    }
    case pvdf::FilmOutline::Shape::rectangle: {
      const double w = 500 * o.size_m[0], h = 500 * o.size_m[1];
      v = {{-w, -h}, {w, -h}, {w, h}, {-w, h}};
      break;
    }
    case pvdf::FilmOutline::Shape::polygon:
      for (const auto& p : o.vertices_m) v.push_back({1e3 * p[0], 1e3 * p[1]});
      break;
  }
  return v;
}

/// One panel: `values` × `scale` (m → mm, or a fraction → %) over the map on a log colour scale
/// labelled in those units, the target contour, ambiguous (red ×), dead (grey) and failed (dark grey +) nodes, the
/// electrodes and the film outline; the legend below the panel, off the data.
void map_panel(pvdf::plot::Axes& ax, const Candidate& c, const std::vector<double>& values, double scale, double vmin,
               double vmax, double contour_at, const std::string& bar_label) {
  const DesignMaps& m = c.summary.maps;
  pvdf::plot::Grid g;
  g.nx = m.x_m.size();
  g.ny = m.y_m.size();
  g.x0 = m.x_m.front() * 1e3;
  g.x1 = m.x_m.back() * 1e3;
  g.y0 = m.y_m.front() * 1e3;
  g.y1 = m.y_m.back() * 1e3;
  g.values.assign(g.nx * g.ny, std::nan(""));
  pvdf::plot::Grid for_contour = g;
  std::vector<double> ax_x, ax_y, dx, dy, fx, fy;
  const std::size_t n_nodes = c.map.mask.size();
  for (std::size_t p = 0; p < g.values.size(); ++p) {
    // A node of the film whose solve failed at some level (not converged, or never computed) has no
    // value to draw: marked, so that the blank there is not read as the film's edge.
    if (p < n_nodes && c.map.mask[p]) {
      bool failed = false;
      for (std::size_t q = p; q < c.map.status.size(); q += n_nodes) failed = failed || c.map.status[q] != std::uint8_t(pvdf::mapping::PointStatus::ok);
      if (failed) {
        fx.push_back(m.x_m[p % g.nx] * 1e3);
        fy.push_back(m.y_m[p / g.nx] * 1e3);
      }
    }
    if (!m.evaluated[p]) continue;
    const double v = values[p] * scale;
    // Not clamped: values beyond [vmin, vmax] take the end colours and the colour bar marks that
    // with a triangle. Unbounded (no finite bound) is drawn as beyond the top.
    g.values[p] = std::isfinite(v) && v > 0 ? v : std::numeric_limits<double>::infinity();
    // The contour is traced on log10 of the values (the colours' interpolant, pvdf::plot), with
    // finite values: unbounded stands 100 × above the scale.
    for_contour.values[p] = std::log10(std::isfinite(v) && v > 0 ? v : 100 * vmax);
    const double x = m.x_m[p % g.nx] * 1e3, y = m.y_m[p / g.nx] * 1e3;
    if (m.ambiguous[p]) {
      ax_x.push_back(x);
      ax_y.push_back(y);
    }
    if (m.dead[p]) {
      dx.push_back(x);
      dy.push_back(y);
    }
  }
  std::optional<pvdf::Scene> scene;
  try {
    scene = pvdf::parse_scene(nlohmann::json::parse(c.map.scene_json), c.source);
  } catch (const std::exception&) {
    // a map without a readable scene: no outline, electrodes as squares (below)
  }
  ax.field(g, bar_label, false, vmin, vmax).log_color();
  // The mapped area (film less the rim margin) ends on its own curve, any film shape, not on the
  // grid's steps (plot::Axes::field_domain).
  if (scene) ax.field_domain(outline_mm(scene->membrane.outline), 1e3 * c.map.rim_margin_m);
  if (!ax_x.empty()) ax.scatter(ax_x, ax_y, "ambiguous", pvdf::plot::Color{220, 30, 30}, pvdf::plot::Marker::cross, 2.0);
  if (!dx.empty()) ax.scatter(dx, dy, "dead zone", pvdf::plot::Color{150, 150, 150}, pvdf::plot::Marker::square, 2.0);
  if (!fx.empty()) ax.scatter(fx, fy, "no map value (solve failed)", pvdf::plot::Color{60, 60, 60}, pvdf::plot::Marker::plus, 4.0);
  // The target line last, so that the markers do not hide it.
  if (contour_at > vmin && contour_at < vmax) ax.contour(for_contour, {std::log10(contour_at)}, pvdf::plot::Color{255, 255, 255}, 2.0);
  if (scene) {
    ax.polygon(outline_mm(scene->membrane.outline), std::nullopt, pvdf::plot::Color{0, 0, 0}, 1.5);
    for (const auto& e : scene->electrodes) {
      std::vector<std::array<double, 2>> v;
      for (const auto& p : e.outline()) v.push_back({p[0] * 1e3, p[1] * 1e3});
      ax.polygon(v, pvdf::plot::Color{255, 255, 255}, pvdf::plot::Color{0, 0, 0}, 1.0);
    }
  } else {
    std::vector<double> ex, ey;
    for (const auto& e : c.map.electrode_centers_m) {
      ex.push_back(e[0] * 1e3);
      ey.push_back(e[1] * 1e3);
    }
    ax.scatter(ex, ey, "electrodes", pvdf::plot::Color{255, 255, 255}, pvdf::plot::Marker::square, 7.0);
  }
  ax.xlabel("x (mm)").ylabel("y (mm)").equal_aspect().legend(ax_x.empty() && dx.empty() && fx.empty() ? "none" : "outside below");
}

void write_map_figures(const std::vector<const Candidate*>& ranked, const DesignCommandOptions& o,
                       const std::string& noise_text, std::vector<std::string>& written) {
  const std::size_t n = std::min<std::size_t>(ranked.size(), 8);
  const int cols = int(std::min<std::size_t>(n, 4)), rows = int((n + 3) / 4);
  bool any_synthetic = false;
  for (std::size_t i = 0; i < n; ++i) any_synthetic |= ranked[i]->summary.synthetic;
  const std::string kind = any_synthetic ? " — SYNTHETIC maps" : "";
  const double target = o.target_mm;
  for (int which = 0; which < 2; ++which) {
    pvdf::plot::Figure fig(std::max(1100, 460 * cols + 110), 430 * rows + 40, rows, cols);
    fig.shared_colorbar();  // every panel uses the same colour scale
    for (std::size_t i = 0; i < n; ++i) {
      const Candidate& c = *ranked[i];
      auto& ax = fig.axes(int(i) / 4, int(i) % 4);
      if (which == 0) {
        map_panel(ax, c, c.summary.maps.sigma_pos_m, 1e3, target / 100, target * 20, target, "σ$_{pos}$ (mm)");
        ax.title("#" + std::to_string(i + 1) + " " + c.label + ": usable " + pct(c.summary.usable_fraction));
      } else {
        map_panel(ax, c, c.summary.maps.sigma_force_rel, 100, 0.01, 100, 1, "σ$_F$/F (%)");
        ax.title("#" + std::to_string(i + 1) + " " + c.label + ": median " + pct(c.summary.median_sigma_force_rel));
      }
    }
    const std::string what = which == 0 ? "Position bound" : "Force bound";
    fig.suptitle(what + std::string(o.force_known ? " (force known), " : " (force unknown), ") + noise_text + ", " +
                 pvdf::format_printf("%.3g N", o.force_N) + (which == 0 ? ", white line " + pvdf::format_printf("%.3g mm", target) : ", white line 1 %") + kind);
    const std::string path = o.out_dir + (which == 0 ? "/design_position.png" : "/design_force.png");
    fig.save(path);
    written.push_back(path);
  }
}

/// Axis label and scale for a swept scene key: words and a display unit instead of the CLI key
/// ("@layout_radius_m" → "electrode layout radius (mm)", values × 1000).
struct SweepAxis {
  std::string name, unit;  // "electrode layout radius", "mm"
  double scale = 1;        // display value = scene value × scale
  std::string label() const { return name + (unit.empty() ? "" : " (" + unit + ")"); }
};

SweepAxis sweep_axis(const std::string& key) {
  if (key == "@layout_scale") return {"electrode layout scale factor", "", 1};
  if (key == "@layout_radius_m") return {"electrode layout radius", "mm", 1e3};
  if (key == "@rotation_deg") return {"layout rotation", "°", 1};
  if (key == "@electrode_size_m") return {"electrode size", "mm", 1e3};
  // A path into the scene: its last name, the SI suffix turned into a display unit.
  std::string name = key.substr(key.find_last_of('.') == std::string::npos ? 0 : key.find_last_of('.') + 1);
  name = name.substr(0, name.find('['));
  const struct { const char* suffix; const char* unit; double scale; } units[] = {
      {"_N_per_m", "N/m", 1}, {"_deg", "°", 1}, {"_Pa", "GPa", 1e-9}, {"_m", "mm", 1e3}, {"_N", "N", 1}, {"_C", "pC", 1e12}};
  std::string unit;
  double scale = 1;
  for (const auto& u : units) {
    const std::string s = u.suffix;
    if (name.size() > s.size() && name.compare(name.size() - s.size(), s.size(), s) == 0) {
      name.erase(name.size() - s.size());
      unit = u.unit;
      scale = u.scale;
      break;
    }
  }
  std::replace(name.begin(), name.end(), '_', ' ');
  return {name, unit, scale};
}

void write_sweep_figure(const std::vector<Candidate>& all, const std::vector<std::string>& series_names,
                        const DesignCommandOptions& o, const std::string& key, std::vector<std::string>& written) {
  pvdf::plot::Figure fig(1200, 520, 1, 2);
  const SweepAxis axis = sweep_axis(key);
  auto& a = fig.axes(0, 0);
  auto& b = fig.axes(0, 1);
  bool synthetic = false;
  for (std::size_t s = 0; s < series_names.size(); ++s) {
    std::vector<double> x, usable, coverage, median;
    for (const auto& c : all) {
      if (c.series != int(s) || c.refined) continue;
      synthetic |= c.summary.synthetic;
      x.push_back(c.sweep_value * axis.scale);
      usable.push_back(100 * c.summary.usable_fraction);
      coverage.push_back(100 * c.summary.coverage);
      median.push_back(std::isfinite(c.summary.median_sigma_pos_m) ? c.summary.median_sigma_pos_m * 1e3 : std::nan(""));
    }
    const Candidate* best = best_in_series(all, int(s));
    const auto color = pvdf::plot::cycle_color(s);
    a.line(x, usable, series_names[s] + ": usable", color, pvdf::plot::LineStyle::solid, pvdf::plot::Marker::circle);
    a.line(x, coverage, series_names[s] + ": coverage", color, pvdf::plot::LineStyle::dashed, pvdf::plot::Marker::none);
    b.line(x, median, series_names[s], color, pvdf::plot::LineStyle::solid, pvdf::plot::Marker::circle);
    if (best) {
      a.scatter({best->sweep_value * axis.scale}, {100 * best->summary.usable_fraction},
                "best: " + pvdf::format_printf("%.4g", best->sweep_value * axis.scale) + (axis.unit.empty() ? "" : " " + axis.unit), pvdf::plot::Color{220, 30, 30},
                pvdf::plot::Marker::square, 12);
      a.vline(best->sweep_value * axis.scale, pvdf::plot::Color{220, 30, 30});
    }
  }
  a.xlabel(axis.label()).ylabel("area fraction (%)").title(pvdf::format_printf("usable and covered area (σ$_{pos}$ ≤ %.3g mm)", o.target_mm)).grid_lines().legend("best");
  b.xlabel(axis.label()).ylabel("median σ$_{pos}$ (mm)").log_y().title("median position bound").grid_lines().legend("best");
  fig.suptitle("Design sweep of the " + axis.name + " (--vary " + key + ")" +
               (synthetic ? " — SYNTHETIC stand-in maps, not FEM" : ""));
  const std::string path = o.out_dir + "/design_sweep.png";
  fig.save(path);
  written.push_back(path);
}

// ---------------------------------------------------------------------------------------------

/// How check_design_options names an option: as this command's flag ("--noise-C -1e-14",
/// "--target-mm 0", "--force-range-N MIN 0").
std::string design_flag_named(const std::string& key, const std::string& value) {
  if (key == "min_force_N") return "--force-range-N MIN " + value;
  if (key == "max_force_N") return "--force-range-N MAX " + value;
  if (key == "target_m") {
    double m = 0;
    try {
      m = std::stod(value);
    } catch (const std::exception&) {
      return "--target-mm (" + value + " m)";
    }
    return "--target-mm " + pvdf::format_g(m * 1e3);
  }
  if (key.rfind("noise_C", 0) == 0) return "--noise-C " + value;
  if (key == "ambiguity_min_distance_m") return "--ambiguity-distance-m " + value;
  std::string flag = "--" + key;  // force_N, adc_bits, full_scale_C
  std::replace(flag.begin(), flag.end(), '_', '-');
  return value.empty() ? flag : flag + " " + value;
}

/// The analysis options from the command's flags, checked by the library's rule
/// (check_design_options, which the Python design and optimize_layouts share).
DesignOptions design_options(const DesignCommandOptions& o) {
  if (o.scenes.empty() && o.maps.empty()) {
    throw pvdf::InputError("nothing to compare: give one or more SCENE files (or --map MAP.h5)");
  }
  if (!o.vary.empty() && o.scenes.empty()) throw pvdf::InputError("--vary needs a SCENE to vary");
  if (o.spacing_m < 0 || o.refine_spacing_m < 0) throw pvdf::InputError("--spacing-m and --refine-spacing-m must be > 0 (m)");
  if (o.refine_best < 0) throw pvdf::InputError("--refine-best must be >= 0");

  DesignOptions d;
  d.noise_C = pvdf::parse_number_list(o.noise, "--noise-C");
  const auto range = pvdf::parse_number_list(o.force_range, "--force-range-N", 2);
  d.min_force_N = range[0];
  d.max_force_N = range[1];
  d.force_N = o.force_N;
  d.force_known = o.force_known;
  d.target_m = o.target_mm * 1e-3;
  d.adc_bits = o.adc_bits;
  d.include_map_error = o.include_map_error;
  d.full_scale_C = o.full_scale_C;
  d.ambiguity_min_distance_m = o.ambiguity_min_distance_m;
  pvdf::mapping::check_design_options(d, design_flag_named);
  return d;
}

/// The figures' noise label: "σ = 0.05 pC, 12-bit ADC" (per electrode "0.05/0.1" when they differ).
std::string noise_label(const DesignOptions& d, const DesignCommandOptions& o) {
  std::string text;
  for (std::size_t k = 0; k < d.noise_C.size(); ++k) text += (k ? "/" : "") + pvdf::format_printf("%.3g", d.noise_C[k] * 1e12);
  return "σ = " + text + " pC" + (o.adc_bits > 0 ? ", " + std::to_string(o.adc_bits) + "-bit ADC" : "");
}

/// The candidates: each scene (or each value of the swept key on each scene), then each ready map.
/// `series_names` gets one name per scene.
std::vector<Candidate> collect_candidates(const DesignCommandOptions& o, const std::optional<SceneSweep>& sweep,
                                          std::vector<std::string>& series_names) {
  std::vector<Candidate> all;
  for (const auto& path : o.scenes) {
    const pvdf::Scene scene = pvdf::load_scene(path);
    for (const auto& w : scene.warnings) pvdf::app::warn(w);
    const int series = int(series_names.size());
    series_names.push_back(stem(path));
    try {
      for (auto& c : scene_candidates(scene.original, path, stem(path), series, sweep)) all.push_back(std::move(c));
    } catch (const pvdf::InputError& e) {
      throw pvdf::InputError(std::string("--vary: ") + e.what());
    }
  }
  if (sweep && o.synthetic && all.size() >= 2 && same_synthetic_stand_in(all[0], all[1])) {
    // The stand-in sees only geometry, draw angle, d32/d31 and electrode area: say so when the
    // swept key changes none of them.
    pvdf::app::warn("--vary " + sweep->key + " does not change the synthetic stand-in (it models only geometry, draw "
                    "angle, d32/d31 and electrode area): every value will score the same; drop --synthetic for FEM maps");
  }
  for (const auto& path : o.maps) all.push_back(ready_map_candidate(path, stem(path), read_map(path)));
  return all;
}

/// The ranking as text: settings, tables, details, the best layout and the files written.
void print_design_text(const DesignCommandOptions& o, const DesignOptions& d, std::size_t n_layouts, bool any_synthetic,
                       const std::string& noise_text, const std::vector<const Candidate*>& ranked,
                       const std::vector<const Candidate*>& ranked_refined, const Candidate* best,
                       const std::vector<std::string>& written) {
  std::printf("pvdfkit design: %zu layout%s; maps: %s\n", n_layouts, n_layouts == 1 ? "" : "s",
              any_synthetic ? "SYNTHETIC stand-in (geometry, draw angle, d32/d31, electrode area only; not FEM)"
                            : "FEM (pvdfkit map engine) or files");
  std::printf("noise %s, press %.3g N, force range %.3g-%.3g N, force %s, target σpos <= %.3g mm\n",
              noise_text.c_str(), d.force_N, d.min_force_N, d.max_force_N, d.force_known ? "known" : "unknown",
              o.target_mm);
  std::printf("usable = σpos within target, not ambiguous, not dead (figure of merit); σpos = RMS radial error "
              "√(Cxx+Cyy) of the Cramér–Rao bound; σF = relative force bound\n");
  print_table(ranked, "Ranking (preview)");
  for (const Candidate* c : ranked) print_details(*c);
  if (!ranked_refined.empty()) {
    print_table(ranked_refined, "Ranking of the refined winners");
    for (const Candidate* c : ranked_refined) print_details(*c);
  }
  std::printf("\nbest: %s\n", best->label.c_str());
  for (const auto& w : written) std::printf("wrote %s\n", w.c_str());
  if (!o.no_plots) std::printf("wrote %s/design.json\n", o.out_dir.c_str());
}

int run_design(const DesignCommandOptions& o) {
  if (o.optimize) return run_optimize(o);
  const DesignOptions d = design_options(o);
  const double spacing = o.spacing_m > 0 ? o.spacing_m : (o.synthetic ? 0.001 : 0.003);

  // Step 1: the candidates.
  std::vector<std::string> series_names;
  std::optional<SceneSweep> sweep;
  try {
    if (!o.vary.empty()) sweep = parse_scene_sweep(o.vary);
  } catch (const pvdf::InputError& e) {
    throw pvdf::InputError(std::string("--vary: ") + e.what());
  }
  std::vector<Candidate> all = collect_candidates(o, sweep, series_names);
  if (!o.no_plots && std::filesystem::is_directory(o.out_dir)) {
    // The files the run ends with, checked before the maps are computed (a device or a link
    // where design.json belongs is refused now, not after the work).
    for (const char* name : {"/design.json", "/design_position.png", "/design_force.png", "/design_sweep.png"}) {
      pvdf::app::check_output_file(o.out_dir + name, "--out-dir");
    }
  }

  // Step 2: the study (mapping::run_design_study): preview maps, their evaluation and ranking, the
  // winners refined at a finer spacing and ranked again.
  DesignStudyOptions so;
  so.analysis = d;
  so.spacing_m = spacing;
  so.refine_best = o.refine_best;
  so.refine_spacing_m = o.refine_spacing_m;
  std::vector<MemorySample> memory;
  DesignStudy study = run_design_study(std::move(all), so, design_maps(o, &memory));
  const std::vector<Candidate>& candidates = study.candidates;
  DesignStudyReport& report = study.report;

  // Step 3: report.
  const std::string noise_text = noise_label(d, o);
  std::vector<std::string> written;
  if (!o.no_plots) {
    pvdf::make_directories(o.out_dir);
    write_map_figures(report.ranked_refined.empty() ? report.ranked : report.ranked_refined, o, noise_text, written);
    if (sweep) write_sweep_figure(candidates, series_names, o, sweep->key, written);
  }
  report.sweep = sweep;
  report.figures = written;
  const Candidate* best = &report.best();
  nlohmann::json j = design_study_json(d, report);  // what --json prints and design.json holds
  j["peak_resident_bytes"] = pvdf::peak_resident_bytes();
  j["memory"] = nlohmann::json::array();
  for (const auto& m : memory) {
    j["memory"].push_back({{"phase", m.phase}, {"positions", m.positions}, {"resident_bytes", m.resident_bytes}});
  }
  if (!o.no_plots) {
    pvdf::write_file_atomically(o.out_dir + "/design.json", [&j](std::ostream& out) { out << j.dump(2) << '\n'; });
  }

  if (o.json) {
    std::cout << j.dump(2) << '\n';
  } else {
    print_design_text(o, d, candidates.size(), report.synthetic, noise_text, report.ranked, report.ranked_refined, best,
                      written);
  }
  // Every layout unable to locate is a numerical outcome, not a ranking.
  if (study.any_can_locate()) return pvdf::exit_code::success;
  std::cerr << "error: no layout can locate a press (singular Fisher matrix everywhere)\n";
  return pvdf::exit_code::numerical;
}

}  // namespace pvdf::app::design

PVDF_COMMAND(75, [](CLI::App& root) {
  using pvdf::app::design::DesignCommandOptions;
  using pvdf::app::design::run_design;
  auto* sub = root.add_subcommand(
      "design",
      "Compare candidate sensor layouts before fabrication: Cramer-Rao error maps, coverage, ambiguity, "
      "sensitivity, dynamic range, dead zones; ranking and PNG maps (docs/design.md)");
  auto o = std::make_shared<DesignCommandOptions>();
  sub->add_option("SCENE", o->scenes, "Scene file(s) (JSON, docs/scene.md) of the candidate layouts");
  sub->add_option("--vary", o->vary,
                  "Sweep one scene key, KEY=START:STEP:STOP, e.g. material.draw_angle_deg=0:15:90, "
                  "electrodes[0].center_m[1]=0.008:0.002:0.016, @layout_radius_m=0.006:0.002:0.02, @rotation_deg, "
                  "@layout_scale, @electrode_size_m (docs/design.md)");
  sub->add_option("--noise-C", o->noise, "1-sigma charge noise per electrode before quantization, one value or one per electrode (C) (default 5e-14)");
  sub->add_option("--target-mm", o->target_mm, "Coverage target for the position bound (mm) (default 0.5)")
      ->check(pvdf::app::number_in(0, 1000, "mm", true));
  sub->add_option("--force-N", o->force_N, "Force of the evaluated presses (N), the force level of FEM maps (default 1)")
      ->check(pvdf::app::number_in(0, 1e4, "N (the rule of loads[].force_N, pushing)", true));
  sub->add_option("--force-range-N", o->force_range, "Forces the sensor must serve MIN,MAX (N): ADC full scale at MAX, 1-LSB check at MIN (default 0.25,4)");
  sub->add_flag("--include-map-error", o->include_map_error,
                "Add each map node's estimated charge error to the noise (the bound of a lookup on this map) (default "
                "the sensor's noise alone)");
  sub->add_flag("--force-known", o->force_known, "Figure of merit with the force measured separately (fit x, y only)");
  sub->add_option("--spacing-m", o->spacing_m, "Grid spacing of the preview maps (m) (default 0.003 for FEM maps: a preview, coarser than `map`'s 0.002; 0.001 "
                  "with --synthetic)")
      ->check(pvdf::app::number_in(1e-4, 0.02, "m (the range of synthetic-map)"));
  sub->add_flag("--synthetic", o->synthetic, "Instant previews on the analytic stand-in instead of FEM maps (labelled synthetic)");
  sub->add_option("--map", o->maps, "Evaluate a ready charge map (HDF5) as one more layout (repeatable)");
  sub->add_option("--refine-best", o->refine_best, "Recompute the best N layouts at --refine-spacing-m and rank them again (default 0)")
      ->check(pvdf::app::integer_in(0, 1000));
  sub->add_option("--refine-spacing-m", o->refine_spacing_m, "Grid spacing of the refined maps (m) (default half the preview spacing)")
      ->check(pvdf::app::number_in(1e-4, 0.02, "m (the range of synthetic-map)"));
  sub->add_option("--tolerance", o->tolerance, "FEM maps: requested relative charge error (default the scene's model.tolerance)")
      ->check(pvdf::app::number_in(1e-8, 0.5, "(the rule of the scene key model.tolerance), e.g. 0.01"));
  sub->add_option("--threads", o->threads, "FEM maps: worker threads, 0 = all cores (default 0)")->check(pvdf::app::integer_in(0, 1024));
  sub->add_option("--adc-bits", o->adc_bits, "ADC resolution (bits, bipolar); 0 = ideal (default 12)")
      ->check(pvdf::app::integer_in(0, 32));
  sub->add_option("--full-scale-C", o->full_scale_C, "ADC full scale (C) (default 1.25 x the largest charge at the top of the force range)")
      ->check(pvdf::app::number_in(0, 1e-3, "C", true));
  sub->add_option("--ambiguity-distance-m", o->ambiguity_min_distance_m,
                  "Another accepted solution farther than max(this, 3 sigma) is a distinct press (m) (default the target)")
      ->check(pvdf::app::number_in(0, 1, "m"));
  sub->add_flag("--json", o->json, "Print the ranking as JSON");
  sub->add_flag("--optimize", o->optimize,
                "Search electrode layouts (counts, centres, sizes, angles) on the SCENE's film instead of ranking typed "
                "ones; maps from --atlas (or --synthetic); docs/design.md section 7");
  sub->add_option("--atlas", o->atlas_path, "--optimize: charge-density atlas of the film (`pvdfkit atlas`)");
  sub->add_option("--electrodes-min", o->electrodes_min, "--optimize: fewest electrodes (default 3)");
  sub->add_option("--electrodes-max", o->electrodes_max, "--optimize: most electrodes (default 6)");
  sub->add_option("--size-min-m", o->size_min_m, "--optimize: smallest electrode side (m) (default 0.001)");
  sub->add_option("--size-max-m", o->size_max_m, "--optimize: largest electrode side (m) (default 0.004)");
  sub->add_flag("--square", o->square, "--optimize: square electrodes only (default rectangles w x h)");
  sub->add_flag("--no-rotation", o->no_rotation, "--optimize: electrodes axis-aligned (default any angle)");
  sub->add_option("--min-gap-m", o->min_gap_m, "--optimize: smallest distance between two electrodes (m) (default 0.0005)");
  sub->add_option("--clamp-margin-m", o->clamp_margin_m,
                  "--optimize: every electrode corner at least this far inside the clamp outline (m) (default 0.001)");
  sub->add_option("--seed", o->seed, "--optimize: random seed; equal seeds give equal results (default 1)");
  sub->add_option("--budget", o->budget, "--optimize: evaluations (map + analysis) per electrode count (default 300)");
  sub->add_option("--search-stride", o->search_stride,
                  "--optimize: evaluate every N-th grid node during the search, winners on the full grid (default 1)");
  sub->add_flag("--verify", o->verify, "--optimize --atlas: FEM map of each winner at the atlas's grid, evaluated again (slow)");
  sub->add_option("-o,--out-dir", o->out_dir, "Folder for design_position.png, design_force.png, design_sweep.png, design.json, maps/ (default design-out)")
      ->check(pvdf::app::output_folder());
  sub->add_flag("--no-plots", o->no_plots, "Write no files (ranking on stdout only)");
  sub->add_flag("--quiet", o->quiet, "No progress on stderr (warnings and errors are still reported)");
  return pvdf::app::Subcommand{sub, [o] { return run_design(*o); }};
});
