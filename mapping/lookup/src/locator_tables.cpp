// The lookup's precomputed tables (docs/lookup.md §1.2–1.5), built once by the Locator's
// constructor in named steps: settings, the coarse table of cell directions, each cell's local
// direction model per force level, its compact float copies for the search, the fold-prone
// cells and the direction bins.
#include "locator_detail.hpp"
#include "pvdf/mapping/locator.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"

namespace pvdf::mapping {

using detail::direction_key;
using detail::normalize;
using detail::Vec;

/// The local model of one usable cell at one force level, at the cell centre (cell units t, s).
struct Locator::CellLevelModel {
  Vec d{};                                                  ///< unit direction of G
  std::array<std::array<double, 2>, max_electrodes> J{};    ///< ∂d/∂(t, s)
  std::array<Vec, 2> P{};                                   ///< rows (t, s) of (JᵀJ)⁻¹Jᵀ; 0 where JᵀJ is singular
  double log_g = 0;                                         ///< ln |G| − p ln F
  std::array<double, 2> log_g_grad{};                       ///< ∂ ln|G| / ∂(t, s)
  std::array<std::array<double, 3>, max_electrodes> H{};    ///< ∂²d / ∂(tt, ts, ss)
  std::array<double, 3> log_g_hess{};                       ///< ∂² ln|G| / ∂(tt, ts, ss)
};

namespace {

/// Largest squared distance, over the four corners of cell (i, j) at level f, between the
/// corner's unit direction and a model's prediction there (offsets ±½ cell).
template <class Predicted>
double corner_error2(const MapInterpolant& interp, std::size_t ne, std::size_t f, std::size_t i, std::size_t j,
                     Predicted&& predicted) {
  double worst = 0;
  for (int b = 0; b < 2; ++b) {
    for (int a = 0; a < 2; ++a) {
      Vec n{};
      for (std::size_t k = 0; k < ne; ++k) n[k] = interp.node_value(f, i + std::size_t(a), j + std::size_t(b), k);
      normalize(n.data(), ne);
      double e2 = 0;
      for (std::size_t k = 0; k < ne; ++k) {
        const double e = n[k] - predicted(k, a - 0.5, b - 0.5);
        e2 += e * e;
      }
      worst = std::max(worst, e2);
    }
  }
  return worst;
}

}  // namespace

Locator::Locator(const ChargeMap& map, const LocatorOptions& options)
    : interp_(map), ne_(map.ne()), names_(map.electrode_names), options_(options) {
  configure(map, options);
  DirectionRanges ranges;
  const std::vector<std::array<double, 4>> boxes = build_coarse_table(map, ranges);
  std::vector<double> linear_error2;
  const std::vector<CellLevelModel> models = build_cell_models(map, linear_error2);
  build_scan_table(models, linear_error2);
  build_model_table(models);
  mark_fold_cells(models);
  if (cells_.empty()) throw InputError("map has no usable cell (four ok nodes with non-zero charge); nothing can be located");
  build_direction_bins(boxes, ranges);
  set_map_error(map);
}

void Locator::configure(const ChargeMap& map, const LocatorOptions& options) {
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
    if (!std::isfinite(s) || !(s > 0)) throw InputError("locator noise_C = " + pvdf::format_g(s) + " must be finite and > 0 (C)");
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
  double lo = options.min_force_N, hi = options.max_force_N;
  if (!(lo > 0)) lo = 0.5 * map.forces_N.front();
  if (!(hi > 0)) hi = 2.0 * map.forces_N.back();
  if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi)) {
    throw InputError("locator force range " + pvdf::format_g(lo) + ".." + pvdf::format_g(hi) + " N must satisfy 0 < min < max");
  }
  log_force_lo_ = std::log(lo);
  log_force_hi_ = std::log(hi);
  if (options.known_force_N != 0.0) {
    if (!(options.known_force_N > 0) || !std::isfinite(options.known_force_N)) {
      throw InputError("locator known_force_N = " + pvdf::format_g(options.known_force_N) + " must be finite and > 0 (N)");
    }
    fixed_force_ = true;
    log_force_lo_ = log_force_hi_ = std::log(options.known_force_N);
  }
}

