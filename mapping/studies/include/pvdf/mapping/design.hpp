// Layout evaluation before fabrication: from a charge map and a charge-noise model, the
// Cramér–Rao bound of the lookup's position and force errors over the film, ambiguity regions,
// per-electrode sensitivity, dynamic range against the ADC, and dead zones. No deal.II: the
// analysis takes ChargeMaps (FEM or synthetic); docs/design.md explains every definition.
#pragma once

#include "pvdf/core/scene.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/synthetic.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace pvdf::mapping {

/// How messages name an option, given its key (snake_case, the options' field: "size_min_m",
/// "noise_C[0]") and its value as text (empty for a switch named alone). The command passes its
/// flags' spelling ("--size-min-m 0"), the Python package its keywords' ("optimize_layouts:
/// size_min_m = 0"); empty = the field's own name ("size_min_m = 0"). The library spells no flag.
using OptionNaming = std::function<std::string(const std::string& key, const std::string& value)>;

/// `key` and `value` as `naming` spells them (empty naming: "key = value", or "key" alone).
std::string named_option(const OptionNaming& naming, const std::string& key, const std::string& value);

/// Settings of a layout evaluation (public members with defaults).
struct DesignOptions {
  /// Force of the evaluated presses (N): bounds, sensitivity and ambiguity are computed at it.
  double force_N = 1.0;
  /// Force range the sensor must serve (N): the ADC full scale is set at max_force_N, the 1-LSB
  /// check is made at min_force_N, and the lookup treats forces outside as implausible.
  double min_force_N = 0.25;
  double max_force_N = 4.0;
  /// 1-σ charge noise per electrode (C) before quantization; empty = the map's; one value = all.
  std::vector<double> noise_C;
  /// Coverage target for the position bound σ_pos (m).
  double target_m = 0.5e-3;
  /// Figure of merit with the force measured separately (a force transducer): only (x, y) are
  /// estimated. Default: force unknown, (x, y, F) estimated from the charges alone.
  bool force_known = false;
  /// ADC resolution (bits, bipolar: LSB = full scale / 2^(bits−1)); 0 = ideal (no quantization).
  int adc_bits = 12;
  /// ADC full scale as a charge (C); 0 = full_scale_margin × the largest |charge| of any
  /// electrode over the map at max_force_N (one common full scale for all channels).
  double full_scale_C = 0.0;
  double full_scale_margin = 1.25;
  /// Ambiguity: a position that the lookup accepts within noise for noise-free charges of the
  /// press is a *distinct* press when farther than max(this, 3·σ_pos) from it; 0 = target_m
  /// (a solution within the target does not spoil the figure of merit).
  double ambiguity_min_distance_m = 0.0;
  bool check_ambiguity = true;
  /// Add the map's per-node estimated charge error (format-2 maps) to the channel noise as a
  /// further 1-σ term. Off by default: the bound is then the sensor's, set by its noise alone, and
  /// does not change with the resolution of the map it is computed from.
  bool include_map_error = false;
  /// Dead zone: the RMS signal-to-noise √(Σ(q_k/σ_k)²/n) is below this (the lookup's no_press).
  double dead_snr = 3.0;
  /// Fisher matrix singular (bound = +∞, "cannot locate") when its smallest eigenvalue after
  /// diagonal equilibration is below this × the largest.
  double singular_rcond = 1e-12;
};

/// The one check of a layout evaluation's settings, for `pvdfkit design` (typed layouts and
/// `--optimize`) and the Python `design`/`optimize_layouts` alike: throws InputError naming the
/// option as `naming` spells it, its value, the rule and the fix. The rules: force_N in (0, 1e4] N;
/// 0 < min_force_N < max_force_N ≤ 1e4 N; each noise_C in (0, 1e-6) C; target_m in (0, 1] m;
/// adc_bits 0 (ideal) or 2..32; full_scale_C in [0, 1e-3] C (0 = from the map);
/// ambiguity_min_distance_m in [0, 1] m.
void check_design_options(const DesignOptions& options, const OptionNaming& naming = {});

/// Cramér–Rao bound at one press from the noise-weighted Jacobian.
struct PointBound {
  static constexpr double kInf = std::numeric_limits<double>::infinity();
  bool singular = true;            ///< Fisher matrix rank-deficient: the press cannot be located
  double sigma_x_m = kInf, sigma_y_m = kInf;
  double sigma_pos_m = kInf;       ///< √(C_xx + C_yy): RMS radial position error (m)
  double sigma_major_m = kInf;     ///< major semi-axis of the 1-σ error ellipse (m)
  double sigma_force_rel = kInf;   ///< σ_F / F = √C_lnF,lnF (0 when the force is known)
};

