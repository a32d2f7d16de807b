// Fusion of a computed map with measurements: per-electrode gain and offset fitted from presses
// at known positions and forces, with leave-one-out validation and a before/after report.
#pragma once

#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/map.hpp"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace pvdf::mapping {

/// One calibration press: where, how hard, and what each electrode measured.
struct Measurement {
  double x_m = 0, y_m = 0, force_N = 0;
  std::vector<double> charge_C;  ///< [n_electrodes], in the map's electrode order
  std::size_t line = 0;          ///< line in the CSV file (for messages)
};

/// Reads `x_m,y_m,force_N,charge_<name>_C...` (one charge column per map electrode, any order,
/// every cell filled; unknown columns ignored) with pvdf::read_measured (core/measured.hpp), the
/// reader `fit` uses, under MeasuredRules{every_charge, ignore_other_columns}. Malformed rows are
/// refused with their line number (InputError).
std::vector<Measurement> read_measurements(const std::string& path, const std::vector<std::string>& electrode_names);

/// Errors of one variant (uncalibrated map, calibrated in-sample, leave-one-out).
struct CalibrationErrors {
  std::vector<double> rms_charge_C;   ///< per electrode: RMS(measured − predicted)
  double rms_position_m = 0;          ///< locating the measured charges with the known force
  double median_position_m = 0;       ///< same, median (robust to the few presses on map folds)
  double rms_force_relative = 0;      ///< locating with unknown force: RMS of (F − F_true)/F_true
  double median_force_relative = 0;   ///< same, median (an ambiguous press may pick the other solution)
  int n_located = 0;                  ///< presses that got a position (of n_presses)
};

struct CalibrationReport {
  Calibration calibration;            ///< the fit on all presses
  std::vector<std::string> electrode_names;
  std::size_t n_presses = 0;          ///< presses inside the map (used)
  CalibrationErrors before;           ///< the raw map
  CalibrationErrors after_in_sample;  ///< calibrated with all presses, evaluated on the same presses
  CalibrationErrors after_leave_one_out;  ///< each press predicted by a fit without it
  nlohmann::json to_json() const;
};

/// Fits q_measured,k ≈ gain_k · q_map,k(x, y, F) + offset_k by linear least squares per
/// electrode, validates by leave-one-out, and reports charge, position and force errors before
/// and after. The map's own calibration (if any) is ignored. Needs >= 3 presses inside the map
/// with distinct predicted charges per electrode; throws InputError otherwise.
CalibrationReport fit_calibration(const ChargeMap& map, const std::vector<Measurement>& presses,
                                  const LocatorOptions& options = {}, const std::string& source = "");

}  // namespace pvdf::mapping
