// The lookup: coarse direction table, Levenberg–Marquardt on the interpolant, flags, 1-σ.
#include "pvdf/mapping/locator.hpp"

#include "pvdf/core/error.hpp"

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <limits>

// The hot paths of the lookup are compiled twice, for any x86-64 and for x86-64-v3 (AVX2, FMA:
// +6 % locates/s measured, docs/lookup.md §3), and the loader picks the one the CPU runs (GCC
// function multiversioning). AVX-512 clones measured slower (−3 %): not built.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define PVDF_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define PVDF_CLONES
#endif

namespace pvdf::mapping {

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

namespace {

using Vec = std::array<double, max_electrodes>;

/// The coarse table's key of a direction: two pseudo-angles of its first three components,
/// no atan2 or sqrt. φ is the "diamond angle" of (n0, n1) (monotone in atan2(n1, n0), in
/// (−2, 2], cut at n0 < 0, n1 = 0 like atan2), θ = n2 / (|n0| + |n1| + |n2|) (monotone in
/// the elevation for a fixed φ). Any continuous key serves: the table is built with this one.
inline void direction_key(const double* n, double& phi, double& theta) {
  const double a0 = std::abs(n[0]), a1 = std::abs(n[1]);
  const double l1 = a0 + a1 + 1e-300;
  const double r = n[1] / l1;
  phi = n[0] >= 0 ? r : (n[1] >= 0 ? 2.0 - r : -2.0 - r);
  theta = n[2] / (l1 + std::abs(n[2]));
}

/// Solves the symmetric positive definite 3×3 system A x = b by a closed-form LDLᵀ (no
/// pivoting, no square roots: the damped normal equations are SPD; three reciprocals instead
/// of Cholesky's three square roots and nine divisions, which sat on the critical path).
/// Returns a non-finite x if A is not SPD (a pivot ≤ 0 or NaN).
inline std::array<double, 3> solve_spd3(const std::array<double, 6>& A, const std::array<double, 3>& b) {
  // A: upper triangle 00 01 02 11 12 22.
  const double d0 = A[0], i0 = 1.0 / d0;
  const double l10 = A[1] * i0, l20 = A[2] * i0;
  const double d1 = A[3] - l10 * A[1], i1 = 1.0 / d1;
  const double l21 = (A[4] - l20 * A[1]) * i1;
  const double d2 = A[5] - l20 * A[2] - l21 * l21 * d1, i2 = 1.0 / d2;
  if (!(d0 > 0 && d1 > 0 && d2 > 0)) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    return {nan, nan, nan};
  }
  const double y0 = b[0], y1 = b[1] - l10 * y0, y2 = b[2] - l20 * y0 - l21 * y1;
  const double x2 = y2 * i2, x1 = y1 * i1 - l21 * x2, x0 = y0 * i0 - l10 * x1 - l20 * x2;
  return {x0, x1, x2};
}

/// The coarse search's test of one candidate cell against the query direction (compact float
/// record, Locator::scan_): the offset δ its linear model predicts (cell units), the model's
/// residual² there and the force of a start; false when the cell cannot hold a solution.
struct CandidateTest {
  double dt, ds, res2, l;
};
template <std::size_t NE>
inline bool test_candidate(const float* sc, std::size_t ne_runtime, const double* q_unit, double log_q_norm,
                           double noise2, bool fixed_force, double log_force, double log_lo, double log_hi,
                           double p_exp, double inv_p, CandidateTest& out) {
  const std::size_t ne = NE > 0 ? NE : ne_runtime;
  const float* tail = sc + 6 * ne;
  // Level: the known force, or the force that makes the cell's mean |G| match |q|.
  const double l = std::clamp(fixed_force ? log_force : (log_q_norm - double(tail[1])) * inv_p, log_lo, log_hi);
  // The cell's linear model carried to l predicts the offset δ.
  const double dl = l - double(tail[0]);
  double e[NE > 0 ? NE : 8];
  double dt = 0, ds = 0;
  for (std::size_t n = 0; n < ne; ++n) {
    e[n] = q_unit[n] - double(sc[n]) - double(sc[3 * ne + n]) * dl;
    dt += double(sc[ne + n]) * e[n];
    ds += double(sc[2 * ne + n]) * e[n];
  }
  if (!(std::abs(dt) <= 1.0 && std::abs(ds) <= 1.0)) return false;  // predicted beyond the neighbours
  double res2 = 0;
  for (std::size_t n = 0; n < ne; ++n) {
    const double r = e[n] - double(sc[4 * ne + n]) * dt - double(sc[5 * ne + n]) * ds;
    res2 += r * r;
  }
  // Within what the model's own error and the noise allow: a solution may be here.
  if (res2 > 4.0 * double(tail[6]) + 9.0 * noise2 + 1e-14) return false;
  // Force at the predicted point: |q| = F^p |G(δ, l)| with ln |G| linear in δ and l.
  const double log_g = double(tail[2]) + double(tail[3]) * dt + double(tail[4]) * ds + double(tail[5]) * dl;
  double l1 = l;
  if (fixed_force) {
    // The known force must also explain the magnitude (else: an unknown-force twin).
    if (std::abs(log_q_norm - p_exp * l - log_g) > 0.05 + 3.0 * std::sqrt(std::max(noise2, 0.0))) return false;
  } else {
    l1 = (log_q_norm - log_g) * inv_p;
    // A solution needs a plausible force: far outside the range, this is not one.
    if (l1 < log_lo - 0.25 || l1 > log_hi + 0.25) return false;
    l1 = std::clamp(l1, log_lo, log_hi);
  }
  out = {dt, ds, res2, l1};
  return true;
}

/// A number for a message, printed like %g (never "-0.000000").
std::string text_g(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g", v);
  return buffer;
}

inline double normalize(double* v, std::size_t n) {
  double s = 0;
  for (std::size_t k = 0; k < n; ++k) s += v[k] * v[k];
  s = std::sqrt(s);
  if (s > 0) {
    for (std::size_t k = 0; k < n; ++k) v[k] /= s;
  }
  return s;
}

}  // namespace

