// Layout evaluation from a charge map: Cramér–Rao bounds, ambiguity through the deployed lookup,
// sensitivity, ADC dynamic range, dead zones; and the scene edits behind `pvdfkit design --vary`.
#include "pvdf/core/membrane_scaling.hpp"
#include "pvdf/mapping/design.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/mapping/interpolant.hpp"
#include "pvdf/mapping/locator.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace pvdf::mapping {

namespace {

constexpr double inf = std::numeric_limits<double>::infinity();
constexpr double nan = std::numeric_limits<double>::quiet_NaN();

std::string num(double v) {
  std::ostringstream s;
  s.precision(6);
  s << v;
  return s.str();
}

/// Quantile q ∈ [0, 1] of `values` (nearest rank; +∞ entries sort last). 0 for an empty list.
double quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const std::size_t k = std::min(values.size() - 1, std::size_t(std::floor(q * double(values.size() - 1) + 0.5)));
  return values[k];
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Cramér–Rao bound
//
// For Gaussian charge noise q = Q(θ) + e, e ~ N(0, Σ), Σ = diag(σ_k²), the Fisher information of
// θ = (x, y, ln F) is I = JᵀΣ⁻¹J with J = ∂Q/∂θ, and any unbiased estimator has covariance
// ≥ I⁻¹ (Kay, Fundamentals of Statistical Signal Processing I, §3.7). The lookup's LM solution is
// the maximum-likelihood estimate, efficient for small noise, so I⁻¹ is also what it reports as
// σ (docs/lookup.md §1 step 4). Singularity is judged on the equilibrated matrix D I D,
// D = diag(I_ii^−½), whose eigenvalues are scale-free: the test does not depend on units.

PointBound cramer_rao_bound(const std::vector<std::array<double, 3>>& jacobian, const std::vector<double>& sigma_C,
                            bool force_known, double singular_rcond) {
  PointBound b;
  const int n = force_known ? 2 : 3;
  Eigen::Matrix3d fisher = Eigen::Matrix3d::Zero();
  for (std::size_t k = 0; k < jacobian.size(); ++k) {
    const double w = 1.0 / (sigma_C[k] * sigma_C[k]);
    for (int a = 0; a < 3; ++a) {
      for (int c = 0; c < 3; ++c) fisher(a, c) += w * jacobian[k][std::size_t(a)] * jacobian[k][std::size_t(c)];
    }
  }
  const Eigen::MatrixXd info = fisher.topLeftCorner(n, n);
  Eigen::VectorXd d(n);
  for (int a = 0; a < n; ++a) {
    if (!(info(a, a) > 0) || !std::isfinite(info(a, a))) return b;  // a parameter the charges do not see
    d(a) = 1.0 / std::sqrt(info(a, a));
  }
  const Eigen::MatrixXd scaled = d.asDiagonal() * info * d.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scaled);
  if (eig.info() != Eigen::Success) return b;
  const double lo = eig.eigenvalues().minCoeff(), hi = eig.eigenvalues().maxCoeff();
  if (!(lo > singular_rcond * hi)) return b;
  const Eigen::MatrixXd scaled_inv =
      eig.eigenvectors() * eig.eigenvalues().cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
  const Eigen::MatrixXd cov = d.asDiagonal() * scaled_inv * d.asDiagonal();
  b.singular = false;
  b.sigma_x_m = std::sqrt(cov(0, 0));
  b.sigma_y_m = std::sqrt(cov(1, 1));
  b.sigma_pos_m = std::sqrt(cov(0, 0) + cov(1, 1));
  const Eigen::Matrix2d cxy = cov.topLeftCorner(2, 2);
  b.sigma_major_m = std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(cxy).eigenvalues().maxCoeff());
  b.sigma_force_rel = force_known ? 0.0 : std::sqrt(cov(2, 2));
  return b;
}

std::string design_status_name(DesignStatus status) {
  return status == DesignStatus::ok ? "ok" : "unable_to_locate";
}

// ---------------------------------------------------------------------------------------------
// Layout evaluation

