// The seed-000 scanner restore: scanner scenes, scans as numpy arrays, identification of the
// inverse filters from scans of known forces, and their application (offline and streaming).
#include "arguments.hpp"
#include "bindings.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/json_reader.hpp"
#include "pvdf/restore/apply.hpp"
#include "pvdf/restore/filter.hpp"
#include "pvdf/restore/scan_io.hpp"
#include "pvdf/restore/scanner.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

namespace pvdf::python {
namespace {

namespace r = pvdf::restore;

const char* scan_expected = "a pvdfkit.restore.Scan (from simulate, read_scan or Scan(x_m, m1_V, m2_V))";
const char* filter_expected = "a pvdfkit.restore.InverseFilter (from identify or load_filter)";

template <class T>
py::array_t<T> read_only(const std::vector<T>& values) {
  py::array_t<T> out = to_array(values);
  out.attr("setflags")(py::arg("write") = false);
  return out;
}

/// The rules `pvdfkit restore` applies to a scan CSV (restore/src/scan_io.cpp): at least 16
/// samples, x increasing in uniform steps (each within 1 % of the median step).
void check_uniform(const std::vector<double>& x, const std::string& what) {
  if (x.size() < 16) {
    throw pvdf::InputError(what + " has " + std::to_string(x.size()) + " samples; a scan needs at least 16");
  }
  std::vector<double> steps;
  for (std::size_t i = 1; i < x.size(); ++i) steps.push_back(x[i] - x[i - 1]);
  std::nth_element(steps.begin(), steps.begin() + std::ptrdiff_t(steps.size() / 2), steps.end());
  const double dx = steps[steps.size() / 2];
  if (!(dx > 0)) throw pvdf::InputError(what + ": positions do not increase; x_m must increase from sample to sample (m)");
  for (std::size_t i = 1; i < x.size(); ++i) {
    const double step = x[i] - x[i - 1];
    if (std::abs(step - dx) > 0.01 * dx) {
      throw pvdf::InputError(what + "[" + std::to_string(i) + "]: position step " + pvdf::format_g(step) +
                             " m differs from the median step " + pvdf::format_g(dx) +
                             " m by more than 1 %; a scan must be uniformly sampled (resample it first)");
    }
  }
}

/// A scanner scene: a ScannerScene, or a dict or file path read by restore.load_scanner_scene.
r::ScannerScene scanner_scene(py::object value, const std::string& what) {
  if (py::isinstance<r::ScannerScene>(value)) return value.cast<r::ScannerScene>();
  const bool path_like = py::isinstance<py::str>(value) || py::hasattr(value, "__fspath__");
  if (!py::isinstance<py::dict>(value) && !path_like) {
    throw pvdf::InputError(what + " = " + arg::shown(value) + " (" + arg::type_name(value) +
                           ") must be a pvdfkit.restore.ScannerScene, a dict of scanner-scene keys or a file path");
  }
  const py::object source = py::isinstance<py::dict>(value) ? py::object(py::str(what)) : py::object(py::none());
  return py::module_::import("pvdfkit.restore").attr("load_scanner_scene")(value, source).cast<r::ScannerScene>();
}

/// Where the filter is not finite ("h[0][1][17] = nan"), or "".
std::string non_finite_part(const r::InverseFilter& f) {
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < 2; ++j) {
      for (std::size_t k = 0; k < f.h[i][j].size(); ++k) {
        if (!std::isfinite(f.h[i][j][k])) {
          return "h[" + std::to_string(i) + "][" + std::to_string(j) + "][" + std::to_string(k) + "] = " + pvdf::format_g(f.h[i][j][k]);
        }
      }
    }
  }
  for (const auto& [name, value] : {std::pair<const char*, double>{"beta", f.beta}, {"beta_abs", f.beta_abs},
                                    {"sample_spacing_m", f.sample_spacing_m}}) {
    if (!std::isfinite(value)) return std::string(name) + " = " + pvdf::format_g(value);
  }
  return "";
}