Locator::Locator(const ChargeMap& map, const LocatorOptions& options)
    : interp_(map), ne_(map.ne()), names_(map.electrode_names), options_(options) {
  if (ne_ < 3) {
    throw InputError("map has " + std::to_string(ne_) + " electrode(s); locating (x, y, F) needs at least 3");
  }
  if (options.noise_C.empty()) {
    noise_ = map.noise_C;
  } else if (options.noise_C.size() == 1) {
    noise_.assign(ne_, options.noise_C[0]);
  } else if (options.noise_C.size() == ne_) {
    noise_ = options.noise_C;
  } else {
    throw InputError("locator noise_C: " + std::to_string(options.noise_C.size()) + " values given; give 1 or " +
                     std::to_string(ne_) + " (one per electrode)");
  }
  for (double s : noise_) {
    if (!std::isfinite(s) || !(s > 0)) throw InputError("locator noise_C = " + text_g(s) + " must be finite and > 0 (C)");
  }
  gain_.assign(ne_, 1.0);
  offset_.assign(ne_, 0.0);
  if (options.use_calibration && map.calibration) {
    gain_ = map.calibration->gain;
    offset_ = map.calibration->offset_C;
    calibrated_ = true;
  }
  if (options.max_iterations < 1 || options.max_starts < 1 || options.max_starts > 8) {
    throw InputError("locator: max_iterations must be >= 1 and max_starts in 1..8");
  }
  auto limit_for = [&](double dof) {
    return options.chi2_limit > 0 ? options.chi2_limit : dof + 5.0 * std::sqrt(2.0 * std::max(dof, 1.0)) + 4.0;
  };
  chi2_limit_free_ = limit_for(double(ne_) - 3.0);
  chi2_limit_fixed_ = limit_for(double(ne_) - 2.0);
  chi2_limit_ = options.known_force_N > 0 ? chi2_limit_fixed_ : chi2_limit_free_;
  single_level_ = map.nf() == 1;
  // Plausible forces: what the caller says, else half the lowest to twice the highest level
  // (also for a single-level map: the scaling law carries it over that range).
  {
    double lo = options.min_force_N, hi = options.max_force_N;
    if (!(lo > 0)) lo = 0.5 * map.forces_N.front();
    if (!(hi > 0)) hi = 2.0 * map.forces_N.back();
    if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi)) {
      throw InputError("locator force range " + text_g(lo) + ".." + text_g(hi) + " N must satisfy 0 < min < max");
    }
    log_force_lo_ = std::log(lo);
    log_force_hi_ = std::log(hi);
    if (options.known_force_N != 0.0) {
      if (!(options.known_force_N > 0) || !std::isfinite(options.known_force_N)) {
        throw InputError("locator known_force_N = " + text_g(options.known_force_N) + " must be finite and > 0 (N)");
      }
      fixed_force_ = true;
      log_force_lo_ = log_force_hi_ = std::log(options.known_force_N);
    }
  }

  // ---- coarse table
  const std::size_t nx = interp_.nx(), ny = interp_.ny(), nf = interp_.n_levels();
  std::vector<std::array<double, 4>> boxes;  // per usable cell: phi_lo, phi_hi, theta_lo, theta_hi
  double phi_lo = 1e9, phi_hi = -1e9, th_lo = 1e9, th_hi = -1e9;
  for (std::size_t j = 0; j + 1 < ny; ++j) {
    for (std::size_t i = 0; i + 1 < nx; ++i) {
      if (!interp_.cell_usable(i, j)) continue;
      const double xc = interp_.x0() + (double(i) + 0.5) * interp_.hx();
      const double yc = interp_.y0() + (double(j) + 0.5) * interp_.hy();
      Vec centre{}, mean_dir{};
      double mean_norm = 0;
      std::array<Vec, 16> level_dirs{};
      const std::size_t n_lev = std::min<std::size_t>(nf, 16);
      for (std::size_t f = 0; f < n_lev; ++f) {
        const double lf = nf == 1 ? 0.0 : map.forces_N[f] > 0 ? std::log(map.forces_N[f]) : 0.0;
        interp_.evaluate(xc, yc, lf, centre.data(), nullptr);
        const double scale = std::exp(-interp_.force_exponent() * lf);
        for (std::size_t k = 0; k < ne_; ++k) centre[k] *= scale;
        mean_norm += normalize(centre.data(), ne_) / double(n_lev);
        level_dirs[f] = centre;
        for (std::size_t k = 0; k < ne_; ++k) mean_dir[k] += centre[k];
      }
      normalize(mean_dir.data(), ne_);
      std::array<double, 4> box{1e9, -1e9, 1e9, -1e9};
      double radius2 = 0;
      auto include = [&](const double* n) {
        double ph, th;
        direction_key(n, ph, th);
        box[0] = std::min(box[0], ph);
        box[1] = std::max(box[1], ph);
        box[2] = std::min(box[2], th);
        box[3] = std::max(box[3], th);
        double dot = 0;
        for (std::size_t k = 0; k < ne_; ++k) dot += n[k] * mean_dir[k];
        radius2 = std::max(radius2, 1.0 - dot * dot);
      };
      for (std::size_t f = 0; f < n_lev; ++f) {
        include(level_dirs[f].data());
        for (int b = 0; b < 2; ++b) {
          for (int a = 0; a < 2; ++a) {
            Vec n{};
            for (std::size_t k = 0; k < ne_; ++k) n[k] = interp_.node_value(f, i + std::size_t(a), j + std::size_t(b), k);
            normalize(n.data(), ne_);
            include(n.data());
          }
        }
      }
      if (!(mean_norm > 0)) continue;  // a cell with zero charge everywhere cannot be located
      cells_.push_back(j * (nx - 1) + i);
      cell_dir_.insert(cell_dir_.end(), mean_dir.begin(), mean_dir.begin() + long(ne_));
      cell_norm_.push_back(mean_norm);
      cell_radius2_.push_back(radius2);
      cell_xy_.push_back({xc, yc});
      // Grow the box by a quarter of its size each way: the direction inside a cell can
      // bulge slightly beyond the corners' range.
      const double gp = 0.1 * (box[1] - box[0]), gt = 0.1 * (box[3] - box[2]);
      box = {box[0] - gp, box[1] + gp, box[2] - gt, box[3] + gt};
      boxes.push_back(box);
      phi_lo = std::min(phi_lo, box[0]);
      phi_hi = std::max(phi_hi, box[1]);
      th_lo = std::min(th_lo, box[2]);
      th_hi = std::max(th_hi, box[3]);
    }
  }
  // Linear direction model of every usable cell at every level (the coarse search's predictor):
  // unit direction d at the centre, its derivatives in cell units, their least-squares inverse,
  // and how well the linear model reproduces the corner directions.
  // Largest squared distance, over the four corners of cell (i, j) at level f, between the
  // corner's unit direction and a model's prediction there (offsets ±½ cell).
  auto corner_error2 = [&](std::size_t f, std::size_t i, std::size_t j, auto&& predicted) {
    double worst = 0;
    for (int b = 0; b < 2; ++b) {
      for (int a = 0; a < 2; ++a) {
        Vec n{};
        for (std::size_t k = 0; k < ne_; ++k) n[k] = interp_.node_value(f, i + std::size_t(a), j + std::size_t(b), k);
        normalize(n.data(), ne_);
        double e2 = 0;
        for (std::size_t k = 0; k < ne_; ++k) {
          const double e = n[k] - predicted(k, a - 0.5, b - 0.5);
          e2 += e * e;
        }
        worst = std::max(worst, e2);
      }
    }
    return worst;
  };
  // Working tables of the constructor (condensed into scan_ and model_ below). pred, per cell and
  // level: unit direction d (ne), its tangential derivatives J = ∂d/∂(t, s) in cell units
  // ([k][2]), the least-squares inverse P = (JᵀJ)⁻¹Jᵀ (2 × ne), ln |G| at the centre and its
  // gradient ∂ln|G|/∂(t, s). quad: second derivatives of d ([k][tt, ts, ss]) and of ln |G|.
  const std::size_t pred_stride = 5 * ne_ + 3;
  for (double F : map.forces_N) level_log_.push_back(std::log(F));
  std::vector<double> pred(cells_.size() * nf * pred_stride, 0.0);
  const std::size_t quad_stride = 3 * ne_ + 3;
  std::vector<double> quad(cells_.size() * nf * quad_stride, 0.0);
  cell_slot_.assign((nx - 1) * (ny - 1), -1);
  for (std::size_t c = 0; c < cells_.size(); ++c) cell_slot_[cells_[c]] = std::int32_t(c);
  std::vector<double> cell_lin_err2(cells_.size(), 0.0);
  cell_log_norm_.assign(cells_.size(), 0.0);
  for (std::size_t c = 0; c < cells_.size(); ++c) {
    const std::size_t i = cells_[c] % (nx - 1), j = cells_[c] / (nx - 1);
    double log_norm = 0;
    for (std::size_t f = 0; f < nf; ++f) {
      const double lf = std::log(map.forces_N[f]);
      Vec qc{};
      std::array<std::array<double, 3>, max_electrodes> dq{};
      interp_.evaluate(cell_xy_[c][0], cell_xy_[c][1], lf, qc.data(), dq.data());
      const double norm = normalize(qc.data(), ne_);  // qc is now the unit direction d
      log_norm += (std::log(norm) - interp_.force_exponent() * lf) / double(nf);
      double* rec = &pred[(c * nf + f) * pred_stride];
      double* d = rec;
      double* J = rec + ne_;
      double* P = rec + 3 * ne_;
      for (std::size_t k = 0; k < ne_; ++k) d[k] = qc[k];
      for (int a = 0; a < 2; ++a) {  // ∂d/∂t = (I − d dᵀ) ∂q/∂t / |q|
        const double h = a == 0 ? interp_.hx() : interp_.hy();
        double proj = 0;
        for (std::size_t k = 0; k < ne_; ++k) proj += d[k] * dq[k][std::size_t(a)];
        for (std::size_t k = 0; k < ne_; ++k) J[k * 2 + std::size_t(a)] = h * (dq[k][std::size_t(a)] - proj * d[k]) / norm;
      }
      double a00 = 0, a01 = 0, a11 = 0;
      for (std::size_t k = 0; k < ne_; ++k) {
        a00 += J[k * 2] * J[k * 2];
        a01 += J[k * 2] * J[k * 2 + 1];
        a11 += J[k * 2 + 1] * J[k * 2 + 1];
      }
      const double det = a00 * a11 - a01 * a01;
      if (det > 1e-14 * (a00 * a11 + 1e-300)) {
        for (std::size_t k = 0; k < ne_; ++k) {
          P[k] = (a11 * J[k * 2] - a01 * J[k * 2 + 1]) / det;
          P[ne_ + k] = (-a01 * J[k * 2] + a00 * J[k * 2 + 1]) / det;
        }
      }  // else P = 0: the cell predicts its centre (a fold or a flat spot)
      // ln |G| at the centre and its gradient in cell units (refines the force of a start).
      rec[5 * ne_] = std::log(norm) - interp_.force_exponent() * lf;
      for (int a = 0; a < 2; ++a) {
        const double h = a == 0 ? interp_.hx() : interp_.hy();
        double proj = 0;
        for (std::size_t k = 0; k < ne_; ++k) proj += d[k] * dq[k][std::size_t(a)];
        rec[5 * ne_ + 1 + std::size_t(a)] = h * proj / norm;
      }
      // Second derivatives of d and ln |G| in cell units, by central differences of the cell's
      // own patch at ±a (inside the cell): the quadratic model that refines a start (§1.2).
      {
        double* H = &quad[(c * nf + f) * quad_stride];
        const double a = 0.45, xc = cell_xy_[c][0], yc = cell_xy_[c][1], hx = interp_.hx(), hy = interp_.hy();
        auto dir_at = [&](double dt, double ds, Vec& n, double& log_g) {
          interp_.evaluate(xc + dt * hx, yc + ds * hy, lf, n.data(), nullptr);
          log_g = std::log(normalize(n.data(), ne_)) - interp_.force_exponent() * lf;
        };
        Vec pt, mt, ps, ms, pp, pm, mp, mm;
        double gpt, gmt, gps, gms, gpp, gpm, gmp, gmm;
        dir_at(a, 0, pt, gpt);
        dir_at(-a, 0, mt, gmt);
        dir_at(0, a, ps, gps);
        dir_at(0, -a, ms, gms);
        dir_at(a, a, pp, gpp);
        dir_at(a, -a, pm, gpm);
        dir_at(-a, a, mp, gmp);
        dir_at(-a, -a, mm, gmm);
        const double ia2 = 1.0 / (a * a), ia24 = 0.25 / (a * a);
        for (std::size_t k = 0; k < ne_; ++k) {
          H[k * 3 + 0] = (pt[k] + mt[k] - 2 * d[k]) * ia2;
          H[k * 3 + 1] = (pp[k] - pm[k] - mp[k] + mm[k]) * ia24;
          H[k * 3 + 2] = (ps[k] + ms[k] - 2 * d[k]) * ia2;
        }
        const double g0 = rec[5 * ne_];
        H[3 * ne_ + 0] = (gpt + gmt - 2 * g0) * ia2;
        H[3 * ne_ + 1] = (gpp - gpm - gmp + gmm) * ia24;
        H[3 * ne_ + 2] = (gps + gms - 2 * g0) * ia2;
      }
      // Error of the linear model at the four corners (|offset| = ½ cell each way).
      cell_lin_err2[c] = std::max(cell_lin_err2[c], corner_error2(f, i, j, [&](std::size_t k, double dt, double ds) {
                                     return d[k] + J[k * 2] * dt + J[k * 2 + 1] * ds;
                                   }));
    }
    cell_log_norm_[c] = log_norm;
  }
  // The coarse search's model per cell, compact: the middle level's linear model in (t, s)
  // carried to other forces by the secant over the levels, and its worst error at the corners
  // and levels (the start is then refined by refine_start with the exact level blend).
  scan_stride_ = 6 * ne_ + 8;
  scan_.assign(cells_.size() * scan_stride_, 0.0f);
  {
    const std::size_t fm = nf / 2;
    const double span = nf > 1 ? level_log_[nf - 1] - level_log_[0] : 1.0;
    for (std::size_t c = 0; c < cells_.size(); ++c) {
      const std::size_t i = cells_[c] % (nx - 1), j = cells_[c] / (nx - 1);
      const double* rm = &pred[(c * nf + fm) * pred_stride];
      const double* ra = &pred[(c * nf) * pred_stride];
      const double* rb = &pred[(c * nf + nf - 1) * pred_stride];
      float* sc = &scan_[c * scan_stride_];
      std::array<double, max_electrodes> dl{};
      for (std::size_t k = 0; k < ne_; ++k) {
        dl[k] = nf > 1 ? (rb[k] - ra[k]) / span : 0.0;
        sc[k] = float(rm[k]);
        sc[ne_ + k] = float(rm[3 * ne_ + k]);
        sc[2 * ne_ + k] = float(rm[4 * ne_ + k]);
        sc[3 * ne_ + k] = float(dl[k]);
        sc[4 * ne_ + k] = float(rm[ne_ + 2 * k]);
        sc[5 * ne_ + k] = float(rm[ne_ + 2 * k + 1]);
      }
      float* tail = sc + 6 * ne_;
      tail[0] = float(level_log_[fm]);
      tail[1] = float(cell_log_norm_[c]);
      tail[2] = float(rm[5 * ne_]);
      tail[3] = float(rm[5 * ne_ + 1]);
      tail[4] = float(rm[5 * ne_ + 2]);
      tail[5] = nf > 1 ? float((rb[5 * ne_] - ra[5 * ne_]) / span) : 0.0f;
      double err2 = cell_lin_err2[c];
      for (std::size_t f = 0; f < nf; ++f) {
        const double dlf = level_log_[f] - level_log_[fm];
        err2 = std::max(err2, corner_error2(f, i, j, [&](std::size_t k, double dt, double ds) {
                          return rm[k] + dl[k] * dlf + rm[ne_ + 2 * k] * dt + rm[ne_ + 2 * k + 1] * ds;
                        }));
      }
      tail[6] = float(err2);
      // Curvature ratio κ = |H| / σ_min(J) (cell units, worst level): a Newton step δ leaves an
      // error ≈ κ δ² / 2 (levenberg_marquardt's unevaluated last step).
      double kappa = 0;
      for (std::size_t f = 0; f < nf; ++f) {
        const double* r = &pred[(c * nf + f) * pred_stride];
        const double* H = &quad[(c * nf + f) * quad_stride];
        double a00 = 0, a01 = 0, a11 = 0, h2 = 0;
        for (std::size_t k = 0; k < ne_; ++k) {
          const double jt = r[ne_ + 2 * k], js = r[ne_ + 2 * k + 1];
          a00 += jt * jt;
          a01 += jt * js;
          a11 += js * js;
          h2 += H[3 * k] * H[3 * k] + 2 * H[3 * k + 1] * H[3 * k + 1] + H[3 * k + 2] * H[3 * k + 2];
        }
        const double half = 0.5 * (a00 + a11), dev = std::sqrt(0.25 * (a00 - a11) * (a00 - a11) + a01 * a01);
        const double smin = std::sqrt(std::max(half - dev, 0.0));
        kappa = std::max(kappa, smin > 0 ? std::sqrt(h2) / smin : 1e30);
      }
      // Stored as the step threshold it gives: κ δ² / 2 ≤ 1e-4 cell, δ clamped to 1e-3…1e-2.
      tail[7] = float(std::clamp(std::sqrt(2e-4 / std::max(kappa, 1e-30)), 1e-3, 1e-2));
    }
  }
  // The start refinement's and fold search's model per cell and level, compact (float, one
  // contiguous row per level): d, J (t, s), H (tt, ts, ss), then ln |G| and its first and
  // second derivatives. The double tables it came from are not needed after this.
  model_stride_ = 6 * ne_ + 6;
  model_.assign(cells_.size() * nf * model_stride_, 0.0f);
  for (std::size_t c = 0; c < cells_.size(); ++c) {
    for (std::size_t f = 0; f < nf; ++f) {
      const double* r = &pred[(c * nf + f) * pred_stride];
      const double* H = &quad[(c * nf + f) * quad_stride];
      float* m = &model_[(c * nf + f) * model_stride_];
      for (std::size_t k = 0; k < ne_; ++k) {
        m[k] = float(r[k]);
        m[ne_ + k] = float(r[ne_ + 2 * k]);
        m[2 * ne_ + k] = float(r[ne_ + 2 * k + 1]);
        m[3 * ne_ + k] = float(H[3 * k]);
        m[4 * ne_ + k] = float(H[3 * k + 1]);
        m[5 * ne_ + k] = float(H[3 * k + 2]);
      }
      for (int a = 0; a < 3; ++a) {
        m[6 * ne_ + std::size_t(a)] = float(r[5 * ne_ + std::size_t(a)]);
        m[6 * ne_ + 3 + std::size_t(a)] = float(H[3 * ne_ + std::size_t(a)]);
      }
    }
  }
  // Fold-prone cells: where the orientation of the direction map, sign of d · (J_t × J_s),
  // differs between a cell and one of its 8 neighbours at some level, a fold passes within
  // about a cell, and a solution there may have a twin the coarse search cannot separate.
  // (More than three electrodes: no orientation; a cell is fold-prone where J is nearly
  // singular, σ_min/σ_max < 0.1.)
  cell_fold_.assign(cells_.size(), 0);
  {
    std::vector<signed char> orient(cells_.size() * nf, 0);
    for (std::size_t c = 0; c < cells_.size(); ++c) {
      for (std::size_t f = 0; f < nf; ++f) {
        const double* r = &pred[(c * nf + f) * pred_stride];
        if (ne_ == 3) {
          const double jt[3] = {r[3], r[5], r[7]}, js[3] = {r[4], r[6], r[8]};
          const double t = r[0] * (jt[1] * js[2] - jt[2] * js[1]) + r[1] * (jt[2] * js[0] - jt[0] * js[2]) +
                           r[2] * (jt[0] * js[1] - jt[1] * js[0]);
          orient[c * nf + f] = t > 0 ? 1 : t < 0 ? -1 : 0;
        } else {
          double a00 = 0, a01 = 0, a11 = 0;
          for (std::size_t k = 0; k < ne_; ++k) {
            a00 += r[ne_ + 2 * k] * r[ne_ + 2 * k];
            a01 += r[ne_ + 2 * k] * r[ne_ + 2 * k + 1];
            a11 += r[ne_ + 2 * k + 1] * r[ne_ + 2 * k + 1];
          }
          const double half = 0.5 * (a00 + a11), dev = std::sqrt(0.25 * (a00 - a11) * (a00 - a11) + a01 * a01);
          if (half - dev < 0.01 * (half + dev)) cell_fold_[c] = 1;
        }
      }
    }
    if (ne_ == 3) {
      for (std::size_t c = 0; c < cells_.size(); ++c) {
        const long i = long(cells_[c] % (nx - 1)), j = long(cells_[c] / (nx - 1));
        for (long dj = -1; dj <= 1 && !cell_fold_[c]; ++dj) {
          for (long di = -1; di <= 1 && !cell_fold_[c]; ++di) {
            const long ii = i + di, jj = j + dj;
            if (ii < 0 || jj < 0 || ii >= long(nx - 1) || jj >= long(ny - 1)) continue;
            const std::int32_t o = cell_slot_[std::size_t(jj) * (nx - 1) + std::size_t(ii)];
            if (o < 0) continue;
            for (std::size_t f = 0; f < nf; ++f) {
              const int a = orient[c * nf + f], b = orient[std::size_t(o) * nf + f];
              if (a == 0 || a != b) cell_fold_[c] = 1;
            }
          }
        }
      }
    }
    std::size_t n_fold = 0;
    for (auto v : cell_fold_) n_fold += v;
  }
  if (cells_.empty()) throw InputError("map has no usable cell (four ok nodes with non-zero charge); nothing can be located");
  bins_ = options.direction_bins > 0 ? options.direction_bins
                                     : std::clamp(int(3.0 * std::sqrt(double(cells_.size()))), 16, 512);
  const double pad_p = 1e-9 + 1e-6 * (phi_hi - phi_lo), pad_t = 1e-9 + 1e-6 * (th_hi - th_lo);
  phi0_ = phi_lo - pad_p;
  phi1_ = phi_hi + pad_p;
  theta0_ = th_lo - pad_t;
  theta1_ = th_hi + pad_t;
  auto bin_range = [&](const std::array<double, 4>& b, int& p0, int& p1, int& t0, int& t1) {
    p0 = std::clamp(int((b[0] - phi0_) / (phi1_ - phi0_) * bins_), 0, bins_ - 1);
    p1 = std::clamp(int((b[1] - phi0_) / (phi1_ - phi0_) * bins_), 0, bins_ - 1);
    t0 = std::clamp(int((b[2] - theta0_) / (theta1_ - theta0_) * bins_), 0, bins_ - 1);
    t1 = std::clamp(int((b[3] - theta0_) / (theta1_ - theta0_) * bins_), 0, bins_ - 1);
  };
  std::vector<std::uint32_t> counts(std::size_t(bins_) * std::size_t(bins_) + 1, 0);
  for (const auto& b : boxes) {
    int p0, p1, t0, t1;
    bin_range(b, p0, p1, t0, t1);
    for (int t = t0; t <= t1; ++t) {
      for (int p = p0; p <= p1; ++p) ++counts[std::size_t(t * bins_ + p)];
    }
  }
  bin_start_.assign(counts.size(), 0);
  for (std::size_t b = 0; b + 1 < counts.size(); ++b) bin_start_[b + 1] = bin_start_[b] + counts[b];
  bin_cells_.assign(bin_start_.back(), 0);
  // Within each bin the cells whose compact linear model can predict a start (|δ| ≤ 1 cell,
  // the coarse search's test) for some direction of the bin and some force come first; the
  // others (kept for the angular fallback) after bin_split_. The direction of a key is exact
  // for three electrodes (the key is built from the first three components); with more, every
  // cell counts as possible. Test: δ = P (d − d_mid − ∂d/∂lnF Δl) at the bin's four corners and
  // the two ends of the force range, with 0.25 cell of margin for the bin's curvature.
  const double l_min = std::min(level_log_.front(), log_force_lo_) - 0.5;
  const double l_max = std::max(level_log_.back(), log_force_hi_) + 0.5;
  auto key_direction = [](double phi, double theta, double* n) {
    double r, n0;
    if (phi <= 1.0 && phi >= -1.0) {
      r = phi;
      n0 = 1.0 - std::abs(r);
    } else if (phi > 1.0) {
      r = 2.0 - phi;
      n0 = -(1.0 - std::abs(r));
    } else {
      r = -2.0 - phi;
      n0 = -(1.0 - std::abs(r));
    }
    const double th = std::clamp(theta, -0.999999, 0.999999);
    n[0] = n0;
    n[1] = r;
    n[2] = th / (1.0 - std::abs(th));
    const double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int k = 0; k < 3; ++k) n[k] /= len;
  };
  const double dphi = (phi1_ - phi0_) / bins_, dtheta = (theta1_ - theta0_) / bins_;
  auto can_predict = [&](std::size_t c, int p, int t) {
    if (ne_ != 3) return true;
    const float* sc = &scan_[c * scan_stride_];
    const double lm = double(sc[6 * ne_]);
    double lo_t = 1e300, hi_t = -1e300, lo_s = 1e300, hi_s = -1e300;
    for (int corner = 0; corner < 4; ++corner) {
      double n[3];
      key_direction(phi0_ + (p + (corner & 1)) * dphi, theta0_ + (t + (corner >> 1)) * dtheta, n);
      for (const double l : {l_min, l_max}) {
        const double dl = std::isfinite(l) && l > -600 && l < 600 ? l - lm : 0.0;
        double et = 0, es = 0;
        for (std::size_t k = 0; k < 3; ++k) {
          const double e = n[k] - double(sc[k]) - double(sc[3 * ne_ + k]) * dl;
          et += double(sc[ne_ + k]) * e;
          es += double(sc[2 * ne_ + k]) * e;
        }
        lo_t = std::min(lo_t, et);
        hi_t = std::max(hi_t, et);
        lo_s = std::min(lo_s, es);
        hi_s = std::max(hi_s, es);
      }
    }
    const double m = 1.25;
    return hi_t >= -m && lo_t <= m && hi_s >= -m && lo_s <= m;
  };
  std::vector<std::uint32_t> front(bin_start_.begin(), bin_start_.end() - 1), back(bin_start_.begin() + 1, bin_start_.end());
  for (std::size_t c = 0; c < boxes.size(); ++c) {
    int p0, p1, t0, t1;
    bin_range(boxes[c], p0, p1, t0, t1);
    for (int t = t0; t <= t1; ++t) {
      for (int p = p0; p <= p1; ++p) {
        const std::size_t b = std::size_t(t * bins_ + p);
        if (can_predict(c, p, t)) {
          bin_cells_[front[b]++] = std::uint32_t(c);
        } else {
          bin_cells_[--back[b]] = std::uint32_t(c);
        }
      }
    }
  }
  bin_split_ = std::move(front);

}

