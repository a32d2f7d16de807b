// A charge map: the charge of every electrode for every probe position on a regular grid and
// every force level, with its provenance; read from and written to a self-describing HDF5 file
// (layout in docs/mapping.md). No deal.II: deployed code reads maps with this header alone.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace pvdf::mapping {

/// The 1-σ charge noise of a channel when none is given (C): 0.05 pC, the front end of seed 001's
/// bench (docs/lookup.md §1).
inline constexpr double default_noise_C = 0.05e-12;

/// Outcome of one map point (one probe position at one force level). Stored as uint8 in the
/// `status` dataset; the numbers are part of the file format.
enum class PointStatus : std::uint8_t {
  ok = 0,             ///< solved; charge and deflection are valid
  not_converged = 1,  ///< the solver did not converge here; values are NaN/0 and never used
  outside = 2,        ///< the position is outside the film or inside the rim margin (mask = 0)
  not_computed = 3    ///< not (yet) computed, e.g. an interrupted map generation
};
/// "ok" | "not_converged" | "outside" | "not_computed".
std::string status_name(PointStatus status);

/// Per-electrode linear correction fitted from measurements: q_measured ≈ gain·q_map + offset.
struct Calibration {
  std::vector<double> gain;       ///< [n_electrodes], dimensionless
  std::vector<double> offset_C;   ///< [n_electrodes], C
  std::string source;             ///< measurement file it was fitted from
  std::string report_json;        ///< fit report (leave-one-out errors, before/after), JSON text
};

/// Charge map on a regular grid. Arrays are flattened row-major in the order given with each.
struct ChargeMap {
  // --- provenance
  std::string scene_json;          ///< the scene the map was computed for (JSON text)
  std::string pvdfkit_version;     ///< version that wrote the map
  std::string model;               ///< kinematics/model used ("von-karman", "synthetic-analytic", ...)
  double tolerance = 0.0;          ///< requested relative error of the computed charges
  /// Estimated relative error of the charges (max_k |dQ_k| / max_k |Q_k|) and of
  /// deflection_at_load_m: the largest per-node estimate of the map (adjoint-weighted residual
  /// estimates of the discretization and model errors, docs/map-generation.md §6). NaN = unknown
  /// (synthetic map, file written before these existed).
  double estimated_relative_error = std::numeric_limits<double>::quiet_NaN();
  double estimated_deflection_relative_error = std::numeric_limits<double>::quiet_NaN();
  /// Set (not NaN) when estimated_charge_error_C holds each node's *total* error: its own estimate
  /// plus the interpolation error between it and its neighbours plus the error between force
  /// levels (adaptive map generation, docs/map-generation.md §10); the value is the largest
  /// total relative error of the map. The Locator then adds no interpolation estimate of its
  /// own between nodes and levels (docs/lookup.md §1.10). NaN = node estimates only.
  double estimated_total_relative_error = std::numeric_limits<double>::quiet_NaN();
  double rim_margin_m = 0.0;       ///< positions closer than this to the rim are masked out
  std::string description;         ///< free text

  // --- grid: probe positions
  std::vector<double> x_m;         ///< [nx] ascending, equally spaced
  std::vector<double> y_m;         ///< [ny] ascending, equally spaced
  std::vector<std::uint8_t> mask;  ///< [ny][nx]; 1 = inside the film minus the rim margin
  std::vector<double> forces_N;    ///< [nf] ascending, > 0

  // --- electrodes
  std::vector<std::string> electrode_names;                ///< [ne] unique, non-empty
  std::vector<std::array<double, 2>> electrode_centers_m;  ///< [ne] centroid of each electrode
  std::vector<double> noise_C;     ///< [ne] default 1-σ charge noise of each channel (C), > 0

  // --- results
  std::vector<double> charge_C;               ///< [nf][ny][nx][ne]
  std::vector<double> deflection_at_load_m;   ///< [nf][ny][nx]
  std::vector<std::uint8_t> status;           ///< [nf][ny][nx], PointStatus values
  /// Optional exact derivatives of the charge with respect to the probe position (C/m),
  /// [nf][ny][nx][ne] each; empty when absent (the interpolant then uses finite differences).
  std::vector<double> dcharge_dx_C_per_m, dcharge_dy_C_per_m;
  std::vector<double> estimated_charge_error_C;  // [nf][ny][nx][ne], C; empty = not stored

  /// True when estimated_charge_error_C holds totals (between nodes and force levels included):
  /// the one test of it, for the lookup, the flat export and the readers.
  bool charge_error_is_total() const { return !std::isnan(estimated_total_relative_error); }

  std::optional<Calibration> calibration;     ///< fitted from measurements (pvdfkit calibrate)

  std::size_t nx() const { return x_m.size(); }
  std::size_t ny() const { return y_m.size(); }
  std::size_t nf() const { return forces_N.size(); }
  std::size_t ne() const { return electrode_names.size(); }
  /// Index into status/deflection: [f][j][i].
  std::size_t point(std::size_t f, std::size_t j, std::size_t i) const { return (f * ny() + j) * nx() + i; }
  /// Index into charge_C: [f][j][i][k].
  std::size_t charge_index(std::size_t f, std::size_t j, std::size_t i, std::size_t k) const {
    return point(f, j, i) * ne() + k;
  }
  /// Sizes all result arrays for the current axes, forces and electrodes; status = not_computed.
  void allocate();
  /// Largest |charge| over every node, level and electrode (C; 0 for an empty map). Nodes
  /// without a value (NaN) are skipped.
  double largest_charge_C() const;
};

/// Checks every array shape, axis spacing, value range and finiteness. Throws pvdf::InputError
/// naming `source` and the dataset/attribute at fault (`map.h5: /forces_N[1] = 0.5 must be >
/// /forces_N[0] = 1 (ascending)`).
void validate(const ChargeMap& map, const std::string& source);

}  // namespace pvdf::mapping