void bind_scan(py::module_& m) {
  py::class_<r::ScannerScene>(m, "ScannerScene", R"doc(A scanner scene: sensor, scan, acquisition chain and surface (docs/restore.md).

Make one with pvdfkit.restore.load_scanner_scene (file or dict) or default_scanner_scene().)doc")
      .def_readonly("source", &r::ScannerScene::source)
      .def_readonly("warnings", &r::ScannerScene::warnings)
      .def_readonly("speed_m_per_s", &r::ScannerScene::speed_m_per_s)
      .def_readonly("sample_rate_Hz", &r::ScannerScene::sample_rate_Hz)
      .def_property_readonly("sample_spacing_m", &r::ScannerScene::sample_spacing_m)
      .def_property_readonly("n_samples", &r::ScannerScene::n_samples);
  m.def("default_scanner_scene", &r::default_scanner_scene, "Seed 000 Table 1 defaults, no surface loads.");
  m.def("_load_scanner_scene_file", &r::load_scanner_scene, py::arg("path"));
  m.def("_parse_scanner_scene_text", [](const std::string& text, const std::string& source) {
    return r::parse_scanner_scene(pvdf::parse_json_text(text, source), source);
  }, py::arg("text"), py::arg("source"));

  py::class_<r::Scan>(m, "Scan", R"doc(A scan on a uniform grid: scanner position x_m (m), strip signals m1_V and m2_V (V), and,
when known, the reference surface forces per sample fx_N and fz_N (N; empty arrays otherwise). All shape (n,).

Made from arrays, a scan is checked as ``pvdfkit restore`` checks a scan CSV: at least 16 samples,
every value finite, x_m increasing in uniform steps (within 1 %). Its arrays read as read-only copies.)doc")
      .def(py::init([](py::object x_m, py::object m1_V, py::object m2_V, py::object fx_N, py::object fz_N) {
             r::Scan s;
             s.x_m = arg::vector(x_m, "Scan: x_m", {false, true, "give scanner positions in m, increasing uniformly"});
             s.m1_V = arg::vector(m1_V, "Scan: m1_V", {false, true, "give strip 1's signal in V, one per position"});
             s.m2_V = arg::vector(m2_V, "Scan: m2_V", {false, true, "give strip 2's signal in V, one per position"});
             if (!fx_N.is_none()) s.fx_N = arg::vector(fx_N, "Scan: fx_N", {false, true, "give the reference shear force per sample in N"});
             if (!fz_N.is_none()) s.fz_N = arg::vector(fz_N, "Scan: fz_N", {false, true, "give the reference normal force per sample in N"});
             const std::size_t n = s.x_m.size();
             if (s.m1_V.size() != n || s.m2_V.size() != n || (!s.fx_N.empty() && s.fx_N.size() != n) ||
                 (!s.fz_N.empty() && s.fz_N.size() != n)) {
               throw pvdf::InputError("Scan: x_m has " + std::to_string(n) + " samples, m1_V " + std::to_string(s.m1_V.size()) +
                                      ", m2_V " + std::to_string(s.m2_V.size()) +
                                      "; m1_V, m2_V (and fx_N, fz_N when given) must have as many");
             }
             if (s.fx_N.empty() != s.fz_N.empty()) throw pvdf::InputError("Scan: give both fx_N and fz_N, or neither");
             check_uniform(s.x_m, "Scan: x_m");
             s.source = "<arrays>";
             return s;
           }),
           py::arg("x_m"), py::arg("m1_V"), py::arg("m2_V"), py::arg("fx_N") = py::none(), py::arg("fz_N") = py::none())
      .def_property_readonly("x_m", [](const r::Scan& s) { return read_only(s.x_m); })
      .def_property_readonly("m1_V", [](const r::Scan& s) { return read_only(s.m1_V); })
      .def_property_readonly("m2_V", [](const r::Scan& s) { return read_only(s.m2_V); })
      .def_property_readonly("fx_N", [](const r::Scan& s) { return read_only(s.fx_N); })
      .def_property_readonly("fz_N", [](const r::Scan& s) { return read_only(s.fz_N); })
      .def_property_readonly("sample_spacing_m", &r::Scan::sample_spacing_m)
      .def_readonly("source", &r::Scan::source)
      .def("__len__", &r::Scan::size);
  m.def("simulate", [](py::object scene, py::object noise, py::object adc, py::object moving_average) {
          const r::ScannerScene s = scanner_scene(scene, "simulate: scene");
          r::SimulateOptions o;
          o.noise = arg::flag(noise, "simulate: noise");
          o.adc = arg::flag(adc, "simulate: adc");
          o.moving_average = arg::flag(moving_average, "simulate: moving_average");
          return r::simulate_scan(s, o);
        },
        py::arg("scene"), py::arg("noise") = true, py::arg("adc") = true, py::arg("moving_average") = true,
        "Simulates the two strip signals of a scan of the scene's surface (closed-form stress-rate responses, noise, ADC, moving average).");
  m.def("read_scan", [](py::object path, py::object speed_m_per_s) {
          const std::string p = arg::path(path, "read_scan: path");
          const double speed = arg::number_in(speed_m_per_s, "read_scan: speed_m_per_s", 0, 10,
                                              "m/s (0 = the file has x_m; seed 000 scanned at 0.01-0.1 m/s)");
          return r::read_scan_csv(p, speed);
        },
        py::arg("path"), py::arg("speed_m_per_s") = 0.0,
        "Reads a scan CSV `x_m,m1_V,m2_V[,fx_ref_N,fz_ref_N]` (or `t_s,...` with speed_m_per_s in m/s).");
  m.def("write_scan", [](py::object path, py::object scan, py::object comment) {
          const std::string p = arg::output_file(path, "write_scan: path");
          const r::Scan& s = arg::object<r::Scan>(scan, "write_scan: scan", scan_expected);
          r::write_scan_csv(p, s, arg::text(comment, "write_scan: comment"));
        },
        py::arg("path"), py::arg("scan"), py::arg("comment") = "", "Writes a scan CSV atomically.");
}

