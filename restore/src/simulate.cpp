// The forward simulator: surface loads -> closed-form strip stress-rate signals -> noise, ADC, moving average.
#include "fft.hpp"
#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/restore/scanner.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <random>

namespace pvdf::restore {

namespace {

double signal_per_N(const ScannerScene& s, int strip, int component, double x_rel_m) {
  return strip_signal_per_N(s.sensor.strips[strip], s.sensor.poisson_ratio, s.sensor.feedback_resistance_ohm,
                            s.speed_m_per_s, component == 0 ? ForceComponent::x : ForceComponent::z, x_rel_m);
}


}  // namespace

double Scan::sample_spacing_m() const {
  if (x_m.size() < 2) return 0.0;
  return (x_m.back() - x_m.front()) / static_cast<double>(x_m.size() - 1);
}

namespace {
double largest_abs(const std::vector<double>& v) {
  double largest = 0;
  for (const double x : v)
    if (std::abs(x) > largest) largest = std::abs(x);
  return largest;
}
}  // namespace

double Scan::peak_m1_V() const { return largest_abs(m1_V); }
double Scan::peak_m2_V() const { return largest_abs(m2_V); }

void surface_forces(const ScannerScene& scene, const std::vector<double>& x_m, std::vector<double>& fx_N,
                    std::vector<double>& fz_N) {
  const std::size_t n = x_m.size();
  fx_N.assign(n, 0.0);
  fz_N.assign(n, 0.0);
  if (n < 2) return;
  const double x0 = x_m.front();
  const double dx = (x_m.back() - x_m.front()) / static_cast<double>(n - 1);
  for (const auto& e : scene.edges) {
    const double k = std::round((e.x_m - x0) / dx);
    if (k < 0 || k > static_cast<double>(n - 1)) continue;
    fx_N[static_cast<std::size_t>(k)] += e.fx_N;
    fz_N[static_cast<std::size_t>(k)] += e.fz_N;
  }
  for (const auto& t : scene.textures) {
    const double w = t.ridge_width_m;
    // Primitive of the Hann pressure (F/w)(1 - cos(2 pi (x - a)/w)) on [a, a + w].
    auto primitive = [&](double a, double x) {
      const double s = std::clamp(x, a, a + w) - a;
      return (t.fz_N / w) * (s - w / (2 * pi) * std::sin(2 * pi * s / w));
    };
    for (double a = t.x_start_m; a + w <= t.x_end_m + 1e-12; a += t.period_m) {
      const long k_lo = std::max(0L, static_cast<long>(std::floor((a - x0) / dx)) - 1);
      const long k_hi = std::min(static_cast<long>(n) - 1, static_cast<long>(std::ceil((a + w - x0) / dx)) + 1);
      for (long k = k_lo; k <= k_hi; ++k) {
        const double xc = x0 + static_cast<double>(k) * dx;
        const double f = primitive(a, xc + dx / 2) - primitive(a, xc - dx / 2);
        if (f == 0.0) continue;
        const double frac = std::clamp((xc - t.x_start_m) / (t.x_end_m - t.x_start_m), 0.0, 1.0);
        const double mu = t.mu_start + (t.mu_end - t.mu_start) * frac;
        fz_N[static_cast<std::size_t>(k)] += f;
        fx_N[static_cast<std::size_t>(k)] += mu * f;
      }
    }
  }
}

std::array<std::array<std::vector<double>, 2>, 2> analytic_impulse_responses(const ScannerScene& scene, long lag_min,
                                                                              std::size_t n, bool moving_average) {
  const int w = moving_average ? std::max(1, scene.moving_average_samples) : 1;
  const double dx = scene.sample_spacing_m();
  std::array<std::array<std::vector<double>, 2>, 2> g;
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < 2; ++j) {
      g[i][j].assign(n, 0.0);
      for (std::size_t l = 0; l < n; ++l) {
        double sum = 0;
        for (int m = 0; m < w; ++m) {
          const double lag = static_cast<double>(lag_min + static_cast<long>(l) - m);
          sum += signal_per_N(scene, i, j, lag * dx + scene.sensor.strips[i].offset_m);
        }
        g[i][j][l] = sum / w;
      }
    }
  }
  return g;
}

Scan simulate_scan(const ScannerScene& scene, const SimulateOptions& options) {
  const std::size_t n = scene.n_samples();
  const double dx = scene.sample_spacing_m();
  Scan scan;
  scan.source = scene.source;
  scan.x_m.resize(n);
  for (std::size_t k = 0; k < n; ++k) scan.x_m[k] = scene.x_start_m + static_cast<double>(k) * dx;
  surface_forces(scene, scan.x_m, scan.fx_N, scan.fz_N);

  std::array<std::vector<double>, 2> v{std::vector<double>(n, 0.0), std::vector<double>(n, 0.0)};
  // 1. Edges: the closed form at the exact edge position (x_rel = scanner + strip offset - edge).
  for (const auto& e : scene.edges) {
    for (int i = 0; i < 2; ++i) {
      for (std::size_t k = 0; k < n; ++k) {
        const double x_rel = scan.x_m[k] + scene.sensor.strips[i].offset_m - e.x_m;
        v[i][k] += e.fx_N * signal_per_N(scene, i, 0, x_rel) + e.fz_N * signal_per_N(scene, i, 1, x_rel);
      }
    }
  }
  // 2. Textures: convolution of the per-sample texture force with the sampled response.
  if (!scene.textures.empty()) {
    ScannerScene only_textures = scene;
    only_textures.edges.clear();
    std::vector<double> fx, fz;
    surface_forces(only_textures, scan.x_m, fx, fz);
    const long lag_min = -static_cast<long>(n - 1);
    const auto g = analytic_impulse_responses(scene, lag_min, 2 * n - 1, false);
    for (int i = 0; i < 2; ++i) {
      const auto yx = detail::linear_convolution(fx, g[i][0]);
      const auto yz = detail::linear_convolution(fz, g[i][1]);
      // y[m] = sum_k f[k] g[m - k] with g index m - k = lag - lag_min: signal sample s = m + lag_min.
      for (std::size_t k = 0; k < n; ++k) v[i][k] += yx[k + n - 1] + yz[k + n - 1];
    }
  }
  // 3. Acquisition chain (seed 000 Table 1): white noise, 12-bit ADC, moving average.
  std::mt19937_64 rng(scene.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int i = 0; i < 2; ++i) {
    for (std::size_t k = 0; k < n; ++k) {
      double value = v[i][k];
      if (options.noise && scene.noise_V > 0) value += scene.noise_V * normal(rng);
      if (options.adc && scene.adc_bits > 0) {
        const double half_codes = std::ldexp(1.0, scene.adc_bits - 1);
        const double lsb = scene.adc_range_V / half_codes;
        const double code = std::clamp(std::round(value / lsb), -half_codes, half_codes - 1);
        value = code * lsb;
      }
      v[i][k] = value;
    }
    if (options.moving_average && scene.moving_average_samples > 1) {
      const int w = scene.moving_average_samples;
      std::vector<double> out(n);
      double running = 0;
      for (std::size_t k = 0; k < n; ++k) {
        running += v[i][k];
        if (k >= static_cast<std::size_t>(w)) running -= v[i][k - w];
        out[k] = running / w;
      }
      v[i] = std::move(out);
    }
  }
  scan.m1_V = std::move(v[0]);
  scan.m2_V = std::move(v[1]);
  return scan;
}

}  // namespace pvdf::restore
