// The deployment lookup: from the charges of a pressed sensor to where and how hard it was
// pressed, with a 1-σ uncertainty and honest flags. Links no deal.II; thread-safe; no
// allocation in locate().
#pragma once

#include "pvdf/mapping/interpolant.hpp"
#include "pvdf/mapping/map.hpp"

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace pvdf::mapping {

namespace detail {
struct LmPoint;  // Levenberg–Marquardt's working point (locator_fit.cpp)
}

/// Flags of a Location (bit mask). A result with outside_map, no_press or saturated carries no position.
namespace flag {
inline constexpr std::uint32_t outside_map = 1u << 0;        ///< best fit is held by the map's edge or force range and does not fit within noise (or only a vague fallback fit does, docs/lookup.md §1.7)
inline constexpr std::uint32_t ambiguous = 1u << 1;          ///< two distinct positions fit within noise (alternative reported)
inline constexpr std::uint32_t no_press = 1u << 2;           ///< charges are at the noise level: nothing pressed
inline constexpr std::uint32_t poor_fit = 1u << 3;           ///< inside the map but χ² above the limit (model/calibration mismatch?)
inline constexpr std::uint32_t force_extrapolated = 1u << 4; ///< force outside the map's levels (scaling law F^(2/3) used)
inline constexpr std::uint32_t scaling_assumed = 1u << 5;    ///< single-level map: force from the F^(2/3) law
inline constexpr std::uint32_t not_converged = 1u << 6;      ///< Levenberg–Marquardt hit its iteration cap
inline constexpr std::uint32_t ill_conditioned = 1u << 7;    ///< JᵀJ singular (e.g. on a symmetry line): σ's reported as 0
inline constexpr std::uint32_t saturated = 1u << 8;          ///< the front end clipped (ADC at its limits) or lost data: charges unknown, not located
}  // namespace flag

/// "ok" or the set names joined by '|', e.g. "ambiguous|force_extrapolated".
std::string flags_text(std::uint32_t flags);

/// Settings of the lookup (public members with defaults).
struct LocatorOptions {
  /// 1-σ charge noise per electrode (C); empty = the map's /electrodes/noise_C. One value = all.
  std::vector<double> noise_C;
  bool use_calibration = true;        ///< apply the map's /calibration group when present
  int max_iterations = 40;            ///< Levenberg–Marquardt iterations per start
  int max_starts = 6;                 ///< LM runs from this many distinct coarse candidates at most (≤ 8)
  /// no_press when the RMS signal-to-noise √(Σ(q_k/σ_k)²/n) is below this.
  double no_press_snr = 3.0;
  /// χ² = Σ((Q_k − q_k)/σ_k)² above which a fit is "not within noise"; 0 = automatic:
  /// ν + 5·√(2·max(ν, 1)) + 4 with ν = n − 3 degrees of freedom (n − 2 with a known force),
  /// ≈ 11 for three electrodes.
  double chi2_limit = 0.0;
  /// Two fits within noise are distinct solutions (→ ambiguous) when they are more than 3 σ
  /// apart (Mahalanobis distance in (x, y) under either one's covariance) — or, where the
  /// position covariance is singular, when the misfit rises above the χ² limit between them.
  /// A value > 0 here also merges solutions closer than this × grid spacing (0 = off).
  double ambiguity_separation_cells = 0.0;
  /// Plausible force range (N): solutions outside it are not accepted (the fit is held at the
  /// bound and then flagged outside_map if it does not fit within noise). 0 = automatic: half
  /// the lowest to twice the highest force level of the map (a one-level map included). The
  /// range is also the prior of the solutions' probabilities (uniform in F over it).
  /// With unknown force, three charges often have a second exact solution (a far press at a
  /// high force looks like a near press at a low one, docs/lookup.md §2): the range removes
  /// the implausible one.
  double min_force_N = 0.0;
  double max_force_N = 0.0;
  /// Known force (N), e.g. from a force transducer or a fixed test load (seed 001 used 1 N):
  /// only (x, y) are fitted, the problem is overdetermined with three electrodes and the
  /// multiple solutions of the unknown-force case mostly disappear. 0 = force unknown.
  double known_force_N = 0.0;
  /// Coarse search: number of bins per axis of the charge-direction table (0 = automatic).
  int direction_bins = 0;
  /// Valley σ's (docs/lookup.md §1.6): a solution whose linearised 1-σ along its weak position
  /// direction exceeds this many grid cells gets its σ's from the profile of χ² along that
  /// direction (Δχ² = 1, the other parameters re-fitted) where that is wider, and its
  /// probability the same widening. 0 = linearised σ's only.
  double valley_sigma_cells = 0.2;
  /// The map's error between its nodes and force levels, estimated from the map when the
  /// Locator is built (estimate_interpolation_error, docs/lookup.md §1.10), joins the charge
  /// noise with the map's per-node estimate (ChargeMap::estimated_charge_error_C): the fits'
  /// weights, χ², flags, σ's and probabilities use σ_k² + e_k². false = the per-node estimate
  /// alone (the lookup before version 5: σ's that cover the noise, not the map's error).
  bool interpolation_error = true;
  /// The map's error between nodes and levels as it is correlated between the electrodes
  /// (docs/lookup.md §1.11): its common relative scale of all charges (which a free force
  /// absorbs without moving the position) enters the noise model as one shared term
  /// σ_α²·Q Qᵀ, the rest per electrode. false = every share independent per electrode (the
  /// lookup before r12: with the force unknown, σ's too wide, docs/lookup.md §7c).
  bool correlated_map_error = true;
};

/// A located press. Values are SI; σ's are 1-σ from the charge-noise model, (JᵀWJ)⁻¹.
struct Location {
  double x_m = 0, y_m = 0, force_N = 0;
  double residual = 0;                ///< χ = √Σ((Q_k − q_k)/σ_k)² at the solution (noise units)
  double sigma_x_m = 0, sigma_y_m = 0, sigma_F_N = 0;
  /// How much of the σ's is the map's own error rather than the charge noise: the mean over the
  /// electrodes of e_k²/(σ_k² + e_k²) at the answer (e: the map's error there, docs/lookup.md §1.10;
  /// σ: the charge noise). 0 = the noise alone (or a map without errors); near 1 = a finer map
  /// would narrow the answer, a quieter front end would not.
  double map_error_share = 0;
  std::uint32_t flags = 0;
  int iterations = 0;                 ///< LM iterations of the reported solution
  int n_starts = 0;                   ///< LM runs made
  int n_solutions = 0;                ///< distinct positions that fit within noise (> 1: ambiguous); all are reported
  /// Most solutions one lookup reports (the main answer and up to seven alternatives).
  static constexpr int max_solutions = 8;
  /// Posterior probability of the main answer among the n_solutions reported (docs/lookup.md
  /// §1.8: Gaussian charge noise, prior uniform over the map's area and the force range). The
  /// main answer is the most probable solution; 1 when it is the only one.
  double probability = 0;
  /// With `ambiguous`: the next most probable other solution (= alternatives[0]).
  struct Alternative {
    double x_m = 0, y_m = 0, force_N = 0, residual = 0, sigma_x_m = 0, sigma_y_m = 0, sigma_F_N = 0;
    double probability = 0;  ///< posterior probability of this solution (the n_solutions sum to 1)
  } alternative;
  /// With `ambiguous`: every other solution, most probable first (n_alternatives = n_solutions − 1).
  std::array<Alternative, max_solutions - 1> alternatives{};
  int n_alternatives = 0;
  /// With outside_map: where the best fit was held (x_m, y_m, force_N) by the map's edge or the
  /// force range — not an answer, a start for the next sample of a stream (Tracker). Else 0.
  std::array<double, 3> held{};
  bool has_position() const { return (flags & (flag::outside_map | flag::no_press | flag::saturated)) == 0; }
};

/// Map → press lookup: coarse search in a table of charge directions, then Levenberg–Marquardt
/// in (x, y, ln F) on the smooth interpolant, from up to max_starts distant candidates.
///   Locator locator(map);  Location r = locator.locate(q);
class Locator {
 public:
  /// Precomputes the interpolant and the coarse table. Throws InputError for < 3 electrodes,
  /// bad noise values, or a calibration of the wrong size.
  explicit Locator(const ChargeMap& map, const LocatorOptions& options = {});

  /// Locates one press from the measured charges q[0..n_electrodes) (C). Thread-safe, no
  /// allocation. Non-finite charges give no_press|outside_map flags, never NaN.
  Location locate(const double* charges_C) const;
  Location locate(const std::vector<double>& charges_C) const { return locate(charges_C.data()); }
  /// Same with the force known (N; e.g. a force transducer reading): fits (x, y) only.
  /// A non-positive or non-finite force gives outside_map.
  Location locate(const double* charges_C, double known_force_N) const;
  Location locate(const std::vector<double>& charges_C, double known_force_N) const {
    return locate(charges_C.data(), known_force_N);
  }

  /// Fits from the given starts only — (x_m, y_m, force_N) each, e.g. the previous sample's
  /// answers of a tracked press — with no coarse search, no fold-twin search and no fallback:
  /// the same fits, choice, flags and σ's as locate() otherwise (force known when the options
  /// say so). `ambiguous` is only as complete as the starts: a solution no start leads to is not
  /// reported. Starts off the map or with a non-positive force are skipped (at most 8 are
  /// fitted); none left gives outside_map. Thread-safe, no allocation.
  Location locate_from(const double* charges_C, const std::array<double, 3>* starts, int n_starts) const;

  /// The full search with hints — (x_m, y_m, force_N) each, e.g. the last sample's answer of a
  /// tracked stream (docs/lookup.md §1.9): locate()'s coarse search, fits and fold twins; only
  /// when none of them fits within noise are the hints fitted, and if every hint's fit is held
  /// by the map's edge or the force range outside noise the answer is outside_map without
  /// locate()'s angular fallback (starts at cell centres). Otherwise locate()'s answer.
  /// `held`: the hints are the last sample's held fit (an outside_map answer), not solutions;
  /// then charges that no cell's direction model reaches (the coarse search has no start at
  /// all) are outside_map at once, held at hints[0], without any fit (docs/lookup.md §1.9).
  /// Thread-safe, no allocation.
  Location locate_near(const double* charges_C, const std::array<double, 3>* hints, int n_hints,
                       bool held = false) const;

  /// The map's (calibrated, if enabled) charges for a press at (x, y) with force F; false outside.
  bool predict(double x_m, double y_m, double force_N, double* charges_C) const;
  /// The map's error (C, one per electrode, calibrated like predict()) that the lookup adds to
  /// the charge noise for a press at (x, y) with force F: the per-node estimate and the
  /// interpolation error between nodes and levels in quadrature (docs/lookup.md §1.10); 0 when
  /// the map states none and interpolation_error is off. False off the usable cells.
  bool charge_error(double x_m, double y_m, double force_N, double* error_C) const;

  std::size_t n_electrodes() const { return ne_; }
  const std::vector<std::string>& electrode_names() const { return names_; }
  const std::vector<double>& noise_C() const { return noise_; }
  const MapInterpolant& interpolant() const { return interp_; }
  double chi2_limit() const { return chi2_limit_; }
  bool calibrated() const { return calibrated_; }

 private:
  struct Query;
  // ---- construction (locator_tables.cpp), in this order
  struct CellLevelModel;  ///< one cell's local direction model at one force level
  struct DirectionRanges {
    double phi_lo, phi_hi, theta_lo, theta_hi;
  };
  /// Noise, calibration, χ² limits and the force range from the options.
  void configure(const ChargeMap& map, const LocatorOptions& options);
  /// cells_, cell_dir_, cell_norm_, cell_radius2_, cell_xy_; returns each cell's box of
  /// direction keys (φ lo, hi, θ lo, hi) and their overall range.
  std::vector<std::array<double, 4>> build_coarse_table(const ChargeMap& map, DirectionRanges& ranges);
  /// One cell's model at one level (ln F = lf).
  CellLevelModel cell_level_model(std::size_t cell, double lf) const;
  /// Every cell's model at every level ([cell][level]), level_log_, cell_slot_, cell_log_norm_,
  /// and per cell the linear model's worst squared error at its corners.
  std::vector<CellLevelModel> build_cell_models(const ChargeMap& map, std::vector<double>& linear_error2);
  void build_scan_table(const std::vector<CellLevelModel>& models, const std::vector<double>& linear_error2);
  void build_model_table(const std::vector<CellLevelModel>& models);
  void mark_fold_cells(const std::vector<CellLevelModel>& models);
  void build_direction_bins(const std::vector<std::array<double, 4>>& boxes, const DirectionRanges& ranges);
  /// The map's own charge error: ChargeMap::estimated_charge_error_C when stored, and the
  /// interpolation error estimated from the map (options.interpolation_error).
  void set_map_error(const ChargeMap& map);

  struct Fit {
    double x = 0, y = 0, l = 0, chi2 = 0;
    std::array<double, 3> sigma{0, 0, 0};
    std::array<double, 6> jtj{};  ///< weighted JᵀJ at the end point (upper triangle: 00 01 02 11 12 22)
    int iterations = 0;
    bool converged = false, blocked = false, ok = false, singular = false, duplicate = false;
    bool vague = false;     ///< within noise, but the charges do not place it (without_position)
    bool fallback = false;  ///< started by the angular fallback (no coarse-search start fitted within noise)
    double log_widen = 0;   ///< ln(valley half-width / linearised σ) along the weak direction (valley_sigma)
    /// The model's charges at the end point (the last evaluation, carried along the last step
    /// taken unevaluated by its Jacobian): χ² under the map's own error needs no evaluation.
    std::array<double, max_electrodes> model{};
    /// The Jacobian rows at the last evaluation (not zeroed: written with the end point) and the
    /// map's own error² at the end point (set by add_map_error when has_variance).
    std::array<std::array<double, 3>, max_electrodes> grad;
    std::array<double, max_electrodes> variance;
    /// The map's common-scale error² at the end point per electrode, σ_α²·model_k² (C², §1.11):
    /// the noise model is diag(σ_k² + variance_k) + u uᵀ, u_k = σ_α·model_k = sign(model_k)·√shared2_k.
    std::array<double, max_electrodes> shared2{};
    bool has_shared = false;
    bool has_variance = false;
  };
  Fit levenberg_marquardt(const double* q, const double* inv_sigma, double x, double y, double l, bool fixed_force,
                          double log_lo, double log_hi, const Fit* found, int n_found) const;
  /// The model, χ² and normal equations at (x, y, ln F) into a working point (locator_fit.cpp);
  /// false off the usable cells.
  bool lm_evaluate(double x, double y, double l, bool fixed_force, const double* q, const double* w,
                   detail::LmPoint& point) const;
  /// A nearly undamped Gauss–Newton step small enough to be taken without an evaluation.
  bool final_step_ok(double x, double y, double l, const std::array<double, 3>& step, double lambda, double log_lo,
                     double log_hi) const;
  /// The minimum at (x, y, l) is held by the map's edge or the force range.
  bool held_by_edge(const std::array<double, 6>& JtJ, const std::array<double, 3>& Jtr, double x, double y, double l,
                    bool fixed_force, double log_lo, double log_hi) const;
  /// Fills fit.sigma / fit.singular from fit.jtj (only for the fits that are reported).
  void covariance(Fit& fit, const Query& query) const;
  /// Widens fit.sigma to the profile of χ² along the weak position direction where that is
  /// wider (locator_valley.cpp); returns the posterior volume's widening, ln ≥ 0.
  double valley_sigma(const Query& query, Fit& fit) const;
  /// The profile point at offset t along the unit direction v from the fit: the offset s across
  /// and ln F re-fitted from (s, l); χ² there. False off the map.
  bool valley_point(const Query& query, const double* weights, const Fit& fit, const std::array<double, 2>& v, double t,
                    double& s, double& l, double& chi2) const;
  /// The weighted JᵀJ behind the reported σ's: fit.jtj, or with the map's own error added to
  /// the charge noise where the map stores one.
  std::array<double, 6> reported_jtj(const Fit& fit, const Query& query) const;
  /// Replaces each fit's χ² by the one under the charge noise plus the map's own error.
  void add_map_error(const Query& query, std::array<Fit, 8>& fits, int n_fits) const;
  /// The map's charge error at (x, y, ln F) in two parts (§1.11): per electrode the square of the
  /// part independent between electrodes (C²), and the square of the common relative scale of
  /// all charges, σ_α² (unitless; 0 without correlated_map_error): the error's covariance is
  /// diag(variance_C2) + σ_α² Q Qᵀ, Q the map's charges there. False off the grid.
  /// `total_C2` (optional): per electrode the total e_k² before the split.
  bool map_variance_at(double x, double y, double l, double* variance_C2, double& scale2,
                       double* total_C2 = nullptr) const;
  Location locate_impl(const double* charges_C, bool fixed_force, double log_known_force,
                       const std::array<double, 3>* hints = nullptr, int n_hints = 0, bool held = false) const;
  /// A query prepared for fitting: calibration undone, weights, unit direction, force bounds.
  struct Query {
    std::array<double, max_electrodes> q, w, q_unit;  ///< entries 0..ne−1 are set by prepare()
    double q_norm = 0, log_q_norm = 0, noise2 = 0, log_lo = 0, log_hi = 0, limit = 0, log_known_force = 0;
    bool fixed_force = false;
  };
  /// False (with the answer's flags in `early_flags`: no_press, or outside_map|no_press for
  /// non-finite charges) when there is nothing to fit.
  bool prepare(const double* charges_C, bool fixed_force, double log_known_force, Query& query,
               std::uint32_t& early_flags) const;
  /// Fits the fold twins of the fits within noise (fold-prone cells only); returns the new count.
  int add_fold_twins(const Query& query, std::array<Fit, 8>& fits, int n_fits) const;
  /// Choice, flags, covariance and alternatives from the fits.
  Location finish(const Query& query, std::array<Fit, 8>& fits, int n_fits) const;
  /// A fit of the angular fallback within noise that still carries no usable position
  /// (docs/lookup.md §1.7): its force sits on the plausible range's bound and its 1-σ position
  /// uncertainty exceeds one grid cell, or the uncertainty exceeds half the map's extent.
  /// Needs fit.sigma (covariance).
  bool without_position(const Fit& fit, const Query& query) const;
  /// Position, force, σ's and flags of the main answer from its fit (σ's computed).
  void fill_main(const Query& query, const Fit& fit, Location& out) const;
  /// The best fit (index `best`, within noise) and every other fit within noise that is a
  /// distinct solution (group[0] = best); returns their number.
  int distinct_solutions(const Query& query, const std::array<Fit, 8>& fits, int n_fits, int best,
                         std::array<int, 8>& group) const;
  /// ln of a solution's unnormalized posterior mass (Laplace approximation, docs/lookup.md §1.8).
  double log_posterior_weight(const Query& query, const Fit& fit) const;
  bool distinct_minima(const double* q, const double* w, const Fit& a, const Fit& b, double separation,
                       double limit) const;
  struct Shortlist {
    static constexpr int capacity = 16;
    std::array<std::size_t, capacity> cell{};
    std::array<double, capacity> score{};
    int n = 0;
  };
  /// A start predicted by the linearized direction of one cell: position, ln F, residual².
  struct Start {
    double x = 0, y = 0, l = 0, score = 0;
  };
  struct StartList {
    static constexpr int capacity = 8;
    std::array<Start, capacity> start{};
    int n = 0;
  };
  /// Fits the hints no fit has ended near (within half a cell); returns the new count.
  int add_hint_fits(const Query& query, const std::array<double, 3>* hints, int n_hints, std::array<Fit, 8>& fits,
                    int n_fits) const;
  /// Coarse search: bins of the direction table → cells whose linearized direction reaches the
  /// query inside (or next to) the cell → distinct starts, best first. Returns false when no
  /// cell can produce the direction (then the old angular shortlist is used). The query's own
  /// bin is scanned, and when it has no start the ring of its 8 neighbours (own_bin_only: not).
  bool predicted_starts(const double* q_unit, double log_q_norm, double noise2, bool fixed_force, double log_force,
                        double log_lo, double log_hi, StartList& starts, bool own_bin_only = false) const;
  /// The compact model of the cell holding (x, y), blended between the force levels around l,
  /// with the point's offset from the cell centre (cell units). False off the usable cells.
  struct CellModel {
    std::size_t cell = 0;
    double dt = 0, ds = 0;
    std::array<double, 6 * max_electrodes + 6> v;  ///< d, Jt, Js, Htt, Hts, Hss (ne each), ln|G| terms (6)
  };
  bool cell_model(double x, double y, double l, CellModel& m) const;
  /// Index into cells_ of the usable cell holding (x, y); −1 off the map or in an unusable cell.
  std::int32_t slot_at(double x, double y) const {
    const double u = (x - interp_.x0()) * interp_.inv_hx(), v = (y - interp_.y0()) * interp_.inv_hy();
    if (!(u >= 0 && v >= 0 && u < double(interp_.nx() - 1) && v < double(interp_.ny() - 1))) return -1;
    return cell_slot_[std::size_t(v) * (interp_.nx() - 1) + std::size_t(u)];
  }
  /// Moves a start to the solution of the quadratic direction model of the cell that holds it
  /// (two passes: the point may move into a neighbour), with the force from |q|. No evaluation
  /// of the interpolant; leaves the start as it is where the model has no solution nearby.
  void refine_start(const double* q_unit, double log_q_norm, bool fixed_force, double log_lo, double log_hi,
                    Start& start) const;
  /// Starts for a fold's twin of a solution: guesses of the other zero of its cell's quadratic
  /// direction model along the weak direction, less than 1.5 cells away (0, 1 or 2 of them).
  int fold_twins(const Fit& fit, std::array<Start, 2>& twins) const;
  void coarse_candidates(const double* q_unit, double noise2, Shortlist& list) const;
  void scan_cells(const std::uint32_t* begin, const std::uint32_t* end, const double* q_unit, double noise2,
                  Shortlist& list) const;

  MapInterpolant interp_;
  std::size_t ne_ = 0;
  std::vector<std::string> names_;
  std::vector<double> noise_;
  std::vector<double> gain_, offset_;
  /// The map's own charge error per usable cell j·(nx − 1) + i, level and electrode: four shares
  /// (node estimate, between nodes, between level f and f + 1, beyond the end level per unit
  /// ln F) at the cell's four corners (i, j), (i+1, j), (i, j+1), (i+1, j+1); C at the level's
  /// force, float (empty: none; map_variance_at combines them).
  std::vector<float> map_error_;
  /// With correlated_map_error, per usable cell and level, at the four corners: the fraction ρ of
  /// each share's variance that is a common relative scale of all charges (between nodes,
  /// between level f and f + 1, beyond the end level; 12 floats in [0, 1]), then that scale α
  /// itself (12 floats, unitless; beyond the levels per unit ln F); §1.11.
  std::vector<float> map_scale_;
  bool calibrated_ = false;
  LocatorOptions options_;
  double chi2_limit_ = 0, chi2_limit_free_ = 0, chi2_limit_fixed_ = 0;
  bool single_level_ = false;
  double log_force_lo_ = -69, log_force_hi_ = 69;
  bool fixed_force_ = false;

  // Coarse table: per usable cell, the unit direction of G at its centre (mean over levels),
  // the mean |G| and the squared angular radius of the cell; bins of (φ, θ) → cell lists.
  std::vector<std::size_t> cells_;          ///< cell index j*(nx−1)+i of usable cells
  std::vector<double> cell_dir_;            ///< [cell][ne]
  std::vector<double> cell_norm_;           ///< |G| at the centre (C/N^p), mean over levels
  std::vector<double> cell_radius2_;        ///< max 1 − (ĉ·n̂)² over corners and levels
  std::vector<std::array<double, 2>> cell_xy_;
  // (The constructor's working tables — per cell and level the linear direction model d, J, P,
  // ln |G| and its gradient, and the second derivatives — are condensed into model_ and scan_.)
  /// The same per cell and level as float rows of model_stride_ (what locate() reads): d, Jt, Js,
  /// Htt, Hts, Hss (ne each), then ln |G| and its derivatives t, s, tt, ts, ss.
  std::vector<float> model_;
  std::size_t model_stride_ = 0;
  std::vector<std::int32_t> cell_slot_;     ///< grid cell j*(nx−1)+i → index into cells_, −1 if none
  std::vector<std::uint8_t> cell_fold_;     ///< per cell: a fold of the direction map passes within ~1 cell
  std::vector<double> level_log_;           ///< ln of the map's force levels
  std::vector<double> cell_log_norm_;       ///< ln of the mean |G| over levels (first guess of ln F)
  int bins_ = 0;
  double phi0_ = 0, phi1_ = 1, theta0_ = 0, theta1_ = 1;
  std::vector<std::uint32_t> bin_start_;    ///< CSR: bin b holds bin_cells_[bin_start_[b] .. bin_start_[b+1])
  std::vector<std::uint32_t> bin_cells_;    ///< indices into cells_
  std::vector<std::uint32_t> bin_split_;    ///< per bin: entries before it can predict a start (the rest: fallback only)
  /// Per cell (stride scan_stride_, float: small enough to stay in cache), the coarse search's
  /// whole model: the middle level's direction d, the rows of its inverse P (t, then s), its
  /// Jacobian J (t, then s columns), ∂d/∂ln F across the levels (secant); then that level's ln F,
  /// the cell's mean ln |G|, ln |G| at the centre with its gradient (t, s) and ∂/∂ln F, the
  /// largest squared error of this model at the corners and levels, and the largest Newton step
  /// (cell units) taken without a new evaluation: from the curvature ratio κ = |H| / σ_min(J),
  /// the error κ δ² / 2 it leaves below 1e-4 cell.
  std::vector<float> scan_;
  std::size_t scan_stride_ = 0;
};

/// The map error the lookup carries at a press (Locator::charge_error: node estimate and the error
/// between nodes and force levels, in quadrature, or a map's stored totals), relative to that
/// press's largest charge, over 5 x 5 points in every usable cell, at every force level and half
/// way (in ln F) between consecutive levels: its median, 90th percentile and largest value. What a
/// map states as its total error for a user of the lookup (`map` prints it; MapReport). NaN where
/// no lookup can be built (fewer than three electrodes, no usable cell).
struct LookupErrorSummary {
  double median = std::numeric_limits<double>::quiet_NaN();
  double p90 = std::numeric_limits<double>::quiet_NaN();
  double max = std::numeric_limits<double>::quiet_NaN();
  std::size_t n_points = 0;  ///< points sampled (inside usable cells, at every level)
};
LookupErrorSummary lookup_error_summary(const ChargeMap& map);

}  // namespace pvdf::mapping
