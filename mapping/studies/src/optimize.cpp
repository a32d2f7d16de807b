// Electrode layout search (optimize.hpp, docs/design.md §7).
#include "pvdf/mapping/optimize.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <random>

namespace pvdf::mapping {

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

/// The search space of one count: per electrode (x, y, w[, h][, angle]) mapped from [0, 1].
struct LayoutSpace {
  int n = 0;
  double x_lo = 0, x_hi = 0, y_lo = 0, y_hi = 0;
  double size_lo = 0, size_hi = 0;
  double angle_hi = 0;  ///< angles in [0, angle_hi); 0 = not searched
  bool square = false;
  std::size_t per_electrode() const { return 3 + (square ? 0 : 1) + (angle_hi > 0 ? 1 : 0); }
  std::size_t dimension() const { return std::size_t(n) * per_electrode(); }

  std::vector<OrientedRect> decode(const std::vector<double>& u) const {
    std::vector<OrientedRect> layout(static_cast<std::size_t>(n));
    for (std::size_t k = 0; k < layout.size(); ++k) {
      const double* v = &u[k * per_electrode()];
      OrientedRect& r = layout[k];
      r.center_m = {x_lo + v[0] * (x_hi - x_lo), y_lo + v[1] * (y_hi - y_lo)};
      r.width_m = size_lo + v[2] * (size_hi - size_lo);
      r.height_m = square ? r.width_m : size_lo + v[3] * (size_hi - size_lo);
      r.angle_rad = angle_hi > 0 ? v[square ? 3 : 4] * angle_hi : 0.0;
    }
    return layout;
  }

  std::vector<double> encode(const std::vector<OrientedRect>& layout) const {
    auto unit = [](double v, double lo, double hi) { return hi > lo ? std::clamp((v - lo) / (hi - lo), 0.0, 1.0) : 0.5; };
    std::vector<double> u;
    for (const auto& r : layout) {
      u.push_back(unit(r.center_m[0], x_lo, x_hi));
      u.push_back(unit(r.center_m[1], y_lo, y_hi));
      u.push_back(unit(r.width_m, size_lo, size_hi));
      if (!square) u.push_back(unit(r.height_m, size_lo, size_hi));
      if (angle_hi > 0) {
        const double a = std::fmod(std::fmod(r.angle_rad, angle_hi) + angle_hi, angle_hi);
        u.push_back(a / angle_hi);
      }
    }
    return u;
  }
};

/// The objective's keys, smaller first, in the order of ranks_before.
std::vector<double> objective_keys(const DesignSummary& s) {
  const auto finite_or_inf = [](double v) { return std::isnan(v) ? std::numeric_limits<double>::infinity() : v; };
  return {s.status == DesignStatus::ok ? 0.0 : 1.0, -s.usable_fraction, -s.coverage, finite_or_inf(s.median_sigma_pos_m)};
}

/// The scene's electrodes as rectangles, when they all are rectangles (else empty).
std::vector<OrientedRect> rectangles_of(const pvdf::Scene& scene) {
  std::vector<OrientedRect> layout;
  for (const auto& e : scene.electrodes) {
    if (e.shape != pvdf::Electrode::Shape::rectangle) return {};
    layout.push_back({e.center_m, e.size_m[0], e.size_m[1], e.angle_rad});
  }
  return layout;
}

nlohmann::json rect_json(const OrientedRect& r) {
  return {{"center_m", {r.center_m[0], r.center_m[1]}}, {"size_m", {r.width_m, r.height_m}}, {"angle_deg", r.angle_rad * 180.0 / pi}};
}

nlohmann::json finite_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

}  // namespace

