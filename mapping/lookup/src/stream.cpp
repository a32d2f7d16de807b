// Streaming CSV lookup with line-numbered handling of malformed rows.
#include "pvdf/mapping/stream.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"

#include <cstdio>
#include <istream>
#include <ostream>
#include <vector>

namespace pvdf::mapping {

std::string stream_output_header() {
  std::string h = "t_s,x_m,y_m,force_N,residual,sigma_x_m,sigma_y_m,sigma_F_N,flags,p_best,n_solutions";
  for (int a = 1; a < Location::max_solutions; ++a) {
    const std::string p = ",alt" + std::to_string(a) + "_";
    h += p + "x_m" + p + "y_m" + p + "force_N" + p + "p";
  }
  return h;
}

std::string stream_row_fields(const Location& r) {
  char buffer[160];
  std::string row;
  if (r.has_position()) {
    std::snprintf(buffer, sizeof buffer, "%.9g,%.9g,%.9g,%.6g,%.4g,%.4g,%.4g,", r.x_m, r.y_m, r.force_N, r.residual,
                  r.sigma_x_m, r.sigma_y_m, r.sigma_F_N);
    row = buffer;
  } else {
    row = ",,,,,,,";
  }
  row += flags_text(r.flags);
  if (r.has_position()) {
    std::snprintf(buffer, sizeof buffer, ",%.4g,%d", r.probability, r.n_solutions);
    row += buffer;
  } else {
    row += ",,0";
  }
  for (int a = 0; a + 1 < Location::max_solutions; ++a) {
    if (r.has_position() && a < r.n_alternatives) {
      const auto& alt = r.alternatives[std::size_t(a)];
      std::snprintf(buffer, sizeof buffer, ",%.9g,%.9g,%.9g,%.4g", alt.x_m, alt.y_m, alt.force_N, alt.probability);
      row += buffer;
    } else {
      row += ",,,,";
    }
  }
  return row;
}

StreamSummary locate_stream(const Locator& locator, std::istream& in, std::ostream& out, std::ostream& warnings,
                            const StreamOptions& options) {
  StreamSummary summary;
  std::string line;
  std::size_t line_no = 0;
  std::vector<std::string> header;
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    header = split_csv_line(line);
    break;
  }
  if (header.empty()) throw InputError(options.source + ": no CSV header; the first line must name the columns, e.g. t_s," +
                                       "charge_" + locator.electrode_names()[0] + "_C,...");
  const std::size_t ne = locator.n_electrodes();
  std::vector<long> charge_col(ne, -1);
  long time_col = -1;
  for (std::size_t c = 0; c < header.size(); ++c) {
    if (header[c] == "t_s") time_col = long(c);
    for (std::size_t k = 0; k < ne; ++k) {
      if (header[c] == "charge_" + locator.electrode_names()[k] + "_C") charge_col[k] = long(c);
    }
  }
  for (std::size_t k = 0; k < ne; ++k) {
    if (charge_col[k] < 0) {
      std::string need;
      for (std::size_t m = 0; m < ne; ++m) need += (m ? "," : "") + std::string("charge_") + locator.electrode_names()[m] + "_C";
      throw InputError(options.source + ":" + std::to_string(line_no) + ": header lacks column charge_" +
                       locator.electrode_names()[k] + "_C; the map's electrodes need columns " + need);
    }
  }
  out << stream_output_header() << '\n' << std::flush;

  std::array<double, max_electrodes> q{};
  TrackerOptions tracker_options;
  tracker_options.search_interval = options.search_interval;
  Tracker tracker(locator, tracker_options);
  auto skip = [&](const std::string& reason) {
    const std::string where = options.source + ":" + std::to_string(line_no) + ": " + reason;
    if (options.strict) {
      throw InputError(where + " (strict reading refuses malformed rows; without it they are skipped and counted)");
    }
    ++summary.skipped;
    if (int(summary.skipped) <= options.max_warnings) warnings << "warning: " << where << "; row skipped\n";
    if (int(summary.skipped) == options.max_warnings + 1) warnings << "warning: further skipped rows are only counted\n";
  };
  while (std::getline(in, line)) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    ++summary.rows;
    const auto fields = split_csv_line(line);
    if (fields.size() != header.size()) {
      skip("has " + std::to_string(fields.size()) + " fields but the header has " + std::to_string(header.size()));
      continue;
    }
    bool good = true;
    for (std::size_t k = 0; k < ne && good; ++k) {
      if (!parse_finite(fields[std::size_t(charge_col[k])], q[k])) {
        skip("column " + header[std::size_t(charge_col[k])] + " = '" + fields[std::size_t(charge_col[k])] +
             "' is not a finite number");
        good = false;
      }
    }
    double t = 0;
    if (good && time_col >= 0 && !parse_finite(fields[std::size_t(time_col)], t)) {
      skip("column t_s = '" + fields[std::size_t(time_col)] + "' is not a finite number");
      good = false;
    }
    if (!good) {
      tracker.reset();  // a gap in the stream: search the next row afresh
      continue;
    }
    const Location r = tracker.next(q.data());
    const std::string t_text = time_col >= 0 ? fields[std::size_t(time_col)] : std::to_string(summary.rows - 1);
    if (r.has_position()) ++summary.located;
    if (r.flags != 0) ++summary.flagged;
    out << t_text << ',' << stream_row_fields(r) << '\n' << std::flush;
  }
  summary.tracking = tracker.summary();
  return summary;
}

}  // namespace pvdf::mapping
