// The map's error between its nodes and force levels (docs/lookup.md §1.10) and what the lookup
// does with it. Oracle: the analytic SyntheticModel the maps are sampled from — the estimate is
// made from the map's nodes alone, the truth from the closed form between them. Also: the
// deployed flat map answers bit for bit as the HDF5 map.
#include "fixture.hpp"

#include "pvdf/mapping/flat_map.hpp"
#include "pvdf/mapping/interpolation_error.hpp"
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/map_io.hpp"
#include "pvdf/mapping/synthetic.hpp"

#include <catch2/catch.hpp>

#include <cstring>
#include <filesystem>
#include <random>

using namespace pvdf::mapping;
using pvdf_test::Press;

namespace {

SyntheticModel skewed_model() {
  SyntheticModel m;     // seed-001 triangle, anisotropic, decaying like d^-0.8
  m.force_skew = 0.05;  // force exponent 2/3 ± 0.05 across the film: the levels matter
  return m;
}

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

/// Largest |charge| of a press (C).
double largest(const std::vector<double>& q) {
  double m = 0;
  for (const double v : q) m = std::max(m, std::abs(v));
  return m;
}

/// Estimated and true relative error (max over electrodes / the press's largest charge) of the
/// map's interpolant at one press.
struct ErrorPair {
  double estimate, truth;
};

bool error_pair(const Locator& locator, const SyntheticModel& model, const Press& p, ErrorPair& out) {
  std::array<double, max_electrodes> q{}, e{};
  if (!locator.predict(p.x_m, p.y_m, p.force_N, q.data()) || !locator.charge_error(p.x_m, p.y_m, p.force_N, e.data())) {
    return false;
  }
  const std::vector<double> truth = pvdf_test::charges(model, p);
  double t = 0, s = 0;
  for (std::size_t k = 0; k < truth.size(); ++k) {
    t = std::max(t, std::abs(q[k] - truth[k]));
    s = std::max(s, e[k]);
  }
  out = {s / largest(truth), t / largest(truth)};
  return true;
}

/// Effectivity of the estimate over presses: share of estimate/truth in [0.5, 3] where the truth
/// exceeds 1e-3, and the largest truth/estimate anywhere the truth exceeds 1e-4.
struct Effectivity {
  int counted = 0, within = 0;
  double worst_under = 0, median = 0;
};

Effectivity effectivity(const Locator& locator, const SyntheticModel& model, const std::vector<Press>& presses) {
  Effectivity r;
  std::vector<double> ratios;
  for (const Press& p : presses) {
    ErrorPair e{};
    if (!error_pair(locator, model, p, e)) continue;
    if (e.truth > 1e-4) r.worst_under = std::max(r.worst_under, e.truth / e.estimate);
    if (e.truth <= 1e-3) continue;
    ++r.counted;
    r.within += e.estimate >= 0.5 * e.truth && e.estimate <= 3 * e.truth;
    ratios.push_back(e.estimate / e.truth);
  }
  if (!ratios.empty()) r.median = pvdf_test::median(ratios);
  return r;
}

}  // namespace

