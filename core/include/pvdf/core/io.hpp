// Output files that are never half-written, number-range flags, and line-numbered CSV reading.
#pragma once

#include <functional>
#include <iosfwd>
#include <string>
#include <vector>

namespace pvdf {

/// Writes a file atomically: `write` fills a temporary file beside `path`, which is flushed
/// and renamed over `path` only if `write` returns without throwing. A crash or an exception
/// leaves either the old file or none, never a half-written one. Throws InputError when the
/// folder cannot be written.
void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write);
/// Same for binary writers that need a file name (libpng, HDF5): `write` gets the temporary
/// path, and the file is renamed to `path` afterwards.
void write_path_atomically(const std::string& path, const std::function<void(const std::string&)>& write);

/// Why `path` cannot be an output file, or "" when it can: an empty name, a folder, a symbolic
/// link (renaming over it would replace the link, not its target), a device or other special
/// file (/dev/full, a FIFO), or a folder that is missing or not writable. Outputs are renamed only
/// over a regular file or nothing; write_path_atomically applies this rule before it writes and
/// again before it renames.
std::string output_path_problem(const std::string& path);
/// Throws InputError "`what`: PATH <problem>" when output_path_problem(path) is not empty.
void check_output_path(const std::string& path, const std::string& what);

/// Largest number of data rows a whole-file CSV input (fit, compare, calibrate) may hold.
inline constexpr std::size_t max_csv_rows = 100000;
/// Longest cell of a whole-file CSV input (characters): a number or a column name needs far
/// fewer, and the readers that quote a cell in a message then quote at most this many.
inline constexpr std::size_t max_csv_cell_chars = 80;
/// Messages quote at most this many characters of a cell or flag value.
inline constexpr std::size_t max_quoted_chars = 80;
/// `text` for a message: control bytes escaped, cut to `max_quoted_chars` characters ("..." marks a cut).
std::string quote_cell(const std::string& text);
/// Checks a CSV input before a reader loads it: no NUL byte, a header whose column names are
/// unique, no cell longer than max_csv_cell_chars, and at most `max_rows` data rows (0 = no limit:
/// only the header is checked). Throws InputError naming `what` (the flag or argument), the file,
/// the line and the fix.
void check_csv_file(const std::string& path, const std::string& what, std::size_t max_rows = max_csv_rows);

/// Creates a folder and its parents if missing; InputError if that fails.
void make_directories(const std::string& path);

/// Parses "START:STEP:STOP" (inclusive STOP, up to round-off) into values; `what` names the
/// flag in messages. Limits the count to `max_count`.
std::vector<double> parse_range(const std::string& text, const std::string& what, std::size_t max_count = 100000);
/// Parses "A,B,C" into finite numbers; `count` = 0 accepts any count >= 1.
std::vector<double> parse_number_list(const std::string& text, const std::string& what, std::size_t count = 0);

/// A table read from CSV with a header row. Numbers only; comment lines start with '#'. Read as
/// spreadsheets and pandas write it: a UTF-8 byte-order mark, quoted fields and CRLF line ends.
struct CsvTable {
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;   ///< rows[i][j] is column j of data row i
  std::vector<std::size_t> line_numbers;   ///< 1-based file line of each data row
  /// Index of a column, or throws InputError naming the file and the missing column.
  std::size_t column(const std::string& name) const;
  bool has_column(const std::string& name) const;
  std::string source;
};

/// How read_csv treats a malformed data row (wrong field count, non-number, non-finite).
enum class BadRowPolicy {
  refuse,  ///< throw InputError naming the file and the line number
  skip     ///< skip it, and append "file:line: reason" to `skipped`
};

/// Reads a numeric CSV file with a header. Throws InputError for a missing file or header.
CsvTable read_csv(const std::string& path, BadRowPolicy policy = BadRowPolicy::refuse,
                  std::vector<std::string>* skipped = nullptr);
/// Same from a stream; `source` names it.
CsvTable read_csv(std::istream& in, const std::string& source, BadRowPolicy policy = BadRowPolicy::refuse,
                  std::vector<std::string>* skipped = nullptr);

/// Splits one CSV line on commas: quoted fields ("a, b", "" for a quote), a leading UTF-8
/// byte-order mark and a trailing CR are handled, unquoted fields trimmed.
std::vector<std::string> split_csv_line(const std::string& line);
/// A number as printf's %g (six significant digits): for messages.
std::string format_g(double x);
/// One number printed with a printf conversion for a double (`"%.3g mm"`, `"%.1f %%"`); the
/// text is cut at 127 bytes. The one home of the "printf of one number" helper.
std::string format_printf(const char* format, double x);
/// Parses a finite double from the whole of `text`; false if it is not one.
bool parse_finite(const std::string& text, double& value);

}  // namespace pvdf
