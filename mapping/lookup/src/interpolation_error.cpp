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

namespace {

/// The split of a signed error vector s over the electrodes (G units) against the node's reduced
/// charges g (docs/lookup.md §1.11): α = s·g / g·g (the least-squares common scale) and the rest
/// s − α g, orthogonal to g, so |s|² = α²|g|² + |s − α g|². The node's 2·ne + 1 channels hold the
/// totals |s_k| (each raised to the largest so far, as before the split) and the split of the
/// largest vector so far (|s|² compared; rest and scale from one and the same vector).
void split_into(const double* s, const double* g, std::size_t ne, double* channels) {
  double sg = 0, gg = 0, ss = 0, held = 0;
  for (std::size_t k = 0; k < ne; ++k) {
    sg += s[k] * g[k];
    gg += g[k] * g[k];
    ss += s[k] * s[k];
    if (!std::isnan(channels[ne + k])) held += channels[ne + k] * channels[ne + k];
  }
  const double alpha = gg > 0 ? sg / gg : 0.0;
  const bool first = std::isnan(channels[2 * ne]);
  if (!first) held += channels[2 * ne] * channels[2 * ne] * gg;
  for (std::size_t k = 0; k < ne; ++k) channels[k] = std::isnan(channels[k]) ? std::abs(s[k]) : std::max(channels[k], std::abs(s[k]));
  if (!first && ss <= held) return;
  for (std::size_t k = 0; k < ne; ++k) channels[ne + k] = std::abs(s[k] - alpha * g[k]);
  channels[2 * ne] = std::abs(alpha);
}

/// Hierarchical surpluses of G per [f][j][i] in 2·ne + 1 channels (split_into: total, rest,
/// scale) over the grids of every other node that do not hold the node; NaN where none covers it.
std::vector<double> surplus_channels(const ChargeMap& map) {
  const std::size_t nx = map.nx(), ny = map.ny(), nf = map.nf(), ne = map.ne(), nc = 2 * ne + 1;
  std::vector<double> s(nf * ny * nx * nc, unknown);
  const std::vector<std::uint8_t> ok = usable_nodes(map);
  std::vector<double> log_f(nf), scale(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    log_f[f] = std::log(map.forces_N[f]);
    scale[f] = std::pow(map.forces_N[f], -membrane_charge_exponent);
  }
  std::array<double, max_electrodes> q{}, g{}, d{};
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
              g[k] = map.charge_C[map.charge_index(f, j, i, k)] * scale[f];
              d[k] = g[k] - q[k] * to_g;
            }
            split_into(d.data(), g.data(), ne, &s[map.point(f, j, i) * nc]);
          }
        }
      }
    }
  }
  return s;
}

}  // namespace

std::vector<double> hierarchical_surplus_G(const ChargeMap& map) {
  const std::size_t ne = map.ne(), nc = 2 * ne + 1;
  const std::vector<double> c = surplus_channels(map);
  const std::size_t n_points = c.size() / nc;
  std::vector<double> s(n_points * ne);
  for (std::size_t n = 0; n < n_points; ++n) {
    for (std::size_t k = 0; k < ne; ++k) s[n * ne + k] = c[n * nc + k];
  }
  return s;
}