TEST_CASE("the interpolation error estimate between nodes holds against the closed form", "[mapping][map_error]") {
  // The map at h, the truth at the nodes of the h/2 grid it does not hold (cell centres and edge
  // midpoints), at each level's force (no level interpolation). What holds (docs/lookup.md
  // §1.10): the estimate is conservative — no true error above 1e-4 exceeds 3× its estimate —
  // and its median effectivity lies in [1, 3] at 1 mm; at 2 mm, where the charge's features next
  // to the electrodes (2 mm core) are not resolved by the 4 and 8 mm grids the rate is measured
  // on, it overestimates (median ≈ 6). The share within [0.5, 3] is printed, not asserted:
  // 90 % is not met (about 70 % at 1 mm, 30 % at 2 mm).
  const SyntheticModel model = skewed_model();
  for (const double h : {2e-3, 1e-3}) {
    const ChargeMap map = build_synthetic_map(model, h, 3e-3, {0.5, 1.0, 2.0}, 0.05e-12);
    const Locator locator(map);
    std::vector<Press> presses;
    for (std::size_t f = 0; f < map.nf(); ++f) {
      for (std::size_t j = 0; j + 1 < map.ny(); ++j) {
        for (std::size_t i = 0; i + 1 < map.nx(); ++i) {
          if (!locator.interpolant().cell_usable(i, j)) continue;
          for (const auto& o : {std::array<double, 2>{0.5, 0.5}, std::array<double, 2>{0.5, 0.0}, std::array<double, 2>{0.0, 0.5}}) {
            presses.push_back({map.x_m[i] + o[0] * h, map.y_m[j] + o[1] * h, map.forces_N[f]});
          }
        }
      }
    }
    const Effectivity r = effectivity(locator, model, presses);
    INFO("h = " << h * 1e3 << " mm: " << r.within << " of " << r.counted << " presses with a true error above 1e-3 have "
                << "estimate/true in [0.5, 3] (median " << r.median << "); largest true/estimate " << r.worst_under);
    CHECK(r.counted >= 100);
    CHECK(r.worst_under <= 3.0);
    CHECK(r.median >= 1.0);
    CHECK(r.median <= (h < 1.5e-3 ? 3.0 : 8.0));
  }
}

TEST_CASE("the interpolation error estimate between force levels holds against the closed form", "[mapping][map_error]") {
  // Nodes (no position interpolation) at the geometric midpoints of the levels; the model's
  // force exponent varies across the film (force_skew), so G = Q/F^(2/3) is curved in ln F.
  SyntheticModel model = skewed_model();
  model.force_skew = 0.3;
  for (const std::vector<double>& levels : {std::vector<double>{0.25, 1.0, 4.0}, std::vector<double>{0.25, 0.5, 1.0, 2.0, 4.0}}) {
    const ChargeMap map = build_synthetic_map(model, 2e-3, 3e-3, levels, 0.05e-12);
    const Locator locator(map);
    std::vector<Press> presses;
    for (std::size_t f = 0; f + 1 < map.nf(); ++f) {
      for (std::size_t j = 0; j < map.ny(); j += 2) {
        for (std::size_t i = 0; i < map.nx(); i += 2) {
          if (locator.interpolant().node_usable(i, j)) presses.push_back({map.x_m[i], map.y_m[j], std::sqrt(levels[f] * levels[f + 1])});
        }
      }
    }
    const Effectivity r = effectivity(locator, model, presses);
    INFO(levels.size() << " levels: " << r.within << " of " << r.counted << " presses with a true error above 1e-3 have "
                       << "estimate/true in [0.5, 3] (median " << r.median << "); largest true/estimate " << r.worst_under);
    CHECK(r.counted >= 100);
    CHECK(r.within >= 0.9 * r.counted);
    CHECK(r.worst_under <= 3.0);
  }
}

