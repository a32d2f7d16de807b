// The share of a film where three charges fit more than one press (docs/lookup.md §2).
#include "pvdf/mapping/ambiguity.hpp"

#include "pvdf/mapping/locator.hpp"

#include <array>

namespace pvdf::mapping {

AmbiguityShare ambiguity_share(const ChargeMap& map) {
  AmbiguityShare out;
  const std::size_t f = map.nf() / 2;
  out.force_N = map.forces_N[f];
  out.min_force_N = 0.5 * map.forces_N.front();
  out.max_force_N = 2.0 * map.forces_N.back();
  const Locator unknown(map);
  LocatorOptions within;
  within.min_force_N = 0.75 * out.force_N;
  within.max_force_N = 1.25 * out.force_N;
  const Locator ranged(map, within);
  std::size_t n_unknown = 0, n_known = 0, n_ranged = 0;
  std::array<double, max_electrodes> q{};
  for (std::size_t j = 0; j < map.ny(); ++j) {
    for (std::size_t i = 0; i < map.nx(); ++i) {
      if (!unknown.interpolant().node_usable(i, j)) continue;
      for (std::size_t k = 0; k < map.ne(); ++k) q[k] = map.charge_C[map.charge_index(f, j, i, k)];
      const Location a = unknown.locate(q.data());
      if (!a.has_position()) continue;  // a node the lookup cannot use (e.g. no charge)
      ++out.nodes;
      n_unknown += a.n_solutions > 1;
      const Location b = unknown.locate(q.data(), out.force_N);
      n_known += b.has_position() && b.n_solutions > 1;
      const Location c = ranged.locate(q.data());
      n_ranged += c.has_position() && c.n_solutions > 1;
    }
  }
  if (out.nodes > 0) {
    out.force_unknown = double(n_unknown) / double(out.nodes);
    out.force_known = double(n_known) / double(out.nodes);
    out.force_within_25 = double(n_ranged) / double(out.nodes);
  }
  return out;
}

}  // namespace pvdf::mapping