void check_optimize_options(const OptimizeOptions& o) {
  const auto name = [&o](const std::string& key, const std::string& value) { return named_option(o.naming, key, value); };
  const auto integer = [](long long v) { return std::to_string(v); };
  if (o.electrodes_min < 3) {
    throw InputError(name("electrodes_min", integer(o.electrodes_min)) +
                     " must be >= 3 (a press has three unknowns x, y, F); give 3 or more");
  }
  if (o.electrodes_max < o.electrodes_min) {
    throw InputError(name("electrodes_max", integer(o.electrodes_max)) + " is below " +
                     name("electrodes_min", integer(o.electrodes_min)) + "; give max >= min");
  }
  if (o.electrodes_max > 16) {
    throw InputError(name("electrodes_max", integer(o.electrodes_max)) + " must be <= 16 (the search space grows "
                     "5 variables per electrode); give 16 or fewer");
  }
  if (!(o.size_min_m > 0) || !std::isfinite(o.size_min_m)) {
    throw InputError(name("size_min_m", pvdf::format_g(o.size_min_m)) + " must be > 0 (m), e.g. 0.001");
  }
  if (!(o.size_max_m >= o.size_min_m) || !std::isfinite(o.size_max_m)) {
    throw InputError(name("size_max_m", pvdf::format_g(o.size_max_m)) + " must be >= " + name("size_min_m", pvdf::format_g(o.size_min_m)) + " (m)");
  }
  if (!(o.min_gap_m >= 0) || !std::isfinite(o.min_gap_m)) {
    throw InputError(name("min_gap_m", pvdf::format_g(o.min_gap_m)) + " must be >= 0 (m), e.g. 0.0005");
  }
  if (!(o.clamp_margin_m >= 0) || !std::isfinite(o.clamp_margin_m)) {
    throw InputError(name("clamp_margin_m", pvdf::format_g(o.clamp_margin_m)) + " must be >= 0 (m), e.g. 0.001");
  }
  if (o.budget < 1 || o.budget > 1000000) {
    throw InputError(name("budget", std::to_string(o.budget)) +
                     " must lie in [1, 1000000] (evaluations per electrode count); give e.g. 300");
  }
  if (o.search_stride < 1) {
    throw InputError(name("search_stride", integer(o.search_stride)) + " must be >= 1 (1 = the full map)");
  }
}

void check_optimize_maps(const OptimizeMaps& m, const OptionNaming& naming) {
  const auto name = [&naming](const std::string& key, const std::string& value) { return named_option(naming, key, value); };
  if (m.atlas_path.empty() && !m.synthetic) {
    throw InputError("no map source: give " + name("atlas", "FILE") +
                     " (a charge-density atlas of the film, `pvdfkit atlas SCENE -o FILE`) or " + name("synthetic", "") +
                     " (the analytic stand-in, a preview)");
  }
  if (!m.atlas_path.empty() && m.synthetic) {
    throw InputError(name("atlas", m.atlas_path) + " and " + name("synthetic", "") + ": give one of them");
  }
  if (!m.atlas_path.empty() && (m.spacing_m > 0 || m.tolerance > 0)) {
    const bool spacing = m.spacing_m > 0;
    throw InputError(name(spacing ? "spacing_m" : "tolerance", pvdf::format_g(spacing ? m.spacing_m : m.tolerance)) + " with " +
                     name("atlas", m.atlas_path) + ": the atlas fixes the grid and the tolerance; drop it or make another atlas");
  }
  if (!m.atlas_path.empty() && !std::filesystem::is_regular_file(m.atlas_path)) {
    throw InputError(name("atlas", m.atlas_path) + ": no such file; make one with `pvdfkit atlas SCENE -o " + m.atlas_path + "`");
  }
  if (m.synthetic && (m.spacing_m < 0 || !std::isfinite(m.spacing_m))) {
    throw InputError(name("spacing_m", pvdf::format_g(m.spacing_m)) + " must be > 0 (m), e.g. 0.001");
  }
}

MapProvider synthetic_map_provider(double spacing_m, double force_N) {
  const double spacing = spacing_m > 0 ? spacing_m : 0.001;
  return [spacing, force_N](const pvdf::Scene& s) { return synthetic_map_for_scene(s, spacing, force_N, 5e-14); };
}

nlohmann::json scene_with_layout(const nlohmann::json& scene, const std::vector<OrientedRect>& layout) {
  nlohmann::json out = scene;
  out["electrodes"] = nlohmann::json::array();
  for (std::size_t k = 0; k < layout.size(); ++k) {
    nlohmann::json e = rect_json(layout[k]);
    e["name"] = "E" + std::to_string(k + 1);
    out["electrodes"].push_back(e);
  }
  return out;
}

ChargeMap coarsen_map(const ChargeMap& map, int stride) {
  if (stride <= 1) return map;
  ChargeMap c = map;
  std::vector<std::size_t> is, js;
  for (std::size_t i = 0; i < map.nx(); i += std::size_t(stride)) is.push_back(i);
  for (std::size_t j = 0; j < map.ny(); j += std::size_t(stride)) js.push_back(j);
  c.x_m.clear();
  c.y_m.clear();
  for (std::size_t i : is) c.x_m.push_back(map.x_m[i]);
  for (std::size_t j : js) c.y_m.push_back(map.y_m[j]);
  const std::size_t ne = map.ne();
  auto pick = [&](const std::vector<double>& per_node_electrode) {
    std::vector<double> out;
    if (per_node_electrode.empty()) return out;
    for (std::size_t f = 0; f < map.nf(); ++f)
      for (std::size_t j : js)
        for (std::size_t i : is)
          for (std::size_t k = 0; k < ne; ++k) out.push_back(per_node_electrode[map.charge_index(f, j, i, k)]);
    return out;
  };
  c.charge_C = pick(map.charge_C);
  c.dcharge_dx_C_per_m = pick(map.dcharge_dx_C_per_m);
  c.dcharge_dy_C_per_m = pick(map.dcharge_dy_C_per_m);
  c.estimated_charge_error_C = pick(map.estimated_charge_error_C);
  c.mask.clear();
  for (std::size_t j : js)
    for (std::size_t i : is) c.mask.push_back(map.mask[j * map.nx() + i]);
  c.status.clear();
  c.deflection_at_load_m.clear();
  for (std::size_t f = 0; f < map.nf(); ++f) {
    for (std::size_t j : js) {
      for (std::size_t i : is) {
        c.status.push_back(map.status[map.point(f, j, i)]);
        if (!map.deflection_at_load_m.empty()) c.deflection_at_load_m.push_back(map.deflection_at_load_m[map.point(f, j, i)]);
      }
    }
  }
  return c;
}