TEST_CASE("sigma covers the error between nodes and force levels: 2-sigma coverage of 90-98 %", "[mapping][map_error]") {
  // Presses at random between nodes and force levels, Gaussian charge noise; the truth from the
  // closed form. With the force known, each coordinate of an unambiguous answer must lie within
  // 2σ for 90–98 % of them (Gaussian: 95.4 %; measured 0.978 / 0.955): σ half as large
  // (0.718 / 0.705 before the split of §1.11) or twice as large (0.998 / 0.998) fails (measured by
  // scaling the σ's here, docs/lookup.md §1.10). With the force unknown the map error's common
  // scale is absorbed by ln F (§1.11): 0.964 / 0.956, asserted from both sides too (before the
  // split 0.988 / 0.996, above the band).
  const SyntheticModel model = skewed_model();
  const ChargeMap map = build_synthetic_map(model, 2e-3, 3e-3, {0.5, 1.0, 2.0}, 0.05e-12);
  for (const bool known_force : {true, false}) {
    const Locator locator(map);
    const std::vector<Press> presses = pvdf_test::random_presses(known_force ? 600 : 1500, 0.02, 0.55, 1.8, 11);
    std::mt19937 rng(12);
    std::normal_distribution<double> noise(0.0, 0.05e-12);
    int n = 0, in_x = 0, in_y = 0, in_f = 0;
    for (const Press& p : presses) {
      std::vector<double> q = pvdf_test::charges(model, p);
      for (double& v : q) v += noise(rng);
      const Location r = known_force ? locator.locate(q, p.force_N) : locator.locate(q);
      if (!r.has_position() || (r.flags & flag::ambiguous)) continue;
      ++n;
      in_x += std::abs(r.x_m - p.x_m) <= 2 * r.sigma_x_m;
      in_y += std::abs(r.y_m - p.y_m) <= 2 * r.sigma_y_m;
      in_f += std::abs(r.force_N - p.force_N) <= 2 * r.sigma_F_N;
    }
    const double cx = double(in_x) / n, cy = double(in_y) / n, cf = double(in_f) / n;
    INFO((known_force ? "force known" : "force unknown") << ": " << n << " unambiguous answers; within 2 sigma: x " << cx
                                                         << ", y " << cy << ", F " << cf);
    CHECK(n >= 150);
    CHECK(cx >= 0.90);
    CHECK(cy >= 0.90);
    CHECK(cx <= 0.98);
    CHECK(cy <= 0.98);
  }
}

TEST_CASE("the total error a map states (lookup_error_summary) bounds the lookup's error and the true one", "[mapping][map_error]") {
  // What `map` prints and MapReport keeps for users: the map error the lookup carries, relative
  // to a press's largest charge, over the film. Checked at presses drawn at random between the
  // nodes and between the force levels (not the summary's own sample points): no press's carried
  // error above the stated largest (5 % slack: the sample stands 2 % inside the corners), the
  // stated median that of the presses within ±30 %, and, against the closed form, no press's true
  // error above the stated largest. A summary sampled next to the nodes only (where the
  // interpolation share vanishes) fails the first and the median check here (tried: 0.084 against
  // 0.49 carried).
  const SyntheticModel model = skewed_model();
  const ChargeMap map = build_synthetic_map(model, 2e-3, 3e-3, {0.5, 1.0, 2.0}, 0.05e-12);
  const LookupErrorSummary stated = lookup_error_summary(map);
  REQUIRE(std::isfinite(stated.max));
  REQUIRE(stated.n_points > 1000);
  CHECK(stated.median <= stated.p90);
  CHECK(stated.p90 <= stated.max);
  const Locator locator(map);
  std::vector<double> carried;
  double worst_carried = 0, worst_true = 0;
  // Area-uniform over the map's usable cells (the summary's domain), log-uniform in force.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int n = 0; n < 20000; ++n) {
    const Press p{map.x_m.front() + u(rng) * (map.x_m.back() - map.x_m.front()),
                  map.y_m.front() + u(rng) * (map.y_m.back() - map.y_m.front()), 0.5 * std::pow(4.0, u(rng))};
    ErrorPair e{};
    if (!error_pair(locator, model, p, e)) continue;  // outside the usable cells
    carried.push_back(e.estimate);
    worst_carried = std::max(worst_carried, e.estimate);
    worst_true = std::max(worst_true, e.truth);
  }
  REQUIRE(carried.size() >= 1000);
  const double median_carried = pvdf_test::median(carried);
  INFO("stated median " << stated.median << ", p90 " << stated.p90 << ", max " << stated.max << "; at " << carried.size()
                        << " random presses: carried median " << median_carried << ", max " << worst_carried
                        << "; true max " << worst_true);
  CHECK(worst_carried <= 1.05 * stated.max);
  CHECK(median_carried >= stated.median / 1.3);
  CHECK(median_carried <= stated.median * 1.3);
  CHECK(worst_true <= stated.max);
}