namespace {

/// The layout options' checks; returns the per-electrode charge noise (C) to use.
std::vector<double> checked_noise(const ChargeMap& map, const DesignOptions& o) {
  const std::size_t ne = map.ne();
  if (ne < 3) {
    throw InputError("design: the layout has " + std::to_string(ne) +
                     " electrodes; locating a press with unknown force needs at least 3");
  }
  if (!(o.force_N > 0) || !std::isfinite(o.force_N)) throw InputError("design: force " + num(o.force_N) + " N must be > 0 (DesignOptions::force_N)");
  if (!(o.min_force_N > 0) || !(o.max_force_N > o.min_force_N) || !std::isfinite(o.max_force_N)) {
    throw InputError("design: force range " + num(o.min_force_N) + ".." + num(o.max_force_N) +
                     " N must satisfy 0 < MIN < MAX (DesignOptions::min_force_N, max_force_N)");
  }
  if (!(o.target_m > 0)) throw InputError("design: coverage target " + num(o.target_m) + " m must be > 0 (DesignOptions::target_m)");
  if (o.adc_bits != 0 && (o.adc_bits < 2 || o.adc_bits > 32)) {
    throw InputError("design: ADC resolution " + std::to_string(o.adc_bits) + " bits must be 0 (ideal) or 2..32 (DesignOptions::adc_bits)");
  }
  if (!(o.full_scale_C >= 0) || !(o.full_scale_margin >= 1)) {
    throw InputError("design: full scale must be >= 0 C and its margin >= 1");
  }
  std::vector<double> noise = o.noise_C.empty() ? map.noise_C : o.noise_C;
  if (noise.size() == 1) noise.assign(ne, noise[0]);
  if (noise.size() != ne) {
    throw InputError("design: " + std::to_string(noise.size()) + " noise values for " + std::to_string(ne) +
                     " electrodes; give one value or one per electrode (DesignOptions::noise_C)");
  }
  for (double s : noise) {
    if (!(s > 0) || !std::isfinite(s)) throw InputError("design: charge noise " + num(s) + " C must be > 0 (DesignOptions::noise_C)");
  }
  return noise;
}

/// What the steps of evaluate_design share: the map, its interpolant, the summary being
/// filled, and the per-node values (index p of DesignMaps, p * ne + k per electrode).
struct DesignEvaluation {
  DesignEvaluation(const ChargeMap& map_in, const DesignOptions& options, std::vector<double> noise_C)
      : map(map_in), o(options), ne(map_in.ne()), nx(map_in.nx()), ny(map_in.ny()), np(nx * ny),
        noise(std::move(noise_C)), interp(map_in) {}
  void allocate();
  void sample_nodes();
  void front_end();
  void bounds();
  void ambiguity();
  void area_figures();
  void electrode_reports();