OptimizeSummary optimize_layouts(const nlohmann::json& scene_json, const std::string& source, const MapProvider& provider,
                                 const OptimizeOptions& o) {
  check_optimize_options(o);
  const auto t_start = std::chrono::steady_clock::now();
  const pvdf::Scene reference = pvdf::parse_scene(scene_json, source);
  const FilmOutline& outline = reference.membrane.outline;

  // Step 1: the search box. A centre at least margin + half the smallest side from the outline's
  // bounding box; the constraints do the rest.
  const auto box = outline.bounding_box_m();
  const double inset = o.clamp_margin_m + 0.5 * o.size_min_m;
  LayoutSpace space;
  space.x_lo = box[0] + inset;
  space.x_hi = box[1] - inset;
  space.y_lo = box[2] + inset;
  space.y_hi = box[3] - inset;
  space.size_lo = o.size_min_m;
  space.size_hi = o.size_max_m;
  space.square = o.square;
  space.angle_hi = o.rotate ? (o.square ? 0.5 * pi : pi) : 0.0;
  if (!(space.x_hi > space.x_lo && space.y_hi > space.y_lo)) {
    throw InputError(named_option(o.naming, "clamp_margin_m", pvdf::format_g(o.clamp_margin_m)) + " with " +
                     named_option(o.naming, "size_min_m", pvdf::format_g(o.size_min_m)) + ": no room on the film of " +
                     source + " (bounding box " + pvdf::format_g(box[1] - box[0]) + " x " + pvdf::format_g(box[3] - box[2]) +
                     " m); give a smaller margin or size");
  }

  OptimizeSummary summary;
  // The reference layout on the full map, for comparison.
  if (reference.electrodes.size() >= 3) {
    try {
      summary.reference = evaluate_design(provider(reference), o.design);
      summary.reference_evaluated = true;
    } catch (const InputError&) {
      summary.reference_evaluated = false;
    }
  }
  const std::vector<OrientedRect> reference_layout = rectangles_of(reference);

  // Step 2: one differential evolution per count.
  const std::size_t n_counts = std::size_t(o.electrodes_max - o.electrodes_min + 1);
  for (int n = o.electrodes_min; n <= o.electrodes_max; ++n) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::size_t count_index = std::size_t(n - o.electrodes_min);
    space.n = n;
    CountResult result;
    result.n_electrodes = n;

    DifferentialEvolutionOptions de;
    de.dimension = space.dimension();
    de.population = o.population;
    de.seed = o.seed * 1000003ULL + std::uint64_t(n);
    de.max_evaluations = o.budget;
    if (int(reference_layout.size()) == n) de.initial.push_back(space.encode(reference_layout));
    // The previous count's winner plus one electrode where it fits (the first feasible of up to
    // 500 seeded draws): the search for n starts no worse than n − 1 did, so a count's curve is
    // not bent down by a search that has not yet rediscovered the smaller layout.
    if (!summary.counts.empty() && summary.counts.back().found) {
      std::mt19937_64 rng(de.seed ^ 0x9e3779b97f4a7c15ULL);
      LayoutSpace one = space;
      one.n = 1;
      for (int t = 0; t < 500; ++t) {
        std::vector<double> u(one.dimension());
        for (double& v : u) v = double(rng() >> 11) * 0x1.0p-53;
        std::vector<OrientedRect> grown = summary.counts.back().layout;
        grown.push_back(one.decode(u)[0]);
        if (layout_violation_m(grown, outline, o.min_gap_m, o.clamp_margin_m) == 0) {
          de.initial.push_back(space.encode(grown));
          break;
        }
      }
    }

    auto violation = [&](const std::vector<double>& u) {
      const auto layout = space.decode(u);
      return layout_violation_m(layout, outline, o.min_gap_m, o.clamp_margin_m);
    };
    auto objective = [&](const std::vector<double>& u) {
      const auto layout = space.decode(u);
      if (o.keep_evaluated) result.evaluated.push_back(layout);
      try {
        const pvdf::Scene candidate = pvdf::parse_scene(scene_with_layout(scene_json, layout), source);
        return objective_keys(evaluate_design(coarsen_map(provider(candidate), o.search_stride), o.design));
      } catch (const InputError&) {
        ++result.n_rejected;  // a rule of the scene reader or the analysis the constraints do not cover
        return std::vector<double>{2.0};
      }
    };
    auto on_evaluation = [&](std::size_t done) {
      if (o.progress) o.progress(count_index, n_counts, done, o.budget);
    };
    const DifferentialEvolutionSummary ds = differential_evolution(violation, objective, de, on_evaluation);
    result.status = ds.status;
    result.n_evaluations = ds.n_evaluations;
    result.n_trials = ds.n_trials;
    result.n_generations = ds.n_generations;
    result.found = ds.status != DifferentialEvolutionStatus::no_feasible_point && ds.best.keys.size() == 4;
    if (result.found) {
      result.layout = space.decode(ds.best_x);
      result.search_usable_fraction = -ds.best.keys[1];
      result.scene = scene_with_layout(scene_json, result.layout);
      // Step 3: the winner on the full map.
      result.summary = evaluate_design(provider(pvdf::parse_scene(result.scene, source)), o.design);
    }
    result.seconds = seconds_since(t0);
    summary.counts.push_back(std::move(result));
  }
  for (std::size_t i = 0; i < summary.counts.size(); ++i) {
    const auto& c = summary.counts[i];
    const auto& b = summary.counts[summary.best];
    if (c.found && (!b.found || ranks_before(c.summary, b.summary))) summary.best = i;
  }
  summary.seconds = seconds_since(t_start);
  return summary;
}

