// `pvdfkit locate`: where was the sensor pressed and how hard, from its electrode charges and a
// charge map: one press (--charges-C), a CSV stream, or pictures of the map.
#include "command.hpp"
#include "map_checks.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/map_io.hpp"
#include "pvdf/mapping/pictures.hpp"
#include "pvdf/mapping/stream.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <streambuf>

namespace {

struct LocateOptions {
  std::string map_path;
  std::string charges;
  std::string noise;
  double force_N = 0;
  bool force_N_given = false;
  std::string force_range;
  bool no_calibration = false;
  bool json = false;
  bool stream = false;
  std::string input;
  bool strict = false;
  std::string plot_path;
  std::string pictures_dir;
};

nlohmann::json flags_json(std::uint32_t flags) {
  nlohmann::json a = nlohmann::json::array();
  const std::string text = pvdf::mapping::flags_text(flags);
  if (text == "ok") return a;
  std::size_t start = 0;
  while (true) {
    const std::size_t bar = text.find('|', start);
    a.push_back(text.substr(start, bar - start));
    if (bar == std::string::npos) break;
    start = bar + 1;
  }
  return a;
}

using namespace pvdf::mapping;

/// The map's electrode names in order, "A,B,C": the order of --charges-C and of every output.
std::string electrode_order(const ChargeMap& map) {
  std::string out;
  for (const auto& n : map.electrode_names) out += (out.empty() ? "" : ",") + n;
  return out;
}

/// The lookup options from the flags, each checked against its rule.
LocatorOptions locator_options(const LocateOptions& o, const ChargeMap& map) {
  LocatorOptions options;
  if (!o.noise.empty()) options.noise_C = pvdf::parse_number_list(o.noise, "--noise-C");
  if (options.noise_C.size() > 1 && options.noise_C.size() != map.ne()) {
    throw pvdf::InputError("--noise-C " + pvdf::quote_cell(o.noise) + ": " + std::to_string(options.noise_C.size()) +
                           " values for a map of " + std::to_string(map.ne()) + " electrodes; give one value, or one per " +
                           "electrode in the map's order " + electrode_order(map));
  }
  options.use_calibration = !o.no_calibration;
  if (!o.force_range.empty()) {
    const auto r = pvdf::parse_number_list(o.force_range, "--force-range-N", 2);
    options.min_force_N = r[0];
    options.max_force_N = r[1];
    if (!(r[0] > 0) || !(r[1] > r[0])) throw pvdf::InputError("--force-range-N " + o.force_range + ": need 0 < MIN < MAX (N)");
  }
  if (o.force_N_given && !(o.force_N > 0 && std::isfinite(o.force_N))) {
    throw pvdf::InputError("--force-N " + pvdf::format_g(o.force_N) + ": must be finite and > 0 (N); omit it when the force is unknown");
  }
  if (!options.noise_C.empty()) {
    for (double s : options.noise_C) {
      if (!(s > 0 && std::isfinite(s))) throw pvdf::InputError("--noise-C " + o.noise + ": " + pvdf::format_g(s) + " must be finite and > 0 (C)");
      if (s > 1e-6) {
        throw pvdf::InputError("--noise-C " + pvdf::quote_cell(o.noise) + ": " + pvdf::format_g(s) +
                               " C of noise exceeds 1e-6 C, beyond any film's charge; is the unit pC? (5e-14 C = 0.05 pC)");
      }
    }
  }
  options.known_force_N = o.force_N;
  // A stream reports linearised σ's: the valley σ's would halve its rate (docs/lookup.md §1.6).
  if (o.stream || !o.input.empty()) options.valley_sigma_cells = 0;
  return options;
}

/// `--pictures DIR`: the isocharge picture of each electrode and the map as VTK.
void write_pictures(const LocateOptions& o, const ChargeMap& map, const Locator& locator) {
  pvdf::make_directories(o.pictures_dir);
  const double force = picture_force_N(map, o.force_N);  // given, else the level nearest 1 N
  for (std::size_t k = 0; k < map.ne(); ++k) {
    const std::string path = o.pictures_dir + "/isocharge_" + map.electrode_names[k] + ".png";
    write_isocharge_png(locator, map, k, force, path);
    std::printf("wrote %s\n", path.c_str());
  }
  const std::string vtk = o.pictures_dir + "/charges.vtk";
  write_charge_vtk(map, vtk);
  std::printf("wrote %s\n", vtk.c_str());
}

void print_location_json(const Location& r, const Locator& locator, const ChargeMap& map) {
  nlohmann::json j;
  j["electrodes"] = map.electrode_names;  // the order of --charges-C
  j["flags"] = flags_json(r.flags);
  if (r.has_position()) {
    j["x_m"] = r.x_m;
    j["y_m"] = r.y_m;
    j["force_N"] = r.force_N;
    j["residual"] = r.residual;
    j["sigma_x_m"] = r.sigma_x_m;
    j["sigma_y_m"] = r.sigma_y_m;
    j["sigma_F_N"] = r.sigma_F_N;
    j["map_error_share"] = r.map_error_share;
    j["n_solutions"] = r.n_solutions;
    j["probability"] = r.probability;
    j["p_best"] = r.probability;
    j["calibrated"] = locator.calibrated();
    if (r.flags & flag::ambiguous) {
      nlohmann::json others = nlohmann::json::array();
      for (int a = 0; a < r.n_alternatives; ++a) {
        const auto& alt = r.alternatives[std::size_t(a)];
        others.push_back({{"x_m", alt.x_m}, {"y_m", alt.y_m}, {"force_N", alt.force_N}, {"residual", alt.residual},
                          {"sigma_x_m", alt.sigma_x_m}, {"sigma_y_m", alt.sigma_y_m}, {"sigma_F_N", alt.sigma_F_N},
                          {"probability", alt.probability}});
      }
      j["alternatives"] = others;
    }
  }
  std::cout << j.dump(2) << '\n';
}

void print_location_text(const LocateOptions& o, const Location& r, const ChargeMap& map) {
  std::printf("electrodes: %s (the order of --charges-C)\n", electrode_order(map).c_str());
  if (!r.has_position()) {
    std::printf("flags: %s\n", flags_text(r.flags).c_str());
    return;
  }
  std::printf("x = %.4f mm +- %.4f mm\ny = %.4f mm +- %.4f mm\nF = %.5g N +- %.3g N%s\n", r.x_m * 1e3,
              r.sigma_x_m * 1e3, r.y_m * 1e3, r.sigma_y_m * 1e3, r.force_N, r.sigma_F_N,
              o.force_N > 0 ? " (given)" : "");
  std::printf("residual = %.3g (noise units)\nprobability = %.3g\nflags: %s\n", r.residual, r.probability,
              flags_text(r.flags).c_str());
  if (r.map_error_share > 0.5) {
    std::printf("the +- are %.0f %% the map's own error between its nodes, not the charge noise: a finer map "
                "(smaller --spacing-m) would narrow them (docs/lookup.md section 1.10)\n",
                100 * r.map_error_share);
  }
  for (int a = 0; a < r.n_alternatives; ++a) {
    const auto& alt = r.alternatives[std::size_t(a)];
    std::printf("also fits: x = %.4f mm, y = %.4f mm, F = %.5g N, residual %.3g, probability %.3g\n",
                alt.x_m * 1e3, alt.y_m * 1e3, alt.force_N, alt.residual, alt.probability);
  }
  if (r.flags & flag::ambiguous) std::printf("%d solutions fit within noise in all (all shown)\n", r.n_solutions);
}

/// "0.2-5 N" (or "1 N" for a one-level map): the forces the map was computed at.
std::string force_coverage(const ChargeMap& map) {
  const double lo = map.forces_N.front(), hi = map.forces_N.back();
  return lo == hi ? pvdf::format_g(lo) + " N" : pvdf::format_g(lo) + "-" + pvdf::format_g(hi) + " N";
}

/// `--charges-C`: one press.
int locate_one(const LocateOptions& o, const ChargeMap& map, const Locator& locator) {
  if (o.stream || !o.input.empty()) throw pvdf::InputError("--charges-C and --stream/--input: choose one press or a stream");
  const auto q = pvdf::app::parse_charges(o.charges, map);
  const bool force_outside_levels =
      o.force_N > 0 && (o.force_N < map.forces_N.front() * (1 - 1e-9) || o.force_N > map.forces_N.back() * (1 + 1e-9));
  const Location r = locator.locate(q.data());
  if (o.json) {
    print_location_json(r, locator, map);
  } else {
    print_location_text(o, r, map);
  }
  if (force_outside_levels) {
    const std::string where = "--force-N " + pvdf::format_g(o.force_N) + " N lies beyond the map's force levels: the map covers " +
                              force_coverage(map);
    if (!r.has_position()) {
      std::cerr << "error: " << where << ", and no press fits there; give a force within it, or build the map with "
                << "--forces-N reaching " << pvdf::format_g(o.force_N) << " N\n";
    } else {
      pvdf::app::warn(where + "; the charges were extrapolated in force");
    }
  }
  if (!o.plot_path.empty()) {
    if (!r.has_position()) {
      std::cerr << "warning: no picture: the press has no position\n";
    } else {
      write_intersection_png(locator, map, q.data(), r, o.plot_path);
      if (!o.json) std::printf("plot written to %s\n", o.plot_path.c_str());
    }
  }
  // Numerical honesty: a press outside the map or at the noise level is not a result.
  return r.has_position() ? pvdf::exit_code::success : pvdf::exit_code::numerical;
}

/// The rows of `--stream`/`--input` on their way to the lookup, one line at a time within the
/// limits of a text stream of charges (docs/lookup.md §4): a line longer than max_line_bytes
/// refuses the stream (InputError naming the line: not a CSV of charges, and no line is read
/// whole into memory); a header naming a column twice is refused (the last would win silently);
/// control bytes (NUL included) become visible `\xHH` text and a data cell longer than
/// max_csv_cell_chars becomes `<cell of N characters>`, so such a row fails as malformed (skipped
/// with a warning, or refused with --strict) and its message quotes a short cell. The number of
/// rows is not limited: a stream holds one row at a time (memory does not grow with rows).
class BoundedLines : public std::streambuf {
 public:
  static constexpr std::size_t max_line_bytes = 65536;

