// Reader of measured CSVs (docs/fem-vs-experiment.md §1): strict, every error names the line.
#include "pvdf/core/measured.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

namespace pvdf {

namespace {

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ",") + x;
  return s;
}

}  // namespace

bool MeasuredTable::sigmas_given() const {
  for (const auto& c : observed)
    if (!c.has_sigma) return false;
  return !observed.empty();
}

namespace {

/// The CSV as text cells: header, rows, line numbers (comments and blank lines skipped).
struct RawCsv {
  std::vector<std::string> columns;
  std::size_t header_line = 0;
  std::vector<std::vector<std::string>> rows;
  std::vector<std::size_t> lines;
};

RawCsv read_raw(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open the file; check the path and its permissions");
  RawCsv raw;
  std::string line;
  std::size_t n = 0;
  while (std::getline(in, line)) {
    ++n;
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    auto fields = split_csv_line(line);
    for (auto& f : fields) {
      while (!f.empty() && (f.back() == '\r' || f.back() == ' ')) f.pop_back();
    }
    if (raw.columns.empty()) {
      for (const auto& f : fields)
        if (f.empty()) throw InputError(path + ":" + std::to_string(n) + ": empty column name in the header; name every column");
      raw.columns = fields;
      raw.header_line = n;
      continue;
    }
    if (fields.size() != raw.columns.size()) {
      throw InputError(path + ":" + std::to_string(n) + ": has " + std::to_string(fields.size()) +
                       " fields, the header has " + std::to_string(raw.columns.size()) + "; fix or remove the row");
    }
    raw.rows.push_back(fields);
    raw.lines.push_back(n);
  }
  if (raw.columns.empty()) throw InputError(path + ": no header row; the first line must name the columns");
  return raw;
}

/// Every column other than x_m, y_m, force_N and deflection_m must be a sigma_ column of a value
/// column or the charge column of one of the scene's electrodes; `where` = "path:header line: ".
void check_other_columns(const RawCsv& t, const std::map<std::string, std::size_t>& index,
                         const std::vector<std::string>& allowed_charges, const std::vector<std::string>& electrode_names,
                         const std::string& where, const std::string& expected, bool ignore_unknown) {
  for (const auto& c : t.columns) {
    if (c == "x_m" || c == "y_m" || c == "force_N" || c == "deflection_m") continue;
    if (c.rfind("sigma_", 0) == 0) {
      const std::string of = c.substr(6);
      if (of == "x_m" || of == "y_m" || of == "force_N") {
        throw InputError(where + "column '" + c + "': uncertainties of the press position and force are not modelled; "
                         "convert them into sigma_ of the deflection and charges (docs/fem-vs-experiment.md §1)");
      }
      if (!index.count(of)) {
        throw InputError(where + "column '" + c + "' has no value column '" + of + "'; add it or remove the sigma column");
      }
      continue;
    }
    if (c.rfind("charge_", 0) == 0 && c.size() > 9 && c.compare(c.size() - 2, 2, "_C") == 0) {
      bool known = false;
      for (const auto& a : allowed_charges) known = known || a == c;
      if (!known) {
        throw InputError(where + "column '" + c + "' names an electrode the scene does not have; the scene's are " +
                         join(electrode_names) + " (columns " + join(allowed_charges) + ")");
      }
      continue;
    }
    if (!ignore_unknown) throw InputError(where + "unknown column '" + c + "'; a measured CSV has " + expected);
  }
}

}  // namespace

