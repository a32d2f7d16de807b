// `pvdfkit lookup-accuracy`: on a given charge map, the lookup against the seed-001 triangulation —
// median position error against charge noise and locates per second — by Monte Carlo presses
// whose true charges are the map's own interpolant (a self-consistency check: it measures
// noise sensitivity and the triangulation's model error, not the map's interpolation error).
#include "command.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/mapping/map_io.hpp"
#include "pvdf/plot/plot.hpp"
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/triangulation.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <memory>
#include <random>

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

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

int run_compare(const CompareOptions& o) {
  using namespace pvdf::mapping;
  const ChargeMap map = read_map(o.map_path);
  const auto noise = pvdf::parse_number_list(o.noise, "--noise-C");
  for (double s : noise) {
    if (!(s > 0)) throw pvdf::InputError("--noise-C " + pvdf::format_g(s) + ": every level must be > 0 (C)");
  }
  LocatorOptions base;
  base.use_calibration = false;  // truth and lookup both use the raw map
  const Locator truth(map, base);
  const Triangulation tri(truth, map);
  const double f_lo = map.forces_N.front(), f_hi = map.forces_N.back();

  // Presses inside the map (truth defined) and within the radius.
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<double> u(0, 1);
  struct Press {
    double x, y, F;
    std::array<double, max_electrodes> q;
  };
  std::vector<Press> presses;
  std::size_t attempts = 0;
  const auto n_wanted = static_cast<std::size_t>(o.presses);
  while (presses.size() < n_wanted && attempts++ < 100 * n_wanted) {
    Press p{};
    p.x = (2 * u(rng) - 1) * o.radius_m;
    p.y = (2 * u(rng) - 1) * o.radius_m;
    p.F = f_lo * std::pow(f_hi / f_lo, u(rng));
    if (std::hypot(p.x, p.y) > o.radius_m || !truth.predict(p.x, p.y, p.F, p.q.data())) continue;
    presses.push_back(p);
  }
  if (presses.size() < 10)
    throw pvdf::InputError(o.map_path + ": fewer than 10 mapped positions within --radius-m " + pvdf::format_g(o.radius_m) +
                           " m of the centre; give a radius inside the map");

  nlohmann::json rows = nlohmann::json::array();
  std::vector<double> e_known, e_free, e_tri, s_known;
  if (!o.json) {
    std::printf("%zu presses within %.1f mm, %.3g-%.3g N (truth: the map's interpolant)\n", presses.size(), o.radius_m * 1e3, f_lo, f_hi);
    std::printf("%10s %16s %16s %16s %16s %12s %12s %12s\n", "noise_pC", "lookup_F_known", "reported_sigma",
                "lookup_F_free", "triangulation", "ambiguous_%", "lookup_/s", "triang_/s");
  }
  for (double sigma : noise) {
    LocatorOptions lo = base;
    lo.noise_C = {sigma};
    const Locator locator(map, lo);
    std::normal_distribution<double> n(0.0, sigma);
    std::vector<std::array<double, max_electrodes>> q(presses.size());
    for (std::size_t i = 0; i < presses.size(); ++i) {
      for (std::size_t k = 0; k < map.ne(); ++k) q[i][k] = presses[i].q[k] + n(rng);
    }
    std::vector<double> a, b, c, s;
    int ambiguous = 0;
    std::clock_t t0 = std::clock();
    for (std::size_t i = 0; i < presses.size(); ++i) {
      const Location r = locator.locate(q[i].data());
      if (!r.has_position()) continue;
      double e = std::hypot(r.x_m - presses[i].x, r.y_m - presses[i].y);
      if (r.flags & flag::ambiguous) ++ambiguous;
      for (int k = 0; k < r.n_alternatives; ++k) {
        const auto& alt = r.alternatives[std::size_t(k)];
        e = std::min(e, std::hypot(alt.x_m - presses[i].x, alt.y_m - presses[i].y));
      }
      b.push_back(e);
    }
    const double lookup_rate = double(presses.size()) / std::max(1e-9, double(std::clock() - t0) / CLOCKS_PER_SEC);
    for (std::size_t i = 0; i < presses.size(); ++i) {
      const Location r = locator.locate(q[i].data(), presses[i].F);
      if (!r.has_position()) continue;
      a.push_back(std::hypot(r.x_m - presses[i].x, r.y_m - presses[i].y));
      s.push_back(std::hypot(r.sigma_x_m, r.sigma_y_m));
    }
    t0 = std::clock();
    for (std::size_t i = 0; i < presses.size(); ++i) {
      const Location r = tri.locate(q[i].data(), presses[i].F);
      if (r.has_position()) c.push_back(std::hypot(r.x_m - presses[i].x, r.y_m - presses[i].y));
    }
    const double tri_rate = double(presses.size()) / std::max(1e-9, double(std::clock() - t0) / CLOCKS_PER_SEC);
    e_known.push_back(median(a) * 1e3);
    s_known.push_back(median(s) * 1e3);
    e_free.push_back(median(b) * 1e3);
    e_tri.push_back(median(c) * 1e3);
    const double amb = 100.0 * ambiguous / double(presses.size());
    rows.push_back({{"noise_C", sigma}, {"median_error_force_known_m", median(a)}, {"median_sigma_force_known_m", median(s)},
                    {"median_error_force_unknown_m", median(b)}, {"median_error_triangulation_m", median(c)},
                    {"ambiguous_fraction", amb / 100}, {"lookup_per_cpu_s", lookup_rate}, {"triangulation_per_cpu_s", tri_rate}});
    if (!o.json) {
      std::printf("%10.3g %13.4f mm %13.4f mm %13.4f mm %13.4f mm %12.1f %12.0f %12.0f\n", sigma * 1e12, e_known.back(),
                  s_known.back(), e_free.back(), e_tri.back(), amb, lookup_rate, tri_rate);
    }
  }
  if (o.json) std::cout << nlohmann::json{{"map", o.map_path}, {"presses", presses.size()}, {"rows", rows}}.dump(2) << '\n';
  if (!o.plot_path.empty()) {
    std::vector<double> noise_pC;
    for (double s : noise) noise_pC.push_back(s * 1e12);
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
  sub->add_option("MAP", o->map_path, "Charge map (HDF5)")->required();
  sub->add_option("--presses", o->presses, "Random presses per noise level")
      ->capture_default_str()
      ->check(pvdf::app::integer_in(10, 1000000));
  sub->add_option("--radius-m", o->radius_m, "Presses within this distance of the centre (m)")
      ->capture_default_str()
      ->check(pvdf::app::number_in(0, 10, "m", true));
  sub->add_option("--noise-C", o->noise, "Charge-noise levels, 1-sigma per electrode (C)")->capture_default_str();
  sub->add_option("--seed", o->seed, "Random seed")->capture_default_str();
  sub->add_option("--plot", o->plot_path, "Figure of median position error against noise (.png, .svg or .pdf)")
      ->check(pvdf::app::output_file());
  sub->add_flag("--json", o->json, "Print the table as JSON");
  return pvdf::app::Subcommand{sub, [o] { return run_compare(*o); }};
});