  const ChargeMap& map;
  const DesignOptions& o;
  const std::size_t ne, nx, ny, np;
  const std::vector<double> noise;  // per electrode, before quantization (C)
  const MapInterpolant interp;
  DesignSummary out;
  double log_f = 0;                          // ln of the design force
  std::vector<std::array<double, 2>> where;  // [np] evaluation point of the node (m)
  std::vector<double> q_hi, q_lo;            // [np][ne] charges at the ends of the force range (C)
  std::vector<std::array<double, 3>> jac;    // [np][ne] dQ/d(x, y, ln F) at the design force
  std::vector<double> sigma;                 // [ne] channel noise with quantization (C)
  std::vector<std::size_t> below_k;          // [ne] evaluated points below one LSB at the range's bottom
  std::size_t n_singular = 0, n_dead = 0, n_saturated = 0, n_below = 0;
  std::size_t n_ambiguous = 0, n_silent = 0, n_failed = 0;
};

void DesignEvaluation::allocate() {
  out.model = map.model;
  out.tolerance = map.tolerance;
  out.spacing_m = nx > 1 ? (map.x_m.back() - map.x_m.front()) / double(nx - 1) : 0.0;
  out.synthetic = map.model.rfind("synthetic", 0) == 0;
  out.force_known = o.force_known;
  out.force_N = o.force_N;
  out.min_force_N = o.min_force_N;
  out.max_force_N = o.max_force_N;
  out.target_m = o.target_m;
  out.adc_bits = o.adc_bits;

  DesignMaps& m = out.maps;
  m.x_m = map.x_m;
  m.y_m = map.y_m;
  m.evaluated.assign(np, 0);
  for (auto* v : {&m.sigma_pos_m, &m.sigma_pos_unknown_force_m, &m.sigma_pos_known_force_m, &m.sigma_major_m,
                  &m.sigma_force_rel, &m.ambiguity_distance_m}) {
    v->assign(np, nan);
  }
  m.ambiguous.assign(np, 0);
  m.dead.assign(np, 0);
  m.singular.assign(np, 0);
  m.lookup_failed.assign(np, 0);
  m.charge_C.assign(np * ne, nan);
}

void DesignEvaluation::sample_nodes() {
  DesignMaps& m = out.maps;
  // Step 1: the evaluation points are the mapped nodes. A node on the edge of the usable region
  // is evaluated from any adjacent usable cell (the interpolant is C¹, so the side does not matter).
  log_f = std::log(o.force_N);
  const double log_lo = std::log(o.min_force_N), log_hi = std::log(o.max_force_N);
  const double nudge = 1e-9 * out.spacing_m;
  where.assign(np, {});
  q_hi.assign(np * ne, nan);
  q_lo.assign(np * ne, nan);
  jac.assign(np * ne, {});
  std::vector<double> q(ne);
  std::vector<std::array<double, 3>> dq(ne);
  for (std::size_t j = 0; j < ny; ++j) {
    for (std::size_t i = 0; i < nx; ++i) {
      const std::size_t p = m.index(i, j);
      if (!map.mask[p]) continue;
      ++out.n_mapped;
      bool found = false;
      for (const auto& off : {std::array<double, 2>{0, 0}, {nudge, nudge}, {-nudge, nudge}, {-nudge, -nudge},
                              {nudge, -nudge}}) {
        const double x = map.x_m[i] + off[0], y = map.y_m[j] + off[1];
        if (interp.evaluate(x, y, log_f, q.data(), dq.data())) {
          where[p] = {x, y};
          found = true;
          break;
        }
      }
      if (!found) continue;
      m.evaluated[p] = 1;
      ++out.n_evaluated;
      for (std::size_t k = 0; k < ne; ++k) {
        m.charge_C[p * ne + k] = q[k];
        jac[p * ne + k] = dq[k];
      }
      interp.evaluate(where[p][0], where[p][1], log_hi, &q_hi[p * ne], nullptr);
      interp.evaluate(where[p][0], where[p][1], log_lo, &q_lo[p * ne], nullptr);
    }
  }
  if (out.n_evaluated == 0) {
    throw InputError("design: the map has no usable interpolation cell (all mapped nodes isolated); use a finer map spacing");
  }
}

void DesignEvaluation::front_end() {
  const DesignMaps& m = out.maps;
  // Step 2: the front end. One full scale for all channels (the same amplifier on each), bipolar
  // ADC: LSB = FS / 2^(bits−1); quantization adds LSB²/12 to each channel's noise variance.
  double q_max = 0;
  for (std::size_t p = 0; p < np; ++p) {
    if (!m.evaluated[p]) continue;
    for (std::size_t k = 0; k < ne; ++k) q_max = std::max(q_max, std::abs(q_hi[p * ne + k]));
  }
  out.full_scale_C = o.full_scale_C > 0 ? o.full_scale_C : o.full_scale_margin * q_max;
  out.lsb_C = o.adc_bits > 0 ? out.full_scale_C / std::ldexp(1.0, o.adc_bits - 1) : 0.0;
  sigma.assign(ne, 0.0);
  for (std::size_t k = 0; k < ne; ++k) sigma[k] = std::sqrt(noise[k] * noise[k] + out.lsb_C * out.lsb_C / 12.0);
  out.lsb_over_noise = out.lsb_C / *std::min_element(noise.begin(), noise.end());
}

void DesignEvaluation::bounds() {
  DesignMaps& m = out.maps;
  // Step 3: bounds and dead zones at every evaluated point. With include_map_error, a map with
  // per-node error estimates (format 2) adds each node's estimated charge error, as a further
  // independent 1-σ term, to the channel noise there (at the force level nearest to the design
  // force, scaled to it by F^(2/3)): the bound of a lookup that uses this very map.
  below_k.assign(ne, 0);
  std::vector<std::array<double, 3>> jp(ne);
  std::size_t f_near = 0;
  for (std::size_t f = 0; f < map.nf(); ++f) {
    if (std::abs(std::log(map.forces_N[f]) - log_f) < std::abs(std::log(map.forces_N[f_near]) - log_f)) f_near = f;
  }
  const double err_scale = pvdf::membrane_charge_factor(o.force_N / map.forces_N[f_near]);
  std::vector<double> sigma_p(ne);
  for (std::size_t p = 0; p < np; ++p) {
    if (!m.evaluated[p]) continue;
    for (std::size_t k = 0; k < ne; ++k) {
      jp[k] = jac[p * ne + k];
      const double e = !o.include_map_error || map.estimated_charge_error_C.empty()
                           ? 0.0
                           : err_scale * map.estimated_charge_error_C[map.charge_index(f_near, p / nx, p % nx, k)];
      sigma_p[k] = std::isfinite(e) ? std::hypot(sigma[k], e) : sigma[k];
    }
    const PointBound unknown = cramer_rao_bound(jp, sigma_p, false, o.singular_rcond);
    const PointBound known = cramer_rao_bound(jp, sigma_p, true, o.singular_rcond);
    const PointBound& fom = o.force_known ? known : unknown;
    m.sigma_pos_unknown_force_m[p] = unknown.sigma_pos_m;
    m.sigma_pos_known_force_m[p] = known.sigma_pos_m;
    m.sigma_pos_m[p] = fom.sigma_pos_m;
    m.sigma_major_m[p] = fom.sigma_major_m;
    m.sigma_force_rel[p] = unknown.sigma_force_rel;
    m.singular[p] = fom.singular ? 1 : 0;
    n_singular += m.singular[p];
    double snr2 = 0;
    bool saturated = false, below = false;
    for (std::size_t k = 0; k < ne; ++k) {
      snr2 += std::pow(m.charge_C[p * ne + k] / sigma[k], 2);
      if (o.adc_bits > 0 && std::abs(q_hi[p * ne + k]) > out.full_scale_C) saturated = true;
      if (o.adc_bits > 0 && std::abs(q_lo[p * ne + k]) < out.lsb_C) {
        below = true;
        ++below_k[k];
      }
    }
    m.dead[p] = std::sqrt(snr2 / double(ne)) < o.dead_snr ? 1 : 0;
    n_dead += m.dead[p];
    n_saturated += saturated;
    n_below += below;
  }
}

void DesignEvaluation::ambiguity() {
  DesignMaps& m = out.maps;
  // Step 4: ambiguity, judged by the deployed lookup itself: noise-free charges of the press are
  // located with the same noise model and force range. Every accepted solution (the reported
  // one and the alternatives) farther than max(min distance, 3σ_pos) from the press is a
  // distinct press giving the same charges within noise. The Locator merges solutions closer
  // than one grid cell, so a fold next to an electrode can make it report only the wrong one:
  // that counts as ambiguous too, and as "silent" when the Locator raised no flag.
  if (o.check_ambiguity) {
    LocatorOptions lo;
    lo.noise_C = sigma;
    lo.use_calibration = false;
    lo.min_force_N = o.min_force_N;
    lo.max_force_N = o.max_force_N;
    // The deployed lookup calls a second solution "within noise" when its χ² is below the
    // automatic limit L = ν + 5√(2ν) + 4. Noise moves an alternative's χ² by about ±2√χ²,
    // so an alternative just above L (noise-free) still fits in a few percent of real presses:
    // judged here against L + 4√L (two of those standard deviations), a conservative margin.
    {
      const double nu = std::max(double(ne) - (o.force_known ? 2.0 : 3.0), 0.0);
      const double limit = nu + 5.0 * std::sqrt(2.0 * std::max(nu, 1.0)) + 4.0;
      lo.chi2_limit = limit + 4.0 * std::sqrt(limit);
    }
    const Locator locator(map, lo);
    const double min_distance = o.ambiguity_min_distance_m > 0 ? o.ambiguity_min_distance_m : o.target_m;
    for (std::size_t p = 0; p < np; ++p) {
      if (!m.evaluated[p] || m.dead[p]) continue;
      const double* qp = &m.charge_C[p * ne];
      const Location r = o.force_known ? locator.locate(qp, o.force_N) : locator.locate(qp);
      m.ambiguity_distance_m[p] = 0;
      if (!r.has_position()) {
        m.lookup_failed[p] = 1;
        ++n_failed;
        continue;
      }
      const double threshold =
          std::max(min_distance, std::isfinite(m.sigma_pos_m[p]) ? 3 * m.sigma_pos_m[p] : 0.0);
      const double x = where[p][0], y = where[p][1];
      double far = std::hypot(r.x_m - x, r.y_m - y);
      for (int a = 0; a < r.n_alternatives; ++a) {
        const auto& alt = r.alternatives[std::size_t(a)];
        far = std::max(far, std::hypot(alt.x_m - x, alt.y_m - y));
      }
      if (far > threshold) {
        m.ambiguous[p] = 1;
        m.ambiguity_distance_m[p] = far;
        ++n_ambiguous;
        n_silent += (r.flags & flag::ambiguous) == 0;
      }
    }
  }
}

void DesignEvaluation::area_figures() {
  DesignMaps& m = out.maps;
  // Step 5: area figures over the mapped nodes (a mapped node that cannot be evaluated counts
  // as unbounded); the per-electrode figures follow (electrode_reports).
  std::vector<double> pos, pos_known, force;
  std::size_t n_cover = 0, n_usable = 0;
  for (std::size_t p = 0; p < np; ++p) {
    if (!map.mask[p]) continue;
    if (!m.evaluated[p]) {
      pos.push_back(inf);
      pos_known.push_back(inf);
      force.push_back(inf);
      continue;
    }
    pos.push_back(m.sigma_pos_m[p]);
    pos_known.push_back(m.sigma_pos_known_force_m[p]);
    force.push_back(m.sigma_force_rel[p]);
    const bool covered = m.sigma_pos_m[p] <= o.target_m;
    n_cover += covered;
    n_usable += covered && !m.ambiguous[p] && !m.dead[p] && !m.lookup_failed[p];
  }
  const double n_map = double(out.n_mapped), n_eval = double(out.n_evaluated);
  out.coverage = double(n_cover) / n_map;
  out.usable_fraction = double(n_usable) / n_map;
  out.singular_fraction = double(n_singular) / n_eval;
  out.ambiguous_fraction = double(n_ambiguous) / n_eval;
  out.lookup_failed_fraction = double(n_failed) / n_eval;
  out.silent_ambiguous_fraction = double(n_silent) / n_eval;
  out.dead_fraction = double(n_dead) / n_eval;
  out.saturated_fraction = double(n_saturated) / n_eval;
  out.below_lsb_fraction = double(n_below) / n_eval;
  out.median_sigma_pos_m = quantile(pos, 0.5);
  out.p90_sigma_pos_m = quantile(pos, 0.9);
  out.median_sigma_pos_known_force_m = quantile(pos_known, 0.5);
  out.median_sigma_force_rel = quantile(force, 0.5);
  out.p90_sigma_force_rel = quantile(force, 0.9);
  try {
    const Scene scene = parse_scene(nlohmann::json::parse(map.scene_json), "map scene");
    out.mapped_area_fraction = n_map * out.spacing_m * out.spacing_m / scene.membrane.outline.area_m2();
  } catch (const std::exception&) {
    out.mapped_area_fraction = 0;  // a map whose scene copy is not a full scene (old synthetic maps)
  }
  if (n_singular == out.n_evaluated) {
    out.status = DesignStatus::unable_to_locate;
    out.status_reason = std::string("the Fisher matrix of (x, y") + (o.force_known ? "" : ", F") +
                        ") is singular at every evaluated point: the electrodes' charges do not determine the press "
                        "(coincident or redundant electrodes?)";
  }
}

void DesignEvaluation::electrode_reports() {
  const DesignMaps& m = out.maps;
  const double n_eval = double(out.n_evaluated);
  std::vector<double> q(ne);
  std::vector<std::array<double, 3>> dq(ne);
  for (std::size_t k = 0; k < ne; ++k) {
    ElectrodeReport e;
    e.name = map.electrode_names[k];
    e.center_m = map.electrode_centers_m[k];
    e.noise_C = noise[k];
    e.effective_noise_C = sigma[k];
    std::vector<double> sens;
    for (std::size_t p = 0; p < np; ++p) {
      if (!m.evaluated[p]) continue;
      sens.push_back(jac[p * ne + k][2] / o.force_N);  // ∂q/∂F = (∂q/∂ln F)/F
      e.max_charge_C = std::max(e.max_charge_C, std::abs(q_hi[p * ne + k]));
    }
    e.median_sensitivity_C_per_N = quantile(sens, 0.5);
    if (interp.evaluate(e.center_m[0], e.center_m[1], log_f, q.data(), dq.data())) {
      e.sensitivity_at_center_C_per_N = dq[k][2] / o.force_N;
    } else {
      e.sensitivity_at_center_C_per_N = nan;
    }
    e.below_lsb_fraction = double(below_k[k]) / n_eval;
    out.electrodes.push_back(e);
  }
}

}  // namespace