TEST_CASE("the flat export answers bit for bit as the HDF5 map, per-node errors included", "[mapping][map_error][flat_map]") {
  // A map with a per-node error estimate (varying by node, level and electrode), through HDF5
  // and through the flat bytes: the same presses (between nodes and levels, with noise) give the
  // same positions, σ's, probabilities, flags and alternatives to the last bit.
  const SyntheticModel model = skewed_model();
  ChargeMap map = build_synthetic_map(model, 2e-3, 3e-3, {0.5, 1.0, 2.0}, 0.05e-12);
  map.estimated_charge_error_C.assign(map.charge_C.size(), std::nan(""));
  for (std::size_t n = 0; n < map.charge_C.size(); ++n) {
    if (map.status[n / map.ne()] == std::uint8_t(PointStatus::ok)) {
      map.estimated_charge_error_C[n] = std::abs(map.charge_C[n]) * (1e-3 + 2e-3 * double(n % 5) / 4.0);
    }
  }
  const auto dir = std::filesystem::temp_directory_path() / "pvdf_test_map_error";
  std::filesystem::create_directories(dir);
  const std::string h5 = (dir / "map.h5").string();
  write_map(h5, map);
  const ChargeMap from_h5 = read_map(h5);
  const std::vector<unsigned char> bytes = encode_flat_map(from_h5, h5);
  const ChargeMap from_flat = decode_flat_map(bytes.data(), bytes.size(), "map.flat");
  REQUIRE(from_flat.estimated_charge_error_C.size() == map.charge_C.size());

  const std::vector<Press> presses = pvdf_test::random_presses(300, 0.03, 0.4, 3.0, 21);
  std::mt19937 rng(22);
  std::normal_distribution<double> noise(0.0, 0.05e-12);
  int compared = 0, differ = 0, with_map_error = 0;
  for (const double valley : {0.2, 0.0}) {
    LocatorOptions options;
    options.valley_sigma_cells = valley;
    const Locator a(from_h5, options), b(from_flat, options);
    const Locator without(from_h5, [&] {
      LocatorOptions o = options;
      o.interpolation_error = false;
      return o;
    }());
    for (const Press& p : presses) {
      std::vector<double> q = pvdf_test::charges(model, p);
      for (double& v : q) v += noise(rng);
      for (const bool known : {false, true}) {
        const Location ra = known ? a.locate(q, p.force_N) : a.locate(q);
        const Location rb = known ? b.locate(q, p.force_N) : b.locate(q);
        const Location rw = known ? without.locate(q, p.force_N) : without.locate(q);
        ++compared;
        bool same = ra.flags == rb.flags && ra.n_solutions == rb.n_solutions && ra.n_alternatives == rb.n_alternatives &&
                    same_bits(ra.x_m, rb.x_m) && same_bits(ra.y_m, rb.y_m) && same_bits(ra.force_N, rb.force_N) &&
                    same_bits(ra.residual, rb.residual) && same_bits(ra.sigma_x_m, rb.sigma_x_m) &&
                    same_bits(ra.sigma_y_m, rb.sigma_y_m) && same_bits(ra.sigma_F_N, rb.sigma_F_N) &&
                    same_bits(ra.probability, rb.probability);
        for (int s = 0; same && s < ra.n_alternatives; ++s) {
          const auto &x = ra.alternatives[std::size_t(s)], &y = rb.alternatives[std::size_t(s)];
          same = same_bits(x.x_m, y.x_m) && same_bits(x.y_m, y.y_m) && same_bits(x.force_N, y.force_N) &&
                 same_bits(x.sigma_x_m, y.sigma_x_m) && same_bits(x.sigma_y_m, y.sigma_y_m) &&
                 same_bits(x.probability, y.probability);
        }
        differ += !same;
        // The interpolation error changes the answers (else this test would not see it).
        with_map_error += ra.has_position() && rw.has_position() && ra.sigma_x_m != rw.sigma_x_m;
      }
    }
  }
  INFO(differ << " of " << compared << " answers differ; " << with_map_error << " have other σ's without the interpolation error");
  CHECK(differ == 0);
  CHECK(with_map_error > compared / 2);
}

