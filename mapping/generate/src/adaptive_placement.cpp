// Map generation, adaptive placement (docs/map-generation.md §10): the solves go where the
// interpolant needs them, and every node stores its total error.
//
// Levels ℓ = 0..L on the stored grid (spacing h): level ℓ's nodes are the multiples of
// s_ℓ = 2^(L−ℓ)·h. Level 0 is solved everywhere. The error of level ℓ's interpolant (the
// lookup's own bicubic Hermite, MapInterpolant, on the nodes of spacing s_ℓ) near a node is
// predicted from that level's own nodes: κ·max(|Δ⁴ₓG|, |Δ⁴ᵧG|), the fourth differences of
// G = Q/F^(2/3) at step s_ℓ through the node (the interpolant's leading error term, measured
// where it is used; no rate extrapolated from a coarser level). κ = 1/8: a cubic Hermite
// interpolant with 4th-order slopes misses a slope discontinuity (the probe's footprint meeting an
// electrode's edge) in its cell by at most 0.060 × the corners' mean |Δ⁴| in the median over
// where the kink lies, ≤ 1/8 at 81 % of them (a Gaussian bump one spacing wide: 0.045, a smooth
// quartic 0.0026 — smooth regions are over-stated, by a small absolute amount). Within a cell the
// prediction is bilinear in its corners' values: local to the press, not the cell's largest.
// A cell is refined (the next level's five nodes inside it solved) where the largest of its
// corners' predictions exceeds the interpolation's share of the tolerance; otherwise it governs:
// the stored grid's nodes in it not solved are filled from its interpolant, and every node in it
// carries the prediction at its place.
//
// Total stored error of a node, per level and electrode (C), the three shares independent hence
// in quadrature (as the lookup adds its shares, docs/lookup.md §1.10):
//   own estimate (solved) or the largest of the governing cell's corners (filled)
//   ⊕ the predicted interpolation error at the node (the largest over the cells it belongs to)
//   ⊕ the error between force levels (estimate_interpolation_error's curvature term, both
//     intervals next to the level).
// The lookup (ChargeMap::estimated_total_relative_error set) reads it as the map's whole error.
#include "generator.hpp"

#include "pvdf/core/membrane_scaling.hpp"
#include "pvdf/mapping/interpolant.hpp"
#include "pvdf/mapping/interpolation_error.hpp"

#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