bool ranks_before(const DesignSummary& a, const DesignSummary& b) {
  if ((a.status == DesignStatus::ok) != (b.status == DesignStatus::ok)) return a.status == DesignStatus::ok;
  if (a.usable_fraction != b.usable_fraction) return a.usable_fraction > b.usable_fraction;
  if (a.coverage != b.coverage) return a.coverage > b.coverage;
  return a.median_sigma_pos_m < b.median_sigma_pos_m;
}

std::vector<std::size_t> rank_designs(const std::vector<DesignSummary>& summaries) {
  std::vector<std::size_t> order(summaries.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t i, std::size_t j) { return ranks_before(summaries[i], summaries[j]); });
  return order;
}

DesignSummary evaluate_design(const ChargeMap& map, const DesignOptions& o) {
  DesignEvaluation e(map, o, checked_noise(map, o));
  e.allocate();
  e.sample_nodes();
  e.front_end();
  e.bounds();
  e.ambiguity();
  e.area_figures();
  e.electrode_reports();
  return std::move(e.out);
}

nlohmann::json design_summary_json(const DesignSummary& s) {
  auto value = [](double v) -> nlohmann::json {
    if (std::isfinite(v)) return v;
    return nullptr;  // +∞ (unbounded) or not available: documented as null
  };
  nlohmann::json j;
  j["status"] = design_status_name(s.status);
  if (!s.status_reason.empty()) j["status_reason"] = s.status_reason;
  j["model"] = s.model;
  j["synthetic"] = s.synthetic;
  j["tolerance"] = s.tolerance;
  j["spacing_m"] = s.spacing_m;
  j["force_known"] = s.force_known;
  j["force_N"] = s.force_N;
  j["force_range_N"] = {s.min_force_N, s.max_force_N};
  j["target_m"] = s.target_m;
  j["n_mapped"] = s.n_mapped;
  j["n_evaluated"] = s.n_evaluated;
  j["coverage"] = s.coverage;
  j["usable_fraction"] = s.usable_fraction;
  j["figure_of_merit"] = s.figure_of_merit();
  j["singular_fraction"] = s.singular_fraction;
  j["ambiguous_fraction"] = s.ambiguous_fraction;
  j["silent_ambiguous_fraction"] = s.silent_ambiguous_fraction;
  j["lookup_failed_fraction"] = s.lookup_failed_fraction;
  j["dead_fraction"] = s.dead_fraction;
  j["median_sigma_pos_m"] = value(s.median_sigma_pos_m);
  j["p90_sigma_pos_m"] = value(s.p90_sigma_pos_m);
  j["median_sigma_pos_known_force_m"] = value(s.median_sigma_pos_known_force_m);
  j["median_sigma_force_rel"] = value(s.median_sigma_force_rel);
  j["p90_sigma_force_rel"] = value(s.p90_sigma_force_rel);
  j["mapped_area_fraction"] = s.mapped_area_fraction;
  j["adc_bits"] = s.adc_bits;
  j["full_scale_C"] = s.full_scale_C;
  j["lsb_C"] = s.lsb_C;
  j["lsb_over_noise"] = s.lsb_over_noise;
  j["saturated_fraction"] = s.saturated_fraction;
  j["below_lsb_fraction"] = s.below_lsb_fraction;
  j["electrodes"] = nlohmann::json::array();
  for (const auto& e : s.electrodes) {
    j["electrodes"].push_back({{"name", e.name},
                               {"center_m", e.center_m},
                               {"sensitivity_at_center_C_per_N", value(e.sensitivity_at_center_C_per_N)},
                               {"median_sensitivity_C_per_N", value(e.median_sensitivity_C_per_N)},
                               {"max_charge_C", e.max_charge_C},
                               {"noise_C", e.noise_C},
                               {"effective_noise_C", e.effective_noise_C},
                               {"below_lsb_fraction", e.below_lsb_fraction}});
  }
  return j;
}

