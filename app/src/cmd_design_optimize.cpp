// `pvdfkit design --optimize` (docs/design.md section 7): electrode layouts searched on the SCENE's
// film (mapping::optimize_layouts) with maps from an atlas or the synthetic stand-in; the winners
// written as scenes, their error maps and the Pareto figure, optionally verified by FEM maps.
#include "cmd_design.hpp"
#include "command.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/progress.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/mapping/optimize.hpp"
#include "pvdf/plot/plot.hpp"
#ifdef PVDF_HAVE_MAP_GENERATION
#include "pvdf/mapping/atlas.hpp"
#include "pvdf/mapping/atlas_provider.hpp"
#endif

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <limits>
#include <memory>

namespace pvdf::app::design {

using namespace pvdf::mapping;

namespace {

/// How the library's checks name an option: as this command's flag ("--size-min-m 0", "--synthetic").
std::string flag_named(const std::string& key, const std::string& value) {
  std::string flag = "--" + key;
  std::replace(flag.begin(), flag.end(), '_', '-');
  return value.empty() ? flag : flag + " " + value;
}

/// The search settings from the flags (each checked by the library's rule, check_optimize_options,
/// which the Python optimize_layouts shares).
OptimizeOptions optimize_options(const DesignCommandOptions& o, const DesignOptions& d) {
  OptimizeOptions oo;
  oo.naming = flag_named;
  oo.electrodes_min = o.electrodes_min;
  oo.electrodes_max = o.electrodes_max;
  oo.size_min_m = o.size_min_m;
  oo.size_max_m = o.size_max_m;
  oo.square = o.square;
  oo.rotate = !o.no_rotation;
  oo.min_gap_m = o.min_gap_m;
  oo.clamp_margin_m = o.clamp_margin_m;
  if (o.seed < 0) throw pvdf::InputError("--seed " + std::to_string(o.seed) + " must be >= 0; give e.g. 1");
  if (o.budget < 0) {  // not representable below; 0 and the top of the range are the library's check
    throw pvdf::InputError("--budget " + std::to_string(o.budget) +
                           " must lie in [1, 1000000] (evaluations per electrode count); give e.g. 300");
  }
  oo.seed = std::uint64_t(o.seed);
  oo.budget = std::size_t(o.budget);
  oo.search_stride = o.search_stride;
  oo.design = d;
  check_optimize_options(oo);
  return oo;
}

/// The table of the winners (text): one row per count, the reference layout first.
std::string optimize_table(const OptimizeSummary& s) {
  std::string t;
  char line[256];
  std::snprintf(line, sizeof line, "%-10s %8s %9s %12s %11s %8s %9s  %s\n", "electrodes", "usable", "coverage",
                "median σpos", "evaluations", "rejected", "seconds", "status");
  t += line;
  if (s.reference_evaluated) {
    std::snprintf(line, sizeof line, "%-10s %8s %9s %12s %11s %8s %9s  %s\n",
                  ("ref " + std::to_string(s.reference.electrodes.size())).c_str(), pct(s.reference.usable_fraction).c_str(),
                  pct(s.reference.coverage).c_str(), mm(s.reference.median_sigma_pos_m).c_str(), "-", "-", "-",
                  "the scene's own layout");
    t += line;
  }
  for (std::size_t i = 0; i < s.counts.size(); ++i) {
    const CountResult& c = s.counts[i];
    if (c.found) {
      std::snprintf(line, sizeof line, "%-10d %8s %9s %12s %11zu %8zu %9.2f  %s%s\n", c.n_electrodes,
                    pct(c.summary.usable_fraction).c_str(), pct(c.summary.coverage).c_str(),
                    mm(c.summary.median_sigma_pos_m).c_str(), c.n_evaluations, c.n_rejected, c.seconds,
                    differential_evolution_status_name(c.status).c_str(), i == s.best ? "  BEST" : "");
    } else {
      std::snprintf(line, sizeof line, "%-10d %8s %9s %12s %11zu %8zu %9.2f  %s\n", c.n_electrodes, "-", "-", "-",
                    c.n_evaluations, c.n_rejected, c.seconds, "no layout meets the constraints");
    }
    t += line;
  }
  return t;
}

/// Usable area (and coverage) against the electrode count, and the median bound: the Pareto view
/// (more electrodes cost channels and wiring).
void write_pareto_figure(const OptimizeSummary& s, const DesignCommandOptions& o, bool synthetic,
                         std::vector<std::string>& written) {
  pvdf::plot::Figure fig(1200, 520, 1, 2);
  auto& a = fig.axes(0, 0);
  auto& b = fig.axes(0, 1);
  std::vector<double> n, usable, coverage, median;
  for (const auto& c : s.counts) {
    if (!c.found) continue;
    n.push_back(c.n_electrodes);
    usable.push_back(100 * c.summary.usable_fraction);
    coverage.push_back(100 * c.summary.coverage);
    median.push_back(std::isfinite(c.summary.median_sigma_pos_m) ? 1e3 * c.summary.median_sigma_pos_m : std::nan(""));
  }
  a.line(n, usable, "usable (best found)", pvdf::plot::cycle_color(0), pvdf::plot::LineStyle::solid, pvdf::plot::Marker::circle);
  a.line(n, coverage, "coverage", pvdf::plot::cycle_color(0), pvdf::plot::LineStyle::dashed, pvdf::plot::Marker::none);
  b.line(n, median, "best found", pvdf::plot::cycle_color(0), pvdf::plot::LineStyle::solid, pvdf::plot::Marker::circle);
  if (s.reference_evaluated) {
    const double nr = double(s.reference.electrodes.size());
    a.scatter({nr}, {100 * s.reference.usable_fraction}, "the scene's layout", pvdf::plot::Color{220, 30, 30},
              pvdf::plot::Marker::square, 10);
    if (std::isfinite(s.reference.median_sigma_pos_m)) {
      b.scatter({nr}, {1e3 * s.reference.median_sigma_pos_m}, "the scene's layout", pvdf::plot::Color{220, 30, 30},
                pvdf::plot::Marker::square, 10);
    }
  }
  // Whole electrode counts on x, half a count of room either side; on the log y of the median bound
  // room for every point (the scene's layout included) so that no marker sits on the frame.
  double n_lo = n.empty() ? 3 : n.front(), n_hi = n.empty() ? 3 : n.back();
  double m_lo = std::numeric_limits<double>::infinity(), m_hi = 0;
  for (double m : median)
    if (std::isfinite(m) && m > 0) m_lo = std::min(m_lo, m), m_hi = std::max(m_hi, m);
  if (s.reference_evaluated) {
    n_lo = std::min(n_lo, double(s.reference.electrodes.size()));
    n_hi = std::max(n_hi, double(s.reference.electrodes.size()));
    const double r = 1e3 * s.reference.median_sigma_pos_m;
    if (std::isfinite(r) && r > 0) m_lo = std::min(m_lo, r), m_hi = std::max(m_hi, r);
  }
  a.integer_x().xlim(n_lo - 0.5, n_hi + 0.5);
  b.integer_x().xlim(n_lo - 0.5, n_hi + 0.5);
  if (m_hi > 0 && std::isfinite(m_lo)) b.ylim(m_lo / 1.25, m_hi * 1.25);
  a.xlabel("electrodes").ylabel("area fraction (%)").title(pvdf::format_printf("usable area (σ$_{pos}$ ≤ %.3g mm)", o.target_mm)).grid_lines().legend("best");
  b.xlabel("electrodes").ylabel("median σ$_{pos}$ (mm)").log_y().title("median position bound").grid_lines().legend("best");
  fig.suptitle("design --optimize: best layout per electrode count (seed " + std::to_string(o.seed) + ", budget " +
               std::to_string(o.budget) + ")" + (synthetic ? " — SYNTHETIC stand-in maps, not FEM" : ", maps from the atlas"));
  for (const char* ext : {".png", ".svg"}) {
    const std::string path = o.out_dir + "/optimize_pareto" + ext;
    fig.save(path);
    written.push_back(path);
  }
}

/// The winner of each count that found one, as a candidate (label best-N, its map from `provider`).
std::vector<Candidate> optimize_winners(const OptimizeSummary& s, const DesignCommandOptions& o, const MapProvider& provider) {
  std::vector<Candidate> winners;
  for (const auto& c : s.counts) {
    if (!c.found) continue;
    Candidate w;
    w.label = "best-" + std::to_string(c.n_electrodes);
    w.source = o.out_dir + "/" + w.label + ".json";
    w.scene = c.scene;
    w.map_source = o.synthetic ? "synthetic" : "atlas";
    w.map = provider(pvdf::parse_scene(c.scene, w.source));
    w.summary = c.summary;
    w.summary.synthetic = o.synthetic;
    winners.push_back(std::move(w));
  }
  return winners;
}

/// The winners as scenes (best-N.json), their error maps and the Pareto figure, in --out-dir.
void write_optimize_files(const std::vector<Candidate>& winners, const OptimizeSummary& s, const DesignCommandOptions& o,
                          const DesignOptions& d, std::vector<std::string>& written) {
  pvdf::make_directories(o.out_dir);
  for (const auto& w : winners) {
    pvdf::write_file_atomically(w.source, [&w](std::ostream& out) { out << w.scene->dump(2) << '\n'; });
    written.push_back(w.source);
  }
  if (winners.empty()) return;
  // Panels best first, so that each panel's "#k" is the winner's rank (mapping::rank_candidates).
  const std::vector<const Candidate*> shown = rank_candidates(winners);
  write_map_figures(shown, o, noise_label(d, o), written);
  write_pareto_figure(s, o, o.synthetic, written);
}

#ifdef PVDF_HAVE_MAP_GENERATION
/// --verify: each winner's FEM map at the atlas's grid and tolerance, evaluated again (optimize.json's `verify`).
nlohmann::json verify_winners(const std::vector<Candidate>& winners, const DesignCommandOptions& o, const DesignOptions& d,
                              const ChargeAtlas& atlas) {
  DesignCommandOptions vo = o;
  vo.tolerance = atlas.tolerance;
  std::vector<Candidate> verified = winners;
  std::vector<Candidate*> to_verify;
  for (auto& v : verified) to_verify.push_back(&v);
  map_and_evaluate("verify", to_verify, atlas.spacing_m,
                   design_maps(vo, nullptr, "design --optimize --verify: FEM maps, positions"), d);
  nlohmann::json verify = nlohmann::json::array();
  for (std::size_t i = 0; i < winners.size(); ++i) {
    const Candidate& v = verified[i];
    verify.push_back({{"n_electrodes", v.summary.electrodes.size()},
                      {"map_file", v.map_file},
                      {"usable_fraction_fem", v.summary.usable_fraction},
                      {"usable_fraction_atlas", winners[i].summary.usable_fraction},
                      {"coverage_fem", v.summary.coverage},
                      {"coverage_atlas", winners[i].summary.coverage}});
  }
  return verify;
}
#endif

/// The search as text: settings, objective, the table, the verification and the files written.
void print_optimize_text(const DesignCommandOptions& o, const OptimizeOptions& oo, const DesignOptions& d,
                         const std::string& table, const nlohmann::json& j, const std::vector<std::string>& written) {
  std::printf("pvdfkit design --optimize %s: %d-%d electrodes, sides %.3g-%.3g mm%s%s, gap >= %.3g mm, clamp margin >= "
              "%.3g mm; maps: %s\n",
              o.scenes.front().c_str(), oo.electrodes_min, oo.electrodes_max, 1e3 * oo.size_min_m, 1e3 * oo.size_max_m,
              oo.square ? " (squares)" : "", oo.rotate ? ", rotated" : ", unrotated", 1e3 * oo.min_gap_m,
              1e3 * oo.clamp_margin_m, o.synthetic ? "SYNTHETIC stand-in" : ("atlas " + o.atlas_path).c_str());
  std::printf("objective: usable area (σpos <= %.3g mm, force %s), then coverage, then median σpos; differential "
              "evolution, seed %llu, budget %zu evaluations per count\n",
              o.target_mm, d.force_known ? "known" : "unknown", static_cast<unsigned long long>(oo.seed), oo.budget);
  std::fputs(table.c_str(), stdout);
  if (j.contains("verify")) {
    for (const auto& v : j["verify"]) {
      std::printf("verify %d electrodes: FEM map usable %s (atlas %s), coverage %s (atlas %s), %s\n",
                  v["n_electrodes"].get<int>(), pct(v["usable_fraction_fem"].get<double>()).c_str(),
                  pct(v["usable_fraction_atlas"].get<double>()).c_str(), pct(v["coverage_fem"].get<double>()).c_str(),
                  pct(v["coverage_atlas"].get<double>()).c_str(), v["map_file"].get<std::string>().c_str());
    }
  }
  for (const auto& w : written) std::printf("wrote %s\n", w.c_str());
  if (!o.no_plots) std::printf("wrote %s/optimize.txt\nwrote %s/optimize.json\n", o.out_dir.c_str(), o.out_dir.c_str());
}

}  // namespace

int run_optimize(const DesignCommandOptions& o) {
  // Step 1: every input checked before the search.
  if (o.scenes.size() != 1) {
    throw pvdf::InputError("--optimize takes one SCENE (the film, settings and starting layout), got " +
                           std::to_string(o.scenes.size()) + "; give exactly one");
  }
  if (!o.vary.empty() || !o.maps.empty() || o.refine_best > 0) {
    throw pvdf::InputError("--optimize searches layouts itself: drop --vary, --map and --refine-best");
  }
  OptimizeMaps maps;
  maps.atlas_path = o.atlas_path;
  maps.synthetic = o.synthetic;
  maps.spacing_m = o.spacing_m;
  maps.tolerance = o.tolerance;
  check_optimize_maps(maps, flag_named);
  DesignCommandOptions so = o;
  const DesignOptions d = design_options(so);
  const OptimizeOptions oo_checked = optimize_options(o, d);
  const pvdf::Scene scene = pvdf::load_scene(o.scenes.front());
  for (const auto& w : scene.warnings) pvdf::app::warn(w);
  MapProvider provider;
#ifdef PVDF_HAVE_MAP_GENERATION
  std::shared_ptr<const ChargeAtlas> atlas;
  if (!o.atlas_path.empty()) provider = atlas_map_provider(o.atlas_path, scene, oo_checked, &atlas);
#else
  if (!o.atlas_path.empty()) {
    throw pvdf::InputError("--atlas: this pvdfkit was built without the FEM (PVDF_WITH_FEM=OFF) and cannot read atlases; "
                           "use --synthetic for a preview");
  }
#endif
  if (o.verify && o.synthetic) throw pvdf::InputError("--verify checks atlas winners with FEM maps: drop --synthetic");
#ifndef PVDF_HAVE_MAP_GENERATION
  if (o.verify) throw pvdf::InputError("--verify: this pvdfkit was built without FEM map generation; drop --verify");
#endif
  if (o.synthetic) provider = synthetic_map_provider(o.spacing_m, o.force_N);
  if (!o.no_plots && std::filesystem::is_directory(o.out_dir)) {
    for (const char* name : {"/optimize.json", "/optimize.txt", "/optimize_pareto.png", "/optimize_pareto.svg",
                             "/design_position.png", "/design_force.png"}) {
      pvdf::app::check_output_file(o.out_dir + name, "--out-dir");
    }
  }

  // Step 2: the search, with progress and an ETA on stderr.
  OptimizeOptions oo = oo_checked;
  const std::size_t n_counts = std::size_t(oo.electrodes_max - oo.electrodes_min + 1);
  std::unique_ptr<pvdf::Progress> bar;
  if (!o.quiet) bar = std::make_unique<pvdf::Progress>("design --optimize: evaluations", n_counts * oo.budget);
  oo.progress = [&bar](std::size_t count, std::size_t, std::size_t done, std::size_t budget) {
    if (bar) bar->update(count * budget + done);
  };
  const OptimizeSummary s = optimize_layouts(scene.original, o.scenes.front(), provider, oo);
  if (bar) bar->finish();

  // Step 3: files — the winners as scenes, the table, the figures.
  nlohmann::json j = optimize_summary_json(s, oo, maps, o.scenes.front());
  std::vector<std::string> written;
  const std::vector<Candidate> winners = optimize_winners(s, o, provider);
  if (!o.no_plots) write_optimize_files(winners, s, o, d, written);

  // Step 4 (opt-in): each winner's FEM map at the atlas's grid, evaluated again.
#ifdef PVDF_HAVE_MAP_GENERATION
  if (o.verify && !winners.empty()) j["verify"] = verify_winners(winners, o, d, *atlas);
#endif
  j["files"] = written;
  const std::string table = optimize_table(s);
  if (!o.no_plots) {
    pvdf::write_file_atomically(o.out_dir + "/optimize.txt", [&table](std::ostream& out) { out << table; });
    pvdf::write_file_atomically(o.out_dir + "/optimize.json", [&j](std::ostream& out) { out << j.dump(2) << '\n'; });
  }
  if (o.json) {
    std::cout << j.dump(2) << '\n';
  } else {
    print_optimize_text(o, oo, d, table, j, written);
  }
  if (winners.empty()) {
    std::cerr << "error: no layout of " << oo.electrodes_min << "-" << oo.electrodes_max
              << " electrodes meets the size, gap and margin constraints on this film; relax --size-min-m, --min-gap-m or "
                 "--clamp-margin-m\n";
    return pvdf::exit_code::numerical;
  }
  return pvdf::exit_code::success;
}

}  // namespace pvdf::app::design