r::BetaPolicy parse_policy(const std::string& policy) {
  if (policy == "constant") return r::BetaPolicy::constant;
  if (policy == "frequency") return r::BetaPolicy::frequency;
  if (policy == "gcv") return r::BetaPolicy::gcv;
  if (policy == "discrepancy") return r::BetaPolicy::discrepancy;
  if (policy == "lcurve") return r::BetaPolicy::lcurve;
  if (policy == "morozov") return r::BetaPolicy::morozov;
  if (policy == "predicted") return r::BetaPolicy::predicted;
  throw pvdf::InputError("identify: beta_policy = " + policy +
                         " must be constant, frequency, gcv, discrepancy, lcurve, morozov or predicted");
}

/// 'auto' (-1: the design picks it from G, as the command's default) or a length in [0, hi] m.
double auto_or_length(py::object value, const std::string& what, double hi, const std::string& meaning) {
  if (py::isinstance<py::str>(value)) {
    if (value.cast<std::string>() == "auto") return -1;
    throw pvdf::InputError(what + " = " + arg::shown(value) + " must be 'auto' or a length in m; " + meaning);
  }
  return arg::number_in(value, what, 0, hi, "m; " + meaning);
}

r::InverseFilter identify(py::object scans, py::object beta, py::object beta_policy_arg, py::object taps_arg,
                          py::object delay_arg, py::object g_window_arg, py::object resolution_m, py::object low_cut_wavelength_m,
                          py::object corner_wavelength_m, py::object window, py::object regularization_arg) {
  const std::string f = "identify: ";
  r::DesignOptions d;
  const std::string regularization = arg::text(regularization_arg, f + "regularization");
  if (regularization != "isotropic" && regularization != "tikhonov") {
    throw pvdf::InputError(f + "regularization = '" + regularization + "' must be isotropic (default) or tikhonov (seed 000 eq. 4)");
  }
  d.isotropic = regularization == "isotropic";
  if (!d.isotropic) d.predicted_beta_scale = 0.25;
  // The rules and defaults of `pvdfkit restore identify` (app/src/cmd_restore.cpp).
  d.taps = std::size_t(arg::integer_in(taps_arg, f + "taps", 64, 4194304, "(the FIR length, even, e.g. 8192)"));
  if (d.taps % 2 != 0) throw pvdf::InputError(f + "taps = " + std::to_string(d.taps) + " must be even; give an even FIR length such as 8192");
  const long long delay = arg::integer_in(delay_arg, f + "delay_samples", -1, (long long)d.taps - 1, "(-1 = taps / 2)");
  d.delay_samples = long(delay);
  d.g_window = std::size_t(arg::integer_in(g_window_arg, f + "g_window", 0, 4194304, "(0 = taps; else even and >= 64)"));
  if (d.g_window != 0 && (d.g_window < 64 || d.g_window % 2 != 0)) {
    throw pvdf::InputError(f + "g_window = " + std::to_string(d.g_window) + " must be 0 (= taps) or even and >= 64; give an even "
                           "number of lags or omit it");
  }
  d.resolution_m = auto_or_length(resolution_m, f + "resolution_m", 1, "0 = no target (seed 000), 'auto' = 1.5 x the strips' effective depth");
  d.low_cut_wavelength_m = auto_or_length(low_cut_wavelength_m, f + "low_cut_wavelength_m", 100,
                                          "0 = off (seed 000), 'auto' = 10 x the strips' effective depth");
  d.corner_wavelength_m = arg::number_in(corner_wavelength_m, f + "corner_wavelength_m", 0, 1, "m (a wavelength; 0 = none)");
  d.window = arg::text(window, f + "window");
  std::string policy = arg::text(beta_policy_arg, f + "beta_policy");
  if (py::isinstance<py::str>(beta)) {
    const std::string text = beta.cast<std::string>();
    // The names `pvdfkit restore identify --beta` takes, with the same meanings.
    static const std::map<std::string, std::string> named = {
        {"auto", "predicted"}, {"predicted", "predicted"}, {"gcv", "gcv"},          {"lcurve", "lcurve"},
        {"morozov", "morozov"}, {"noise-floor", "discrepancy"}, {"discrepancy", "discrepancy"}};
    const auto it = named.find(text);
    if (it == named.end()) {
      throw pvdf::InputError(f + "beta = '" + pvdf::escape_control_bytes(text) + "' must be a number in (0, 1e6) (relative, seed 000 "
                             "used 1e-4) or auto, predicted, gcv, lcurve, morozov, noise-floor");
    }
    const std::string& chosen = it->second;
    if (!policy.empty() && policy != chosen) throw pvdf::InputError(f + "beta " + text + " contradicts beta_policy " + policy);
    policy = chosen;
  } else {
    d.beta = arg::number_in(beta, f + "beta", 1e-15, 1e6, "(relative, seed 000 used 1e-4), or 'auto'");
    if (policy.empty()) policy = d.corner_wavelength_m > 0 ? "frequency" : "constant";
  }
  d.beta_policy = parse_policy(policy);
  if (!py::isinstance<py::list>(scans) && !py::isinstance<py::tuple>(scans)) {
    throw pvdf::InputError(f + "scans = " + arg::shown(scans) + " (" + arg::type_name(scans) +
                           ") must be a list of (Scan, fx_N, fz_N, edge_x_m) tuples, at least 2");
  }
  std::vector<r::IdentificationScan> id;
  std::size_t i = 0;
  for (const py::handle item : scans) {
    const std::string at = f + "scans[" + std::to_string(i++) + "]";
    if (!(py::isinstance<py::tuple>(item) || py::isinstance<py::list>(item)) || py::len(item) != 4) {
      throw pvdf::InputError(at + " = " + arg::shown(item) + " must be a tuple (Scan, fx_N, fz_N, edge_x_m): the scan of one "
                             "raised edge, its forces in N and its position in m");
    }
    const py::sequence t = py::reinterpret_borrow<py::sequence>(item);
    r::IdentificationScan s;
    s.scan = arg::object<r::Scan>(t[0], at + "[0]", scan_expected);
    s.fx_N = arg::number_in(t[1], at + "[1] (fx_N)", -1e6, 1e6, "N (the edge's shear force)");
    s.fz_N = arg::number_in(t[2], at + "[2] (fz_N)", -1e6, 1e6, "N (the edge's normal force)");
    s.edge_x_m = arg::number_in(t[3], at + "[3] (edge_x_m)", -10, 10, "m (the edge's position on the scan's x_m axis)");
    id.push_back(std::move(s));
  }
  r::InverseFilter filter;
  {
    py::gil_scoped_release release;
    const r::TransferMatrix transfer = r::identify_transfer(id, d);
    filter = r::design_inverse(transfer, id, d);
  }
  const std::string bad = non_finite_part(filter);
  if (!bad.empty()) {
    throw pvdf::NumericalError("identify: the designed filter is not finite (" + bad +
                               "); the identification scans do not determine G; check them (restore.simulate to compare)");
  }
  return filter;
}

