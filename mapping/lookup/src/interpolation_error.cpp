// The map's interpolation error from its own charges (docs/lookup.md §1.10).
//
// Position: the grid of every other node (spacing 2h; four of them, by their offset) is
// interpolated with the same bicubic scheme, and at the nodes it does not hold the difference
// to the map's value — the hierarchical surplus S₁ — is that coarser interpolant's true error.
// The same one level down (each 2h grid against its 4h grids) gives S₂. Per node, ρ₁ = W₂/W₁
// (W: the largest surplus within ±2 nodes) is the factor by which the error fell from 4h to 2h;
// the map's own error (spacing h) is S₁/ρ₀ with ρ₀ = min(16, ρ₁²).
// Force: the reduced charge G = Q/F^p is interpolated linearly in ln F; its second divided
// difference across three levels bounds the chord's error between two (|G''|·Δ²/8).
#include "pvdf/mapping/interpolation_error.hpp"

#include "pvdf/mapping/interpolant.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace pvdf::mapping {

namespace {

constexpr double unknown = std::numeric_limits<double>::quiet_NaN();

/// Per node: inside the mask and ok at every level (the interpolant's usable node).
std::vector<std::uint8_t> usable_nodes(const ChargeMap& map) {
  std::vector<std::uint8_t> ok(map.nx() * map.ny(), 0);
  for (std::size_t j = 0; j < map.ny(); ++j) {
    for (std::size_t i = 0; i < map.nx(); ++i) {
      bool good = map.mask[j * map.nx() + i] != 0;
      for (std::size_t f = 0; good && f < map.nf(); ++f) good = map.status[map.point(f, j, i)] == std::uint8_t(PointStatus::ok);
      ok[j * map.nx() + i] = good ? 1 : 0;
    }
  }
  return ok;
}

}  // namespace

ChargeMap every_nth_node(const ChargeMap& map, std::size_t n, std::size_t ox, std::size_t oy) {
  ChargeMap c;
  for (std::size_t i = ox; i < map.nx(); i += n) c.x_m.push_back(map.x_m[i]);
  for (std::size_t j = oy; j < map.ny(); j += n) c.y_m.push_back(map.y_m[j]);
  c.forces_N = map.forces_N;
  c.electrode_names = map.electrode_names;
  if (c.nx() < 2 || c.ny() < 2) return c;
  const std::size_t ne = map.ne(), nf = map.nf();
  const bool slopes = !map.dcharge_dx_C_per_m.empty();
  c.mask.resize(c.nx() * c.ny());
  c.status.resize(nf * c.nx() * c.ny());
  c.charge_C.resize(c.status.size() * ne);
  if (slopes) {
    c.dcharge_dx_C_per_m.resize(c.charge_C.size());
    c.dcharge_dy_C_per_m.resize(c.charge_C.size());
  }
  for (std::size_t j = 0; j < c.ny(); ++j) {
    for (std::size_t i = 0; i < c.nx(); ++i) {
      const std::size_t fi = ox + n * i, fj = oy + n * j;
      c.mask[j * c.nx() + i] = map.mask[fj * map.nx() + fi];
      for (std::size_t f = 0; f < nf; ++f) {
        c.status[c.point(f, j, i)] = map.status[map.point(f, fj, fi)];
        for (std::size_t k = 0; k < ne; ++k) {
          c.charge_C[c.charge_index(f, j, i, k)] = map.charge_C[map.charge_index(f, fj, fi, k)];
          if (slopes) {
            c.dcharge_dx_C_per_m[c.charge_index(f, j, i, k)] = map.dcharge_dx_C_per_m[map.charge_index(f, fj, fi, k)];
            c.dcharge_dy_C_per_m[c.charge_index(f, j, i, k)] = map.dcharge_dy_C_per_m[map.charge_index(f, fj, fi, k)];
          }
        }
      }
    }
  }
  return c;
}

