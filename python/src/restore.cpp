// The seed-000 scanner restore: scanner scenes, scans as numpy arrays, identification of the
// inverse filters from scans of known forces, and their application (offline and streaming).
#include "bindings.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/json_reader.hpp"
#include "pvdf/restore/apply.hpp"
#include "pvdf/restore/filter.hpp"
#include "pvdf/restore/scan_io.hpp"
#include "pvdf/restore/scanner.hpp"

#include <cmath>
#include <map>
#include <optional>
#include <variant>

namespace pvdf::python {
namespace {

namespace r = pvdf::restore;

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
when known, the reference surface forces per sample fx_N and fz_N (N; empty arrays otherwise). All shape (n,).)doc")
      .def(py::init([](const DoubleArray& x_m, const DoubleArray& m1_V, const DoubleArray& m2_V,
                       const std::optional<DoubleArray>& fx_N, const std::optional<DoubleArray>& fz_N) {
             r::Scan s;
             s.x_m = to_vector(x_m, "Scan: x_m");
             s.m1_V = to_vector(m1_V, "Scan: m1_V");
             s.m2_V = to_vector(m2_V, "Scan: m2_V");
             if (fx_N) s.fx_N = to_vector(*fx_N, "Scan: fx_N");
             if (fz_N) s.fz_N = to_vector(*fz_N, "Scan: fz_N");
             const std::size_t n = s.x_m.size();
             if (s.m1_V.size() != n || s.m2_V.size() != n || (!s.fx_N.empty() && s.fx_N.size() != n) ||
                 (!s.fz_N.empty() && s.fz_N.size() != n)) {
               throw pvdf::InputError("Scan: x_m has " + std::to_string(n) + " samples; m1_V, m2_V (and fx_N, fz_N when "
                                      "given) must have as many");
             }
             s.source = "<arrays>";
             return s;
           }),
           py::arg("x_m"), py::arg("m1_V"), py::arg("m2_V"), py::arg("fx_N") = py::none(), py::arg("fz_N") = py::none())
      .def_property_readonly("x_m", [](const r::Scan& s) { return to_array(s.x_m); })
      .def_property_readonly("m1_V", [](const r::Scan& s) { return to_array(s.m1_V); })
      .def_property_readonly("m2_V", [](const r::Scan& s) { return to_array(s.m2_V); })
      .def_property_readonly("fx_N", [](const r::Scan& s) { return to_array(s.fx_N); })
      .def_property_readonly("fz_N", [](const r::Scan& s) { return to_array(s.fz_N); })
      .def_property_readonly("sample_spacing_m", &r::Scan::sample_spacing_m)
      .def_readonly("source", &r::Scan::source)
      .def("__len__", &r::Scan::size);
  m.def("simulate", [](const r::ScannerScene& scene, bool noise, bool adc, bool moving_average) {
          r::SimulateOptions o;
          o.noise = noise;
          o.adc = adc;
          o.moving_average = moving_average;
          return r::simulate_scan(scene, o);
        },
        py::arg("scene"), py::arg("noise") = true, py::arg("adc") = true, py::arg("moving_average") = true,
        "Simulates the two strip signals of a scan of the scene's surface (closed-form stress-rate responses, noise, ADC, moving average).");
  m.def("read_scan", &r::read_scan_csv, py::arg("path"), py::arg("speed_m_per_s") = 0.0,
        "Reads a scan CSV `x_m,m1_V,m2_V[,fx_ref_N,fz_ref_N]` (or `t_s,...` with speed_m_per_s in m/s).");
  m.def("write_scan", &r::write_scan_csv, py::arg("path"), py::arg("scan"), py::arg("comment") = "",
        "Writes a scan CSV atomically.");
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

r::InverseFilter identify(const py::list& scans, std::variant<double, std::string> beta, const std::string& beta_policy,
                          std::size_t taps, long delay_samples, std::size_t g_window, double resolution_m,
                          double low_cut_wavelength_m, double corner_wavelength_m, const std::string& window,
                          const std::string& regularization) {
  r::DesignOptions d;
  if (regularization != "isotropic" && regularization != "tikhonov") {
    throw pvdf::InputError("identify: regularization = '" + regularization + "' must be isotropic (default) or tikhonov (seed 000 eq. 4)");
  }
  d.isotropic = regularization == "isotropic";
  if (!d.isotropic) d.predicted_beta_scale = 0.25;
  d.taps = taps;
  d.delay_samples = delay_samples;
  d.g_window = g_window;
  d.resolution_m = resolution_m;
  d.low_cut_wavelength_m = low_cut_wavelength_m;
  d.corner_wavelength_m = corner_wavelength_m;
  d.window = window;
  std::string policy = beta_policy;
  if (const auto* text = std::get_if<std::string>(&beta)) {
    // The names `pvdfkit restore identify --beta` takes, with the same meanings.
    static const std::map<std::string, std::string> named = {
        {"auto", "predicted"}, {"predicted", "predicted"}, {"gcv", "gcv"},          {"lcurve", "lcurve"},
        {"morozov", "morozov"}, {"noise-floor", "discrepancy"}, {"discrepancy", "discrepancy"}};
    const auto it = named.find(*text);
    if (it == named.end()) {
      throw pvdf::InputError("identify: beta = '" + *text + "' must be a number > 0 (relative, seed 000 used 1e-4) or "
                             "auto, predicted, gcv, lcurve, morozov, noise-floor");
    }
    const std::string& chosen = it->second;
    if (!policy.empty() && policy != chosen) throw pvdf::InputError("identify: beta " + *text + " contradicts beta_policy " + policy);
    policy = chosen;
  } else {
    const double b = std::get<double>(beta);
    if (!(b > 0) || !std::isfinite(b)) {
      throw pvdf::InputError("identify: beta = " + std::to_string(b) + " must be a number > 0 (relative, seed 000 used 1e-4) or 'auto'");
    }
    d.beta = b;
    if (policy.empty()) policy = corner_wavelength_m > 0 ? "frequency" : "constant";
  }
  d.beta_policy = parse_policy(policy);
  std::vector<r::IdentificationScan> id;
  for (const auto& item : scans) {
    const auto t = item.cast<py::tuple>();
    if (t.size() != 4) throw pvdf::InputError("identify: each scan is a tuple (Scan, fx_N, fz_N, edge_x_m)");
    r::IdentificationScan s;
    s.scan = t[0].cast<r::Scan>();
    s.fx_N = t[1].cast<double>();
    s.fz_N = t[2].cast<double>();
    s.edge_x_m = t[3].cast<double>();
    id.push_back(std::move(s));
  }
  py::gil_scoped_release release;
  const r::TransferMatrix transfer = r::identify_transfer(id, d);
  return r::design_inverse(transfer, id, d);
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
        py::arg("taps") = std::size_t(8192), py::arg("delay_samples") = -1L, py::arg("g_window") = std::size_t(0),
        py::arg("resolution_m") = 0.0, py::arg("low_cut_wavelength_m") = 0.0, py::arg("corner_wavelength_m") = 0.0,
        py::arg("window") = "tukey", py::arg("regularization") = "isotropic",
        R"doc(Identifies the 2x2 transfer matrix G from >= 2 scans of known forces (seed 000 eq. 6) and designs the
regularized inverse filters (eq. 4), as ``pvdfkit restore identify`` does.

scans: list of (Scan, fx_N, fz_N, edge_x_m): the forces (N) of a raised edge at world position
edge_x_m (m). beta: 'auto' (default, as the command: the beta minimizing the predicted mu error), a
relative regularization (seed 000: 1e-4), or 'predicted', 'gcv', 'lcurve', 'morozov', 'noise-floor'.
resolution_m: target Gaussian FWHM (m, 0 = none); low_cut_wavelength_m: damp longer wavelengths (m).
regularization: 'isotropic' (default, as the command: f_x and f_z blurred alike, mu unbiased) or
'tikhonov' (seed 000 eq. 4).)doc");
  m.def("load_filter", &r::load_filter, py::arg("path"), "Reads a filter JSON written by save_filter or `pvdfkit restore identify`.");
  m.def("save_filter", &r::save_filter, py::arg("path"), py::arg("filter"), "Writes a filter as JSON, atomically.");
  m.def("apply", [](const r::InverseFilter& filter, const r::Scan& scan, double mu_threshold_N, std::size_t block_samples) {
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
        py::arg("filter"), py::arg("scan"), py::arg("mu_threshold_N") = -1.0, py::arg("block_samples") = std::size_t(0),
        "Restores f_x, f_z (N per sample) and mu from a scan (as `pvdfkit restore apply`). mu_threshold_N < 0: 30 % of "
        "the largest restored f_z. block_samples > 0: the streaming restorer in blocks of that size. Returns RestoredForces.");
}

}  // namespace

void bind_restore(py::module_& m) {
  bind_scan(m);
  bind_filter(m);
}

}  // namespace pvdf::python