MeasuredTable read_measured(const std::string& path, const std::vector<std::string>& electrode_names,
                            const MeasuredRules& rules) {
  const RawCsv t = read_raw(path);
  const std::string where = path + ":" + std::to_string(t.header_line) + ": ";
  auto has_column = [&](const std::string& c) { return std::find(t.columns.begin(), t.columns.end(), c) != t.columns.end(); };
  std::vector<std::string> allowed_charges;
  for (const auto& n : electrode_names) allowed_charges.push_back("charge_" + n + "_C");
  const std::string expected = "x_m,y_m,force_N and any of deflection_m," + join(allowed_charges) +
                               " with optional sigma_<column> for each of those";

  for (const char* required : {"x_m", "y_m", "force_N"}) {
    if (!has_column(required)) {
      throw InputError(where + "missing column '" + required + "' (the header has " + join(t.columns) +
                       "); a measured CSV needs " + expected);
    }
  }
  // Classify every column: known value columns, sigma columns, or an error.
  std::map<std::string, std::size_t> index;
  for (std::size_t j = 0; j < t.columns.size(); ++j) {
    const std::string& c = t.columns[j];
    if (index.count(c)) throw InputError(where + "column '" + c + "' appears twice; keep one");
    index[c] = j;
  }
  MeasuredTable m;
  m.source = path;
  std::vector<std::string> value_columns;
  if (index.count("deflection_m")) value_columns.push_back("deflection_m");
  for (const auto& c : allowed_charges)
    if (index.count(c)) value_columns.push_back(c);
  if (rules.every_charge) {
    for (const auto& c : allowed_charges) {
      if (!index.count(c)) {
        throw InputError(where + "missing column '" + c + "' (the header has " + join(t.columns) + "); the electrodes need " +
                         "x_m,y_m,force_N," + join(allowed_charges));
      }
    }
  }
  check_other_columns(t, index, allowed_charges, electrode_names, where, expected, rules.ignore_other_columns);
  if (value_columns.empty()) {
    throw InputError(where + "no observed column (the header has " + join(t.columns) + "); give deflection_m and/or " +
                     join(allowed_charges));
  }
  int n_sigma = 0;
  for (const auto& c : value_columns) n_sigma += index.count("sigma_" + c) ? 1 : 0;
  if (n_sigma != 0 && n_sigma != static_cast<int>(value_columns.size())) {
    std::string missing;
    for (const auto& c : value_columns)
      if (!index.count("sigma_" + c)) missing += (missing.empty() ? "" : ",") + ("sigma_" + c);
    throw InputError(where + "sigma columns are given for some observed columns but not for " + missing +
                     "; give a sigma for every observed column or for none (then the fit estimates one relative "
                     "uncertainty from the scatter)");
  }
  if (t.rows.empty()) throw InputError(path + ": no data rows after the header; add one row per press");

  // A cell is a finite number; an empty cell in an observed column (and its sigma) = not measured.
  auto cell = [&](std::size_t r, const std::string& c, bool may_be_empty) {
    const std::string& text = t.rows[r][index[c]];
    double x = 0;
    if (text.empty() && may_be_empty) return std::numeric_limits<double>::quiet_NaN();
    if (!parse_finite(text, x)) {
      throw InputError(path + ":" + std::to_string(t.lines[r]) + ": column " + c + " = '" + text +
                       "' is not a finite number" + (may_be_empty ? " (leave the cell empty if not measured)" : "") +
                       "; fix or remove the row");
    }
    return x;
  };
  for (std::size_t r = 0; r < t.rows.size(); ++r) {
    const std::string at = path + ":" + std::to_string(t.lines[r]) + ": ";
    const double f = cell(r, "force_N", false);
    if (!(f > 0)) throw InputError(at + "force_N = " + std::to_string(f) + " must be > 0; fix or remove the row");
    m.line.push_back(t.lines[r]);
    m.x_m.push_back(cell(r, "x_m", false));
    m.y_m.push_back(cell(r, "y_m", false));
    m.force_N.push_back(f);
  }
  for (const auto& c : value_columns) {
    ObservedColumn o;
    o.name = c;
    for (std::size_t k = 0; k < allowed_charges.size(); ++k)
      if (allowed_charges[k] == c) o.electrode = static_cast<int>(k);
    o.has_sigma = index.count("sigma_" + c) > 0;
    for (std::size_t r = 0; r < t.rows.size(); ++r) {
      const double v = cell(r, c, !(rules.every_charge && o.electrode >= 0));
      o.value.push_back(v);
      if (!o.has_sigma) continue;
      const double s = cell(r, "sigma_" + c, true);
      if (std::isnan(v) != std::isnan(s)) {
        throw InputError(path + ":" + std::to_string(t.lines[r]) + ": " + c + " and sigma_" + c +
                         " must both be given or both be empty; fix the row");
      }
      if (!std::isnan(s) && !(s > 0)) {
        std::ostringstream msg;
        msg << path << ":" << t.lines[r] << ": sigma_" << c << " = " << s
            << " must be > 0 (a 1-sigma uncertainty in the column's unit); fix or remove the row";
        throw InputError(msg.str());
      }
      o.sigma.push_back(s);
    }
    m.observed.push_back(std::move(o));
  }
  std::size_t n_values = 0;
  for (const auto& o : m.observed)
    for (double v : o.value) n_values += std::isnan(v) ? 0 : 1;
  if (n_values == 0) throw InputError(path + ": no measured value in any observed column; fill in at least one");
  return m;
}

}  // namespace pvdf
