// The flat-surface level: a stress-rate sensor is blind to the steady load (G(0) = 0) and the inverse
// filter damps the longest wavelengths, so a restored feature sits in a shallow trough carrying its
// missing mean. Where the surface is flat the excess load is zero: that fixes the integration constant
// (and the missing long wavelengths) as a smooth curve through the flat samples.
#include "pvdf/core/constants.hpp"

#include "baseline.hpp"

#include "fft.hpp"

#include <algorithm>
#include <cmath>
#include <complex>

namespace pvdf::restore::detail {

namespace {

// Gaussian smoothing (standard deviation sigma samples) by FFT linear convolution, zero outside.
std::vector<double> smooth(const std::vector<double>& v, double sigma) {
  const std::size_t n = v.size();
  const auto half = static_cast<std::size_t>(std::ceil(5 * sigma));
  detail::RealFft fft(detail::good_fft_size(n + 2 * half + 1));
  const std::size_t L = fft.size();
  std::vector<std::complex<double>> V(fft.bins());
  fft.forward(v.data(), n, V.data());
  for (std::size_t k = 0; k < V.size(); ++k) {
    const double w = 2 * pi * static_cast<double>(k) / static_cast<double>(L);
    V[k] *= std::exp(-0.5 * w * w * sigma * sigma);
  }
  std::vector<double> out(L);
  fft.inverse(V.data(), out.data());
  out.resize(n);
  return out;
}

// Weighted smoothing: smooth(w f) / smooth(w); where the flat samples are too far (weight < 5 %), a
// four times wider kernel bridges the gap.
std::vector<double> weighted(const std::vector<double>& f, const std::vector<double>& w, double sigma) {
  const std::size_t n = f.size();
  std::vector<double> wf(n);
  for (std::size_t i = 0; i < n; ++i) wf[i] = w[i] * f[i];
  const auto a = smooth(wf, sigma), b = smooth(w, sigma);
  std::vector<double> a4, b4;
  std::vector<double> out(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    if (b[i] > 0.05) {
      out[i] = a[i] / b[i];
      continue;
    }
    if (a4.empty()) {
      a4 = smooth(wf, 4 * sigma);
      b4 = smooth(w, 4 * sigma);
    }
    out[i] = b4[i] > 1e-9 ? a4[i] / b4[i] : 0.0;
  }
  return out;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<long>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

void fit_flat_baseline(RestoredForces& r, double scale_m, double resolution_m) {
  const std::size_t n = r.fz_N_per_m.size();
  const double dx = r.sample_spacing_m;
  const double sigma = std::max(2.0, scale_m / dx);
  const auto guard = static_cast<long>(std::max(3.0, 2 * resolution_m / dx));
  double peak = 0;
  for (double v : r.fz_N_per_m) peak = std::max(peak, std::abs(v));
  std::vector<double> w(n, 1.0);
  std::vector<double> bz = weighted(r.fz_N_per_m, w, sigma);
  for (int pass = 0; pass < 4; ++pass) {
    std::vector<double> res(n);
    for (std::size_t i = 0; i < n; ++i) res[i] = r.fz_N_per_m[i] - bz[i];
    std::vector<double> dev(n);
    const double m = median(res);
    for (std::size_t i = 0; i < n; ++i) dev[i] = std::abs(res[i] - m);
    const double noise = 1.4826 * median(dev);
    const double tol = std::max(2.5 * noise, 0.02 * peak);
    // Not flat: beyond the tolerance; flat samples must also be `guard` samples from any such sample.
    std::vector<double> flat(n, 1.0);
    long last_bad = -(guard + 1);
    for (std::size_t i = 0; i < n; ++i) {
      if (std::abs(res[i]) > tol) last_bad = static_cast<long>(i);
      if (static_cast<long>(i) - last_bad <= guard) flat[i] = 0.0;
    }
    last_bad = static_cast<long>(n) + guard + 1;
    for (std::size_t j = n; j-- > 0;) {
      if (std::abs(res[j]) > tol) last_bad = static_cast<long>(j);
      if (last_bad - static_cast<long>(j) <= guard) flat[j] = 0.0;
    }
    double count = 0;
    for (double v : flat) count += v;
    if (count < 0.05 * static_cast<double>(n)) break;  // nothing flat enough: keep the previous pass
    w = flat;
    bz = weighted(r.fz_N_per_m, w, sigma);
  }
  double count = 0;
  for (double v : w) count += v;
  r.flat_fraction = count / static_cast<double>(n);
  r.baseline_fz_N_per_m = bz;
  r.baseline_fx_N_per_m = weighted(r.fx_N_per_m, w, sigma);
}

}  // namespace pvdf::restore::detail