// ---------------------------------------------------------------------------------------------
// Layouts as scenes

SyntheticModel synthetic_model_for_scene(const pvdf::Scene& scene) {
  if (scene.electrodes.size() < 3) {
    throw InputError(scene.source + ": " + std::to_string(scene.electrodes.size()) +
                     " electrodes; a layout needs at least 3 to locate a press");
  }
  SyntheticModel m;
  m.names.clear();
  m.centers_m.clear();
  double area = 0;
  for (const auto& e : scene.electrodes) {
    m.names.push_back(e.name);
    m.centers_m.push_back(e.centroid_m());
    area += e.area_m2();
  }
  area /= double(scene.electrodes.size());
  const auto& outline = scene.membrane.outline;
  m.film_radius_m = outline.shape == FilmOutline::Shape::circle ? outline.radius_m : outline.inscribed_radius_m();
  m.draw_angle_rad = scene.material.draw_angle_rad;
  if (scene.material.d31_C_per_N != 0) m.d32_over_d31 = scene.material.d32_C_per_N / scene.material.d31_C_per_N;
  // The model's defaults describe a 2 mm × 2 mm electrode: the charge integrates the stress over
  // the area (∝ area), and the charge peak under the probe is smoothed over the electrode (∝ √area).
  const double ratio = area / 4e-6;
  m.scale_C *= ratio;
  m.core_m *= std::sqrt(ratio);
  return m;
}

