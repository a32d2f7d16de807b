// The filter file: self-describing JSON (format in docs/restore.md), written atomically, read strictly.
#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/json_reader.hpp"
#include "pvdf/restore/filter.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <set>

namespace pvdf::restore {

namespace {
const char* const format_name = "pvdfkit-restore-filter";
const char* const h_names[2][2] = {{"h11", "h12"}, {"h21", "h22"}};
const char* const g_names[2][2] = {{"g11", "g12"}, {"g21", "g22"}};
constexpr double max_tap = 1e12;

std::vector<double> taps_of(const std::string& source, const nlohmann::json& j, const std::string& key,
                            std::size_t n) {
  if (!j.contains(key)) throw InputError(source + ": " + key + " is missing; it is required (docs/restore.md)");
  const auto& a = j.at(key);
  if (!a.is_array() || a.size() != n) {
    throw InputError(source + ": " + key + " must be an array of " + std::to_string(n) + " numbers (taps); it is " +
                     (a.is_array() ? "an array of " + std::to_string(a.size()) : std::string("not an array")));
  }
  std::vector<double> out(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (!a[i].is_number() || !std::isfinite(a[i].get<double>())) {
      throw InputError(source + ": " + key + "[" + std::to_string(i) + "] = " + json_excerpt(a[i]) +
                       " must be a finite number; regenerate the filter with 'pvdfkit restore identify'");
    }
    // A tap of 1e12 N/V would turn a microvolt of noise into a meganewton: no identified filter comes near.
    if (std::abs(a[i].get<double>()) > max_tap) {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%g", a[i].get<double>());
      throw InputError(source + ": " + key + "[" + std::to_string(i) + "] = " + buf +
                       " must be within +-1e+12 (N/V for filter taps, V/N for G); regenerate the filter with "
                       "'pvdfkit restore identify'");
    }
    out[i] = a[i].get<double>();
  }
  return out;
}
}  // namespace

void save_filter(const std::string& path, const InverseFilter& f) {
  nlohmann::json j;
  j["format"] = format_name;
  j["format_version"] = 1;
  j["pvdfkit_version"] = f.pvdfkit_version;
  j["description"] = "2x2 inverse FIR filter: f[n] = sum_t h[t] m[n + D - t] (D = delay_samples); f_x from h11*m1 + "
                     "h12*m2, f_z from h21*m1 + h22*m2; forces in N per sample at the scan's x_m (divide by sample_spacing_m for N/m)";
  j["sample_spacing_m"] = f.sample_spacing_m;
  j["taps"] = f.taps;
  j["delay_samples"] = f.delay_samples;
  j["design_fft_length"] = f.design_fft_length;
  j["window"] = f.window;
  j["resolution_m"] = f.resolution_m;
  j["effective_depth_m"] = f.effective_depth_m;
  j["beta"] = {{"policy", f.beta_policy}, {"regularization", f.regularization}, {"relative", f.beta}, {"absolute_V2_per_N2", f.beta_abs},
               {"corner_wavelength_m", f.corner_wavelength_m}, {"low_cut_wavelength_m", f.low_cut_wavelength_m}};
  nlohmann::json gcv = nlohmann::json::array();
  for (const auto& [b, v] : f.gcv_curve) gcv.push_back({b, v});
  j["beta"]["gcv_curve"] = gcv;
  j["beta"]["reason"] = f.beta_reason;
  j["beta"]["selection_criterion"] = f.selection_criterion;
  nlohmann::json sel = nlohmann::json::array();
  for (const auto& [b, v] : f.selection_curve) sel.push_back({b, v});
  j["beta"]["selection_curve"] = sel;
  j["conditioning"] = {{"G_cond_min", f.conditioning.min},
                       {"G_cond_median", f.conditioning.median},
                       {"G_cond_max", f.conditioning.max},
                       {"band_fraction", f.conditioning.band_fraction},
                       {"force_matrix_cond", f.transfer.force_condition_number},
                       {"truncated_energy_fraction", f.truncated_energy_fraction},
                       {"peak_fraction", f.peak_fraction},
                       {"lobe_force_fraction", f.lobe_force_fraction}};
  nlohmann::json id = nlohmann::json::array();
  for (std::size_t s = 0; s < f.transfer.forces.size(); ++s) {
    id.push_back({{"fx_N", f.transfer.forces[s][0]}, {"fz_N", f.transfer.forces[s][1]},
                  {"edge_x_m", f.transfer.forces[s][2]},
                  {"snr", s < f.transfer.scan_snr.size() ? f.transfer.scan_snr[s] : 0.0}});
  }
  j["identification"] = {{"scans", id},
                         {"noise_rms_V", {f.transfer.noise_rms_V[0], f.transfer.noise_rms_V[1]}},
                         {"noise_psd_V2", {f.transfer.noise_psd_V2[0], f.transfer.noise_psd_V2[1]}},
                         {"g_noise_power_V2_per_N2", f.transfer.g_noise_power},
                         {"g_lag_min", f.transfer.lag_min}};
  for (int i = 0; i < 2; ++i)
    for (int k = 0; k < 2; ++k) {
      j["filters"][h_names[i][k]] = f.h[i][k];
      j["identification"][g_names[i][k]] = f.transfer.g[i][k];
    }
  write_file_atomically(path, [&](std::ostream& out) { out << j.dump(1) << '\n'; });
}

InverseFilter load_filter(const std::string& path) {
  const nlohmann::json j = read_json_file(path);
  const JsonObjectReader top(path, "", j);
  if (top.string("format") != format_name) top.fail("format", std::string("must be \"") + format_name + "\"");
  if (top.integer_or("format_version", 0, 0, 1000) != 1) top.fail("format_version", "must be 1 (this pvdfkit reads version 1)");
  InverseFilter f;
  f.pvdfkit_version = top.string_or("pvdfkit_version", "");
  top.string_or("description", "");
  f.sample_spacing_m = top.in_range_or("sample_spacing_m", 0, 1e-9, 1);
  if (!(f.sample_spacing_m > 0)) top.fail("sample_spacing_m", "is missing; it must be in [1e-9, 1] m");
  f.taps = static_cast<std::size_t>(top.integer_or("taps", 0, 2, 1L << 24));
  if (f.taps < 2) top.fail("taps", "is missing or < 2");
  f.delay_samples = top.integer_or("delay_samples", -1, 0, static_cast<long>(f.taps) - 1);
  if (f.delay_samples < 0) top.fail("delay_samples", "is missing; it must be in [0, taps)");
  f.design_fft_length = static_cast<std::size_t>(top.integer_or("design_fft_length", 0, 0, 1L << 26));
  f.window = top.choice_or("window", "tukey", {"tukey", "hann", "none"});
  f.resolution_m = top.in_range_or("resolution_m", 0, 0, 1);
  f.effective_depth_m = top.in_range_or("effective_depth_m", 0, 0, 1);
  const auto beta = top.object("beta");
  f.beta_policy = beta.choice_or("policy", "constant", {"constant", "frequency", "gcv", "discrepancy", "lcurve", "morozov", "predicted"});
  f.regularization = beta.choice_or("regularization", "tikhonov", {"isotropic", "tikhonov"});
  f.beta = beta.non_negative_or("relative", 0);
  f.beta_abs = beta.non_negative_or("absolute_V2_per_N2", 0);
  f.corner_wavelength_m = beta.non_negative_or("corner_wavelength_m", 0);
  f.low_cut_wavelength_m = beta.non_negative_or("low_cut_wavelength_m", 0);
  if (beta.has("gcv_curve")) {
    for (const auto& p : beta.points("gcv_curve", 0)) f.gcv_curve.emplace_back(p[0], p[1]);
  }
  f.beta_reason = beta.string_or("reason", "");
  f.selection_criterion = beta.string_or("selection_criterion", "");
  if (beta.has("selection_curve")) {
    for (const auto& p : beta.points("selection_curve", 0)) f.selection_curve.emplace_back(p[0], p[1]);
  }
  beta.finish();
  if (auto c = top.object_if("conditioning")) {
    f.conditioning.min = c->non_negative_or("G_cond_min", 0);
    f.conditioning.median = c->non_negative_or("G_cond_median", 0);
    f.conditioning.max = c->non_negative_or("G_cond_max", 0);
    f.conditioning.band_fraction = c->in_range_or("band_fraction", 0, 0, 1);
    f.transfer.force_condition_number = c->non_negative_or("force_matrix_cond", 0);
    f.truncated_energy_fraction = c->in_range_or("truncated_energy_fraction", 0, 0, 1);
    f.peak_fraction = c->non_negative_or("peak_fraction", 0);
    f.lobe_force_fraction = c->in_range_or("lobe_force_fraction", 0, -10, 10);
    c->finish();
  }
  // Tap arrays are read here (the reader marks them used through object_if/has checks below).
  const auto filters = top.object("filters");
  for (int i = 0; i < 2; ++i)
    for (int k = 0; k < 2; ++k) f.h[i][k] = taps_of(path + ": filters", filters.json(), h_names[i][k], f.taps);
  for (auto it = filters.json().begin(); it != filters.json().end(); ++it) {
    static const std::set<std::string> known = {"h11", "h12", "h21", "h22"};
    if (!known.count(it.key())) filters.fail(it.key(), "is an unknown key; filters holds h11, h12, h21, h22");
  }
  if (top.has("identification")) try {
    const auto& id = j.at("identification");
    top.object("identification");  // marks it used; its contents are informative
    if (!id.is_object()) top.fail("identification", "must be an object");
    if (id.contains("g_lag_min") && id.at("g_lag_min").is_number_integer()) f.transfer.lag_min = id.at("g_lag_min").get<long>();
    if (id.contains("noise_rms_V") && id.at("noise_rms_V").is_array() && id.at("noise_rms_V").size() == 2) {
      f.transfer.noise_rms_V = {id.at("noise_rms_V")[0].get<double>(), id.at("noise_rms_V")[1].get<double>()};
    }
    for (int i = 0; i < 2; ++i)
      for (int k = 0; k < 2; ++k)
        if (id.contains(g_names[i][k])) {
          f.transfer.g[i][k] = taps_of(path + ": identification", id, g_names[i][k], id.at(g_names[i][k]).size());
        }
    if (id.contains("scans") && id.at("scans").is_array()) {
      for (const auto& s : id.at("scans")) {
        if (s.is_object() && s.contains("fx_N") && s.contains("fz_N") && s.contains("edge_x_m")) {
          f.transfer.forces.push_back({s.at("fx_N").get<double>(), s.at("fz_N").get<double>(), s.at("edge_x_m").get<double>()});
        }
      }
    }
  } catch (const nlohmann::json::exception& e) {
    throw InputError(path + ": identification has a value of the wrong type (" + e.what() +
                     "); regenerate the filter with 'pvdfkit restore identify'");
  }
  top.finish();
  f.transfer.sample_spacing_m = f.sample_spacing_m;
  return f;
}

}  // namespace pvdf::restore