void bind_filter(py::module_& m) {
  py::class_<r::InverseFilter>(m, "InverseFilter", R"doc(Inverse FIR filters restoring (f_x, f_z) from the two strip signals.

h: shape (2, 2, taps), h[i, j] maps signal j (0 = m1, 1 = m2) to force i (0 = f_x, 1 = f_z), N/V per
sample, with the modelling delay ``delay_samples``; g: the identified transfer matrix, shape (2, 2, n)
(V/N, lag = index + g_lag_min samples).)doc")
      .def_readonly("sample_spacing_m", &r::InverseFilter::sample_spacing_m)
      .def_readonly("taps", &r::InverseFilter::taps)
      .def_readonly("delay_samples", &r::InverseFilter::delay_samples)
      .def_readonly("beta_policy", &r::InverseFilter::beta_policy)
      .def_readonly("beta", &r::InverseFilter::beta, "relative regularization (the chosen one for gcv/auto)")
      .def_readonly("regularization", &r::InverseFilter::regularization, "'isotropic' or 'tikhonov'")
      .def_readonly("peak_fraction", &r::InverseFilter::peak_fraction,
                    "restored f_z peak of a sharp edge as a fraction of the target resolution's peak (1 = met)")
      .def_readonly("lobe_force_fraction", &r::InverseFilter::lobe_force_fraction,
                    "force an isolated sharp feature keeps within +-3 resolutions of it (fraction of the true force)")
      .def_readonly("beta_abs", &r::InverseFilter::beta_abs, "beta x max s^2 ((V/N)^2)")
      .def_readonly("resolution_m", &r::InverseFilter::resolution_m)
      .def_readonly("low_cut_wavelength_m", &r::InverseFilter::low_cut_wavelength_m)
      .def_readonly("window", &r::InverseFilter::window)
      .def_readonly("truncated_energy_fraction", &r::InverseFilter::truncated_energy_fraction)
      .def_property_readonly("h", [](const r::InverseFilter& f) {
        py::array_t<double> out({py::ssize_t(2), py::ssize_t(2), py::ssize_t(f.taps)});
        double* p = out.mutable_data();
        for (int i = 0; i < 2; ++i)
          for (int j = 0; j < 2; ++j) p = std::copy(f.h[i][j].begin(), f.h[i][j].end(), p);
        return out;
      })
      .def_property_readonly("g", [](const r::InverseFilter& f) {
        const auto& g = f.transfer.g;
        const std::size_t n = g[0][0].size();
        py::array_t<double> out({py::ssize_t(2), py::ssize_t(2), py::ssize_t(n)});
        double* p = out.mutable_data();
        for (int i = 0; i < 2; ++i)
          for (int j = 0; j < 2; ++j) p = std::copy(g[i][j].begin(), g[i][j].begin() + std::ptrdiff_t(std::min(n, g[i][j].size())), p);
        return out;
      })
      .def_property_readonly("g_lag_min", [](const r::InverseFilter& f) { return f.transfer.lag_min; })
      .def_property_readonly("conditioning", [](const r::InverseFilter& f) {
        py::dict d;
        d["min"] = f.conditioning.min;
        d["median"] = f.conditioning.median;
        d["max"] = f.conditioning.max;
        d["band_fraction"] = f.conditioning.band_fraction;
        d["force_condition_number"] = f.transfer.force_condition_number;
        return d;
      }, "condition numbers of G(k) over its band, and cond of the identification force matrix")
      .def_property_readonly("warnings", [](const r::InverseFilter& f) { return f.transfer.warnings; });
  m.def("identify", &identify, py::arg("scans"), py::arg("beta") = "auto", py::arg("beta_policy") = "",
        py::arg("taps") = 8192, py::arg("delay_samples") = -1, py::arg("g_window") = 0,
        py::arg("resolution_m") = "auto", py::arg("low_cut_wavelength_m") = "auto", py::arg("corner_wavelength_m") = 0.0,
        py::arg("window") = "tukey", py::arg("regularization") = "isotropic",
        R"doc(Identifies the 2x2 transfer matrix G from >= 2 scans of known forces (seed 000 eq. 6) and designs the
regularized inverse filters (eq. 4), as ``pvdfkit restore identify`` does.

scans: list of (Scan, fx_N, fz_N, edge_x_m): the forces (N) of a raised edge at world position
edge_x_m (m). beta: 'auto' (default, as the command: the beta minimizing the predicted mu error), a
relative regularization in [1e-15, 1e6] (seed 000: 1e-4), or 'predicted', 'gcv', 'lcurve', 'morozov',
'noise-floor'. taps: even, in [64, 4194304]; delay_samples: -1 (= taps / 2) or 0..taps-1; g_window:
0 (= taps) or even >= 64. resolution_m: target Gaussian FWHM (m, in [0, 1]; 0 = none as seed 000;
default 'auto' as the command: 1.5 x the strips' effective depth); low_cut_wavelength_m: damp longer
wavelengths (m, in [0, 100]; 0 = off; default 'auto': 10 x the effective depth). Forces in
[-1e6, 1e6] N, edge positions in [-10, 10] m.
regularization: 'isotropic' (default, as the command: f_x and f_z blurred alike, mu unbiased) or
'tikhonov' (seed 000 eq. 4). A filter that comes out not finite raises NumericalError.)doc");
  m.def("load_filter", [](py::object path) { return r::load_filter(arg::path(path, "load_filter: path")); },
        py::arg("path"), "Reads a filter JSON written by save_filter or `pvdfkit restore identify`.");
  m.def("save_filter", [](py::object path, py::object filter_arg) {
          const std::string p = arg::output_file(path, "save_filter: path");
          const r::InverseFilter& filter = arg::object<r::InverseFilter>(filter_arg, "save_filter: filter", filter_expected);
          const std::string bad = non_finite_part(filter);
          if (!bad.empty()) throw pvdf::InputError("save_filter: filter." + bad + " is not finite; identify the filter again");
          r::save_filter(p, filter);
        },
        py::arg("path"), py::arg("filter"), "Writes a filter as JSON, atomically (a filter that is not finite is refused).");
  m.def("apply", [](py::object filter_arg, py::object scan_arg, py::object mu_threshold_arg, py::object block_arg) {
          const r::InverseFilter& filter = arg::object<r::InverseFilter>(filter_arg, "apply: filter", filter_expected);
          const r::Scan& scan = arg::object<r::Scan>(scan_arg, "apply: scan", scan_expected);
          const double mu_threshold_N = arg::number(mu_threshold_arg, "apply: mu_threshold_N",
                                                    "(N per sample; < 0 = 30 % of the largest restored f_z)");
          if (mu_threshold_N > 1e6) {  // the rule of `pvdfkit restore apply --mu-threshold-N`
            throw pvdf::InputError("apply: mu_threshold_N = " + pvdf::format_g(mu_threshold_N) +
                                   " must lie in [0, 1e6] N per sample, or be < 0 for 30 % of the largest restored f_z");
          }
          const std::size_t block_samples =
              std::size_t(arg::integer_in(block_arg, "apply: block_samples", 0, 16777216, "(0 = offline; else the streaming block)"));
          py::gil_scoped_release release;
          if (block_samples == 0) return r::restore_scan(filter, scan, mu_threshold_N);
          // Streaming: blocks as a real-time loop would push them; forces equal the offline ones after flush.
          r::RestoredForces checked = r::restore_scan(filter, scan, mu_threshold_N);  // validates spacing
          r::StreamingRestorer s(filter, block_samples);
          std::vector<double> fx, fz;
          for (std::size_t i = 0; i < scan.size(); i += block_samples) {
            const std::size_t n = std::min(block_samples, scan.size() - i);
            s.push(scan.m1_V.data() + i, scan.m2_V.data() + i, n, fx, fz);
          }
          s.flush(fx, fz);
          fx.resize(scan.size());
          fz.resize(scan.size());
          // The streamed forces per sample get the same finishing as the offline path: flat-surface
          // level, line forces in N/m and mu.
          r::RestoredForces forces;
          forces.x_m = checked.x_m;
          forces.fx_N = fx;
          forces.fz_N = fz;
          r::RestoreOptions options;
          options.mu_threshold_N = mu_threshold_N;
          r::finish_forces(filter, forces, options);
          return forces;
        },
        py::arg("filter"), py::arg("scan"), py::arg("mu_threshold_N") = -1.0, py::arg("block_samples") = 0,
        "Restores f_x, f_z (N per sample) and mu from a scan (as `pvdfkit restore apply`). mu_threshold_N < 0: 30 % of "
        "the largest restored f_z. block_samples > 0: the streaming restorer in blocks of that size. Returns RestoredForces.");
}

}  // namespace

void bind_restore(py::module_& m) {
  bind_scan(m);
  bind_filter(m);
}

}  // namespace pvdf::python