std::vector<std::array<double, 4>> Locator::build_coarse_table(const ChargeMap& map, DirectionRanges& ranges) {
  // Per usable cell: the mean unit direction of G over the levels at its centre, the mean |G|,
  // the squared angular radius (corners and levels), and the box of direction keys it covers.
  const std::size_t nx = interp_.nx(), ny = interp_.ny(), nf = interp_.n_levels();
  std::vector<std::array<double, 4>> boxes;  // per usable cell: phi_lo, phi_hi, theta_lo, theta_hi
  ranges = {1e9, -1e9, 1e9, -1e9};
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
      // Grow the box by a tenth of its size each way: the direction inside a cell can bulge
      // slightly beyond the corners' range.
      const double gp = 0.1 * (box[1] - box[0]), gt = 0.1 * (box[3] - box[2]);
      box = {box[0] - gp, box[1] + gp, box[2] - gt, box[3] + gt};
      boxes.push_back(box);
      ranges.phi_lo = std::min(ranges.phi_lo, box[0]);
      ranges.phi_hi = std::max(ranges.phi_hi, box[1]);
      ranges.theta_lo = std::min(ranges.theta_lo, box[2]);
      ranges.theta_hi = std::max(ranges.theta_hi, box[3]);
    }
  }
  return boxes;
}

Locator::CellLevelModel Locator::cell_level_model(std::size_t c, double lf) const {
  // Unit direction d at the centre, its derivatives J in cell units and their least-squares
  // inverse P, ln |G| with its gradient, and by central differences of the cell's own patch at
  // ±0.45 cell the second derivatives of d and ln |G| (the quadratic model of §1.3).
  CellLevelModel m;
  Vec qc{};
  std::array<std::array<double, 3>, max_electrodes> dq{};
  interp_.evaluate(cell_xy_[c][0], cell_xy_[c][1], lf, qc.data(), dq.data());
  const double norm = normalize(qc.data(), ne_);  // qc is now the unit direction d
  for (std::size_t k = 0; k < ne_; ++k) m.d[k] = qc[k];
  for (int a = 0; a < 2; ++a) {  // ∂d/∂t = (I − d dᵀ) ∂q/∂t / |q|
    const double h = a == 0 ? interp_.hx() : interp_.hy();
    double proj = 0;
    for (std::size_t k = 0; k < ne_; ++k) proj += m.d[k] * dq[k][std::size_t(a)];
    for (std::size_t k = 0; k < ne_; ++k) m.J[k][std::size_t(a)] = h * (dq[k][std::size_t(a)] - proj * m.d[k]) / norm;
  }
  double a00 = 0, a01 = 0, a11 = 0;
  for (std::size_t k = 0; k < ne_; ++k) {
    a00 += m.J[k][0] * m.J[k][0];
    a01 += m.J[k][0] * m.J[k][1];
    a11 += m.J[k][1] * m.J[k][1];
  }
  const double det = a00 * a11 - a01 * a01;
  if (det > 1e-14 * (a00 * a11 + 1e-300)) {
    for (std::size_t k = 0; k < ne_; ++k) {
      m.P[0][k] = (a11 * m.J[k][0] - a01 * m.J[k][1]) / det;
      m.P[1][k] = (-a01 * m.J[k][0] + a00 * m.J[k][1]) / det;
    }
  }  // else P = 0: the cell predicts its centre (a fold or a flat spot)
  m.log_g = std::log(norm) - interp_.force_exponent() * lf;
  for (int a = 0; a < 2; ++a) {
    const double h = a == 0 ? interp_.hx() : interp_.hy();
    double proj = 0;
    for (std::size_t k = 0; k < ne_; ++k) proj += m.d[k] * dq[k][std::size_t(a)];
    m.log_g_grad[std::size_t(a)] = h * proj / norm;
  }
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
    m.H[k][0] = (pt[k] + mt[k] - 2 * m.d[k]) * ia2;
    m.H[k][1] = (pp[k] - pm[k] - mp[k] + mm[k]) * ia24;
    m.H[k][2] = (ps[k] + ms[k] - 2 * m.d[k]) * ia2;
  }
  const double g0 = m.log_g;
  m.log_g_hess[0] = (gpt + gmt - 2 * g0) * ia2;
  m.log_g_hess[1] = (gpp - gpm - gmp + gmm) * ia24;
  m.log_g_hess[2] = (gps + gms - 2 * g0) * ia2;
  return m;
}