ChargeMap synthetic_map_for_scene(const pvdf::Scene& scene, double spacing_m, double force_N, double noise_C) {
  const SyntheticModel model = synthetic_model_for_scene(scene);
  const double rim = scene.probe.radius_m + 1e-3;
  ChargeMap map = build_synthetic_map(model, spacing_m, rim, {force_N}, noise_C);
  // Mask by the real outline (the synthetic grid covers the inscribed circle of other outlines).
  for (std::size_t j = 0; j < map.ny(); ++j) {
    for (std::size_t i = 0; i < map.nx(); ++i) {
      const std::size_t p = j * map.nx() + i;
      if (map.mask[p] && !scene.membrane.outline.contains({map.x_m[i], map.y_m[j]}, rim)) {
        map.mask[p] = 0;
        for (std::size_t f = 0; f < map.nf(); ++f) map.status[map.point(f, j, i)] = std::uint8_t(PointStatus::outside);
      }
    }
  }
  nlohmann::json copy = scene_to_json(scene);
  if (scene.original.contains("name")) copy["name"] = scene.original["name"];
  map.scene_json = copy.dump();
  map.description = "synthetic stand-in for the layout of " + scene.source +
                    " (pvdf::mapping::SyntheticModel: geometry, draw angle, d32/d31 and electrode area only), "
                    "not an FEM result";
  return map;
}

SceneSweep parse_scene_sweep(const std::string& text) {
  const std::size_t eq = text.find('=');
  if (eq == std::string::npos || eq == 0 || eq + 1 == text.size()) {
    throw InputError("scene sweep '" + text + "': expected KEY=START:STEP:STOP, e.g. material.draw_angle_deg=0:15:90");
  }
  SceneSweep s;
  s.key = text.substr(0, eq);
  s.values = pvdf::parse_range(text.substr(eq + 1), "scene sweep of " + s.key, 1000);
  if (s.values.empty()) throw InputError("scene sweep '" + text + "': the range holds no value");
  return s;
}