/// Cramér–Rao bound from the Jacobian.
/// @param[in] jacobian  ne rows of {∂q/∂x (C/m), ∂q/∂y (C/m), ∂q/∂ln F (C)}
/// @param[in] sigma_C   ne noise values (C), > 0
/// @param[in] force_known  estimate (x, y) only (2×2 Fisher block) instead of (x, y, ln F)
/// Covariance = (JᵀΣ⁻¹J)⁻¹; a rank-deficient Fisher matrix gives singular = true and +∞ bounds.
PointBound cramer_rao_bound(const std::vector<std::array<double, 3>>& jacobian, const std::vector<double>& sigma_C,
                            bool force_known, double singular_rcond = 1e-12);

/// Maps over the evaluation grid (the map's nodes), [ny][nx] row-major; NaN where not evaluated.
struct DesignMaps {
  std::vector<double> x_m, y_m;
  std::vector<std::uint8_t> evaluated;        ///< 1 = mapped node inside a usable interpolation cell
  std::vector<double> sigma_pos_m;            ///< figure-of-merit bound (force known or unknown per options), +∞ singular
  std::vector<double> sigma_pos_unknown_force_m;
  std::vector<double> sigma_pos_known_force_m;
  std::vector<double> sigma_major_m;          ///< major semi-axis, same mode as sigma_pos_m
  std::vector<double> sigma_force_rel;        ///< σ_F/F with unknown force
  std::vector<double> ambiguity_distance_m;   ///< farthest distinct accepted solution (0 = none)
  std::vector<std::uint8_t> ambiguous;        ///< a distinct press fits the same charges within noise
  std::vector<std::uint8_t> dead;             ///< RMS signal-to-noise below dead_snr (the lookup's no_press)
  std::vector<std::uint8_t> singular;         ///< Fisher matrix singular: bound +∞
  std::vector<std::uint8_t> lookup_failed;    ///< the lookup returned no position for noise-free charges
  std::vector<double> charge_C;               ///< [ny][nx][ne] at options.force_N
  std::size_t index(std::size_t i, std::size_t j) const { return j * x_m.size() + i; }
};

/// Per-electrode figures.
struct ElectrodeReport {
  std::string name;
  std::array<double, 2> center_m{0, 0};
  double sensitivity_at_center_C_per_N = 0;   ///< ∂q_k/∂F for a press on the electrode's centre, at force_N
  double median_sensitivity_C_per_N = 0;      ///< median of ∂q_k/∂F over the evaluated area, at force_N
  double max_charge_C = 0;                    ///< largest |q_k| over the evaluated area at max_force_N
  double noise_C = 0;                         ///< σ_k before quantization
  double effective_noise_C = 0;               ///< √(σ_k² + LSB²/12)
  double below_lsb_fraction = 0;              ///< evaluated points where |q_k| < 1 LSB at min_force_N
};

/// Outcome of a layout evaluation.
enum class DesignStatus {
  ok,                 ///< a finite bound somewhere on the film
  unable_to_locate    ///< the Fisher matrix is singular at every evaluated point (e.g. coincident electrodes)
};
std::string design_status_name(DesignStatus status);

/// Everything `evaluate_design` found for one layout.
struct DesignSummary {
  DesignStatus status = DesignStatus::ok;
  std::string status_reason;
  // --- provenance
  std::string model;            ///< the map's model ("von-karman", "synthetic-analytic", ...)
  double tolerance = 0;         ///< the map's requested relative charge error
  double spacing_m = 0;         ///< grid spacing of the map (= evaluation grid)
  bool synthetic = false;       ///< map from the analytic stand-in, not from the FEM
  bool force_known = false;
  double force_N = 0, min_force_N = 0, max_force_N = 0, target_m = 0;
  // --- area figures (fractions of the mapped nodes: film minus the rim margin)
  std::size_t n_mapped = 0, n_evaluated = 0;
  double coverage = 0;          ///< σ_pos ≤ target
  double usable_fraction = 0;   ///< σ_pos ≤ target, not ambiguous, not dead, lookup succeeded (figure of merit)
  double singular_fraction = 0, ambiguous_fraction = 0, dead_fraction = 0, lookup_failed_fraction = 0;
  /// Ambiguous points where the Locator raised no `ambiguous` flag (it reported only a wrong
  /// solution, e.g. across a fold next to an electrode, closer than one grid cell to the truth).
  double silent_ambiguous_fraction = 0;
  double median_sigma_pos_m = 0, p90_sigma_pos_m = 0;  ///< over mapped nodes (not evaluated = +∞); may be +∞
  double median_sigma_pos_known_force_m = 0;
  double median_sigma_force_rel = 0, p90_sigma_force_rel = 0;
  double mapped_area_fraction = 0;  ///< mapped nodes × spacing² / film area (when the film area is known, else 0)
  // --- front end
  int adc_bits = 0;
  double full_scale_C = 0, lsb_C = 0;
  double lsb_over_noise = 0;           ///< LSB / smallest σ_k (> 1: the ADC, not the amplifier, limits)
  double saturated_fraction = 0;       ///< evaluated points where some |q_k| > full scale at max_force_N
  double below_lsb_fraction = 0;       ///< evaluated points where some electrode is < 1 LSB at min_force_N
  std::vector<ElectrodeReport> electrodes;
  DesignMaps maps;
  double figure_of_merit() const { return usable_fraction; }
};