namespace {

/// Largest non-NaN value of channel k of an [f][j][i][nc] array within ±r nodes of (i, j); NaN if none.
double window_max(const std::vector<double>& a, const ChargeMap& map, std::size_t nc, std::size_t f, std::size_t i,
                  std::size_t j, std::size_t k, long r) {
  double best = unknown;
  for (long dj = -r; dj <= r; ++dj) {
    for (long di = -r; di <= r; ++di) {
      const long ii = long(i) + di, jj = long(j) + dj;
      if (ii < 0 || jj < 0 || ii >= long(map.nx()) || jj >= long(map.ny())) continue;
      const double v = a[map.point(f, std::size_t(jj), std::size_t(ii)) * nc + k];
      if (!std::isnan(v)) best = std::isnan(best) ? v : std::max(best, v);
    }
  }
  return best;
}

/// Between nodes, in G units ([f][j][i][2·ne + 1]: the total, rest and scale channels of
/// surplus_channels): S₁(n), the error of the 2h interpolants at the node, carried to h by
/// ρ₀ = min(16, ρ₁²), ρ₁ = max(1, W₂/W₁) the ratio measured from 4h to 2h (W: the largest
/// surplus within ±2 nodes), ρ₁ = 2 where it cannot be measured; each channel with its own ρ.
std::vector<double> between_nodes(const ChargeMap& map) {
  // ne here counts channels (2·electrodes + 1), each handled as the totals were.
  const std::size_t nx = map.nx(), ny = map.ny(), nf = map.nf(), ne = 2 * map.ne() + 1;
  const std::vector<double> s1 = surplus_channels(map);
  std::vector<double> s2(s1.size(), unknown);
  for (std::size_t oy = 0; oy < 2; ++oy) {
    for (std::size_t ox = 0; ox < 2; ++ox) {
      const ChargeMap c = every_nth_node(map, 2, ox, oy);
      if (c.nx() < 2 || c.ny() < 2) continue;
      const std::vector<double> sc = surplus_channels(c);
      for (std::size_t f = 0; f < nf; ++f) {
        for (std::size_t j = 0; j < c.ny(); ++j) {
          for (std::size_t i = 0; i < c.nx(); ++i) {
            for (std::size_t k = 0; k < ne; ++k) s2[map.point(f, oy + 2 * j, ox + 2 * i) * ne + k] = sc[c.point(f, j, i) * ne + k];
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
          const double w1 = window_max(s1, map, ne, f, i, j, k, 2), w2 = window_max(s2, map, ne, f, i, j, k, 2);
          // Next to under-resolved features the ratio grows from one halving to the next (an
          // analytic feature converges exponentially until h resolves it, then like h⁴): the
          // ratio measured one level coarser, squared, capped at the bicubic's 16.
          const double rho1 = w1 > 0 && w2 >= 0 ? std::max(1.0, w2 / w1) : unmeasured_ratio;
          const double rho0 = std::min(16.0, rho1 * rho1);
          const double s = s1[map.point(f, j, i) * ne + k];
          e[map.point(f, j, i) * ne + k] = std::isnan(s) ? unknown : s / rho0;
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
            const std::size_t n = map.point(f, j, i) * ne + k;
            if (!std::isnan(e[n])) continue;
            next[n] = window_max(e, map, ne, f, i, j, k, 1);
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
  const std::size_t nx = map.nx(), ny = map.ny(), nf = map.nf(), ne = map.ne(), nc = 2 * ne + 1;
  const std::size_t n = nf * ny * nx * ne, n_points = nf * ny * nx;
  InterpolationError out;
  out.between_levels_C.assign(n, 0.0);
  out.beyond_levels_C.assign(n, 0.0);
  out.between_levels_rest_C.assign(n, 0.0);
  out.beyond_levels_rest_C.assign(n, 0.0);
  out.between_levels_scale.assign(n_points, 0.0);
  out.beyond_levels_scale.assign(n_points, 0.0);
  std::vector<double> force_p(nf), log_f(nf);
  for (std::size_t f = 0; f < nf; ++f) {
    force_p[f] = std::pow(map.forces_N[f], membrane_charge_exponent);
    log_f[f] = std::log(map.forces_N[f]);
  }
  {  // between nodes: the three channel groups, in C at the level's force (the scale unitless)
    const std::vector<double> c = between_nodes(map);
    out.between_nodes_C.assign(n, 0.0);
    out.between_nodes_rest_C.assign(n, 0.0);
    out.between_nodes_scale.assign(n_points, 0.0);
    for (std::size_t f = 0; f < nf; ++f) {
      for (std::size_t p = 0; p < nx * ny; ++p) {
        const std::size_t at = f * nx * ny + p;
        for (std::size_t k = 0; k < ne; ++k) {
          out.between_nodes_C[at * ne + k] = c[at * nc + k] * force_p[f];
          out.between_nodes_rest_C[at * ne + k] = c[at * nc + ne + k] * force_p[f];
        }
        out.between_nodes_scale[at] = c[at * nc + 2 * ne];
      }
    }
  }
  if (nf < 2) return out;
  const std::vector<std::uint8_t> ok = usable_nodes(map);
  // Force: G_f of one node (all electrodes, [f][k]); the signed curvature at each inner level
  // from its two neighbours, and its split into a common scale β_f of G_f and the rest.
  std::vector<double> g(nf * ne), curvature(nf * ne, 0.0), curvature_rest(nf * ne, 0.0), curvature_scale(nf, 0.0);
  std::array<double, max_electrodes> v{}, mid{};
  // The split of v against the reduced charges `ref`: |α| returned, |v_k − α ref_k| into rest.
  auto split = [&](const double* ref, double* rest) {
    double sg = 0, gg = 0;
    for (std::size_t k = 0; k < ne; ++k) {
      sg += v[k] * ref[k];
      gg += ref[k] * ref[k];
    }
    const double alpha = gg > 0 ? sg / gg : 0.0;
    for (std::size_t k = 0; k < ne; ++k) rest[k] = std::abs(v[k] - alpha * ref[k]);
    return std::abs(alpha);
  };
  std::array<double, max_electrodes> rest{}, rest2{};
  for (std::size_t p = 0; p < nx * ny; ++p) {
    if (!ok[p]) continue;
    for (std::size_t f = 0; f < nf; ++f) {
      for (std::size_t k = 0; k < ne; ++k) g[f * ne + k] = map.charge_C[(f * nx * ny + p) * ne + k] / force_p[f];
    }
    for (std::size_t f = 1; f + 1 < nf; ++f) {
      const double a = log_f[f] - log_f[f - 1], b = log_f[f + 1] - log_f[f];
      for (std::size_t k = 0; k < ne; ++k) {
        const double chord = (b * g[(f - 1) * ne + k] + a * g[(f + 1) * ne + k]) / (a + b);
        v[k] = 2.0 * (g[f * ne + k] - chord) / (a * b);
        curvature[f * ne + k] = std::abs(v[k]);
      }
      curvature_scale[f] = split(&g[f * ne], &curvature_rest[f * ne]);
    }
    for (std::size_t f = 0; f + 1 < nf; ++f) {
      const double d = log_f[f + 1] - log_f[f];
      const std::size_t at = f * nx * ny + p;
      const bool measured = f >= 1 || f + 2 < nf;  // a curvature at one of this interval's ends
      if (measured) {
        // The largest curvature measured at the interval's ends, × Δ²/8 (each part on its own).
        // The split from the end with the larger curvature vector (|κ|² = β²|G|² + |κ − βG|²).
        std::size_t split_end = nf;
        double largest = -1;
        for (const std::size_t end : {f, f + 1}) {
          if (end < 1 || end + 1 >= nf) continue;
          double norm2 = 0;
          for (std::size_t k = 0; k < ne; ++k) norm2 += curvature[end * ne + k] * curvature[end * ne + k];
          if (norm2 > largest) {
            largest = norm2;
            split_end = end;
          }
        }
        for (std::size_t k = 0; k < ne; ++k) {
          double c = 0;
          for (const std::size_t end : {f, f + 1}) {
            if (end >= 1 && end + 1 < nf) c = std::max(c, curvature[end * ne + k]);
          }
          out.between_levels_C[at * ne + k] = c * d * d / 8.0 * force_p[f];
          out.between_levels_rest_C[at * ne + k] = curvature_rest[split_end * ne + k] * d * d / 8.0 * force_p[f];
        }
        out.between_levels_scale[at] = curvature_scale[split_end] * d * d / 8.0;
      } else {
        // With two levels no curvature is measurable: a quarter of the change, the chord's
        // largest departure from a parabola that is flat at one end; split against the
        // interval's mean G.
        for (std::size_t k = 0; k < ne; ++k) {
          v[k] = 0.25 * (g[(f + 1) * ne + k] - g[f * ne + k]);
          mid[k] = 0.5 * (g[(f + 1) * ne + k] + g[f * ne + k]);
          out.between_levels_C[at * ne + k] = std::abs(v[k]) * force_p[f];
        }
        out.between_levels_scale[at] = split(mid.data(), rest.data());
        for (std::size_t k = 0; k < ne; ++k) out.between_levels_rest_C[at * ne + k] = rest[k] * force_p[f];
      }
    }
    // Beyond the levels G is held; the true G moves on with the end interval's slope (and its
    // curvature over that interval, conservatively), split against the end level's G.
    for (const bool top : {false, true}) {
      const std::size_t f_end = top ? nf - 1 : 0, f_in = top ? nf - 2 : 1;
      const std::size_t f_curv = top ? nf - 2 : 1;  // the inner level next to the end (nf > 2)
      const double d = std::abs(log_f[f_end] - log_f[f_in]);
      for (std::size_t k = 0; k < ne; ++k) v[k] = (g[f_end * ne + k] - g[f_in * ne + k]) / d;
      const double slope_scale = split(&g[f_end * ne], rest.data());
      const double c_scale = nf > 2 ? curvature_scale[f_curv] : 0.0;
      const std::size_t at = f_end * nx * ny + p;
      for (std::size_t k = 0; k < ne; ++k) {
        const double c = nf > 2 ? curvature[f_curv * ne + k] : 0.0, cr = nf > 2 ? curvature_rest[f_curv * ne + k] : 0.0;
        rest2[k] = cr;
        out.beyond_levels_C[at * ne + k] = (std::abs(v[k]) + 0.5 * c * d) * force_p[f_end];
        out.beyond_levels_rest_C[at * ne + k] = (rest[k] + 0.5 * rest2[k] * d) * force_p[f_end];
      }
      out.beyond_levels_scale[at] = slope_scale + 0.5 * c_scale * d;
    }
  }
  return out;
}

}  // namespace pvdf::mapping
