// The cylindrical scanner of seed 000 as a simulator: a JSON scene (sensor, scan, acquisition chain,
// surface), line loads from raised edges and textures, and the two strip signals a scan records.
#pragma once

#include "pvdf/restore/physics.hpp"

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace pvdf::restore {

/// A raised edge (seed 000 Fig. 6): a concentrated contact force at world position x_m.
struct Edge {
  double x_m = 0;
  double fx_N = 0;  ///< drag (opposes the motion)
  double fz_N = 0;  ///< normal, pressing
};

/// A texture: ridges of Hann-shaped contact pressure, one every `period_m` from x_start_m to x_end_m,
/// each `ridge_width_m` wide and carrying the normal force fz_N; the friction coefficient varies
/// linearly from mu_start to mu_end along the texture, f_x(x) = mu(x) f_z(x).
struct Texture {
  double x_start_m = 0, x_end_m = 0, period_m = 0, ridge_width_m = 0, fz_N = 0;
  double mu_start = 0, mu_end = 0;
};

/// A scanner scene (`pvdfkit restore simulate SCENE`); keys and defaults in docs/restore.md.
/// Defaults follow seed 000 Table 1: 10 kHz, 12-bit ADC, 50 mm/s (range 10-100 mm/s), 100 mm scan.
struct ScannerScene {
  Sensor sensor;
  double layer_thickness_m = 5e-3;  ///< silicone skin; the half-space model needs depth << thickness
  double x_start_m = -0.05, x_end_m = 0.05;  ///< scanner positions of the first and last sample
  double speed_m_per_s = 0.05;
  double sample_rate_Hz = 10000;
  int adc_bits = 12;                 ///< 0 = no quantization
  double adc_range_V = 5;            ///< ADC input range [-range, +range]; clipped outside
  double noise_V = 0.002;            ///< rms white noise at the ADC input
  int moving_average_samples = 8;    ///< causal moving average after the ADC (1 = none)
  std::uint64_t seed = 1;
  std::vector<Edge> edges;
  std::vector<Texture> textures;
  std::string source = "(built-in)";
  std::vector<std::string> warnings;

  double sample_spacing_m() const { return speed_m_per_s / sample_rate_Hz; }
  std::size_t n_samples() const;
};

/// The built-in scene: seed 000 Table 1 defaults, a horizontal strip (k = 23, 3, -33 pC/N) and a
/// vertical one (k = -33, 23, 3 pC/N), both 1 mm deep, 1.5 mm apart; no surface loads.
ScannerScene default_scanner_scene();
/// Parses a scene strictly (unknown keys, wrong types, out-of-range values throw InputError naming the key).
ScannerScene parse_scanner_scene(const nlohmann::json& json, const std::string& source);
ScannerScene load_scanner_scene(const std::string& path);

/// A recorded scan on a uniform grid: scanner position x_m[n] = x0 + n dx, the two conditioned strip
/// signals, and (when known, e.g. from the simulator or a force/torque sensor) the surface force per
/// sample at world position x_m[n].
struct Scan {
  std::vector<double> x_m, m1_V, m2_V;
  std::vector<double> fx_N, fz_N;  ///< reference forces per sample (empty when unknown)
  double sample_spacing_m() const;
  std::size_t size() const { return x_m.size(); }
  /// Largest |m1| and |m2| (V): what the ADC must hold.
  double peak_m1_V() const;
  double peak_m2_V() const;
  std::string source;
};

/// Which stages of the acquisition chain the simulator applies.
struct SimulateOptions {
  bool noise = true;
  bool adc = true;
  bool moving_average = true;
};

/// The surface force per sample (N) at world positions x_m (a uniform grid): edges put their force
/// on the nearest sample, textures integrate their pressure over each sample.
void surface_forces(const ScannerScene& scene, const std::vector<double>& x_m, std::vector<double>& fx_N,
                    std::vector<double>& fz_N);

/// Simulates a scan: strip signals from the closed-form stress-rate responses (edges evaluated at their
/// exact positions, textures by convolution with the sampled response), white noise, ADC, moving average.
Scan simulate_scan(const ScannerScene& scene, const SimulateOptions& options = {});

/// The analytic discrete transfer from the force per sample to the conditioned signals: g[i][j][l] is the
/// response of strip i (0, 1) to a unit force j (0 = x, 1 = z) l + lag_min samples earlier (lag = signal
/// sample minus force sample), including the moving average; what identification must recover.
std::array<std::array<std::vector<double>, 2>, 2> analytic_impulse_responses(const ScannerScene& scene,
                                                                              long lag_min, std::size_t n,
                                                                              bool moving_average = true);

}  // namespace pvdf::restore