TEST_CASE("a map that stores its total error: counted once by the lookup, the same through HDF5 and the flat v3 export",
          "[mapping][map_error][flat_map]") {
  // The total stored at the nodes (adaptive generation, docs/map-generation.md §10) is the
  // Locator's map error at a press — bilinear in the cell, linear in ln F — with no interpolation
  // estimate added between nodes and levels; the same map marked as node estimates only gets it.
  const SyntheticModel model = skewed_model();
  ChargeMap map = build_synthetic_map(model, 2e-3, 3e-3, {0.5, 1.0, 2.0}, 0.05e-12);
  map.estimated_charge_error_C.assign(map.charge_C.size(), 0.0);
  for (std::size_t n = 0; n < map.charge_C.size(); ++n) {
    map.estimated_charge_error_C[n] = std::abs(map.charge_C[n]) * (2e-3 + 1e-3 * double(n % 3));
  }
  ChargeMap total = map;
  total.estimated_total_relative_error = 0.004;
  const Locator node_only(map), with_total(total);
  int compared = 0, added = 0;
  for (std::size_t j = 2; j + 3 < map.ny(); j += 3) {
    for (std::size_t i = 2; i + 3 < map.nx(); i += 3) {
      const double x = 0.5 * (map.x_m[i] + map.x_m[i + 1]), y = 0.5 * (map.y_m[j] + map.y_m[j + 1]);
      const double F = std::sqrt(map.forces_N[0] * map.forces_N[1]);  // mid-way in ln F
      std::array<double, max_electrodes> e_total{}, e_node{}, q{};
      if (!with_total.predict(x, y, F, q.data()) || !with_total.charge_error(x, y, F, e_total.data())) continue;
      REQUIRE(node_only.charge_error(x, y, F, e_node.data()));
      for (std::size_t k = 0; k < map.ne(); ++k) {
        // The closed form of what is stored: bilinear at the cell centre, linear in ln F.
        double expected = 0;
        for (std::size_t f = 0; f < 2; ++f) {
          for (std::size_t c = 0; c < 4; ++c) {
            expected += 0.125 * total.estimated_charge_error_C[total.charge_index(f, j + c / 2, i + c % 2, k)];
          }
        }
        // The Locator keeps its map errors as floats: agreement to float precision.
        CHECK(std::abs(e_total[k] - expected) <= 1e-6 * expected);
        ++compared;
        added += e_node[k] > e_total[k] * (1 + 1e-6);
      }
    }
  }
  CHECK(compared >= 30);
  CHECK(added >= compared / 2);  // node estimates only: the lookup's own interpolation estimate joins them

  const std::vector<unsigned char> bytes = encode_flat_map(total, "total.h5");
  std::uint32_t version = 0, contents = 0;
  std::memcpy(&version, bytes.data() + 8, 4);
  std::memcpy(&contents, bytes.data() + 32, 4);
  CHECK(version == 3);
  CHECK((contents & flat_map_charge_error_is_total) != 0);
  const ChargeMap back = decode_flat_map(bytes.data(), bytes.size(), "total.flat");
  CHECK(back.estimated_total_relative_error == total.estimated_total_relative_error);
  const std::vector<unsigned char> node_bytes = encode_flat_map(map, "map.h5");
  std::memcpy(&version, node_bytes.data() + 8, 4);
  CHECK(version == 2);  // node estimates only: still readable by version-2 runtimes
  const Locator from_flat(back);
  const std::vector<Press> presses = pvdf_test::random_presses(40, 0.03, 0.4, 3.0, 29);
  int differ = 0, located = 0;
  for (const Press& p : presses) {
    const std::vector<double> q = pvdf_test::charges(model, p);
    const Location a = with_total.locate(q), b = from_flat.locate(q);
    located += a.has_position();
    differ += !(a.flags == b.flags && same_bits(a.x_m, b.x_m) && same_bits(a.y_m, b.y_m) && same_bits(a.sigma_x_m, b.sigma_x_m) &&
                same_bits(a.probability, b.probability));
  }
  CHECK(located >= 30);
  CHECK(differ == 0);
}