  BoundedLines(std::istream& source, std::string name) : source_(source), name_(std::move(name)) {}

 protected:
  int_type underflow() override {
    if (gptr() < egptr()) return traits_type::to_int_type(*gptr());
    if (!next_line()) return traits_type::eof();
    setg(&line_[0], &line_[0], &line_[0] + line_.size());
    return traits_type::to_int_type(*gptr());
  }

 private:
  bool next_line() {
    std::string raw;
    std::streambuf* in = source_.rdbuf();
    bool ended = false;
    while (true) {
      const int_type c = in->sbumpc();
      if (traits_type::eq_int_type(c, traits_type::eof())) break;
      if (c == '\n') {
        ended = true;
        break;
      }
      if (raw.size() >= max_line_bytes) {
        throw pvdf::InputError(name_ + ":" + std::to_string(line_no_ + 1) + ": a line longer than " +
                               std::to_string(max_line_bytes) + " bytes; a row of charges is a few hundred: is this the " +
                               "right input (CSV rows t_s,charge_<name>_C,...)?");
      }
      raw += traits_type::to_char_type(c);
    }
    if (raw.empty() && !ended) return false;
    ++line_no_;
    line_ = visible(raw);
    const bool data = !line_.empty() && line_[0] != '#' && !(line_.size() == 1 && line_[0] == '\r');
    if (data && !header_seen_) {
      header_seen_ = true;
      check_header();
    } else if (data) {
      shorten_cells();
    }
    line_ += '\n';
    return true;
  }

