// Bench measurements for a fit, a comparison or a calibration: one row per press (position, force)
// with any of the deflection under the probe and the electrode charges, each with an optional 1-σ
// column. The one reader of measured CSVs (`fit`, `compare`, `calibrate`, `rays`, Python).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace pvdf {

/// One observed column: `deflection_m` or `charge_<electrode>_C`.
struct ObservedColumn {
  std::string name;                  ///< the CSV header, e.g. "charge_A_C"
  int electrode = -1;                ///< scene electrode index for a charge column, -1 for the deflection
  bool has_sigma = false;            ///< a `sigma_<name>` column was given
  std::vector<double> value;         ///< [row] in SI units (m, C)
  std::vector<double> sigma;         ///< [row] 1-σ (same unit), empty when has_sigma is false
};

/// A measured CSV (docs/fem-vs-experiment.md §1).
struct MeasuredTable {
  std::string source;                ///< file name, for messages
  std::vector<std::size_t> line;     ///< [row] 1-based line in the file
  std::vector<double> x_m, y_m, force_N;
  std::vector<ObservedColumn> observed;  ///< deflection first (if any), then charges in scene electrode order
  std::size_t n_rows() const { return line.size(); }
  /// True when every observed column has its sigma column (false when none has).
  bool sigmas_given() const;
};

/// What a reader of measured CSVs asks beyond the common rules.
struct MeasuredRules {
  /// Every electrode's charge column must be present and every one of its cells filled (a map
  /// comparison or a calibration compares all channels of each press); a fit takes any subset.
  bool every_charge = false;
  /// Columns that are none of the known ones are ignored (notes, a timestamp); false = refused
  /// (a fit: an unknown column is most likely a misspelt observed one).
  bool ignore_other_columns = false;
};

/// Reads a measured CSV: required columns x_m, y_m, force_N; optional deflection_m and
/// charge_<name>_C for names in `electrode_names`; optional sigma_<column> for each of those.
/// Throws pvdf::InputError naming the file, the line number and the fix for: a missing required
/// column, no observed column, a charge column of an electrode the scene does not have, a sigma
/// column without its value column or for x/y/force, sigma columns given for some observed
/// columns but not all, an unknown column, a malformed or non-finite value (NaN), a force <= 0,
/// a sigma <= 0, no data rows; and what `rules` adds (a missing charge column or an empty charge cell,
/// naming the columns the electrodes need).
MeasuredTable read_measured(const std::string& path, const std::vector<std::string>& electrode_names,
                            const MeasuredRules& rules = {});

}  // namespace pvdf
