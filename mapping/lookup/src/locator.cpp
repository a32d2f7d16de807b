// The lookup: settings, entry points (locate, locate_from, locate_near), the query's
// preparation and the search's outline; tables in locator_tables.cpp, the coarse search in
// locator_search.cpp, fits and choice in locator_fit.cpp.
#include "locator_detail.hpp"
#include "pvdf/mapping/locator.hpp"

#include <cstdlib>

namespace pvdf::mapping {

using detail::direction_key;
using detail::normalize;
using detail::solve_spd3;
using detail::Vec;


std::string flags_text(std::uint32_t flags) {
  static const char* names[] = {"outside_map", "ambiguous", "no_press", "poor_fit", "force_extrapolated",
                                "scaling_assumed", "not_converged", "ill_conditioned", "saturated"};
  std::string out;
  for (int b = 0; b < 9; ++b) {
    if (flags & (1u << b)) {
      if (!out.empty()) out += '|';
      out += names[b];
    }
  }
  return out.empty() ? "ok" : out;
}

bool Locator::predict(double x_m, double y_m, double force_N, double* charges_C) const {
  if (!(force_N > 0)) return false;
  if (!interp_.evaluate(x_m, y_m, std::log(force_N), charges_C, nullptr)) return false;
  for (std::size_t k = 0; k < ne_; ++k) charges_C[k] = gain_[k] * charges_C[k] + offset_[k];
  return true;
}

Location Locator::locate(const double* charges_C) const {
  return fixed_force_ ? locate_impl(charges_C, true, log_force_lo_) : locate_impl(charges_C, false, 0.0);
}

Location Locator::locate(const double* charges_C, double known_force_N) const {
  if (!(known_force_N > 0) || !std::isfinite(known_force_N)) {
    Location out;
    out.flags = flag::outside_map;
    return out;
  }
  return locate_impl(charges_C, true, std::log(known_force_N));
}

PVDF_CLONES bool Locator::prepare(const double* charges_C, bool fixed_force, double log_known_force, Query& Q,
                                  std::uint32_t& early_flags) const {
  Q.fixed_force = fixed_force;
  Q.log_known_force = log_known_force;
  Q.log_lo = fixed_force ? log_known_force : log_force_lo_;
  Q.log_hi = fixed_force ? log_known_force : log_force_hi_;
  Q.limit = fixed_force ? chi2_limit_fixed_ : chi2_limit_free_;
  double snr2 = 0, noise_norm2 = 0;
  for (std::size_t k = 0; k < ne_; ++k) {
    if (!std::isfinite(charges_C[k])) {
      early_flags = flag::outside_map | flag::no_press;
      return false;
    }
    Q.q[k] = (charges_C[k] - offset_[k]) / gain_[k];
    const double sigma = noise_[k] / std::abs(gain_[k]);
    Q.w[k] = 1.0 / sigma;
    snr2 += (Q.q[k] * Q.w[k]) * (Q.q[k] * Q.w[k]);
    noise_norm2 += sigma * sigma;
    Q.q_unit[k] = Q.q[k];
  }
  if (std::sqrt(snr2 / double(ne_)) < options_.no_press_snr) {
    early_flags = flag::no_press;
    return false;
  }
  Q.q_norm = normalize(Q.q_unit.data(), ne_);
  Q.log_q_norm = std::log(Q.q_norm);
  Q.noise2 = noise_norm2 / (Q.q_norm * Q.q_norm);
  return true;
}

PVDF_CLONES int Locator::add_fold_twins(const Query& Q, std::array<Fit, 8>& fits, int n_starts) const {
  // Folds next to the electrodes: two exact solutions can lie within one cell, where the coarse
  // search's linear models see only one. Each solution within noise proposes its fold twin
  // (the quadratic model of its cell); a twin not already found is fitted too.
  const int n_first = n_starts;
  for (int s = 0; s < n_first && n_starts < int(fits.size()); ++s) {
    const Fit& f = fits[std::size_t(s)];
    if (!f.ok || f.duplicate || f.chi2 > Q.limit) continue;
    std::array<Start, 2> twins;
    const int n_twins = fold_twins(f, twins);
    for (int t = 0; t < n_twins && n_starts < int(fits.size()); ++t) {
      Start& twin = twins[std::size_t(t)];
      refine_start(Q.q_unit.data(), Q.log_q_norm, Q.fixed_force, Q.log_lo, Q.log_hi, twin);
      bool known = false;
      for (int o = 0; o < n_starts && !known; ++o) {
        const Fit& g = fits[std::size_t(o)];
        known = g.ok && std::abs(g.x - twin.x) < 0.05 * interp_.hx() && std::abs(g.y - twin.y) < 0.05 * interp_.hy();
      }
      if (known) continue;
      fits[std::size_t(n_starts)] = levenberg_marquardt(Q.q.data(), Q.w.data(), twin.x, twin.y, twin.l, Q.fixed_force,
                                                        Q.log_lo, Q.log_hi, fits.data(), n_starts);
      ++n_starts;
    }
  }
  return n_starts;
}

PVDF_CLONES Location Locator::locate_impl(const double* charges_C, bool fixed_force, double log_known_force,
                                          const std::array<double, 3>* hints, int n_hints, bool held) const {
  Query Q;
  std::uint32_t early_flags = 0;
  if (!prepare(charges_C, fixed_force, log_known_force, Q, early_flags)) {
    Location early;
    early.flags = early_flags;
    return early;
  }
  const double log_lo = Q.log_lo, log_hi = Q.log_hi, limit = Q.limit, noise2 = Q.noise2, log_q_norm = Q.log_q_norm;
  const Vec& q = Q.q;
  const Vec& w = Q.w;
  const Vec& q_unit = Q.q_unit;

  std::array<Fit, 8> fits{};
  const double p_exp = interp_.force_exponent();
  int n_starts = 0;
  // Coarse search by the linearized direction model: one start per distinct predicted solution.
  StartList predicted;
  if (predicted_starts(q_unit.data(), log_q_norm, noise2, fixed_force, log_known_force, log_lo, log_hi, predicted,
                       held && n_hints > 0)) {
    // Ask early for what each start's refinement and first fit read: its cell's model rows (the
    // two levels around its force) and the interpolant's coefficients.
    for (int s = 0; s < predicted.n && s < options_.max_starts; ++s) {
      const Start& st = predicted.start[std::size_t(s)];
      interp_.prefetch(st.x, st.y);
      const std::int32_t slot = slot_at(st.x, st.y);
      if (slot >= 0) {
        std::size_t f0 = 0;
        double w = 0;
        interp_.level_bracket(st.l, f0, w);
        const char* row = reinterpret_cast<const char*>(&model_[(std::size_t(slot) * interp_.n_levels() + f0) * model_stride_]);
        const std::size_t rows = interp_.n_levels() > 1 ? 2 : 1;  // f0 + 1 exists when there are two levels
        for (std::size_t b = 0; b < rows * model_stride_ * sizeof(float); b += 64) __builtin_prefetch(row + b);
      }
    }
    for (int s = 0; s < predicted.n && n_starts < options_.max_starts; ++s) {
      Start st = predicted.start[std::size_t(s)];
      refine_start(q_unit.data(), log_q_norm, fixed_force, log_lo, log_hi, st);
      fits[std::size_t(n_starts)] =
          levenberg_marquardt(q.data(), w.data(), st.x, st.y, st.l, fixed_force, log_lo, log_hi, fits.data(), n_starts);
      ++n_starts;
    }
  }
  if (held && n_hints > 0 && predicted.n == 0) {
    // A stream's press held outside at the last sample whose charges no cell's direction model
    // reaches now either (no start from the query's own direction bin: a press still weaker than
    // the force range, or still off the map): outside, held where it was — no hint fit, no
    // angular fallback (§1.9).
    Location out;
    out.flags = flag::outside_map;
    out.held = hints[0];
    return out;
  }
  n_starts = add_fold_twins(Q, fits, n_starts);
  bool any_within = false;
  for (int s = 0; s < n_starts; ++s) any_within = any_within || (fits[std::size_t(s)].ok && fits[std::size_t(s)].chi2 <= limit);
  if (!any_within && n_hints > 0) {
    // Hints (the last sample's held fit of a tracked stream): when their fits are held by the
    // map's edge or the force range and do not fit within noise either, the press is still
    // outside — the fallback below is skipped. Otherwise it runs as in locate().
    const int n_with_hints = add_hint_fits(Q, hints, n_hints, fits, n_starts);
    bool all_held = n_with_hints > n_starts;
    for (int s = n_starts; s < n_with_hints; ++s) {
      const Fit& f = fits[std::size_t(s)];
      all_held = all_held && f.ok && f.blocked && f.chi2 > limit;
    }
    if (all_held) {
      Location out;
      out.n_starts = n_with_hints;
      out.flags = flag::outside_map;
      const Fit& f = fits[std::size_t(n_starts)];
      out.held = {f.x, f.y, std::exp(f.l)};
      return out;
    }
  }
  if (!any_within) {
    // No cell's linear model reaches the charges, or none of its fits is within noise (outside
    // the map, far off the model, or a strongly curved cell): the angular shortlist, starts at
    // cell centres at least three cells apart, as many as there is room for.
    Shortlist list;
    coarse_candidates(q_unit.data(), noise2, list);
    const double cluster_distance = 3.0 * std::max(interp_.hx(), interp_.hy());
    std::array<std::size_t, 8> starts{};
    int n_cells = 0;
    for (int c = 0; c < list.n && n_cells < options_.max_starts; ++c) {
      const auto& p = cell_xy_[list.cell[std::size_t(c)]];
      bool far = true;
      for (int s = 0; s < n_cells; ++s) {
        const auto& o = cell_xy_[starts[std::size_t(s)]];
        far = far && (p[0] - o[0]) * (p[0] - o[0]) + (p[1] - o[1]) * (p[1] - o[1]) > cluster_distance * cluster_distance;
      }
      if (far) starts[std::size_t(n_cells++)] = list.cell[std::size_t(c)];
    }
    if (n_starts + n_cells > int(fits.size())) n_starts = std::max(0, int(fits.size()) - n_cells);
    for (int s = 0; s < n_cells; ++s) {
      const std::size_t c = starts[std::size_t(s)];
      double dot = 0;
      for (std::size_t k = 0; k < ne_; ++k) dot += cell_dir_[c * ne_ + k] * q[k];
      const double amplitude = dot > 0 ? dot / cell_norm_[c] : 1.0;
      const double l0 = std::clamp(std::log(amplitude) / p_exp, log_lo, log_hi);
      fits[std::size_t(n_starts)] = levenberg_marquardt(q.data(), w.data(), cell_xy_[c][0], cell_xy_[c][1], l0, fixed_force,
                                                        log_lo, log_hi, fits.data(), n_starts);
      fits[std::size_t(n_starts)].fallback = true;
      ++n_starts;
    }
  }
  return finish(Q, fits, n_starts);
}

int Locator::add_hint_fits(const Query& Q, const std::array<double, 3>* hints, int n_hints, std::array<Fit, 8>& fits,
                           int n_fits) const {
  // A hint no fit has ended near (half a cell) is fitted (from locate_near, only when no fit of
  // the coarse search is within noise).
  for (int h = 0; h < n_hints && n_fits < int(fits.size()); ++h) {
    const std::array<double, 3>& st = hints[h];
    if (!(st[2] > 0) || !std::isfinite(st[2]) || !interp_.inside(st[0], st[1])) continue;
    bool found = false;
    for (int o = 0; o < n_fits && !found; ++o) {
      const Fit& g = fits[std::size_t(o)];
      found = g.ok && std::abs(g.x - st[0]) < 0.5 * interp_.hx() && std::abs(g.y - st[1]) < 0.5 * interp_.hy();
    }
    if (found) continue;
    const double l = Q.fixed_force ? Q.log_known_force : std::clamp(std::log(st[2]), Q.log_lo, Q.log_hi);
    fits[std::size_t(n_fits)] =
        levenberg_marquardt(Q.q.data(), Q.w.data(), st[0], st[1], l, Q.fixed_force, Q.log_lo, Q.log_hi, fits.data(), n_fits);
    ++n_fits;
  }
  return n_fits;
}

Location Locator::locate_near(const double* charges_C, const std::array<double, 3>* hints, int n_hints,
                             bool held) const {
  return fixed_force_ ? locate_impl(charges_C, true, log_force_lo_, hints, n_hints, held)
                      : locate_impl(charges_C, false, 0.0, hints, n_hints, held);
}

Location Locator::locate_from(const double* charges_C, const std::array<double, 3>* starts, int n_starts) const {
  Query Q;
  std::uint32_t early_flags = 0;
  if (!prepare(charges_C, fixed_force_, fixed_force_ ? log_force_lo_ : 0.0, Q, early_flags)) {
    Location early;
    early.flags = early_flags;
    return early;
  }
  std::array<Fit, 8> fits{};
  int n = 0;
  for (int s = 0; s < n_starts && n < int(fits.size()); ++s) {
    const std::array<double, 3>& st = starts[s];
    if (!(st[2] > 0) || !std::isfinite(st[2]) || !interp_.inside(st[0], st[1])) continue;
    const double l = Q.fixed_force ? Q.log_known_force : std::clamp(std::log(st[2]), Q.log_lo, Q.log_hi);
    fits[std::size_t(n)] =
        levenberg_marquardt(Q.q.data(), Q.w.data(), st[0], st[1], l, Q.fixed_force, Q.log_lo, Q.log_hi, fits.data(), n);
    ++n;
  }
  Location out = finish(Q, fits, n);
  return out;
}

}  // namespace pvdf::mapping