/// Evaluates a layout from its charge map. Throws InputError for fewer than 3 electrodes, bad
/// noise values or force range. Pure function of its inputs (no I/O).
DesignSummary evaluate_design(const ChargeMap& map, const DesignOptions& options);

/// Summary as JSON (maps omitted; infinite values as null, documented in docs/design.md).
nlohmann::json design_summary_json(const DesignSummary& summary);

/// The ranking rule of `pvdfkit design` (docs/design.md): true when layout `a` ranks before `b` —
/// a layout that can locate before one that cannot, then the larger usable fraction (the figure
/// of merit), then the larger coverage, then the smaller median σ_pos.
bool ranks_before(const DesignSummary& a, const DesignSummary& b);

/// Indices of `summaries` best first by ranks_before (stable: equal layouts keep their order).
std::vector<std::size_t> rank_designs(const std::vector<DesignSummary>& summaries);

// ---------------------------------------------------------------------------------------------
// Layouts as scenes: synthetic stand-ins, sweeps of one scene key, rotation.

/// The analytic stand-in (SyntheticModel) for a scene's layout: electrode centroids and names,
/// draw angle, d32/d31, film radius (inscribed radius for non-circular outlines), and the
/// electrode area (charge scale ∝ area, smoothing core ∝ √area, both equal to the model's
/// defaults for a 2 mm × 2 mm electrode). Pretension, thickness and moduli do not enter it.
SyntheticModel synthetic_model_for_scene(const pvdf::Scene& scene);

/// Synthetic map of a scene: synthetic_model_for_scene sampled at `spacing_m`, rim margin =
/// probe radius + 1 mm, one force level `force_N`, noise `noise_C` on every channel.
ChargeMap synthetic_map_for_scene(const pvdf::Scene& scene, double spacing_m, double force_N, double noise_C);

/// A parsed `--vary KEY=START:STEP:STOP`.
struct SceneSweep {
  std::string key;
  std::vector<double> values;
};
/// Parses "KEY=START:STEP:STOP" (STOP inclusive). Throws InputError naming the text.
SceneSweep parse_scene_sweep(const std::string& text);

/// Returns the scene (JSON) with `key` set to `value`. Key syntax:
///   a path into the normalized scene (all defaults filled in): dot-separated object keys,
///   `[i]` array indices and `[*]` for every element, e.g. `material.draw_angle_deg`,
///   `electrodes[0].center_m[1]`, `membrane.pretension_N_per_m`, `electrodes[*].size_m`
///   (a number assigned to an array of numbers sets every element);
///   derived keys: `@layout_scale` (electrode positions scaled about their centroid by the
///   factor), `@layout_radius_m` (same, scaled so that the mean distance of the electrode
///   centres from their centroid equals the value), `@rotation_deg` (the whole layout —
///   electrodes, draw direction, loads and outline — rotated about the origin),
///   `@electrode_size_m` (every electrode a square of this side, or a circle of this diameter).
/// Throws InputError for an unknown key, a non-numeric target, or an invalid resulting scene.
nlohmann::json set_scene_key(const nlohmann::json& scene, const std::string& key, double value,
                             const std::string& source);

/// The scene rotated by `angle_rad` about the origin: electrode centres, vertices and angles,
/// the draw angle, load positions, and the outline (circles unchanged; rectangles and
/// ellipses only by multiples of 90°, else InputError; polygons rotated).
nlohmann::json rotate_scene(const nlohmann::json& scene, double angle_rad, const std::string& source);

}  // namespace pvdf::mapping
