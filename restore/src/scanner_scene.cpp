// Strict parsing of scanner scenes (docs/restore.md lists every key, its unit and default).
#include "pvdf/core/error.hpp"
#include "pvdf/core/json_reader.hpp"
#include "pvdf/restore/scanner.hpp"

#include <cmath>
#include <sstream>

namespace pvdf::restore {

std::size_t ScannerScene::n_samples() const {
  return static_cast<std::size_t>(std::floor((x_end_m - x_start_m) / sample_spacing_m() + 1e-9)) + 1;
}

ScannerScene default_scanner_scene() {
  ScannerScene s;
  s.sensor.strips[0].depth_m = 1.0e-3;
  s.sensor.strips[0].offset_m = 0.0;
  // Strip 2 stands vertically (poled along x): a different (k1', k3') pair makes G invertible
  // (docs/restore.md section 1); a lateral offset alone would not.
  s.sensor.strips[1].depth_m = 1.0e-3;
  s.sensor.strips[1].offset_m = 1.5e-3;
  s.sensor.strips[1].k1_C_per_N = -33e-12;
  s.sensor.strips[1].k2_C_per_N = 23e-12;
  s.sensor.strips[1].k3_C_per_N = 3e-12;
  return s;
}

namespace {

Strip parse_strip(const JsonObjectReader& r, const Strip& fallback, double thickness_m) {
  Strip s = fallback;
  s.depth_m = r.positive_or("depth_m", s.depth_m);
  if (s.depth_m >= thickness_m) r.fail("depth_m", "must be < layer.thickness_m = " + std::to_string(thickness_m));
  s.offset_m = r.in_range_or("offset_m", s.offset_m, -0.05, 0.05);
  s.width_m = r.positive_or("width_m", s.width_m);
  s.length_m = r.positive_or("length_m", s.length_m);
  s.k1_C_per_N = r.number_or("k1_C_per_N", s.k1_C_per_N);
  s.k2_C_per_N = r.number_or("k2_C_per_N", s.k2_C_per_N);
  s.k3_C_per_N = r.number_or("k3_C_per_N", s.k3_C_per_N);
  if (std::abs(s.k1_C_per_N) > 1e-9 || std::abs(s.k2_C_per_N) > 1e-9 || std::abs(s.k3_C_per_N) > 1e-9) {
    r.fail("k1_C_per_N", "(or k2, k3) is implausibly large; piezoelectric constants are ~1e-11 C/N (PVDF d33 = -33e-12)");
  }
  r.finish();
  return s;
}

}  // namespace

ScannerScene parse_scanner_scene(const nlohmann::json& json, const std::string& source) {
  ScannerScene s = default_scanner_scene();
  s.source = source;
  const JsonObjectReader top(source, "", json);
  top.string_or("description", "");
  if (auto layer = top.object_if("layer")) {
    s.sensor.poisson_ratio = layer->in_range_or("poisson_ratio", s.sensor.poisson_ratio, 0.0, 0.5);
    s.layer_thickness_m = layer->positive_or("thickness_m", s.layer_thickness_m);
    layer->finish();
  }
  if (auto sensor = top.object_if("sensor")) {
    s.sensor.feedback_resistance_ohm = sensor->positive_or("feedback_resistance_ohm", s.sensor.feedback_resistance_ohm);
    const auto strips = sensor->objects("strips");
    if (sensor->has("strips") && strips.size() != 2) {
      sensor->fail("strips", "must list exactly 2 strips (the scanner has two PVDF strips, seed 000 Fig. 9)");
    }
    for (std::size_t i = 0; i < strips.size(); ++i) s.sensor.strips[i] = parse_strip(strips[i], s.sensor.strips[i], s.layer_thickness_m);
    sensor->finish();
  }
  if (auto scan = top.object_if("scan")) {
    s.x_start_m = scan->in_range_or("x_start_m", s.x_start_m, -1.0, 1.0);
    s.x_end_m = scan->in_range_or("x_end_m", s.x_end_m, -1.0, 1.0);
    if (s.x_end_m <= s.x_start_m) scan->fail("x_end_m", "must be > scan.x_start_m = " + std::to_string(s.x_start_m));
    s.speed_m_per_s = scan->positive_or("speed_m_per_s", s.speed_m_per_s);
    if (s.speed_m_per_s < 0.01 || s.speed_m_per_s > 0.1) {
      s.warnings.push_back(source + ": scan.speed_m_per_s = " + std::to_string(s.speed_m_per_s) +
                           " is outside seed 000 Table 1's range 0.01-0.1 m/s");
    }
    scan->finish();
  }
  if (auto acq = top.object_if("acquisition")) {
    s.sample_rate_Hz = acq->positive_or("sample_rate_Hz", s.sample_rate_Hz);
    s.adc_bits = static_cast<int>(acq->integer_or("adc_bits", s.adc_bits, 0, 24));
    s.adc_range_V = acq->positive_or("adc_range_V", s.adc_range_V);
    s.noise_V = acq->non_negative_or("noise_V", s.noise_V);
    s.moving_average_samples = static_cast<int>(acq->integer_or("moving_average_samples", s.moving_average_samples, 1, 1000));
    s.seed = static_cast<std::uint64_t>(acq->integer_or("seed", static_cast<long>(s.seed), 0, 2147483647L));
    acq->finish();
  }
  if (s.n_samples() > 20000000) {
    top.fail_object("describes " + std::to_string(s.n_samples()) +
                    " samples (scan length / (speed / sample_rate_Hz)); keep it below 2e7");
  }
  if (s.n_samples() < 64) top.fail_object("describes fewer than 64 samples; lengthen the scan or raise sample_rate_Hz");
  if (auto surface = top.object_if("surface")) {
    for (const auto& e : surface->objects("edges")) {
      Edge edge;
      edge.x_m = e.number("x_m");
      edge.fx_N = e.number("fx_N");
      edge.fz_N = e.number("fz_N");
      e.finish();
      s.edges.push_back(edge);
    }
    for (const auto& t : surface->objects("textures")) {
      Texture tex;
      tex.x_start_m = t.number("x_start_m");
      tex.x_end_m = t.number("x_end_m");
      if (tex.x_end_m <= tex.x_start_m) t.fail("x_end_m", "must be > x_start_m");
      tex.period_m = t.positive("period_m");
      tex.ridge_width_m = t.positive("ridge_width_m");
      if (tex.ridge_width_m > tex.period_m) t.fail("ridge_width_m", "must be <= period_m");
      if (tex.ridge_width_m < 2 * s.sample_spacing_m()) {
        t.fail("ridge_width_m", "must span at least 2 samples (sample spacing = speed / sample_rate = " +
                                    std::to_string(s.sample_spacing_m()) + " m)");
      }
      tex.fz_N = t.number("fz_N");
      tex.mu_start = t.number("mu_start");
      tex.mu_end = t.number_or("mu_end", tex.mu_start);
      t.finish();
      s.textures.push_back(tex);
    }
    surface->finish();
  }
  top.finish();
  return s;
}

ScannerScene load_scanner_scene(const std::string& path) { return parse_scanner_scene(read_json_file(path), path); }

}  // namespace pvdf::restore