bool Locator::predict(double x_m, double y_m, double force_N, double* charges_C) const {
  if (!(force_N > 0)) return false;
  if (!interp_.evaluate(x_m, y_m, std::log(force_N), charges_C, nullptr)) return false;
  for (std::size_t k = 0; k < ne_; ++k) charges_C[k] = gain_[k] * charges_C[k] + offset_[k];
  return true;
}

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
                               double log_force, double log_lo, double log_hi, StartList& starts) const {
  starts.n = 0;
  double phi, theta;
  direction_key(q_unit, phi, theta);
  const int p = int(std::floor((phi - phi0_) / (phi1_ - phi0_) * bins_));
  const int t = int(std::floor((theta - theta0_) / (theta1_ - theta0_) * bins_));
  const double p_exp = interp_.force_exponent(), inv_p = 1.0 / p_exp;
  const double hx = interp_.hx(), hy = interp_.hy();
  for (int ring = 0; ring <= 1 && starts.n == 0; ++ring) {
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
  const std::size_t n = 6 * ne_ + 6;
  for (std::size_t k = 0; k < n; ++k) m.v[k] = (1 - w) * double(m0[k]) + w * double(m1[k]);
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
    const double *jt = d + ne_, *js = d + 2 * ne_, *htt = d + 3 * ne_, *hts = d + 4 * ne_, *hss = d + 5 * ne_;
    double dt = m.dt, ds = m.ds;
    // Two Newton steps on q̂ = d + J δ + ½ H(δ, δ) in least squares.
    for (int it = 0; it < 2; ++it) {
      double a00 = 0, a01 = 0, a11 = 0, b0 = 0, b1 = 0;
      for (std::size_t k = 0; k < ne_; ++k) {
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
      if (!(det > 1e-14 * (a00 * a11 + 1e-300))) return;  // a fold: leave the start to the fit
      const double idet = 1.0 / det;
      const double st_t = (a11 * b0 - a01 * b1) * idet, st_s = (a00 * b1 - a01 * b0) * idet;
      if (!(std::abs(st_t) < 1.0 && std::abs(st_s) < 1.0)) return;  // the model has no solution near
      dt += st_t;
      ds += st_s;
    }
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

PVDF_CLONES Locator::Fit Locator::levenberg_marquardt(const double* q, const double* w, double x, double y, double l, bool fixed_force,
                                          double log_lo, double log_hi, const Fit* found, int n_found) const {
  Fit fit;
  Vec model;  // entries 0..ne−1 written by evaluate() before any read
  std::array<std::array<double, 3>, max_electrodes> grad;
  if (!interp_.evaluate(x, y, l, model.data(), grad.data())) return fit;
  auto chi2_of = [&](const Vec& m) {
    double s = 0;
    for (std::size_t k = 0; k < ne_; ++k) {
      const double r = (m[k] - q[k]) * w[k];
      s += r * r;
    }
    return s;
  };
  double chi2 = chi2_of(model);
  double lambda = 1e-3;
  // Normal equations of the weighted residual: JᵀJ (upper triangle 00 01 02 11 12 22) and Jᵀr.
  std::array<double, 6> JtJ;
  std::array<double, 3> Jtr;
  auto normal_equations = [&]() {
    JtJ = {0, 0, 0, 0, 0, 0};
    Jtr = {0, 0, 0};
    for (std::size_t k = 0; k < ne_; ++k) {
      const double g0 = grad[k][0] * w[k], g1 = grad[k][1] * w[k], g2 = grad[k][2] * w[k];
      const double r = (model[k] - q[k]) * w[k];
      JtJ[0] += g0 * g0;
      JtJ[1] += g0 * g1;
      JtJ[2] += g0 * g2;
      JtJ[3] += g1 * g1;
      JtJ[4] += g1 * g2;
      JtJ[5] += g2 * g2;
      Jtr[0] += g0 * r;
      Jtr[1] += g1 * r;
      Jtr[2] += g2 * r;
    }
  };
  if (fixed_force) {  // only (x, y) move: drop the ln F column
    for (std::size_t k = 0; k < ne_; ++k) grad[k][2] = 0;
  }
  normal_equations();
  const double hx = interp_.hx(), hy = interp_.hy();
  // The damped system (JᵀJ + λ diag JᵀJ) step = −Jᵀr; with the force fixed its ln F row is 1.
  auto damped = [&](double lam, double boost, std::array<double, 6>& A) {
    A = JtJ;
    A[0] += lam * JtJ[0] + boost;
    A[3] += lam * JtJ[3] + boost;
    A[5] += lam * JtJ[5] + boost;
    if (fixed_force) A[5] = 1.0;
  };
  auto quad = [&](const std::array<double, 3>& v) {  // vᵀ JᵀJ v
    return JtJ[0] * v[0] * v[0] + JtJ[3] * v[1] * v[1] + JtJ[5] * v[2] * v[2] +
           2.0 * (JtJ[1] * v[0] * v[1] + JtJ[2] * v[0] * v[2] + JtJ[4] * v[1] * v[2]);
  };
  int it = 0;
  bool quadratic_exit = false;
  for (; it < options_.max_iterations; ++it) {
    std::array<double, 6> A;
    damped(lambda, 1e-300, A);
    std::array<double, 3> step = solve_spd3(A, {-Jtr[0], -Jtr[1], -Jtr[2]});
    if (!(std::isfinite(step[0]) && std::isfinite(step[1]) && std::isfinite(step[2]))) {
      lambda *= 10;
      if (lambda > 1e12) break;
      continue;
    }
    if (!fixed_force && (l + step[2] < log_lo || l + step[2] > log_hi)) {
      // The step leaves the plausible force range: move ln F to the bound and solve for (x, y)
      // with it held there (a projected step; it keeps the fit from spinning against the bound).
      const double dl = (l + step[2] < log_lo ? log_lo : log_hi) - l;
      const double b0 = -Jtr[0] - A[2] * dl, b1 = -Jtr[1] - A[4] * dl;
      const double det = A[0] * A[3] - A[1] * A[1];
      if (det > 0) step = {(A[3] * b0 - A[1] * b1) / det, (A[0] * b1 - A[1] * b0) / det, dl};
    }
    // Keep steps within a few cells: the interpolant is only trusted where it is defined.
    double limit = 1.0;
    if (std::abs(step[0]) > 4.0 * hx) limit = std::min(limit, 4.0 * hx / std::abs(step[0]));
    if (std::abs(step[1]) > 4.0 * hy) limit = std::min(limit, 4.0 * hy / std::abs(step[1]));
    if (std::abs(step[2]) > 1.0) limit = std::min(limit, 1.0 / std::abs(step[2]));
    // A nearly undamped Gauss–Newton step this small is in the quadratic phase: the error left
    // after it is ≈ κ δ² / 2 (κ = |H| / σ_min(J) of the cell holding the point). Below 1e-4 cell
    // (the threshold on δ clamped to 1e-3…1e-2 cell, 1e-3 in ln F; the map's own interpolation
    // error is ~1e-3 cell) take it without evaluating the model there; χ² from the linear model,
    // χ² + 2 stepᵀJᵀr + stepᵀJᵀJ step (its change is second order too).
    if (lambda < 1e-2 && std::abs(step[2]) < 1e-3) {
      const std::int32_t slot = slot_at(x, y);
      const double accept = slot >= 0 ? double(scan_[std::size_t(slot) * scan_stride_ + 6 * ne_ + 7]) : 1e-3;
      if (std::abs(step[0]) < accept * hx && std::abs(step[1]) < accept * hy && interp_.inside(x + step[0], y + step[1]) &&
          l + step[2] >= log_lo && l + step[2] <= log_hi) {
        x += step[0];
        y += step[1];
        l += step[2];
        chi2 = std::max(0.0, chi2 + 2.0 * (Jtr[0] * step[0] + Jtr[1] * step[1] + Jtr[2] * step[2]) + quad(step));
        fit.converged = true;
        fit.blocked = false;
        quadratic_exit = true;
        ++it;
        break;
      }
    }
    const double nx = x + limit * step[0], ny = y + limit * step[1], nl = l + limit * step[2];
    Vec trial;
    std::array<std::array<double, 3>, max_electrodes> trial_grad;
    if (nl < log_lo || nl > log_hi || !interp_.evaluate(nx, ny, nl, trial.data(), trial_grad.data())) {
      fit.blocked = true;
      lambda *= 10;
      if (lambda > 1e12) {
        fit.converged = true;
        break;
      }
      continue;
    }
    const double trial_chi2 = chi2_of(trial);
    if (trial_chi2 <= chi2) {
      // Converged when the step is far below any useful resolution (1e-5 of a cell, 1e-7 in
      // ln F) or the misfit no longer drops (relative 1e-8).
      const bool small = std::abs(limit * step[0]) < 1e-5 * hx && std::abs(limit * step[1]) < 1e-5 * hy &&
                         std::abs(limit * step[2]) < 1e-7;
      x = nx;
      y = ny;
      l = nl;
      model = trial;
      grad = trial_grad;
      if (fixed_force) {
        for (std::size_t k = 0; k < ne_; ++k) grad[k][2] = 0;
      }
      const bool tiny_gain = chi2 - trial_chi2 <= 1e-8 * (chi2 + 1e-30);
      chi2 = trial_chi2;
      normal_equations();
      lambda = std::max(lambda * 0.2, 1e-9);
      fit.blocked = false;
      // Heading into a solution an earlier start already found: stop, it adds nothing (two
      // end points closer than a cell are never distinct solutions).
      for (int d = 0; d < n_found; ++d) {
        if (found[d].ok && std::abs(x - found[d].x) < 0.05 * hx && std::abs(y - found[d].y) < 0.05 * hy &&
            std::abs(l - found[d].l) < 0.01) {
          fit.duplicate = true;
          return fit;
        }
      }
      if (small || chi2 < 1e-20 || tiny_gain) {
        fit.converged = true;
        ++it;
        break;
      }
    } else {
      lambda *= 8;
      if (lambda > 1e12) {  // no descent left: a minimum (possibly on the map's edge)
        fit.converged = true;
        break;
      }
    }
  }
  // Is the minimum held by the map's edge? Test the undamped Gauss–Newton step. (Only asked of
  // fits that do not fit within noise — outside_map or poor_fit — so it is skipped after a
  // quadratic-phase exit within noise, the common case.)
  if (!quadratic_exit || chi2 > (fixed_force ? chi2_limit_fixed_ : chi2_limit_free_)) {
    std::array<double, 6> A = JtJ;
    A[0] *= 1.0 + 1e-9;
    A[3] *= 1.0 + 1e-9;
    A[5] *= 1.0 + 1e-9;
    if (fixed_force) A[5] = 1.0;
    const std::array<double, 3> step = solve_spd3(A, {-Jtr[0], -Jtr[1], -Jtr[2]});
    if (std::isfinite(step[0]) && std::isfinite(step[1]) && std::isfinite(step[2]) &&
        (!interp_.inside(x + step[0], y + step[1]) || l + step[2] < log_lo || l + step[2] > log_hi)) {
      fit.blocked = true;
    }
  }
  fit.x = x;
  fit.y = y;
  fit.l = l;
  fit.chi2 = chi2;
  fit.iterations = it;
  fit.jtj = JtJ;
  fit.ok = std::isfinite(chi2) && std::isfinite(x) && std::isfinite(y) && std::isfinite(l);
  return fit;
}

PVDF_CLONES void Locator::covariance(Fit& fit, bool fixed_force) const {
  // Covariance of (x, y, ln F): (JᵀWJ)⁻¹ with the weights already in J. Equilibrated first
  // (S = D JᵀWJ D, D = diag(JᵀWJ)^−½: the x, y columns (C/m) and the ln F column (C) differ by
  // ~1e3), so S has a unit diagonal; with the force known only the (x, y) block counts.
  const auto& m = fit.jtj;  // 00 01 02 11 12 22
  fit.singular = false;
  fit.sigma = {0, 0, 0};
  if (!(m[0] > 0 && m[3] > 0 && (fixed_force || m[5] > 0))) {  // a parameter the charges do not see
    fit.singular = true;
    return;
  }
  const double j00 = m[0], j11 = m[3], j22 = std::max(m[5], 1e-300);
  const double d0 = 1.0 / std::sqrt(j00), d1 = 1.0 / std::sqrt(j11), d2 = fixed_force ? 0.0 : 1.0 / std::sqrt(j22);
  const double s01 = m[1] * d0 * d1, s02 = m[2] * d0 * d2, s12 = m[4] * d1 * d2;
  // S is symmetric with a unit diagonal, so an LDLᵀ with diagonal pivoting starts with pivot 1;
  // its other two pivots (closed form) say whether S is invertible (each above 1e-12 of the
  // first), and only the diagonal of S⁻¹ (cofactor / determinant) is needed.
  const double a11 = 1.0 - s01 * s01, a22 = 1.0 - s02 * s02, a12 = s12 - s01 * s02;  // after pivot 0
  const double p1 = std::max(a11, a22), p2 = std::min(a11, a22) - a12 * a12 / p1;
  if (!(p1 > 1e-12 && std::abs(p2) > 1e-12)) {
    fit.singular = true;
    return;
  }
  const double c00 = 1.0 - s12 * s12, c11 = 1.0 - s02 * s02, c22 = 1.0 - s01 * s01;
  const double det = c00 - s01 * (s01 - s12 * s02) + s02 * (s01 * s12 - s02);
  const double inv_det = 1.0 / det;
  const double v0 = d0 * d0 * c00 * inv_det, v1 = d1 * d1 * c11 * inv_det, v2 = d2 * d2 * c22 * inv_det;
  fit.sigma = {v0 > 0 ? std::sqrt(v0) : 0.0, v1 > 0 ? std::sqrt(v1) : 0.0, v2 > 0 ? std::sqrt(v2) : 0.0};
  if (!(std::isfinite(fit.sigma[0]) && std::isfinite(fit.sigma[1]) && std::isfinite(fit.sigma[2]))) {
    fit.singular = true;
    fit.sigma = {0, 0, 0};
  }
}

bool Locator::distinct_minima(const double* q, const double* w, const Fit& a, const Fit& b, double separation,
                              double limit) const {
  if ((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) <= separation * separation) return false;
  // Two LM end points are different solutions when the misfit rises above the noise limit
  // somewhere between them (a barrier), or the straight path leaves the map.
  Vec model{};
  for (const double t : {0.5, 0.25, 0.75}) {  // the midpoint first: most barriers show there
    const double x = a.x + t * (b.x - a.x), y = a.y + t * (b.y - a.y), l = a.l + t * (b.l - a.l);
    if (!interp_.evaluate(x, y, l, model.data(), nullptr)) return true;
    // Best force at this position (the misfit is nearly quadratic in the amplitude).
    double mq = 0, mm = 0;
    for (std::size_t k = 0; k < ne_; ++k) {
      mq += model[k] * q[k] * w[k] * w[k];
      mm += model[k] * model[k] * w[k] * w[k];
    }
    const double s = mm > 0 ? mq / mm : 1.0;
    double chi2 = 0;
    for (std::size_t k = 0; k < ne_; ++k) {
      const double r = (s * model[k] - q[k]) * w[k];
      chi2 += r * r;
    }
    if (chi2 > limit) return true;
  }
  return false;
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
                      Location& early) const {
  Q.fixed_force = fixed_force;
  Q.log_known_force = log_known_force;
  Q.log_lo = fixed_force ? log_known_force : log_force_lo_;
  Q.log_hi = fixed_force ? log_known_force : log_force_hi_;
  Q.limit = fixed_force ? chi2_limit_fixed_ : chi2_limit_free_;
  double snr2 = 0, noise_norm2 = 0;
  for (std::size_t k = 0; k < ne_; ++k) {
    if (!std::isfinite(charges_C[k])) {
      early = Location{};
      early.flags = flag::outside_map | flag::no_press;
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
    early = Location{};
    early.flags = flag::no_press;
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
                                          const std::array<double, 3>* hints, int n_hints) const {
  Query Q;
  Location early;
  if (!prepare(charges_C, fixed_force, log_known_force, Q, early)) return early;
  const double log_lo = Q.log_lo, log_hi = Q.log_hi, limit = Q.limit, noise2 = Q.noise2, log_q_norm = Q.log_q_norm;
  const Vec& q = Q.q;
  const Vec& w = Q.w;
  const Vec& q_unit = Q.q_unit;

  std::array<Fit, 8> fits{};
  const double p_exp = interp_.force_exponent();
  int n_starts = 0;
  // Coarse search by the linearized direction model: one start per distinct predicted solution.
  StartList predicted;
  if (predicted_starts(q_unit.data(), log_q_norm, noise2, fixed_force, log_known_force, log_lo, log_hi, predicted)) {
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

Location Locator::locate_near(const double* charges_C, const std::array<double, 3>* hints, int n_hints) const {
  return fixed_force_ ? locate_impl(charges_C, true, log_force_lo_, hints, n_hints)
                      : locate_impl(charges_C, false, 0.0, hints, n_hints);
}

std::int64_t Locator::search_bin(const double* charges_C) const {
  Query Q;
  Location early;
  if (!prepare(charges_C, fixed_force_, fixed_force_ ? log_force_lo_ : 0.0, Q, early)) return -1;
  double phi, theta;
  direction_key(Q.q_unit.data(), phi, theta);
  const int p = std::clamp(int(std::floor((phi - phi0_) / (phi1_ - phi0_) * bins_)), -1, bins_);
  const int t = std::clamp(int(std::floor((theta - theta0_) / (theta1_ - theta0_) * bins_)), -1, bins_);
  return std::int64_t(t + 1) * (bins_ + 2) + (p + 1);
}

Location Locator::locate_from(const double* charges_C, const std::array<double, 3>* starts, int n_starts) const {
  Query Q;
  Location early;
  if (!prepare(charges_C, fixed_force_, fixed_force_ ? log_force_lo_ : 0.0, Q, early)) return early;
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

PVDF_CLONES Location Locator::finish(const Query& Q, std::array<Fit, 8>& fits, int n_starts) const {
  const bool fixed_force = Q.fixed_force;
  const double limit = Q.limit;
  Location out;
  out.n_starts = n_starts;
  // Rank: fits within noise first, among them forces inside the map's levels first, then χ².
  auto extrapolated = [&](const Fit& f) {
    return f.l < interp_.min_log_force() - 1e-9 || f.l > interp_.max_log_force() + 1e-9;
  };
  auto better = [&](const Fit& a, const Fit& b) {
    const bool wa = a.chi2 <= limit, wb = b.chi2 <= limit;
    if (wa != wb) return wa;
    if (wa && extrapolated(a) != extrapolated(b)) return !extrapolated(a);
    return a.chi2 < b.chi2;
  };
  int best = -1;
  for (int s = 0; s < n_starts; ++s) {
    if (fits[std::size_t(s)].ok && (best < 0 || better(fits[std::size_t(s)], fits[std::size_t(best)]))) best = s;
  }
  if (best < 0) {
    out.flags = flag::outside_map;
    return out;
  }
  Fit& b = fits[std::size_t(best)];
  covariance(b, fixed_force);
  fill_main(b, out);
  if (b.chi2 > limit) {
    if (b.blocked) {
      out = Location{};
      out.n_starts = n_starts;
      out.flags = flag::outside_map;
      out.held = {b.x, b.y, std::exp(b.l)};
      return out;
    }
    out.flags |= flag::poor_fit;
    return out;
  }
  // Other minima that also fit within noise and lie elsewhere: ambiguous.
  std::array<int, 8> group{};
  const int n_group = distinct_solutions(Q, fits, n_starts, best, group);
  if (n_group == 1) return out;
  // Every solution with its posterior probability; the most probable one is the main answer,
  // the others follow most probable first.
  std::array<double, 8> p{};
  double p_max = -std::numeric_limits<double>::infinity();
  for (int g = 0; g < n_group; ++g) {
    p[std::size_t(g)] = log_posterior_weight(Q, fits[std::size_t(group[std::size_t(g)])]);
    p_max = std::max(p_max, p[std::size_t(g)]);
  }
  double sum = 0;
  for (int g = 0; g < n_group; ++g) sum += (p[std::size_t(g)] = std::exp(p[std::size_t(g)] - p_max));
  for (int g = 0; g < n_group; ++g) p[std::size_t(g)] /= sum;
  for (int a = 1; a < n_group; ++a) {  // insertion sort of a handful, most probable first
    for (int c = a; c > 0 && p[std::size_t(c)] > p[std::size_t(c - 1)]; --c) {
      std::swap(p[std::size_t(c)], p[std::size_t(c - 1)]);
      std::swap(group[std::size_t(c)], group[std::size_t(c - 1)]);
    }
  }
  const int n_starts_made = out.n_starts;
  Fit& main = fits[std::size_t(group[0])];
  if (group[0] != best) {
    covariance(main, fixed_force);
    out = Location{};
    out.n_starts = n_starts_made;
    fill_main(main, out);
  }
  out.flags |= flag::ambiguous;
  out.n_solutions = n_group;
  out.probability = p[0];
  out.n_alternatives = n_group - 1;
  for (int a = 1; a < n_group; ++a) {
    Fit& f = fits[std::size_t(group[std::size_t(a)])];
    if (group[std::size_t(a)] != best) covariance(f, fixed_force);
    out.alternatives[std::size_t(a - 1)] = {f.x, f.y, std::exp(f.l), std::sqrt(f.chi2), f.sigma[0], f.sigma[1],
                                            std::exp(f.l) * f.sigma[2], p[std::size_t(a)]};
  }
  out.alternative = out.alternatives[0];
  return out;
}

void Locator::fill_main(const Fit& b, Location& out) const {
  out.x_m = b.x;
  out.y_m = b.y;
  out.force_N = std::exp(b.l);
  out.residual = std::sqrt(b.chi2);
  out.sigma_x_m = b.sigma[0];
  out.sigma_y_m = b.sigma[1];
  out.sigma_F_N = out.force_N * b.sigma[2];
  out.iterations = b.iterations;
  out.n_solutions = 1;
  out.probability = 1.0;
  if (!b.converged) out.flags |= flag::not_converged;
  if (b.singular) out.flags |= flag::ill_conditioned;
  // The force is outside the map's levels (the scaling law carries the map there) only when it
  // is so by more than its own uncertainty: a press at a level's force is not flagged.
  const double tolerance = std::max(1e-3, 2.0 * b.sigma[2]);
  const bool off_levels = b.l < interp_.min_log_force() - tolerance || b.l > interp_.max_log_force() + tolerance;
  if (off_levels) out.flags |= flag::force_extrapolated;
  if (single_level_ && off_levels) out.flags |= flag::scaling_assumed;
}

double Locator::log_posterior_weight(const Query& Q, const Fit& f) const {
  // Laplace approximation of the posterior mass around a solution: exp(−χ²/2) times the volume
  // (2π)^(k/2) det(A)^(−1/2) of its Gaussian, A = JᵀWJ in (x, y[, ln F]), times the prior's
  // density there. The prior is uniform over the map's area and uniform in F over the force
  // range: in ln F its density is ∝ F. Where JᵀWJ is (nearly) singular the prior itself bounds
  // the posterior's width: A gets the precision of the uniform prior (12 / width²) added.
  const double wx = double(interp_.nx() - 1) * interp_.hx(), wy = double(interp_.ny() - 1) * interp_.hy();
  const double rx = 12.0 / (wx * wx), ry = 12.0 / (wy * wy);
  const auto& m = f.jtj;  // 00 01 02 11 12 22
  const double a00 = m[0] + rx, a01 = m[1], a11 = m[3] + ry;
  double det = 0, floor = rx * ry;
  if (Q.fixed_force) {
    det = a00 * a11 - a01 * a01;
  } else {
    const double width_l = std::max(Q.log_hi - Q.log_lo, 1e-6), rl = 12.0 / (width_l * width_l);
    const double a02 = m[2], a12 = m[4], a22 = m[5] + rl;
    det = a00 * (a11 * a22 - a12 * a12) - a01 * (a01 * a22 - a12 * a02) + a02 * (a01 * a12 - a11 * a02);
    floor *= rl;
  }
  return -0.5 * f.chi2 - 0.5 * std::log(std::max(det, floor)) + (Q.fixed_force ? 0.0 : f.l);
}

int Locator::distinct_solutions(const Query& Q, const std::array<Fit, 8>& fits, int n_starts, int best,
                                std::array<int, 8>& group) const {
  const bool fixed_force = Q.fixed_force;
  const double limit = Q.limit;
  const double separation = options_.ambiguity_separation_cells * std::max(interp_.hx(), interp_.hy());
  // Two end points are one solution when they are within 3 σ of each other (Mahalanobis
  // distance in (x, y) from either one's JᵀWJ, ln F profiled out), or within 1e-3 cell
  // (convergence tolerance), or closer than the optional separation. Where the position
  // block is singular (a symmetry line or a flat spot) the misfit barrier between them decides.
  auto distinct_from = [&](const Fit& a, const Fit& f) {
    const double dx = f.x - a.x, dy = f.y - a.y;
    if (std::abs(dx) < 1e-3 * interp_.hx() && std::abs(dy) < 1e-3 * interp_.hy()) return false;
    if (separation > 0 && dx * dx + dy * dy <= separation * separation) return false;
    double d2 = std::numeric_limits<double>::infinity();
    bool singular = false;
    for (const Fit* g : {&a, &f}) {
      const auto& m = g->jtj;  // 00 01 02 11 12 22
      double s00 = m[0], s01 = m[1], s11 = m[3];
      if (!fixed_force && m[5] > 0) {
        s00 -= m[2] * m[2] / m[5];
        s01 -= m[2] * m[4] / m[5];
        s11 -= m[4] * m[4] / m[5];
      }
      const double det = s00 * s11 - s01 * s01;
      singular = singular || !(det > 1e-12 * (s00 * s11 + 1e-300));
      d2 = std::min(d2, s00 * dx * dx + 2 * s01 * dx * dy + s11 * dy * dy);
    }
    if (singular) return distinct_minima(Q.q.data(), Q.w.data(), a, f, 0.0, limit);
    return d2 > 9.0;
  };
  group[0] = best;
  int n = 1;
  for (int s = 0; s < n_starts; ++s) {
    const Fit& f = fits[std::size_t(s)];
    if (s == best || !f.ok || f.chi2 > limit) continue;
    bool is_new = true;
    for (int d = 0; d < n && is_new; ++d) is_new = distinct_from(fits[std::size_t(group[std::size_t(d)])], f);
    if (is_new) group[std::size_t(n++)] = s;
  }
  return n;
}

}  // namespace pvdf::mapping