namespace pvdf::mapping::detail {
namespace {

/// Interpolation error of the bicubic Hermite interpolant per unit fourth difference of the data
/// at its nodes, for the worst feature a map has, a slope discontinuity in the cell: its largest
/// error in the cell is ≤ κ × the corners' mean |Δ⁴| for 81 % of the kink's positions (median
/// 0.060; 1/16 leaves 46 % above). A press sees less than the cell's largest error.
constexpr double kappa = 1.0 / 8.0;
/// The interpolation's guaranteed share of the tolerance (the rest is left to the node estimates;
/// where those use less, the interpolation may use what they leave).
constexpr double interpolation_share = 0.5;

long floor_mod(long a, long m) { return ((a % m) + m) % m; }

/// The highest difference (up to the fourth) of a line of samples through index i, from the
/// consecutive valid samples nearest to it: 5 → |Δ⁴|, centred if it can be, else shifted by one or
/// two; fewer valid neighbours → |Δ³| (4), |Δ²| (3) — larger than |Δ⁴| for a smooth line, so the
/// served edge is over-stated rather than under-stated; NaN with fewer than 3. f(m), ok(m) for
/// any m (ok false outside the line).
template <class Value, class Valid>
double highest_difference(const Value& f, const Valid& ok, long i) {
  static const double weights[3][5] = {{1, -2, 1, 0, 0}, {-1, 3, -3, 1, 0}, {1, -4, 6, -4, 1}};
  for (int order = 4; order >= 2; --order) {
    const long n = order + 1;
    for (const long shift : {0L, -1L, 1L, -2L, 2L}) {
      const long first = i - n / 2 + shift;
      if (first > i || first + n - 1 < i) continue;
      bool all = true;
      for (long m = first; m < first + n && all; ++m) all = ok(m);
      if (!all) continue;
      double d = 0;
      for (long m = 0; m < n; ++m) d += weights[order - 2][m] * f(first + m);
      return std::abs(d);
    }
  }
  return std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

int Generator::node_level(std::size_t i, std::size_t j) const {
  const long I = grid_.i0 + long(i), J = grid_.j0 + long(j);
  for (int l = 0; l < levels_; ++l) {
    const long s = 1L << (levels_ - l);
    if (floor_mod(I, s) == 0 && floor_mod(J, s) == 0) return l;
  }
  return levels_;
}

// A position holds FEM values at every level (its own or its mirror image's), not a fill.
bool Generator::node_solved(std::size_t p) const {
  if (!map_.mask[p] || interpolated_[p]) return false;
  const std::size_t n = grid_.nx * grid_.ny;
  for (std::size_t f = 0; f < layout_.nf; ++f) {
    if (map_.status[f * n + p] != std::uint8_t(PointStatus::ok)) return false;
  }
  return true;
}

// Every rank learns every rank's solved records (the next level's decision needs all of them and
// must be the same on every rank).
void Generator::share_records() {
  if (!use_mpi_ || size_ <= 1) return;
  const std::vector<double> mine = known_records(true);
  int count = int(mine.size());
  std::vector<int> counts(std::size_t(size_), 0), displs(std::size_t(size_), 0);
  MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD);
  long total = 0;
  for (int r = 0; r < size_; ++r) {
    displs[std::size_t(r)] = int(total);
    total += counts[std::size_t(r)];
  }
  std::vector<double> all(static_cast<std::size_t>(total));
  MPI_Allgatherv(mine.data(), count, MPI_DOUBLE, all.data(), counts.data(), displs.data(), MPI_DOUBLE, MPI_COMM_WORLD);
  for (std::size_t r = 0; r < all.size(); r += layout_.size()) {
    if (!known_[std::size_t(all[r])]) store_record(all.data() + r, false);
  }
}

// Level 0 everywhere, then per level the cells whose predicted error is too large; fills the rest.
// Returns whether any rank stopped early.
bool Generator::run_adaptive_levels() {
  const std::size_t nx = grid_.nx, ny = grid_.ny, n = nx * ny, nf = layout_.nf, ne = layout_.ne;
  const double tol = tolerance_;
  std::vector<double> force_p(nf);
  for (std::size_t f = 0; f < nf; ++f) force_p[f] = std::pow(o_.forces_N[f], membrane_charge_exponent);
  level_positions_.assign(std::size_t(levels_) + 1, 0);
  level_solves_.assign(std::size_t(levels_) + 1, 0);
  double placement_s = 0;

  // Solves the canonical images of `want` (any position), shares them, mirrors; counts the level.
  auto solve_level = [&](const std::vector<std::uint8_t>& want, int level) {
    std::vector<std::uint8_t> canonical_want(n, 0);
    for (std::size_t p = 0; p < n; ++p) {
      if (!want[p] || !map_.mask[p]) continue;
      ++level_positions_[std::size_t(level)];
      const Rep r = rep(p % nx, p / nx);
      canonical_want[r.j * nx + r.i] = 1;
    }
    const std::size_t before = fem_points_solved_;
    progress_total_ = progress_done_;
    for (std::size_t p = 0; p < n; ++p) progress_total_ += canonical_want[p] && !known_[p] ? 1 : 0;
    plan_time_left();
    const bool stopped = run_other_positions(&canonical_want);
    level_solves_[std::size_t(level)] += fem_points_solved_ - before;
    share_records();
    fill_mirrors();
    return stopped;
  };

  std::vector<std::uint8_t> want(n, 0);
  for (std::size_t p = 0; p < n; ++p) want[p] = map_.mask[p] && node_level(p % nx, p / nx) == 0;
  const std::size_t phase_a = fem_points_solved_;  // the force-scaling check positions are level 0
  if (solve_level(want, 0)) return true;
  level_solves_[0] += phase_a;

  for (int level = 0; level <= levels_; ++level) {
    const auto t0 = std::chrono::steady_clock::now();
    const long s = 1L << (levels_ - level);
    const std::size_t ox = std::size_t(floor_mod(-grid_.i0, s)), oy = std::size_t(floor_mod(-grid_.j0, s));
    const ChargeMap coarse = every_nth_node(map_, std::size_t(s), ox, oy);
    const std::size_t cnx = coarse.nx(), cny = coarse.ny();
    auto fine = [&](std::size_t a, std::size_t b) { return (oy + std::size_t(s) * b) * nx + ox + std::size_t(s) * a; };
    // Predicted error of this level's interpolant at each of its nodes (C/N^p, [nf][cny][cnx][ne]):
    // κ·max(|Δ⁴ₓG|, |Δ⁴ᵧG|) at step s over the level's usable nodes (solved, or filled by a coarser
    // level); NaN where neither direction has three usable nodes in a row.
    auto usable = [&](long aa, long bb) {
      if (aa < 0 || bb < 0 || aa >= long(cnx) || bb >= long(cny)) return false;
      const std::size_t p = fine(std::size_t(aa), std::size_t(bb));
      return node_solved(p) || interpolated_[p] != 0;
    };
    std::vector<double> predicted(nf * cny * cnx * ne, std::numeric_limits<double>::quiet_NaN());
    for (std::size_t bb = 0; bb < cny; ++bb) {
      for (std::size_t aa = 0; aa < cnx; ++aa) {
        if (!usable(long(aa), long(bb))) continue;
        for (std::size_t f = 0; f < nf; ++f) {
          for (std::size_t k = 0; k < ne; ++k) {
            auto g = [&](long ia, long ib) {
              return map_.charge_C[(f * n + fine(std::size_t(ia), std::size_t(ib))) * ne + k] / force_p[f];
            };
            const double dx = highest_difference([&](long m) { return g(m, long(bb)); },
                                                 [&](long m) { return usable(m, long(bb)); }, long(aa));
            const double dy = highest_difference([&](long m) { return g(long(aa), m); },
                                                 [&](long m) { return usable(long(aa), m); }, long(bb));
            const double d = std::isnan(dx) ? dy : std::isnan(dy) ? dx : std::max(dx, dy);
            predicted[((f * cny + bb) * cnx + aa) * ne + k] = kappa * d;
          }
        }
      }
    }
    std::vector<std::uint8_t> next_want(n, 0);
    std::vector<double> e(nf * ne);
    for (std::size_t b = 0; b + 1 < cny; ++b) {
      for (std::size_t a = 0; a + 1 < cnx; ++a) {
        const std::size_t corners[4] = {fine(a, b), fine(a + 1, b), fine(a, b + 1), fine(a + 1, b + 1)};
        const std::size_t ca[4] = {a, a + 1, a, a + 1}, cb[4] = {b, b, b + 1, b + 1};
        bool in_mask = true, active = true;
        for (std::size_t c : corners) {
          in_mask = in_mask && map_.mask[c];
          active = active && node_solved(c);
        }
        const std::size_t i0 = ox + std::size_t(s) * a, j0 = oy + std::size_t(s) * b;
        auto mark_inside = [&](std::vector<std::uint8_t>& v) {
          for (std::size_t j = j0; j <= j0 + std::size_t(s); ++j) {
            for (std::size_t i = i0; i <= i0 + std::size_t(s); ++i) {
              if (map_.mask[j * nx + i] && node_level(i, j) == level + 1) v[j * nx + i] = 1;
            }
          }
        };
        if (!active) {
          // A cell the interpolant cannot serve (a corner outside the mask or failed): the next
          // level's nodes in it are solved. A cell inside the mask with filled corners lies in a
          // coarser governing cell: nothing to decide here.
          bool filled_corner = false;
          for (std::size_t c : corners) filled_corner = filled_corner || interpolated_[c];
          if (level < levels_ && !(in_mask && filled_corner)) mark_inside(next_want);
          continue;
        }
        // The cell's largest prediction (its corners'), per level and electrode; unknown where a
        // corner has none (refined; at the finest level the largest known one, else flagged).
        std::fill(e.begin(), e.end(), 0.0);
        bool unknown = false, none = true;
        for (int c = 0; c < 4; ++c) {
          for (std::size_t fk = 0; fk < nf * ne; ++fk) {
            const double v = predicted[(((fk / ne) * cny + cb[c]) * cnx + ca[c]) * ne + fk % ne];
            if (std::isnan(v)) {
              unknown = true;
            } else {
              e[fk] = std::max(e[fk], v);
              none = false;
            }
          }
        }
        // Within the budget? Per level: the largest electrode's predicted error against the
        // interpolation's share of the tolerance × the press's largest charge (smallest corner).
        bool refine = unknown;
        bool exceeded = none;
        for (std::size_t f = 0; f < nf && !none; ++f) {
          double q = 1e300, node = 0, interp = 0;
          for (std::size_t c : corners) {
            double qc = 0;
            for (std::size_t k = 0; k < ne; ++k) {
              qc = std::max(qc, std::abs(map_.charge_C[(f * n + c) * ne + k]));
              node = std::max(node, map_.estimated_charge_error_C[(f * n + c) * ne + k]);
            }
            q = std::min(q, qc);
          }
          for (std::size_t k = 0; k < ne; ++k) interp = std::max(interp, e[f * ne + k] * force_p[f]);
          const double budget = std::max(interpolation_share * tol * q, tol * q - node);
          refine = refine || interp > budget;
          exceeded = exceeded || std::hypot(interp, node) > tol * q;
        }
        if (level < levels_ && refine) {
          mark_inside(next_want);
          continue;
        }
        // A governing cell: every stored node in it carries the prediction at its place, bilinear
        // in the corners' (a corner without one: the cell's largest).
        for (std::size_t j = j0; j <= j0 + std::size_t(s); ++j) {
          for (std::size_t i = i0; i <= i0 + std::size_t(s); ++i) {
            const std::size_t p = j * nx + i;
            if (!map_.mask[p]) continue;
            const double u = double(i - i0) / double(s), v = double(j - j0) / double(s);
            const double w[4] = {(1 - u) * (1 - v), u * (1 - v), (1 - u) * v, u * v};
            for (std::size_t fk = 0; fk < nf * ne; ++fk) {
              double here = 0;
              for (int c = 0; c < 4; ++c) {
                const double pc = predicted[(((fk / ne) * cny + cb[c]) * cnx + ca[c]) * ne + fk % ne];
                here += w[c] * (std::isnan(pc) ? e[fk] : pc);
              }
              double& out = interp_err_G_[((fk / ne) * n + p) * ne + fk % ne];
              out = std::max(out, here);
            }
            if (exceeded) {
              for (std::size_t f = 0; f < nf; ++f) provenance_[f * n + p] |= provenance::tolerance_not_met;
            }
          }
        }
      }
    }
    // The next level's nodes outside every cell of this level (the grid's border rows and
    // columns beyond the last node of this level) have no interpolant: solved.
    if (level < levels_) {
      const std::size_t i_end = cnx >= 2 ? ox + std::size_t(s) * (cnx - 1) : 0, j_end = cny >= 2 ? oy + std::size_t(s) * (cny - 1) : 0;
      for (std::size_t j = 0; j < ny; ++j) {
        for (std::size_t i = 0; i < nx; ++i) {
          const bool covered = cnx >= 2 && cny >= 2 && i >= ox && i <= i_end && j >= oy && j <= j_end;
          if (!covered && map_.mask[j * nx + i] && node_level(i, j) == level + 1) next_want[j * nx + i] = 1;
        }
      }
    }
    placement_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (level == levels_) break;
    if (solve_level(next_want, level + 1)) {
      placement_s_ = placement_s;
      return true;
    }
    // The next level's nodes not solved: filled from this level's interpolant.
    if (cnx < 2 || cny < 2) continue;  // no cell at this level: every next-level node was solved
    const auto t1 = std::chrono::steady_clock::now();
    const MapInterpolant interp(coarse);
    std::vector<double> q(ne);
    for (std::size_t j = 0; j < ny; ++j) {
      for (std::size_t i = 0; i < nx; ++i) {
        const std::size_t p = j * nx + i;
        if (!map_.mask[p] || node_level(i, j) != level + 1) continue;
        if (node_solved(p) || map_.status[p] == std::uint8_t(PointStatus::not_converged)) continue;  // a failed solve stays failed
        bool all = true;
        for (std::size_t f = 0; f < nf && all; ++f) {
          all = interp.evaluate(map_.x_m[i], map_.y_m[j], nf == 1 ? 0.0 : std::log(o_.forces_N[f]), q.data(), nullptr);
          if (!all) break;
          // A one-level interpolant returns G itself (F^p at ln F = 0 is 1).
          const double to_q = nf == 1 ? force_p[f] : 1.0;
          for (std::size_t k = 0; k < ne; ++k) map_.charge_C[(f * n + p) * ne + k] = q[k] * to_q;
        }
        if (!all) continue;  // cannot happen: such nodes were solved (left not_computed otherwise)
        // Filled: status ok, the largest node estimates and deflection error of the cell's corners,
        // the deflection bilinear in them.
        interpolated_[p] = 1;
        const std::size_t a = std::min((i - ox) / std::size_t(s), cnx - 2), b = std::min((j - oy) / std::size_t(s), cny - 2);
        const std::size_t corners[4] = {fine(a, b), fine(a + 1, b), fine(a, b + 1), fine(a + 1, b + 1)};
        const double u = (double(i) - double(ox + std::size_t(s) * a)) / double(s);
        const double v = (double(j) - double(oy + std::size_t(s) * b)) / double(s);
        const double w[4] = {(1 - u) * (1 - v), u * (1 - v), (1 - u) * v, u * v};
        for (std::size_t f = 0; f < nf; ++f) {
          const std::size_t pt = f * n + p;
          map_.status[pt] = std::uint8_t(PointStatus::ok);
          provenance_[pt] = std::uint8_t((provenance_[pt] & provenance::tolerance_not_met) | provenance::interpolated);
          node_model_[pt] = 0;
          double defl = 0, defl_err = 0;
          for (int c = 0; c < 4; ++c) {
            defl += w[c] * map_.deflection_at_load_m[f * n + corners[c]];
            defl_err = std::max(defl_err, deflection_error_[f * n + corners[c]]);
            for (std::size_t k = 0; k < ne; ++k) {
              double& err = map_.estimated_charge_error_C[pt * ne + k];
              const double ec = map_.estimated_charge_error_C[(f * n + corners[c]) * ne + k];
              err = c == 0 ? ec : std::max(err, ec);
            }
          }
          map_.deflection_at_load_m[pt] = defl;
          deflection_error_[pt] = defl_err;
        }
      }
    }
    placement_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  }
  placement_s_ = placement_s;
  return false;
}

// After the gather and the mirror copies: the node estimates' largest share, then every node's
// total error (node + between nodes + between force levels), the report's per-level counts.
void Generator::finish_adaptive(MapReport& report) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t n = grid_.nx * grid_.ny, nf = layout_.nf, ne = layout_.ne;
  double node_max = 0;
  for (std::size_t pt = 0; pt < nf * n; ++pt) {
    if (map_.status[pt] != std::uint8_t(PointStatus::ok)) continue;
    double e = 0, q = 0;
    for (std::size_t k = 0; k < ne; ++k) {
      e = std::max(e, map_.estimated_charge_error_C[pt * ne + k]);
      q = std::max(q, std::abs(map_.charge_C[pt * ne + k]));
    }
    if (q > 0) node_max = std::max(node_max, e / q);
  }
  map_.estimated_relative_error = node_max;
  const InterpolationError between = estimate_interpolation_error(map_);
  std::vector<double> force_p(nf);
  for (std::size_t f = 0; f < nf; ++f) force_p[f] = std::pow(o_.forces_N[f], membrane_charge_exponent);
  for (std::size_t f = 0; f < nf; ++f) {
    for (std::size_t p = 0; p < n; ++p) {
      const std::size_t pt = f * n + p;
      if (map_.status[pt] != std::uint8_t(PointStatus::ok)) continue;
      double e_max = 0, q_max = 0;
      for (std::size_t k = 0; k < ne; ++k) {
        const std::size_t at = pt * ne + k;
        double levels = f + 1 < nf ? between.between_levels_C[at] : 0.0;
        if (f > 0) levels = std::max(levels, between.between_levels_C[((f - 1) * n + p) * ne + k] * force_p[f] / force_p[f - 1]);
        double& e = map_.estimated_charge_error_C[at];
        e = std::sqrt(e * e + std::pow(interp_err_G_[at] * force_p[f], 2) + levels * levels);
        e_max = std::max(e_max, e);
        q_max = std::max(q_max, std::abs(map_.charge_C[at]));
      }
      if (e_max > tolerance_ * q_max) provenance_[pt] |= provenance::tolerance_not_met;
      if (interpolated_[p]) ++report.n_interpolated;
    }
  }
  fill_mirrors();  // the totals and flags of the mirror images are their originals'
  if (use_mpi_ && size_ > 1) {
    std::vector<unsigned long long> c(level_solves_.begin(), level_solves_.end());
    MPI_Allreduce(MPI_IN_PLACE, c.data(), int(c.size()), MPI_UNSIGNED_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
    for (std::size_t l = 0; l < c.size(); ++l) level_solves_[l] = std::size_t(c[l]);
  }
  for (int l = 0; l <= levels_; ++l) report.level_spacing_m.push_back(grid_.spacing * double(1L << (levels_ - l)));
  report.level_positions = level_positions_;
  report.level_solves = level_solves_;
  placement_s_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace pvdf::mapping::detail
