// Streaming lookup: CSV rows of charges on an input stream → CSV rows of located presses on an
// output stream, with a documented policy for malformed rows (docs/lookup.md §4).
#pragma once

#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/tracker.hpp"

#include <cstddef>
#include <iosfwd>
#include <string>

namespace pvdf::mapping {

struct StreamOptions {
  bool strict = false;        ///< a malformed row throws InputError (exit 2) instead of being skipped
  std::string source = "<stdin>";  ///< name of the input in messages
  int max_warnings = 20;      ///< skipped-row warnings printed on `warnings` (then only counted)
  /// Rows are tracked (Tracker: the full search with the previous row's answer as hints, a
  /// search without them at onset and at this interval); 1 = the full search on every row.
  int search_interval = TrackerOptions{}.search_interval;
};

struct StreamSummary {
  std::size_t rows = 0;       ///< data rows read
  std::size_t located = 0;    ///< rows with a position (no outside_map / no_press)
  std::size_t flagged = 0;    ///< rows with any flag
  std::size_t skipped = 0;    ///< malformed rows skipped (non-strict)
  TrackerSummary tracking;    ///< full searches and tracked rows
};

/// Reads a header naming the charge columns `charge_<name>_C` of every map electrode (any
/// order, optional `t_s`, other columns ignored), then one press per row; writes
/// one row per press, columns of stream_output_header() (numbers empty when the row has no
/// position). A malformed row (wrong field count, a non-number, a
/// non-finite value) is skipped with "warning: SOURCE:LINE: reason" on `warnings`, or with
/// strict=true throws InputError naming the line. Lines that are empty or start with '#'
/// are ignored. The output is flushed after every row so a pipe sees results at once.
/// A missing or incomplete header throws InputError.
StreamSummary locate_stream(const Locator& locator, std::istream& in, std::ostream& out, std::ostream& warnings,
                            const StreamOptions& options = {});

/// The output header line (without newline): t_s, the main answer (x_m, y_m, force_N, residual,
/// sigma_x_m, sigma_y_m, sigma_F_N), flags, p_best (its probability), n_solutions, then for
/// a = 1..7 the fixed columns alt<a>_x_m, alt<a>_y_m, alt<a>_force_N, alt<a>_p (empty when the
/// press has fewer solutions).
std::string stream_output_header();

/// One output row without t_s and without newline: the fields after `t_s,` of the header above.
std::string stream_row_fields(const Location& result);

}  // namespace pvdf::mapping