std::vector<double> hierarchical_surplus_G(const ChargeMap& map) {
  const std::size_t nx = map.nx(), ny = map.ny(), nf = map.nf(), ne = map.ne();
  std::vector<double> s(nf * ny * nx * ne, unknown);
  const std::vector<std::uint8_t> ok = usable_nodes(map);
  std::vector<double> log_f(nf), scale(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    log_f[f] = std::log(map.forces_N[f]);
    scale[f] = std::pow(map.forces_N[f], -membrane_charge_exponent);
  }
  std::array<double, max_electrodes> q{};
  for (std::size_t oy = 0; oy < 2; ++oy) {
    for (std::size_t ox = 0; ox < 2; ++ox) {
      const ChargeMap coarse = every_nth_node(map, 2, ox, oy);
      if (coarse.nx() < 2 || coarse.ny() < 2) continue;
      const MapInterpolant I(coarse);
      for (std::size_t j = 0; j < ny; ++j) {
        for (std::size_t i = 0; i < nx; ++i) {
          if ((i % 2 == ox && j % 2 == oy) || !ok[j * nx + i]) continue;
          for (std::size_t f = 0; f < nf; ++f) {
            if (!I.evaluate(map.x_m[i], map.y_m[j], nf == 1 ? 0.0 : log_f[f], q.data(), nullptr)) break;
            // A one-level interpolant returns F^p·G₀ at ln F = 0: G₀ itself.
            const double to_g = nf == 1 ? 1.0 : std::exp(-membrane_charge_exponent * log_f[f]);
            for (std::size_t k = 0; k < ne; ++k) {
              const double v = std::abs(map.charge_C[map.charge_index(f, j, i, k)] * scale[f] - q[k] * to_g);
              double& out = s[map.charge_index(f, j, i, k)];
              out = std::isnan(out) ? v : std::max(out, v);
            }
          }
        }
      }
    }
  }
  return s;
}

namespace {

/// Largest non-NaN value of a [f][j][i][k] array within ±r nodes of (i, j); NaN if none.
double window_max(const std::vector<double>& a, const ChargeMap& map, std::size_t f, std::size_t i, std::size_t j,
                  std::size_t k, long r) {
  double best = unknown;
  for (long dj = -r; dj <= r; ++dj) {
    for (long di = -r; di <= r; ++di) {
      const long ii = long(i) + di, jj = long(j) + dj;
      if (ii < 0 || jj < 0 || ii >= long(map.nx()) || jj >= long(map.ny())) continue;
      const double v = a[map.charge_index(f, std::size_t(jj), std::size_t(ii), k)];
      if (!std::isnan(v)) best = std::isnan(best) ? v : std::max(best, v);
    }
  }
  return best;
}

/// Between nodes, in G units ([f][j][i][k]): S₁(n), the error of the 2h interpolants at the
/// node, carried to h by ρ₀ = min(16, ρ₁²), ρ₁ = max(1, W₂/W₁) the ratio measured from 4h to 2h
/// (W: the largest surplus within ±2 nodes), ρ₁ = 2 where it cannot be measured.
std::vector<double> between_nodes(const ChargeMap& map) {
  const std::size_t nx = map.nx(), ny = map.ny(), nf = map.nf(), ne = map.ne();
  const std::vector<double> s1 = hierarchical_surplus_G(map);
  std::vector<double> s2(s1.size(), unknown);
  for (std::size_t oy = 0; oy < 2; ++oy) {
    for (std::size_t ox = 0; ox < 2; ++ox) {
      const ChargeMap c = every_nth_node(map, 2, ox, oy);
      if (c.nx() < 2 || c.ny() < 2) continue;
      const std::vector<double> sc = hierarchical_surplus_G(c);
      for (std::size_t f = 0; f < nf; ++f) {
        for (std::size_t j = 0; j < c.ny(); ++j) {
          for (std::size_t i = 0; i < c.nx(); ++i) {
            for (std::size_t k = 0; k < ne; ++k) s2[map.charge_index(f, oy + 2 * j, ox + 2 * i, k)] = sc[c.charge_index(f, j, i, k)];
          }
        }
      }
    }
  }
  const std::vector<std::uint8_t> ok = usable_nodes(map);
  constexpr double unmeasured_ratio = 2.0;  // first order: conservative against the 3–16 measured elsewhere
  std::vector<double> e(s1.size(), unknown);
  for (std::size_t f = 0; f < nf; ++f) {
    for (std::size_t j = 0; j < ny; ++j) {
      for (std::size_t i = 0; i < nx; ++i) {
        if (!ok[j * nx + i]) continue;
        for (std::size_t k = 0; k < ne; ++k) {
          const double w1 = window_max(s1, map, f, i, j, k, 2), w2 = window_max(s2, map, f, i, j, k, 2);
          // Next to under-resolved features the ratio grows from one halving to the next (an
          // analytic feature converges exponentially until h resolves it, then like h⁴): the
          // ratio measured one level coarser, squared, capped at the bicubic's 16.
          const double rho1 = w1 > 0 && w2 >= 0 ? std::max(1.0, w2 / w1) : unmeasured_ratio;
          const double rho0 = std::min(16.0, rho1 * rho1);
          const double s = s1[map.charge_index(f, j, i, k)];
          e[map.charge_index(f, j, i, k)] = std::isnan(s) ? unknown : s / rho0;
        }
      }
    }
  }
  // Usable nodes no 2h cell covers (a sliver at the mask's edge): the largest estimate of their
  // neighbours, spread up to four nodes; beyond that the level's largest estimate.
  for (int pass = 0; pass < 4; ++pass) {
    std::vector<double> next = e;
    bool missing = false;
    for (std::size_t f = 0; f < nf; ++f) {
      for (std::size_t j = 0; j < ny; ++j) {
        for (std::size_t i = 0; i < nx; ++i) {
          if (!ok[j * nx + i]) continue;
          for (std::size_t k = 0; k < ne; ++k) {
            const std::size_t n = map.charge_index(f, j, i, k);
            if (!std::isnan(e[n])) continue;
            next[n] = window_max(e, map, f, i, j, k, 1);
            missing = missing || std::isnan(next[n]);
          }
        }
      }
    }
    e.swap(next);
    if (!missing) break;
  }
  for (std::size_t f = 0; f < nf; ++f) {
    for (std::size_t k = 0; k < ne; ++k) {
      double level_max = 0;
      for (std::size_t p = 0; p < nx * ny; ++p) {
        const double v = e[(f * nx * ny + p) * ne + k];
        if (!std::isnan(v)) level_max = std::max(level_max, v);
      }
      for (std::size_t p = 0; p < nx * ny; ++p) {
        double& v = e[(f * nx * ny + p) * ne + k];
        if (std::isnan(v)) v = ok[p] ? level_max : 0.0;
      }
    }
  }
  return e;
}

}  // namespace