std::vector<Locator::CellLevelModel> Locator::build_cell_models(const ChargeMap& map, std::vector<double>& linear_error2) {
  const std::size_t nx = interp_.nx(), nf = interp_.n_levels();
  for (double F : map.forces_N) level_log_.push_back(std::log(F));
  std::vector<CellLevelModel> models(cells_.size() * nf);
  cell_slot_.assign((nx - 1) * (interp_.ny() - 1), -1);
  for (std::size_t c = 0; c < cells_.size(); ++c) cell_slot_[cells_[c]] = std::int32_t(c);
  linear_error2.assign(cells_.size(), 0.0);
  cell_log_norm_.assign(cells_.size(), 0.0);
  for (std::size_t c = 0; c < cells_.size(); ++c) {
    const std::size_t i = cells_[c] % (nx - 1), j = cells_[c] / (nx - 1);
    double log_norm = 0;
    for (std::size_t f = 0; f < nf; ++f) {
      const double lf = std::log(map.forces_N[f]);
      const CellLevelModel& m = models[c * nf + f] = cell_level_model(c, lf);
      log_norm += m.log_g / double(nf);
      // Error of the linear model at the four corners (|offset| = ½ cell each way).
      linear_error2[c] = std::max(linear_error2[c], corner_error2(interp_, ne_, f, i, j, [&](std::size_t k, double dt, double ds) {
                                    return m.d[k] + m.J[k][0] * dt + m.J[k][1] * ds;
                                  }));
    }
    cell_log_norm_[c] = log_norm;
  }
  return models;
}

void Locator::build_scan_table(const std::vector<CellLevelModel>& models, const std::vector<double>& linear_error2) {
  // The coarse search's model per cell, compact: the middle level's linear model in (t, s)
  // carried to other forces by the secant over the levels, and its worst error at the corners
  // and levels (the start is then refined by refine_start with the exact level blend).
  const std::size_t nx = interp_.nx(), nf = interp_.n_levels();
  scan_stride_ = 6 * ne_ + 8;
  scan_.assign(cells_.size() * scan_stride_, 0.0f);
  const std::size_t fm = nf / 2;
  const double span = nf > 1 ? level_log_[nf - 1] - level_log_[0] : 1.0;
  for (std::size_t c = 0; c < cells_.size(); ++c) {
    const std::size_t i = cells_[c] % (nx - 1), j = cells_[c] / (nx - 1);
    const CellLevelModel& rm = models[c * nf + fm];
    const CellLevelModel& ra = models[c * nf];
    const CellLevelModel& rb = models[c * nf + nf - 1];
    float* sc = &scan_[c * scan_stride_];
    std::array<double, max_electrodes> dl{};
    for (std::size_t k = 0; k < ne_; ++k) {
      dl[k] = nf > 1 ? (rb.d[k] - ra.d[k]) / span : 0.0;
      sc[k] = float(rm.d[k]);
      sc[ne_ + k] = float(rm.P[0][k]);
      sc[2 * ne_ + k] = float(rm.P[1][k]);
      sc[3 * ne_ + k] = float(dl[k]);
      sc[4 * ne_ + k] = float(rm.J[k][0]);
      sc[5 * ne_ + k] = float(rm.J[k][1]);
    }
    float* tail = sc + 6 * ne_;
    tail[0] = float(level_log_[fm]);
    tail[1] = float(cell_log_norm_[c]);
    tail[2] = float(rm.log_g);
    tail[3] = float(rm.log_g_grad[0]);
    tail[4] = float(rm.log_g_grad[1]);
    tail[5] = nf > 1 ? float((rb.log_g - ra.log_g) / span) : 0.0f;
    double err2 = linear_error2[c];
    for (std::size_t f = 0; f < nf; ++f) {
      const double dlf = level_log_[f] - level_log_[fm];
      err2 = std::max(err2, corner_error2(interp_, ne_, f, i, j, [&](std::size_t k, double dt, double ds) {
                        return rm.d[k] + dl[k] * dlf + rm.J[k][0] * dt + rm.J[k][1] * ds;
                      }));
    }
    tail[6] = float(err2);
    // Curvature ratio κ = |H| / σ_min(J) (cell units, worst level): a Newton step δ leaves an
    // error ≈ κ δ² / 2 (levenberg_marquardt's unevaluated last step).
    double kappa = 0;
    for (std::size_t f = 0; f < nf; ++f) {
      const CellLevelModel& r = models[c * nf + f];
      double a00 = 0, a01 = 0, a11 = 0, h2 = 0;
      for (std::size_t k = 0; k < ne_; ++k) {
        const double jt = r.J[k][0], js = r.J[k][1];
        a00 += jt * jt;
        a01 += jt * js;
        a11 += js * js;
        h2 += r.H[k][0] * r.H[k][0] + 2 * r.H[k][1] * r.H[k][1] + r.H[k][2] * r.H[k][2];
      }
      const double half = 0.5 * (a00 + a11), dev = std::sqrt(0.25 * (a00 - a11) * (a00 - a11) + a01 * a01);
      const double smin = std::sqrt(std::max(half - dev, 0.0));
      kappa = std::max(kappa, smin > 0 ? std::sqrt(h2) / smin : 1e30);
    }
    // Stored as the step threshold it gives: κ δ² / 2 ≤ 1e-4 cell, δ clamped to 1e-3…1e-2.
    tail[7] = float(std::clamp(std::sqrt(2e-4 / std::max(kappa, 1e-30)), 1e-3, 1e-2));
  }
}

