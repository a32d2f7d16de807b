// Map generation, adaptive placement (docs/map-generation.md §10): the solves go where the
// interpolant needs them, and every node stores its total error.
//
// Levels ℓ = 0..L on the stored grid (spacing h): level ℓ's nodes are the multiples of
// s_ℓ = 2^(L−ℓ)·h. Level 0 is solved everywhere. The error of level ℓ's interpolant (the
// lookup's own bicubic, MapInterpolant, on the nodes of spacing s_ℓ) in one of its cells is
// predicted from hierarchical surpluses: at the nodes new at level ℓ, |G − I_{ℓ−1}G|, the true
// error of the coarser interpolant there (G = Q/F^(2/3)); at level 0 the same against the grids
// of every other level-0 node. One halving of the spacing is assumed to divide the error by
// ρ = min(16, ρ₁²), ρ₁ the fall measured at the previous halving around the cell, never less than
// 2 — the first-order rate the charge shows where the probe's footprint meets an electrode (a
// kink; measured 4 → 2 mm on seed 001, issue 29) — and 2 where ρ₁ is not measured.
// A cell is refined (the next level's five nodes inside it solved) where that prediction exceeds
// the interpolation's share of the tolerance; otherwise it governs: the stored grid's nodes in it
// not solved are filled from its interpolant, and every node in it carries its predicted error.
//
// Total stored error of a node, per level and electrode (C):
//   own estimate (solved) or the largest of the governing cell's corners (filled)
//   + the predicted interpolation error of the cells around it
//   + the error between force levels (estimate_interpolation_error's curvature term, both
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