nlohmann::json optimize_summary_json(const OptimizeSummary& s, const OptimizeOptions& o, const OptimizeMaps& maps,
                                     const std::string& scene_source) {
  nlohmann::json j;
  j["scene"] = scene_source;
  j["maps"] = maps.kind();
  if (!maps.atlas_path.empty()) j["atlas"] = maps.atlas_path;
  j["settings"] = {{"electrodes_min", o.electrodes_min}, {"electrodes_max", o.electrodes_max},
                   {"size_min_m", o.size_min_m},         {"size_max_m", o.size_max_m},
                   {"square", o.square},                 {"rotate", o.rotate},
                   {"min_gap_m", o.min_gap_m},           {"clamp_margin_m", o.clamp_margin_m},
                   {"seed", o.seed},                     {"budget", o.budget},
                   {"search_stride", o.search_stride},   {"target_m", o.design.target_m},
                   {"force_known", o.design.force_known}, {"force_N", o.design.force_N},
                   {"noise_C", o.design.noise_C},        {"adc_bits", o.design.adc_bits},
                   {"method", "differential evolution, current-to-pbest/1/bin, Deb's feasibility rules"}};
  if (s.reference_evaluated) {
    j["reference"] = {{"usable_fraction", s.reference.usable_fraction},
                      {"coverage", s.reference.coverage},
                      {"median_sigma_pos_m", finite_or_null(s.reference.median_sigma_pos_m)},
                      {"n_electrodes", s.reference.electrodes.size()}};
  } else {
    j["reference"] = nullptr;
  }
  j["counts"] = nlohmann::json::array();
  for (const auto& c : s.counts) {
    nlohmann::json r = {{"n_electrodes", c.n_electrodes},
                        {"found", c.found},
                        {"status", differential_evolution_status_name(c.status)},
                        {"evaluations", c.n_evaluations},
                        {"trials", c.n_trials},
                        {"generations", c.n_generations},
                        {"rejected", c.n_rejected},
                        {"seconds", c.seconds}};
    if (c.found) {
      r["usable_fraction"] = c.summary.usable_fraction;
      r["coverage"] = c.summary.coverage;
      r["median_sigma_pos_m"] = finite_or_null(c.summary.median_sigma_pos_m);
      r["search_usable_fraction"] = c.search_usable_fraction;
      r["n_mapped"] = c.summary.n_mapped;  // grid nodes the fractions count
      r["layout"] = nlohmann::json::array();
      for (const auto& rect : c.layout) r["layout"].push_back(rect_json(rect));
    }
    j["counts"].push_back(r);
  }
  j["best_n_electrodes"] = s.counts.empty() || !s.counts[s.best].found ? nlohmann::json(nullptr)
                                                                        : nlohmann::json(s.counts[s.best].n_electrodes);
  j["seconds"] = s.seconds;
  return j;
}

}  // namespace pvdf::mapping