  /// Control bytes (other than tab and a carriage return) as `\xHH`: no number contains them.
  static std::string visible(const std::string& raw) {
    std::string out;
    for (const char ch : raw) {
      const auto b = static_cast<unsigned char>(ch);
      if ((b < 0x20 && ch != '\t' && ch != '\r') || b == 0x7f) {
        char hex[8];
        std::snprintf(hex, sizeof hex, "\\x%02x", b);
        out += hex;
      } else {
        out += ch;
      }
    }
    return out;
  }

  void check_header() const {
    const auto names = pvdf::split_csv_line(line_);
    for (std::size_t i = 0; i < names.size(); ++i) {
      for (std::size_t j = 0; j < i; ++j) {
        if (!names[i].empty() && names[i] == names[j]) {
          throw pvdf::InputError(name_ + ":" + std::to_string(line_no_) + ": column '" + pvdf::quote_cell(names[i]) +
                                 "' appears twice in the header (columns " + std::to_string(j + 1) + " and " +
                                 std::to_string(i + 1) + "); keep one of them");
        }
      }
    }
  }

  void shorten_cells() {
    auto cells = pvdf::split_csv_line(line_);
    bool long_cell = false;
    for (auto& cell : cells) {
      if (cell.size() <= pvdf::max_csv_cell_chars) continue;
      cell = "<cell of " + std::to_string(cell.size()) + " characters>";
      long_cell = true;
    }
    if (!long_cell) return;
    std::string joined;
    for (std::size_t i = 0; i < cells.size(); ++i) {
      const bool quote = cells[i].find_first_of(",\"") != std::string::npos;
      std::string cell = cells[i];
      for (std::size_t at = cell.find('"'); quote && at != std::string::npos; at = cell.find('"', at + 2)) cell.insert(at, 1, '"');
      joined += (i ? "," : "") + (quote ? "\"" + cell + "\"" : cell);
    }
    line_ = joined;
  }

