// The lookup's coarse search (docs/lookup.md §1.2–1.5): candidate cells from the direction
// table, predicted and refined starts, fold twins.
#include "locator_detail.hpp"
#include "pvdf/mapping/locator.hpp"

namespace pvdf::mapping {

using detail::direction_key;
using detail::normalize;
using detail::solve_spd3;
using detail::Vec;
using detail::CandidateTest;
using detail::test_candidate;

void Locator::scan_cells(const std::uint32_t* begin, const std::uint32_t* end, const double* q_unit, double noise2,
                         Shortlist& list) const {
  for (const std::uint32_t* it = begin; it != end; ++it) {
    const std::size_t c = *it;
    const double* d = &cell_dir_[c * ne_];
    double dot = 0;
    for (std::size_t k = 0; k < ne_; ++k) dot += d[k] * q_unit[k];
    if (dot <= 0) continue;
    // Angular misfit in units of what the cell can explain (its own angular radius, plus the
    // noise): ≤ 1 means the query direction plausibly comes from inside this cell. Scoring
    // relative to the cell size keeps small cells near electrodes (where the direction turns
    // fast) from being crowded out by big-looking matches far away.
    const double misfit = (1.0 - dot * dot) / (4.0 * cell_radius2_[c] + 9.0 * std::max(noise2, 0.0) + 1e-14);
    if (noise2 >= 0 && misfit > 1.0) continue;
    bool dup = false;
    for (int m = 0; m < list.n; ++m) dup = dup || list.cell[std::size_t(m)] == c;
    if (dup) continue;
    int pos = list.n;
    while (pos > 0 && list.score[std::size_t(pos - 1)] > misfit) --pos;
    if (pos >= Shortlist::capacity) continue;
    for (int m = std::min(list.n, Shortlist::capacity - 1); m > pos; --m) {
      list.cell[std::size_t(m)] = list.cell[std::size_t(m - 1)];
      list.score[std::size_t(m)] = list.score[std::size_t(m - 1)];
    }
    list.cell[std::size_t(pos)] = c;
    list.score[std::size_t(pos)] = misfit;
    list.n = std::min(list.n + 1, Shortlist::capacity);
  }
}

void Locator::coarse_candidates(const double* q_unit, double noise2, Shortlist& list) const {
  list.n = 0;
  double phi, theta;
  direction_key(q_unit, phi, theta);
  const int p = int(std::floor((phi - phi0_) / (phi1_ - phi0_) * bins_));
  const int t = int(std::floor((theta - theta0_) / (theta1_ - theta0_) * bins_));
  for (int ring = 0; ring <= 1 && list.n == 0; ++ring) {
    for (int tt = t - ring; tt <= t + ring; ++tt) {
      for (int pp = p - ring; pp <= p + ring; ++pp) {
        if (pp < 0 || tt < 0 || pp >= bins_ || tt >= bins_) continue;
        if (ring == 1 && tt != t - 1 && tt != t + 1 && pp != p - 1 && pp != p + 1) continue;
        const std::size_t b = std::size_t(tt * bins_ + pp);
        scan_cells(bin_cells_.data() + bin_start_[b], bin_cells_.data() + bin_start_[b + 1], q_unit, noise2, list);
      }
    }
  }
  if (list.n == 0) {
    // Last resort (a direction no cell produces: outside the map or far off the model): the
    // best-matching cells anywhere, so that the fit can say how far off it is.
    for (std::size_t c = 0; c < cells_.size(); ++c) {
      const std::uint32_t c32 = std::uint32_t(c);
      scan_cells(&c32, &c32 + 1, q_unit, -1.0, list);
    }
  }
}

PVDF_CLONES bool Locator::predicted_starts(const double* q_unit, double log_q_norm, double noise2, bool fixed_force,
                               double log_force, double log_lo, double log_hi, StartList& starts,
                                           bool own_bin_only) const {
  starts.n = 0;
  double phi, theta;
  direction_key(q_unit, phi, theta);
  const int p = int(std::floor((phi - phi0_) / (phi1_ - phi0_) * bins_));
  const int t = int(std::floor((theta - theta0_) / (theta1_ - theta0_) * bins_));
  const double p_exp = interp_.force_exponent(), inv_p = 1.0 / p_exp;
  const double hx = interp_.hx(), hy = interp_.hy();
  const int last_ring = own_bin_only ? 0 : 1;
  for (int ring = 0; ring <= last_ring && starts.n == 0; ++ring) {
    for (int tt = t - ring; tt <= t + ring; ++tt) {
      for (int pp = p - ring; pp <= p + ring; ++pp) {
        if (pp < 0 || tt < 0 || pp >= bins_ || tt >= bins_) continue;
        if (ring == 1 && tt != t - 1 && tt != t + 1 && pp != p - 1 && pp != p + 1) continue;
        const std::size_t b = std::size_t(tt * bins_ + pp);
        // Ask for every candidate's record first: the loads overlap instead of queueing behind
        // the mispredicted branches of the tests below.
        for (std::size_t m = bin_start_[b]; m < bin_split_[b]; ++m) {
          const char* rec = reinterpret_cast<const char*>(&scan_[std::size_t(bin_cells_[m]) * scan_stride_]);
          __builtin_prefetch(rec);
          __builtin_prefetch(rec + 64);
        }
        for (std::size_t m = bin_start_[b]; m < bin_split_[b]; ++m) {
          const std::size_t c = bin_cells_[m];
          const float* sc = &scan_[c * scan_stride_];
          CandidateTest ct{};
          const bool pass = ne_ == 3 ? test_candidate<3>(sc, ne_, q_unit, log_q_norm, noise2, fixed_force, log_force, log_lo,
                                                         log_hi, p_exp, inv_p, ct)
                                     : test_candidate<0>(sc, ne_, q_unit, log_q_norm, noise2, fixed_force, log_force,
                                                         log_lo, log_hi, p_exp, inv_p, ct);
          if (!pass) continue;
          const double dt = ct.dt, ds = ct.ds, l1 = ct.l, res2 = ct.res2;
          Start st{cell_xy_[c][0] + dt * hx, cell_xy_[c][1] + ds * hy, l1, res2};
          if ((std::abs(dt) > 0.5 || std::abs(ds) > 0.5) && !interp_.inside(st.x, st.y)) {
            // Predicted just off the map (a press on its edge): start inside the cell instead.
            st.x = cell_xy_[c][0] + std::clamp(dt, -0.499, 0.499) * hx;
            st.y = cell_xy_[c][1] + std::clamp(ds, -0.499, 0.499) * hy;
          }
          // Same solution as a start already found (predicted within ½ cell)? Keep the better one.
          // (Not wider: across a fold next to an electrode two exact solutions can lie ~0.4 cell
          // apart, each predicted by the cells on its own side.)
          int same = -1;
          for (int o = 0; o < starts.n && same < 0; ++o) {
            const Start& so = starts.start[std::size_t(o)];
            if (std::abs(so.x - st.x) < 0.5 * hx && std::abs(so.y - st.y) < 0.5 * hy) same = o;
          }
          int pos;
          if (same >= 0) {
            if (starts.start[std::size_t(same)].score <= res2) continue;
            pos = same;  // replace, then bubble up
          } else if (starts.n < StartList::capacity) {
            pos = starts.n++;
          } else if (starts.start[StartList::capacity - 1].score > res2) {
            pos = StartList::capacity - 1;
          } else {
            continue;
          }
          starts.start[std::size_t(pos)] = st;
          for (; pos > 0 && starts.start[std::size_t(pos - 1)].score > st.score; --pos) {
            std::swap(starts.start[std::size_t(pos)], starts.start[std::size_t(pos - 1)]);
          }
        }
      }
    }
  }
  return starts.n > 0;
}

namespace {

/// Two Newton steps on q̂ = d + J δ + ½ H(δ, δ) in least squares, from δ = (dt, ds) (cell units;
/// d = the cell model's rows d, Jt, Js, Htt, Hts, Hss of NE each; NE = 0: runtime count). False
/// at a fold (singular) or where the model has no solution near.
template <std::size_t NE>
PVDF_INLINE bool newton_in_cell(const double* d, std::size_t ne_runtime, const double* q_unit, double& dt, double& ds) {
  const std::size_t ne = NE > 0 ? NE : ne_runtime;
  const double *jt = d + ne, *js = d + 2 * ne, *htt = d + 3 * ne, *hts = d + 4 * ne, *hss = d + 5 * ne;
  for (int it = 0; it < 2; ++it) {
    double a00 = 0, a01 = 0, a11 = 0, b0 = 0, b1 = 0;
    for (std::size_t k = 0; k < ne; ++k) {
      const double e = q_unit[k] - d[k] - jt[k] * dt - js[k] * ds -
                       0.5 * (htt[k] * dt * dt + 2 * hts[k] * dt * ds + hss[k] * ds * ds);
      const double ct = jt[k] + htt[k] * dt + hts[k] * ds, cs = js[k] + hts[k] * dt + hss[k] * ds;
      a00 += ct * ct;
      a01 += ct * cs;
      a11 += cs * cs;
      b0 += ct * e;
      b1 += cs * e;
    }
    const double det = a00 * a11 - a01 * a01;
    if (!(det > 1e-14 * (a00 * a11 + 1e-300))) return false;  // a fold: leave the start to the fit
    const double idet = 1.0 / det;
    const double st_t = (a11 * b0 - a01 * b1) * idet, st_s = (a00 * b1 - a01 * b0) * idet;
    if (!(std::abs(st_t) < 1.0 && std::abs(st_s) < 1.0)) return false;  // the model has no solution near
    dt += st_t;
    ds += st_s;
  }
  return true;
}

}  // namespace

PVDF_CLONES bool Locator::cell_model(double x, double y, double l, CellModel& m) const {
  const std::size_t nx = interp_.nx(), ny = interp_.ny(), nf = interp_.n_levels();
  const double u = (x - interp_.x0()) * interp_.inv_hx(), v = (y - interp_.y0()) * interp_.inv_hy();
  if (!(u >= 0 && v >= 0 && u < double(nx - 1) && v < double(ny - 1))) return false;
  const std::size_t i = std::size_t(u), j = std::size_t(v);
  const std::int32_t slot = cell_slot_[j * (nx - 1) + i];
  if (slot < 0) return false;
  m.cell = std::size_t(slot);
  m.dt = u - double(i) - 0.5;
  m.ds = v - double(j) - 0.5;
  std::size_t f0 = 0;
  double w = 0;
  interp_.level_bracket(l, f0, w);
  const float* m0 = &model_[(m.cell * nf + f0) * model_stride_];
  const float* m1 = nf > 1 ? m0 + model_stride_ : m0;
  if (ne_ == 3) {
    for (std::size_t k = 0; k < 24; ++k) m.v[k] = (1 - w) * double(m0[k]) + w * double(m1[k]);
  } else {
    const std::size_t n = 6 * ne_ + 6;
    for (std::size_t k = 0; k < n; ++k) m.v[k] = (1 - w) * double(m0[k]) + w * double(m1[k]);
  }
  return true;
}

PVDF_CLONES void Locator::refine_start(const double* q_unit, double log_q_norm, bool fixed_force, double log_lo, double log_hi,
                           Start& st) const {
  const double hx = interp_.hx(), hy = interp_.hy(), p_exp = interp_.force_exponent();
  double last_u = -1, last_v = -1;
  for (int pass = 0; pass < 2; ++pass) {
    if (pass > 0) {  // the second pass only when the start moved to another cell
      const double u = (st.x - interp_.x0()) * interp_.inv_hx(), v = (st.y - interp_.y0()) * interp_.inv_hy();
      if (std::floor(u) == last_u && std::floor(v) == last_v) return;
    }
    CellModel m;
    if (!cell_model(st.x, st.y, st.l, m)) return;
    last_u = std::floor((st.x - interp_.x0()) * interp_.inv_hx());
    last_v = std::floor((st.y - interp_.y0()) * interp_.inv_hy());
    const double* d = m.v.data();
    double dt = m.dt, ds = m.ds;
    if (!(ne_ == 3 ? newton_in_cell<3>(d, ne_, q_unit, dt, ds) : newton_in_cell<0>(d, ne_, q_unit, dt, ds))) return;
    if (!(std::abs(dt) < 1.5 && std::abs(ds) < 1.5)) return;
    // Never off the map: a solution on the map's edge stays a start the fit can evaluate.
    const double nx = cell_xy_[m.cell][0] + dt * hx, ny = cell_xy_[m.cell][1] + ds * hy;
    if (!interp_.inside(nx, ny)) return;
    st.x = nx;
    st.y = ny;
    if (!fixed_force) {
      const double* g = d + 6 * ne_;
      const double log_g = g[0] + g[1] * dt + g[2] * ds + 0.5 * (g[3] * dt * dt + 2 * g[4] * dt * ds + g[5] * ds * ds);
      st.l = std::clamp((log_q_norm - log_g) * (1.0 / p_exp), log_lo, log_hi);
    }
  }
}

PVDF_CLONES int Locator::fold_twins(const Fit& fit, std::array<Start, 2>& twins) const {
  {
    const std::int32_t slot = slot_at(fit.x, fit.y);
    if (slot < 0 || !cell_fold_[std::size_t(slot)]) return 0;  // no fold nearby: no twin to look for
  }
  CellModel m;
  if (!cell_model(fit.x, fit.y, fit.l, m)) return 0;
  const double hx = interp_.hx(), hy = interp_.hy();
  const double* d = m.v.data();
  const double *jt = d + ne_, *js = d + 2 * ne_, *htt = d + 3 * ne_, *hts = d + 4 * ne_, *hss = d + 5 * ne_;
  const double dt = m.dt, ds = m.ds;
  // The quadratic direction model's Jacobian at the solution and its weak direction v; along v
  // the model changes by a s + ½ b s² (b without its component along d, the sphere's own
  // curvature).
  std::array<double, max_electrodes> at{}, as{};
  double g00 = 0, g01 = 0, g11 = 0;
  for (std::size_t k = 0; k < ne_; ++k) {
    at[k] = jt[k] + htt[k] * dt + hts[k] * ds;
    as[k] = js[k] + hts[k] * dt + hss[k] * ds;
    g00 += at[k] * at[k];
    g01 += at[k] * as[k];
    g11 += as[k] * as[k];
  }
  const double half = 0.5 * (g00 + g11), dev = std::sqrt(0.25 * (g00 - g11) * (g00 - g11) + g01 * g01);
  double v0 = half - dev - g11, v1 = g01;
  if (!(std::abs(g01) > 1e-300)) {
    v0 = g00 <= g11 ? 1.0 : 0.0;
    v1 = 1.0 - v0;
  }
  const double vn = std::sqrt(v0 * v0 + v1 * v1);
  if (!(vn > 0)) return 0;
  v0 /= vn;
  v1 /= vn;
  std::array<double, max_electrodes> bv{};
  double bd = 0;
  for (std::size_t k = 0; k < ne_; ++k) {
    bv[k] = htt[k] * v0 * v0 + 2 * hts[k] * v0 * v1 + hss[k] * v1 * v1;
    bd += bv[k] * d[k];
  }
  double aa = 0, ab = 0, bb = 0;
  for (std::size_t k = 0; k < ne_; ++k) {
    const double a = at[k] * v0 + as[k] * v1;
    const double b = bv[k] - bd * d[k];
    aa += a * a;
    ab += a * b;
    bb += b * b;
  }
  if (!(aa > 0 && bb > 0 && std::abs(ab) > 0)) return 0;
  // Two guesses of the second zero along v: where a s + ½ b s² is smallest in least squares
  // (s = −2 a·b / b·b), and the fold's normal form (u + β w², w²), whose twin of (u, w) is
  // (u, −w): s = −2 a·a / a·b. Only twins the coarse search can miss (within 1.5 cells, not
  // the solution itself) are returned; the fit does the rest.
  int n = 0;
  for (const double s_star : {-2.0 * ab / bb, -2.0 * aa / ab}) {
    if (!(std::abs(s_star) <= 1.5 && std::abs(s_star) >= 0.01)) continue;
    Start& t = twins[std::size_t(n++)];
    t.x = fit.x + s_star * v0 * hx;
    t.y = fit.y + s_star * v1 * hy;
    t.l = fit.l;
    t.score = 0;
  }
  return n;
}

}  // namespace pvdf::mapping