void Locator::build_model_table(const std::vector<CellLevelModel>& models) {
  // The start refinement's and fold search's model per cell and level, compact (float, one
  // contiguous row per level): d, J (t, s), H (tt, ts, ss), then ln |G| and its first and
  // second derivatives.
  const std::size_t nf = interp_.n_levels();
  model_stride_ = 6 * ne_ + 6;
  model_.assign(cells_.size() * nf * model_stride_, 0.0f);
  for (std::size_t c = 0; c < cells_.size(); ++c) {
    for (std::size_t f = 0; f < nf; ++f) {
      const CellLevelModel& r = models[c * nf + f];
      float* m = &model_[(c * nf + f) * model_stride_];
      for (std::size_t k = 0; k < ne_; ++k) {
        m[k] = float(r.d[k]);
        m[ne_ + k] = float(r.J[k][0]);
        m[2 * ne_ + k] = float(r.J[k][1]);
        m[3 * ne_ + k] = float(r.H[k][0]);
        m[4 * ne_ + k] = float(r.H[k][1]);
        m[5 * ne_ + k] = float(r.H[k][2]);
      }
      m[6 * ne_] = float(r.log_g);
      m[6 * ne_ + 1] = float(r.log_g_grad[0]);
      m[6 * ne_ + 2] = float(r.log_g_grad[1]);
      for (int a = 0; a < 3; ++a) m[6 * ne_ + 3 + std::size_t(a)] = float(r.log_g_hess[std::size_t(a)]);
    }
  }
}

void Locator::mark_fold_cells(const std::vector<CellLevelModel>& models) {
  // Fold-prone cells: where the orientation of the direction map, sign of d · (J_t × J_s),
  // differs between a cell and one of its 8 neighbours at some level, a fold passes within
  // about a cell, and a solution there may have a twin the coarse search cannot separate.
  // (More than three electrodes: no orientation; a cell is fold-prone where J is nearly
  // singular, σ_min/σ_max < 0.1.)
  const std::size_t nx = interp_.nx(), ny = interp_.ny(), nf = interp_.n_levels();
  cell_fold_.assign(cells_.size(), 0);
  std::vector<signed char> orient(cells_.size() * nf, 0);
  for (std::size_t c = 0; c < cells_.size(); ++c) {
    for (std::size_t f = 0; f < nf; ++f) {
      const CellLevelModel& r = models[c * nf + f];
      if (ne_ == 3) {
        const double jt[3] = {r.J[0][0], r.J[1][0], r.J[2][0]}, js[3] = {r.J[0][1], r.J[1][1], r.J[2][1]};
        const double t = r.d[0] * (jt[1] * js[2] - jt[2] * js[1]) + r.d[1] * (jt[2] * js[0] - jt[0] * js[2]) +
                         r.d[2] * (jt[0] * js[1] - jt[1] * js[0]);
        orient[c * nf + f] = t > 0 ? 1 : t < 0 ? -1 : 0;
      } else {
        double a00 = 0, a01 = 0, a11 = 0;
        for (std::size_t k = 0; k < ne_; ++k) {
          a00 += r.J[k][0] * r.J[k][0];
          a01 += r.J[k][0] * r.J[k][1];
          a11 += r.J[k][1] * r.J[k][1];
        }
        const double half = 0.5 * (a00 + a11), dev = std::sqrt(0.25 * (a00 - a11) * (a00 - a11) + a01 * a01);
        if (half - dev < 0.01 * (half + dev)) cell_fold_[c] = 1;
      }
    }
  }
  if (ne_ != 3) return;
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

void Locator::build_direction_bins(const std::vector<std::array<double, 4>>& boxes, const DirectionRanges& ranges) {
  bins_ = options_.direction_bins > 0 ? options_.direction_bins
                                     : std::clamp(int(3.0 * std::sqrt(double(cells_.size()))), 16, 512);
  const double pad_p = 1e-9 + 1e-6 * (ranges.phi_hi - ranges.phi_lo), pad_t = 1e-9 + 1e-6 * (ranges.theta_hi - ranges.theta_lo);
  phi0_ = ranges.phi_lo - pad_p;
  phi1_ = ranges.phi_hi + pad_p;
  theta0_ = ranges.theta_lo - pad_t;
  theta1_ = ranges.theta_hi + pad_t;
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

}  // namespace pvdf::mapping