InterpolationError estimate_interpolation_error(const ChargeMap& map) {
  const std::size_t nx = map.nx(), ny = map.ny(), nf = map.nf(), ne = map.ne();
  const std::size_t n = nf * ny * nx * ne;
  InterpolationError out;
  out.between_levels_C.assign(n, 0.0);
  out.beyond_levels_C.assign(n, 0.0);
  out.between_nodes_C = between_nodes(map);
  std::vector<double> force_p(nf), log_f(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    force_p[f] = std::pow(map.forces_N[f], membrane_charge_exponent);
    log_f[f] = std::log(map.forces_N[f]);
  }
  const std::vector<std::uint8_t> ok = usable_nodes(map);
  for (std::size_t f = 0; f < nf; ++f) {
    for (std::size_t p = 0; p < nx * ny; ++p) {
      for (std::size_t k = 0; k < ne; ++k) out.between_nodes_C[(f * nx * ny + p) * ne + k] *= force_p[f];
    }
  }
  if (nf < 2) return out;
  // Force: G_f of one node and electrode; |G''| at each inner level from its two neighbours.
  std::vector<double> g(nf), curvature(nf);
  for (std::size_t p = 0; p < nx * ny; ++p) {
    if (!ok[p]) continue;
    for (std::size_t k = 0; k < ne; ++k) {
      for (std::size_t f = 0; f < nf; ++f) g[f] = map.charge_C[(f * nx * ny + p) * ne + k] / force_p[f];
      for (std::size_t f = 1; f + 1 < nf; ++f) {
        const double a = log_f[f] - log_f[f - 1], b = log_f[f + 1] - log_f[f];
        const double chord = (b * g[f - 1] + a * g[f + 1]) / (a + b);
        curvature[f] = 2.0 * std::abs(g[f] - chord) / (a * b);
      }
      for (std::size_t f = 0; f + 1 < nf; ++f) {
        const double d = log_f[f + 1] - log_f[f];
        double c = -1;  // the largest curvature measured at this interval's ends
        if (f >= 1) c = std::max(c, curvature[f]);
        if (f + 2 < nf) c = std::max(c, curvature[f + 1]);
        // With two levels no curvature is measurable: a quarter of the change, the chord's
        // largest departure from a parabola that is flat at one end.
        const double e = c >= 0 ? c * d * d / 8.0 : 0.25 * std::abs(g[f + 1] - g[f]);
        out.between_levels_C[(f * nx * ny + p) * ne + k] = e * force_p[f];
      }
      // Beyond the levels G is held; the true G moves on with the end interval's slope (and its
      // curvature over that interval, conservatively).
      const double d0 = log_f[1] - log_f[0], d1 = log_f[nf - 1] - log_f[nf - 2];
      const double c0 = nf > 2 ? curvature[1] : 0.0, c1 = nf > 2 ? curvature[nf - 2] : 0.0;
      out.beyond_levels_C[p * ne + k] = (std::abs(g[1] - g[0]) / d0 + 0.5 * c0 * d0) * force_p[0];
      out.beyond_levels_C[((nf - 1) * nx * ny + p) * ne + k] = (std::abs(g[nf - 1] - g[nf - 2]) / d1 + 0.5 * c1 * d1) * force_p[nf - 1];
    }
  }
  return out;
}

}  // namespace pvdf::mapping