namespace pvdf::mapping::detail {
namespace {

/// Error reduction per halving of the spacing assumed by the prediction: at least first order
/// (the kink where the footprint meets an electrode), at most the bicubic's fourth order.
constexpr double min_ratio = 2.0;
constexpr double max_ratio = 16.0;
/// The interpolation's guaranteed share of the tolerance (the rest is left to the node estimates;
/// where those use less, the interpolation may use what they leave).
constexpr double interpolation_share = 0.5;

long floor_mod(long a, long m) { return ((a % m) + m) % m; }

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
    if (level == 0 && cnx >= 2 && cny >= 2) {
      const std::vector<double> s0 = hierarchical_surplus_G(coarse);
      for (std::size_t b = 0; b < cny; ++b) {
        for (std::size_t a = 0; a < cnx; ++a) {
          const std::size_t p = fine(a, b);
          if (!node_solved(p)) continue;
          bool any = false;
          for (std::size_t f = 0; f < nf; ++f) {
            for (std::size_t k = 0; k < ne; ++k) {
              const double v = s0[coarse.charge_index(f, b, a, k)];
              surplus_G_[(f * n + p) * ne + k] = v;
              any = any || !std::isnan(v);
            }
          }
          if (any) surplus_level_[p] = 0;
        }
      }
    }
    // Predicted error of this level's interpolant per cell (C/N^p), from the surpluses measured
    // at this level's nodes within one cell of it (two, three, ... where none is).
    std::vector<std::uint8_t> next_want(n, 0);
    std::vector<double> e(nf * ne), e_prev(nf * ne);
    for (std::size_t b = 0; b + 1 < cny; ++b) {
      for (std::size_t a = 0; a + 1 < cnx; ++a) {
        const std::size_t corners[4] = {fine(a, b), fine(a + 1, b), fine(a, b + 1), fine(a + 1, b + 1)};
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
        // W: the largest surplus at this level's nodes among the cell's corners (within one cell,
        // two where none is); W⁻: the same one level coarser, within twice that. ρ₁ = W⁻/W is how much the
        // error fell at the last halving; the next is assumed to divide it by ρ = min(16, ρ₁²)
        // (floor 2: first order, the kink where the footprint meets an electrode), as the lookup
        // assumes (docs/lookup.md §1.10); ρ = 2 where W⁻ is not measured.
        std::fill(e.begin(), e.end(), -1.0);
        std::fill(e_prev.begin(), e_prev.end(), -1.0);
        long r_used = 1;
        for (long r = 1; r <= 3 && e[0] < 0; ++r) {
          r_used = r;
          for (long bb = long(b) - r + 1; bb <= long(b) + r; ++bb) {
            for (long aa = long(a) - r + 1; aa <= long(a) + r; ++aa) {
              if (aa < 0 || bb < 0 || aa >= long(cnx) || bb >= long(cny)) continue;
              const std::size_t p = fine(std::size_t(aa), std::size_t(bb));
              if (surplus_level_[p] != level) continue;
              for (std::size_t fk = 0; fk < nf * ne; ++fk) {
                const double v = surplus_G_[((fk / ne) * n + p) * ne + fk % ne];
                if (!std::isnan(v)) e[fk] = std::max(e[fk], v);
              }
            }
          }
        }
        if (level > 0 && e[0] >= 0) {
          const long r = 2 * r_used;
          for (long bb = long(b) - r + 1; bb <= long(b) + r; ++bb) {
            for (long aa = long(a) - r + 1; aa <= long(a) + r; ++aa) {
              if (aa < 0 || bb < 0 || aa >= long(cnx) || bb >= long(cny)) continue;
              const std::size_t p = fine(std::size_t(aa), std::size_t(bb));
              if (surplus_level_[p] != level - 1) continue;
              for (std::size_t fk = 0; fk < nf * ne; ++fk) {
                const double v = surplus_G_[((fk / ne) * n + p) * ne + fk % ne];
                if (!std::isnan(v)) e_prev[fk] = std::max(e_prev[fk], v);
              }
            }
          }
        }
        for (std::size_t fk = 0; fk < nf * ne && e[0] >= 0; ++fk) {
          const double rho1 = e_prev[fk] >= 0 && e[fk] > 0 ? e_prev[fk] / e[fk] : 0.0;
          const double rho = std::min(max_ratio, std::max(min_ratio, rho1 * rho1));
          e[fk] = std::max(e[fk], 0.0) / rho;
        }
        bool unknown = e[0] < 0;
        // Within the budget? Per level: the largest electrode's predicted error against the
        // interpolation's share of the tolerance × the press's largest charge (smallest corner).
        bool refine = unknown;
        bool exceeded = unknown;
        for (std::size_t f = 0; f < nf && !unknown; ++f) {
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
          exceeded = exceeded || interp + node > tol * q;
        }
        if (level < levels_ && refine) {
          mark_inside(next_want);
          continue;
        }
        // A governing cell: its prediction is the interpolation error of every stored node in it.
        for (std::size_t j = j0; j <= j0 + std::size_t(s); ++j) {
          for (std::size_t i = i0; i <= i0 + std::size_t(s); ++i) {
            const std::size_t p = j * nx + i;
            if (!map_.mask[p]) continue;
            for (std::size_t fk = 0; fk < nf * ne; ++fk) {
              double& out = interp_err_G_[((fk / ne) * n + p) * ne + fk % ne];
              out = std::max(out, unknown ? 0.0 : e[fk]);
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
    // The next level's nodes: surplus where solved, the interpolant of this level where not.
    if (cnx < 2 || cny < 2) continue;  // no cell at this level: every next-level node was solved
    const auto t1 = std::chrono::steady_clock::now();
    const MapInterpolant interp(coarse);
    std::vector<double> q(ne);
    for (std::size_t j = 0; j < ny; ++j) {
      for (std::size_t i = 0; i < nx; ++i) {
        const std::size_t p = j * nx + i;
        if (!map_.mask[p] || node_level(i, j) != level + 1) continue;
        const bool solved = node_solved(p);
        if (!solved && map_.status[p] == std::uint8_t(PointStatus::not_converged)) continue;  // a failed solve stays failed
        bool all = true;
        for (std::size_t f = 0; f < nf && all; ++f) {
          all = interp.evaluate(map_.x_m[i], map_.y_m[j], nf == 1 ? 0.0 : std::log(o_.forces_N[f]), q.data(), nullptr);
          if (!all) break;
          // A one-level interpolant returns G itself (F^p at ln F = 0 is 1).
          const double to_q = nf == 1 ? force_p[f] : 1.0;
          for (std::size_t k = 0; k < ne; ++k) {
            const std::size_t at = (f * n + p) * ne + k;
            if (solved) {
              surplus_G_[at] = std::abs(map_.charge_C[at] - q[k] * to_q) / force_p[f];
            } else {
              map_.charge_C[at] = q[k] * to_q;
            }
          }
        }
        if (solved) {
          if (all) surplus_level_[p] = std::int8_t(level + 1);
          continue;
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
        e += interp_err_G_[at] * force_p[f] + levels;
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
