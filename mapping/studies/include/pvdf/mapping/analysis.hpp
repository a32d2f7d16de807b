// Analyses of a charge map against seed 001: charge against distance along rays from each
// electrode with the power-law fit of eq. 6 (Fig. 7), and FEM map against measured charges (Fig. 12).
#pragma once

#include "pvdf/mapping/calibration.hpp"
#include "pvdf/mapping/interpolant.hpp"
#include "pvdf/mapping/map.hpp"

#include <nlohmann/json.hpp>

#include <cstddef>
#include <string>
#include <vector>

namespace pvdf::mapping {

/// The film's draw direction (material axis 1) in the map's frame (rad), read from the map's
/// scene copy (`material.draw_angle_deg`, or `synthetic_model.draw_angle_rad`); 0 when absent.
double map_draw_angle_rad(const ChargeMap& map);

// ---------------------------------------------------------------------------------------------
// Charge against distance (seed 001 §2.4 mapping rays, Fig. 7, eq. 6)

/// Settings of the ray analysis (public members with defaults).
struct RayOptions {
  double angle_step_deg = 10.0;  ///< rays at β = 0, step, 2·step, ... < 360° from the draw direction
  std::vector<double> beta_deg;  ///< explicit ray angles (deg) instead of the step, e.g. {45, 65, 85} (Fig. 12)
  double d_min_m = 3.0e-3;       ///< first sample: the 2 mm electrode and the 2 mm probe footprint stay apart
  double d_max_m = 20.0e-3;      ///< last sample (a ray that leaves the map earlier stops there)
  int n_samples = 24;            ///< samples per ray, equally spaced in ln d (equal weight per decade in the fit)
  double force_N = 1.0;          ///< press force (seed 001: 1 N peak)
  int min_points = 6;            ///< fewer usable samples (inside the map, Q > 0) → the ray is not fitted
};

/// One ray: the sampled charge of one electrode along a straight line from its centre, and the
/// least-squares fit of ln Q = ln C1 + C2·ln(d / 1 mm) over the usable samples.
struct RayChargeFit {
  std::size_t electrode = 0;
  double beta_deg = 0;                ///< angle from the draw direction, counter-clockwise (deg)
  std::vector<double> d_m;            ///< distances of the samples inside the map (m)
  std::vector<double> charge_C;       ///< the electrode's charge there (C), same length
  int n_used = 0;                     ///< samples with Q > 0 used in the fit
  int n_nonpositive = 0;              ///< samples inside the map with Q ≤ 0 (not usable in log-log)
  bool fitted = false;
  std::string reason;                 ///< why not fitted (empty when fitted)
  double C1_C = 0;                    ///< Q(d) = C1·(d / 1 mm)^C2: the fitted law's charge at d = 1 mm (C)
  double C2 = 0;                      ///< exponent of eq. 6 (negative: the charge decays)
  double r_squared = 0;               ///< coefficient of determination of the fit in ln Q
  double max_relative_deviation = 0;  ///< max |Q_fit/Q − 1| over the used samples
};

/// Summary of one electrode's rays: the decay exponent n = −C2 against seed 001's 0.58–1.0.
struct RayElectrodeSummary {
  std::string name;
  int n_rays = 0, n_fitted = 0;
  double min_decay_exponent = 0, median_decay_exponent = 0, max_decay_exponent = 0;
  int n_in_paper_range = 0;           ///< fitted rays with 0.58 ≤ −C2 ≤ 1.0
  double min_r_squared = 0;
};

struct RayAnalysis {
  RayOptions options;
  double draw_angle_rad = 0;
  std::vector<RayChargeFit> rays;                      ///< electrode-major, then β ascending
  std::vector<RayElectrodeSummary> electrodes;   ///< [ne]
};

/// Least-squares fit of ln y = a + b·ln(x / x_ref) over points with x > 0 and y > 0.
/// Returns {C1 = exp(a), C2 = b, R² (in ln y), max |fit/y − 1|}; needs ≥ 2 distinct x.
/// Throws InputError when fewer than 2 usable points or all x equal.
struct PowerLawFit {
  double C1 = 0, C2 = 0, r_squared = 0, max_relative_deviation = 0;
  int n_used = 0;
};
PowerLawFit fit_power_law(const std::vector<double>& x, const std::vector<double>& y, double x_ref);

/// Samples every electrode's charge along rays from its centre (seed 001 Fig. 3) on the map's
/// interpolant at options.force_N and fits eq. 6 per ray. Throws InputError for bad options
/// (d_min ≤ 0, d_max ≤ d_min, step not in (0, 360], n_samples < 2, force ≤ 0).
RayAnalysis analyse_rays(const ChargeMap& map, const MapInterpolant& interpolant, const RayOptions& options);

/// Seed 001's range of the decay exponent (§3, eq. 6).
inline constexpr double paper_exponent_min = 0.58;
inline constexpr double paper_exponent_max = 1.0;

// ---------------------------------------------------------------------------------------------
// FEM map against measured charges (seed 001 Fig. 12, "an average difference of 18 %")

/// One measured press: position, force and the charge of every electrode of the map (map order).
/// The same record (and CSV format) as the calibration's presses.
using MeasuredPress = Measurement;

/// Reads a measured-charge CSV: columns x_m, y_m, force_N and charge_<name>_C for every name
/// in `electrode_names` (any order, other columns ignored; '#' comments). Throws InputError
/// naming the file and the missing column, or the line of a malformed row or a force ≤ 0.
/// (Same reader as read_measurements in calibration.hpp.)
std::vector<MeasuredPress> read_measured_csv(const std::string& path, const std::vector<std::string>& electrode_names);

/// A measured press next to the map's prediction.
struct ComparedPress {
  MeasuredPress measured;
  bool in_map = false;                 ///< false: outside the map's usable cells, not compared
  bool force_extrapolated = false;     ///< force outside the map's levels: compared with Q ∝ F^(2/3)
  std::vector<double> map_charge_C;    ///< [ne], NaN when not in the map
  /// [ne] 100·(Q_measured − Q_map)/Q_map (%); NaN when not compared (outside the map, or
  /// |Q_map| below the floor where a percentage means nothing).
  std::vector<double> difference_pct;
};

struct CompareElectrodeSummary {
  std::string name;
  int n_compared = 0;
  double mean_abs_difference_pct = 0;     ///< mean of |difference_pct|: the paper's "average difference"
  double mean_difference_pct = 0;         ///< signed mean (bias: > 0 means measured above the map)
  double rms_difference_pct = 0;
  double max_abs_difference_pct = 0;
};

struct CompareOptions {
  /// |Q_map| below this is not compared as a percentage (C); 0 = 3× the map's noise_C of that electrode.
  double min_map_charge_C = 0;
};

struct Comparison {
  std::vector<ComparedPress> presses;
  std::vector<CompareElectrodeSummary> electrodes;  ///< [ne]
  int n_presses = 0, n_in_map = 0, n_outside = 0, n_force_extrapolated = 0;
  int n_compared_values = 0;
  double mean_abs_difference_pct = 0;               ///< over every compared (press, electrode)
  double mean_difference_pct = 0;
};

/// 100·(measured − predicted)/predicted (%): the difference a comparison reports; NaN where
/// |predicted| < floor_C, where a percentage of a charge within the noise means nothing.
double charge_difference_pct(double measured_C, double predicted_C, double floor_C);

/// The charge floor of a comparison: `min_map_charge_C` when > 0, else 3 × each channel's noise.
std::vector<double> comparison_floor_C(const CompareOptions& options, const std::vector<double>& noise_C);

/// Fills c.electrodes (named `electrode_names`) and c's means from the presses' difference_pct
/// (NaN = not compared): the one home of the comparison's statistics (`compare MAP` and `compare SCENE`).
void summarize_comparison(Comparison& c, const std::vector<std::string>& electrode_names);

/// The summary of a comparison as JSON, the keys `compare MAP` and `compare SCENE` share: n_presses,
/// n_compared_values, the mean |difference| and mean difference (%), seed 001's mean, and per
/// electrode its name, n_compared, mean |d|, mean d, rms and max |d| (%). The commands add their
/// source, model and per-press keys.
nlohmann::json comparison_summary_json(const Comparison& c);

/// Compares measured presses with the map's (uncalibrated) charges at the same position and force.
Comparison compare_with_map(const ChargeMap& map, const MapInterpolant& interpolant,
                            const std::vector<MeasuredPress>& measured, const CompareOptions& options = {});

/// Seed 001's mean FEM-vs-experiment difference (§3), %.
inline constexpr double paper_mean_difference_pct = 18.0;

/// A compared press that a map's spacing h cannot resolve: closer than 2h to an electrode centre,
/// where the map's interpolation error alone reaches tens of % (docs/fem-vs-experiment.md §4).
struct UnresolvedPress {
  std::size_t line = 0;       ///< the press's CSV line
  std::size_t electrode = 0;  ///< the first electrode (map order) it is that close to
  double distance_m = 0;      ///< from that electrode's centre
  double spacing_m = 0;       ///< h = the larger of the map's x and y steps
};

/// The presses of `presses` the map cannot resolve, in their order (none for a map under 2 × 2).
/// The one home of this rule (`compare MAP`, `rays --measured`).
std::vector<UnresolvedPress> presses_map_cannot_resolve(const ChargeMap& map, const std::vector<MeasuredPress>& presses);

}  // namespace pvdf::mapping