  std::istream& source_;
  std::string name_;
  std::string line_;
  std::size_t line_no_ = 0;
  bool header_seen_ = false;
};

/// `--stream` / `--input`: one located row per CSV row.
int locate_rows(const LocateOptions& o, const Locator& locator) {
  if (!o.plot_path.empty() || o.json) throw pvdf::InputError("--plot and --json apply to a single press (--charges-C), not to a stream");
  StreamOptions so;
  so.strict = o.strict;
  std::ifstream file;
  std::istream* in = &std::cin;
  if (!o.input.empty() && o.input != "-") {
    std::error_code ec;
    if (std::filesystem::is_directory(o.input, ec)) {
      throw pvdf::InputError("--input " + pvdf::quote_cell(o.input) + " is a folder; give the CSV file of charges");
    }
    pvdf::check_csv_file(o.input, "--input", 0);  // a stream: its header only (unique columns, no NUL, short cells)
    file.open(o.input);
    if (!file) throw pvdf::InputError(o.input + ": cannot open; check the path");
    in = &file;
    so.source = o.input;
  }
  BoundedLines bounded(*in, so.source);
  std::istream rows(&bounded);
  rows.exceptions(std::ios::badbit);  // a refusal inside BoundedLines reaches main as the InputError it is
  const StreamSummary s = locate_stream(locator, rows, std::cout, std::cerr, so);
  std::cerr << "located " << s.located << " of " << s.rows << " rows (" << s.flagged << " flagged, " << s.skipped
            << " malformed rows skipped)\n";
  return pvdf::exit_code::success;
}

int run_locate(const LocateOptions& o) {
  const ChargeMap map = read_map(o.map_path);
  const Locator locator(map, locator_options(o, map));

  if (!o.pictures_dir.empty()) {
    write_pictures(o, map, locator);
    if (o.charges.empty() && !o.stream && o.input.empty()) return pvdf::exit_code::success;
  }
  if (!o.charges.empty()) return locate_one(o, map, locator);
  if (o.stream || !o.input.empty()) return locate_rows(o, locator);
  if (o.pictures_dir.empty()) {
    throw pvdf::InputError("nothing to do: give --charges-C Q1,Q2,... for one press, --stream (CSV on stdin) or "
                           "--input FILE for many, or --pictures DIR");
  }
  return pvdf::exit_code::success;
}

}  // namespace

PVDF_COMMAND(60, [](CLI::App& root) {
  auto* sub = root.add_subcommand(
      "locate",
      "Locate a press (position, force, 1-sigma, flags) from electrode charges with a charge map; "
      "one press, a CSV stream, or pictures of the map (docs/lookup.md)");
  auto o = std::make_shared<LocateOptions>();
  sub->add_option("MAP", o->map_path, "Charge map (HDF5 from `pvdfkit map`, `synthetic-map` or `calibrate`)")->required();
  sub->add_option("--charges-C", o->charges,
                  "One press: one charge per electrode (C), e.g. 4e-11,2e-11,1.5e-11; the order follows the map's "
                  "electrode names (stored in the map; printed as `electrodes` by locate, text and JSON)");
  sub->add_flag("--json", o->json, "Print the single result as JSON");
  sub->add_option("--noise-C", o->noise, "1-sigma charge noise per electrode, one value or one per electrode in the map's electrode order (C) (default the map's)");
  sub->add_option("--force-N", o->force_N, "Known force of the press (N): fit the position only (and the force of --pictures) (default unknown: fitted with the "
                  "position)")
      ->check(pvdf::app::number_in(0, 1e4, "N (a press beyond 10 kN is no tactile press: is the unit right?)", true))
      ->each([o](const std::string&) { o->force_N_given = true; });
  sub->add_option("--force-range-N", o->force_range, "Plausible forces MIN,MAX (N), also the prior of the solutions' probabilities (default half the lowest to twice the "
                  "highest force level of the map)");
  sub->add_flag("--no-calibration", o->no_calibration, "Ignore the map's calibration group");
  sub->add_flag("--stream", o->stream, "Read CSV rows (t_s,charge_<name>_C,...) on stdin, write located rows on stdout; malformed rows are skipped with a "
                "warning, a line over 64 KiB refuses the stream (docs/lookup.md)");
  sub->add_option("--input", o->input, "Read the CSV rows from this file instead of stdin (implies --stream)");
  sub->add_flag("--strict", o->strict, "Stream: refuse a malformed row (exit 2) instead of skipping it with a warning");
  sub->add_option("--plot", o->plot_path, "Single press: figure (.png, .svg or .pdf) of the isocharge contours of the charges and their intersection")
      ->check(pvdf::app::figure_file());
  sub->add_option("--pictures", o->pictures_dir, "Folder for isocharge_<name>.png per electrode and charges.vtk of the map")
      ->check(pvdf::app::output_folder());
  return pvdf::app::Subcommand{sub, [o] { return run_locate(*o); }};
});