namespace {

/// The scene with every default written out (so that every key of docs/scene.md exists), with
/// its name and description kept.
nlohmann::json normalized(const nlohmann::json& scene, const std::string& source) {
  const Scene s = parse_scene(scene, source);
  nlohmann::json n = scene_to_json(s);
  for (const char* key : {"name", "description"}) {
    if (scene.contains(key)) n[key] = scene[key];
  }
  return n;
}

std::array<double, 2> rotated(const std::array<double, 2>& p, double c, double s) {
  return {c * p[0] - s * p[1], s * p[0] + c * p[1]};
}

/// Sets the value at a path given as segments ("name", "[3]", "[*]"), recursively.
void set_path(nlohmann::json& node, const std::vector<std::string>& segments, std::size_t at, double value,
              const std::string& key, const std::string& source) {
  if (at == segments.size()) {
    if (node.is_number()) {
      node = value;
    } else if (node.is_array() && !node.empty() && std::all_of(node.begin(), node.end(), [](const nlohmann::json& v) { return v.is_number(); })) {
      for (auto& v : node) v = value;
    } else {
      throw InputError(source + ": scene key " + key + ": the key holds " + std::string(node.type_name()) +
                       ", not a number; name a numeric key (docs/design.md §5)");
    }
    return;
  }
  const std::string& seg = segments[at];
  if (seg.front() == '[') {
    if (!node.is_array()) throw InputError(source + ": scene key " + key + ": " + seg + " indexes a non-array");
    if (seg == "[*]") {
      for (auto& v : node) set_path(v, segments, at + 1, value, key, source);
      return;
    }
    std::size_t idx = 0;
    try {
      idx = std::stoul(seg.substr(1, seg.size() - 2));
    } catch (const std::exception&) {
      throw InputError(source + ": scene key " + key + ": bad index " + seg + "; use [0], [1], ... or [*]");
    }
    if (idx >= node.size()) {
      throw InputError(source + ": scene key " + key + ": index " + seg + " out of range (the array has " +
                       std::to_string(node.size()) + " elements)");
    }
    set_path(node[idx], segments, at + 1, value, key, source);
    return;
  }
  if (!node.is_object() || !node.contains(seg)) {
    std::string known;
    if (node.is_object()) {
      for (auto it = node.begin(); it != node.end(); ++it) known += (known.empty() ? "" : ", ") + it.key();
    }
    throw InputError(source + ": scene key " + key + ": no key '" + seg + "' here" +
                     (known.empty() ? "" : " (keys: " + known + ")") + "; see docs/design.md §5");
  }
  set_path(node[seg], segments, at + 1, value, key, source);
}

std::vector<std::string> split_path(const std::string& key) {
  std::vector<std::string> out;
  std::string cur;
  for (std::size_t i = 0; i < key.size(); ++i) {
    const char c = key[i];
    if (c == '.') {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else if (c == '[') {
      if (!cur.empty()) out.push_back(cur);
      const std::size_t close = key.find(']', i);
      if (close == std::string::npos) throw InputError("scene key " + key + ": unclosed '['");
      out.push_back(key.substr(i, close - i + 1));
      cur.clear();
      i = close;
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  if (out.empty()) throw InputError("scene key: empty");
  return out;
}

/// Moves every electrode so that its centroid goes from c to `centroid + factor·(c − centroid)`.
void scale_layout(nlohmann::json& n, const Scene& s, double factor) {
  double cx = 0, cy = 0;
  for (const auto& e : s.electrodes) {
    cx += e.centroid_m()[0];
    cy += e.centroid_m()[1];
  }
  cx /= double(s.electrodes.size());
  cy /= double(s.electrodes.size());
  for (std::size_t k = 0; k < s.electrodes.size(); ++k) {
    const auto c = s.electrodes[k].centroid_m();
    const double dx = (factor - 1) * (c[0] - cx), dy = (factor - 1) * (c[1] - cy);
    auto& je = n["electrodes"][k];
    if (je.contains("center_m")) {
      je["center_m"] = {c[0] + dx, c[1] + dy};
    } else {
      for (auto& v : je["vertices_m"]) v = {v[0].get<double>() + dx, v[1].get<double>() + dy};
    }
  }
}

}  // namespace

nlohmann::json rotate_scene(const nlohmann::json& scene, double angle_rad, const std::string& source) {
  nlohmann::json n = normalized(scene, source);
  const double quarter = angle_rad / (pi / 2);
  const bool right_angle = std::abs(quarter - std::round(quarter)) < 1e-12;
  double c = std::cos(angle_rad), s = std::sin(angle_rad);
  if (right_angle) {  // exact for multiples of 90°: rotated grids then map node to node
    const long k = ((long(std::llround(quarter)) % 4) + 4) % 4;
    c = k == 0 ? 1 : k == 2 ? -1 : 0;
    s = k == 1 ? 1 : k == 3 ? -1 : 0;
  }
  const double angle_deg = angle_rad * 180.0 / pi;
  auto rot = [&](nlohmann::json& p) {
    const auto r = rotated({p[0].get<double>(), p[1].get<double>()}, c, s);
    p = {r[0], r[1]};
  };
  auto wrap = [](double deg) {
    double w = std::fmod(deg, 360.0);
    if (w > 180.0) w -= 360.0;
    if (w <= -180.0) w += 360.0;
    return w;
  };
  for (auto& e : n["electrodes"]) {
    if (e.contains("center_m")) rot(e["center_m"]);
    if (e.contains("vertices_m")) {
      for (auto& v : e["vertices_m"]) rot(v);
    }
    if (e.contains("angle_deg")) e["angle_deg"] = wrap(e["angle_deg"].get<double>() + angle_deg);
  }
  n["material"]["draw_angle_deg"] = wrap(n["material"]["draw_angle_deg"].get<double>() + angle_deg);
  for (auto& l : n["loads"]) {
    if (l.contains("position_m")) rot(l["position_m"]);
  }
  auto& mem = n["membrane"];
  const std::string shape = mem["shape"].get<std::string>();
  const bool odd_quarter = right_angle && (((long(std::llround(quarter)) % 2) + 2) % 2) == 1;
  if (shape == "polygon") {
    for (auto& v : mem["vertices_m"]) rot(v);
  } else if (shape == "rectangle" || shape == "ellipse") {
    const char* key = shape == "rectangle" ? "size_m" : "semi_axes_m";
    if (right_angle) {
      if (odd_quarter) mem[key] = {mem[key][1], mem[key][0]};
    } else if (shape == "rectangle") {
      const double w = mem[key][0].get<double>() / 2, h = mem[key][1].get<double>() / 2;
      nlohmann::json vertices = nlohmann::json::array();
      for (const auto& corner : {std::array<double, 2>{-w, -h}, {w, -h}, {w, h}, {-w, h}}) {
        const auto r = rotated(corner, c, s);
        vertices.push_back({r[0], r[1]});
      }
      mem.erase(key);
      mem["shape"] = "polygon";
      mem["vertices_m"] = vertices;
    } else {
      throw InputError(source + ": an elliptic outline can be rotated only by multiples of 90 degrees, not " +
                       num(angle_deg) + "; use a polygon outline");
    }
  }
  parse_scene(n, source + " rotated by " + num(angle_deg) + " deg");  // validates
  return n;
}

nlohmann::json set_scene_key(const nlohmann::json& scene, const std::string& key, double value,
                             const std::string& source) {
  if (!std::isfinite(value)) throw InputError(source + ": scene key " + key + " = " + num(value) + " must be finite");
  const std::string what = source + " with " + key + " = " + num(value);
  if (key == "@rotation_deg") return rotate_scene(scene, value * pi / 180.0, source);
  nlohmann::json n = normalized(scene, source);
  if (key == "@layout_scale" || key == "@layout_radius_m") {
    const Scene s = parse_scene(n, source);
    if (s.electrodes.empty()) throw InputError(source + ": scene key " + key + ": the scene has no electrodes");
    double factor = value;
    if (key == "@layout_radius_m") {
      double cx = 0, cy = 0, mean = 0;
      for (const auto& e : s.electrodes) {
        cx += e.centroid_m()[0] / double(s.electrodes.size());
        cy += e.centroid_m()[1] / double(s.electrodes.size());
      }
      for (const auto& e : s.electrodes) mean += std::hypot(e.centroid_m()[0] - cx, e.centroid_m()[1] - cy);
      mean /= double(s.electrodes.size());
      if (!(mean > 0)) throw InputError(source + ": scene key @layout_radius_m: all electrodes share one centre");
      factor = value / mean;
    }
    if (!(factor > 0)) throw InputError(what + ": the scale factor must be > 0");
    scale_layout(n, s, factor);
  } else if (key == "@electrode_size_m") {
    if (!(value > 0)) throw InputError(what + ": the electrode size must be > 0 (m)");
    const Scene s = parse_scene(n, source);
    for (std::size_t k = 0; k < s.electrodes.size(); ++k) {
      auto& je = n["electrodes"][k];
      const std::string shape = je["shape"].get<std::string>();
      if (shape == "rectangle") {
        je["size_m"] = {value, value};
      } else if (shape == "circle") {
        je["radius_m"] = value / 2;
      } else {  // polygon: scaled about its centroid to the area of a square of side `value`
        const auto c = s.electrodes[k].centroid_m();
        const double f = value / std::sqrt(s.electrodes[k].area_m2());
        for (auto& v : je["vertices_m"]) {
          v = {c[0] + f * (v[0].get<double>() - c[0]), c[1] + f * (v[1].get<double>() - c[1])};
        }
      }
    }
  } else if (!key.empty() && key.front() == '@') {
    throw InputError(source + ": scene key " + key +
                     ": unknown derived key; known: @layout_scale, @layout_radius_m, @rotation_deg, @electrode_size_m");
  } else {
    set_path(n, split_path(key), 0, value, key, source);
  }
  parse_scene(n, what);  // validates the edited scene
  return n;
}

std::string named_option(const OptionNaming& naming, const std::string& key, const std::string& value) {
  if (naming) return naming(key, value);
  return value.empty() ? key : key + " = " + value;
}

void check_design_options(const DesignOptions& o, const OptionNaming& naming) {
  const auto name = [&naming](const std::string& key, double value) { return named_option(naming, key, pvdf::format_g(value)); };
  const auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  if (!(o.force_N > 0) || !in(o.force_N, 0, 1e4)) {
    throw InputError(name("force_N", o.force_N) + " must lie in (0, 1e4] N (the evaluated press, pushing), e.g. 1");
  }
  if (!(o.min_force_N > 0) || !in(o.min_force_N, 0, 1e4)) {
    throw InputError(name("min_force_N", o.min_force_N) + " must lie in (0, 1e4] N (the smallest force served), e.g. 0.25");
  }
  if (!in(o.max_force_N, 0, 1e4) || !(o.min_force_N < o.max_force_N)) {
    throw InputError(name("min_force_N", o.min_force_N) + " and " + name("max_force_N", o.max_force_N) +
                     ": need 0 < min_force_N < max_force_N <= 1e4 (N)");
  }
  for (std::size_t k = 0; k < o.noise_C.size(); ++k) {
    const std::string key = o.noise_C.size() == 1 ? "noise_C" : "noise_C[" + std::to_string(k) + "]";
    if (!(o.noise_C[k] > 0 && o.noise_C[k] < 1e-6)) {
      throw InputError(name(key, o.noise_C[k]) + " must lie in (0, 1e-6) C (a 1-sigma charge noise; 0.05 pC = 5e-14 C)");
    }
  }
  if (!(o.target_m > 0) || !in(o.target_m, 0, 1)) {
    throw InputError(name("target_m", o.target_m) + " must lie in (0, 1] m, i.e. (0, 1000] mm (the position-error target), e.g. 0.0005 m = 0.5 mm");
  }
  if (o.adc_bits < 0 || o.adc_bits == 1 || o.adc_bits > 32) {
    throw InputError(named_option(naming, "adc_bits", std::to_string(o.adc_bits)) + ": use 0 (ideal) or 2..32 bits");
  }
  if (!in(o.full_scale_C, 0, 1e-3)) {
    throw InputError(name("full_scale_C", o.full_scale_C) + " must lie in [0, 1e-3] C (0 = 1.25 x the largest charge at the largest force)");
  }
  if (!in(o.ambiguity_min_distance_m, 0, 1)) {
    throw InputError(name("ambiguity_min_distance_m", o.ambiguity_min_distance_m) + " must lie in [0, 1] m (0 = the target)");
  }
}

}  // namespace pvdf::mapping
