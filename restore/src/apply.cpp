// Offline and streaming application of the inverse filters.
#include "pvdf/restore/apply.hpp"

#include "baseline.hpp"
#include "fft.hpp"
#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace pvdf::restore {

using cd = std::complex<double>;

void restore_offline(const InverseFilter& f, const std::vector<double>& m1, const std::vector<double>& m2,
                     std::vector<double>& fx, std::vector<double>& fz) {
  if (m1.size() != m2.size() || m1.empty()) {
    throw InputError("restore: the two signals have " + std::to_string(m1.size()) + " and " + std::to_string(m2.size()) +
                     " samples; they must be equal and non-empty");
  }
  const std::size_t n = m1.size(), N = f.taps;
  const auto D = static_cast<std::size_t>(f.delay_samples);
  // Linear convolution length n + N - 1 >= n + D: no circular wrap-around reaches the kept samples.
  detail::RealFft fft(detail::good_fft_size(n + N - 1));
  const std::size_t B = fft.bins();
  std::vector<cd> M1(B), M2(B), H(B), Y0(B, 0.0), Y1(B, 0.0);
  fft.forward(m1.data(), n, M1.data());
  fft.forward(m2.data(), n, M2.data());
  const std::vector<cd>* M[2] = {&M1, &M2};
  std::vector<cd>* Y[2] = {&Y0, &Y1};
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      fft.forward(f.h[i][j].data(), N, H.data());
      for (std::size_t k = 0; k < B; ++k) (*Y[i])[k] += H[k] * (*M[j])[k];
    }
  std::vector<double> y(fft.size());
  fx.resize(n);
  fz.resize(n);
  fft.inverse(Y0.data(), y.data());
  std::copy(y.begin() + static_cast<long>(D), y.begin() + static_cast<long>(D + n), fx.begin());
  fft.inverse(Y1.data(), y.data());
  std::copy(y.begin() + static_cast<long>(D), y.begin() + static_cast<long>(D + n), fz.begin());
}

void friction_coefficient(RestoredForces& r, double threshold) {
  r.mu_threshold_N = threshold;
  r.mu.assign(r.fz_N.size(), 0.0);
  r.mu_valid.assign(r.fz_N.size(), 0);
  for (std::size_t i = 0; i < r.fz_N.size(); ++i) {
    if (r.fz_N[i] > threshold && r.fz_N[i] > 0) {
      r.mu[i] = r.fx_N[i] / r.fz_N[i];
      r.mu_valid[i] = 1;
    }
  }
}

RestoredForces restore_scan(const InverseFilter& f, const Scan& scan, const RestoreOptions& options) {
  const double dx = scan.sample_spacing_m();
  if (std::abs(dx - f.sample_spacing_m) > 0.01 * f.sample_spacing_m) {
    std::ostringstream msg;
    msg << scan.source << ": sample spacing " << dx << " m differs from the filter's " << f.sample_spacing_m
        << " m by more than 1 %; scan at the identification speed and rate, identify a new filter, or resample the "
           "scan onto the filter's grid";
    throw InputError(msg.str());
  }
  RestoredForces r;
  r.x_m = scan.x_m;
  restore_offline(f, scan.m1_V, scan.m2_V, r.fx_N, r.fz_N);
  finish_forces(f, r, options);
  return r;
}

RestoredForces restore_scan(const InverseFilter& f, const Scan& scan, double mu_threshold_N) {
  RestoreOptions o;
  o.mu_threshold_N = mu_threshold_N;
  return restore_scan(f, scan, o);
}

void finish_forces(const InverseFilter& f, RestoredForces& r, const RestoreOptions& o) {
  const std::size_t n = r.fx_N.size();
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(r.fx_N[i]) || !std::isfinite(r.fz_N[i])) {
      throw NumericalError("restore: the restored force at sample " + std::to_string(i) +
                           " is not finite; the filter's taps or the scan's signals are out of range");
    }
  }
  const double dx = r.x_m.size() >= 2 ? (r.x_m.back() - r.x_m.front()) / static_cast<double>(r.x_m.size() - 1)
                                      : f.sample_spacing_m;
  r.sample_spacing_m = dx;
  r.fx_N_per_m.resize(n);
  r.fz_N_per_m.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    r.fx_N_per_m[i] = r.fx_N[i] / dx;
    r.fz_N_per_m[i] = r.fz_N[i] / dx;
  }
  if (o.flat_baseline && n >= 16) {
    double scale = o.baseline_scale_m;
    if (!(scale > 0)) {
      scale = f.low_cut_wavelength_m > 0 ? f.low_cut_wavelength_m / (2 * pi)
                                         : std::max(1.5e-3, 4 * f.resolution_m);
    }
    detail::fit_flat_baseline(r, scale, f.resolution_m);
    for (std::size_t i = 0; i < n; ++i) {
      r.fx_N_per_m[i] -= r.baseline_fx_N_per_m[i];
      r.fz_N_per_m[i] -= r.baseline_fz_N_per_m[i];
      r.fx_N[i] = r.fx_N_per_m[i] * dx;
      r.fz_N[i] = r.fz_N_per_m[i] * dx;
    }
  }
  double threshold = o.mu_threshold_N;
  if (threshold < 0) {
    double peak = 0;
    for (double v : r.fz_N) peak = std::max(peak, v);
    threshold = 0.3 * peak;
  }
  friction_coefficient(r, threshold);
}

Scan resample_scan(const Scan& scan, double dx_new) {
  const double dx = scan.sample_spacing_m();
  if (!(dx > 0) || !(dx_new > 0)) throw InputError(scan.source + ": cannot resample a scan without a positive sample spacing");
  Scan out;
  out.source = scan.source;
  const double span = scan.x_m.back() - scan.x_m.front();
  const auto n = static_cast<std::size_t>(std::floor(span / dx_new + 1e-9)) + 1;
  if (n < 16 || n > (std::size_t{1} << 28)) {
    throw InputError(scan.source + ": resampling to " + std::to_string(dx_new) + " m gives " + std::to_string(n) +
                     " samples; it must give 16 .. 2^28");
  }
  const double gain = dx_new / dx;
  out.x_m.resize(n);
  out.m1_V.resize(n);
  out.m2_V.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const double x = scan.x_m.front() + static_cast<double>(k) * dx_new;
    const double p = (x - scan.x_m.front()) / dx;
    const auto i = std::min(static_cast<std::size_t>(p), scan.size() - 2);
    const double a = p - static_cast<double>(i);
    out.x_m[k] = x;
    out.m1_V[k] = gain * ((1 - a) * scan.m1_V[i] + a * scan.m1_V[i + 1]);
    out.m2_V[k] = gain * ((1 - a) * scan.m2_V[i] + a * scan.m2_V[i + 1]);
  }
  if (scan.fx_N.size() == scan.size() && scan.fz_N.size() == scan.size()) {
    out.fx_N.assign(n, 0.0);
    out.fz_N.assign(n, 0.0);
    for (std::size_t i = 0; i < scan.size(); ++i) {
      const auto k = std::min(n - 1, static_cast<std::size_t>(std::lround((scan.x_m[i] - scan.x_m.front()) / dx_new)));
      out.fx_N[k] += scan.fx_N[i];
      out.fz_N[k] += scan.fz_N[i];
    }
  }
  return out;
}

// Uniformly partitioned overlap-save: the N taps are cut into P = ceil(N / B) partitions of B taps; each
// block of B new samples costs two FFTs of 2B points (one per channel), 4 P spectrum products and two
// inverse FFTs, instead of FFTs of >= N + B points. A frequency-domain delay line keeps the last P input
// spectra of each channel.
struct StreamingRestorer::Impl {
  explicit Impl(std::size_t B) : fft(2 * B, true) {}
  detail::RealFft fft;
  std::size_t taps = 0, delay = 0, parts = 0;
  std::vector<std::vector<cd>> H[2][2];  // [force][signal][partition] spectra
  std::vector<std::vector<cd>> fdl[2];   // [signal][slot] input spectra
  std::size_t slot = 0;
  std::vector<double> in[2];             // previous block followed by the current block (2B)
  std::size_t filled = 0;                // new samples in the current block
  std::size_t to_skip = 0;               // outputs y[0..D) precede force sample 0
  std::size_t received = 0, emitted = 0;
  std::vector<cd> Y[2];
  std::vector<double> y;
};

StreamingRestorer::StreamingRestorer(const InverseFilter& f, std::size_t block_samples) : block_(block_samples) {
  if (block_samples < 1 || block_samples > (1u << 24)) {
    throw InputError("streaming block = " + std::to_string(block_samples) + " samples must be in [1, 16777216]");
  }
  if (f.taps < 1 || f.delay_samples < 0 || static_cast<std::size_t>(f.delay_samples) >= f.taps) {
    throw InputError("streaming: the filter has " + std::to_string(f.taps) + " taps and delay " +
                     std::to_string(f.delay_samples) + "; the delay must be in [0, taps)");
  }
  impl_ = std::make_unique<Impl>(block_);
  auto& s = *impl_;
  const std::size_t B = block_;
  s.taps = f.taps;
  s.delay = static_cast<std::size_t>(f.delay_samples);
  s.to_skip = s.delay;
  s.parts = (f.taps + B - 1) / B;
  const std::size_t bins = s.fft.bins();
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      s.H[i][j].assign(s.parts, std::vector<cd>(bins));
      for (std::size_t p = 0; p < s.parts; ++p) {
        const std::size_t start = p * B;
        const std::size_t count = std::min(B, f.taps - start);
        s.fft.forward(f.h[i][j].data() + start, count, s.H[i][j][p].data());
      }
    }
  for (int c = 0; c < 2; ++c) {
    s.fdl[c].assign(s.parts, std::vector<cd>(bins, 0.0));
    s.in[c].assign(2 * B, 0.0);
    s.Y[c].resize(bins);
  }
  s.y.resize(2 * B);
}

StreamingRestorer::~StreamingRestorer() = default;

std::size_t StreamingRestorer::latency_samples() const { return impl_->delay + block_ - 1; }

void StreamingRestorer::process_block(std::vector<double>& fx, std::vector<double>& fz) {
  auto& s = *impl_;
  const std::size_t B = block_, bins = s.fft.bins();
  for (int c = 0; c < 2; ++c) s.fft.forward(s.in[c].data(), 2 * B, s.fdl[c][s.slot].data());
  for (int i = 0; i < 2; ++i) {
    std::fill(s.Y[i].begin(), s.Y[i].end(), cd(0.0, 0.0));
    for (std::size_t p = 0; p < s.parts; ++p) {
      const std::size_t q = (s.slot + s.parts - p) % s.parts;  // input spectrum p blocks ago
      // Spelled out in real arithmetic: std::complex's operator* goes through the NaN-safe __muldc3.
      const double* h0 = reinterpret_cast<const double*>(s.H[i][0][p].data());
      const double* h1 = reinterpret_cast<const double*>(s.H[i][1][p].data());
      const double* x0 = reinterpret_cast<const double*>(s.fdl[0][q].data());
      const double* x1 = reinterpret_cast<const double*>(s.fdl[1][q].data());
      double* acc = reinterpret_cast<double*>(s.Y[i].data());
      for (std::size_t k = 0; k < 2 * bins; k += 2) {
        acc[k] += h0[k] * x0[k] - h0[k + 1] * x0[k + 1] + h1[k] * x1[k] - h1[k + 1] * x1[k + 1];
        acc[k + 1] += h0[k] * x0[k + 1] + h0[k + 1] * x0[k] + h1[k] * x1[k + 1] + h1[k + 1] * x1[k];
      }
    }
  }
  s.slot = (s.slot + 1) % s.parts;
  // The last B samples of each 2B-point inverse are the linear-convolution outputs of this block.
  const std::size_t skip = std::min(s.to_skip, s.filled);
  const std::size_t count = s.filled - skip;
  const std::size_t room = s.received > s.emitted ? s.received - s.emitted : 0;
  const std::size_t take = std::min(count, room);
  for (int i = 0; i < 2; ++i) {
    s.fft.inverse(s.Y[i].data(), s.y.data());
    auto& out = i == 0 ? fx : fz;
    out.insert(out.end(), s.y.begin() + static_cast<long>(B + skip), s.y.begin() + static_cast<long>(B + skip + take));
  }
  s.emitted += take;
  s.to_skip -= skip;
  for (int c = 0; c < 2; ++c) {
    std::copy(s.in[c].begin() + static_cast<long>(B), s.in[c].end(), s.in[c].begin());
    std::fill(s.in[c].begin() + static_cast<long>(B), s.in[c].end(), 0.0);
  }
  s.filled = 0;
}

void StreamingRestorer::push(const double* m1, const double* m2, std::size_t n, std::vector<double>& fx,
                             std::vector<double>& fz) {
  auto& s = *impl_;
  const std::size_t B = block_;
  s.received += n;
  std::size_t i = 0;
  while (i < n) {
    const std::size_t take = std::min(n - i, B - s.filled);
    std::copy(m1 + i, m1 + i + take, s.in[0].begin() + static_cast<long>(B + s.filled));
    std::copy(m2 + i, m2 + i + take, s.in[1].begin() + static_cast<long>(B + s.filled));
    s.filled += take;
    i += take;
    if (s.filled == B) process_block(fx, fz);
  }
}

void StreamingRestorer::flush(std::vector<double>& fx, std::vector<double>& fz) {
  auto& s = *impl_;
  // Feed zeros (the block tail is already zero) until every received sample has its force.
  while (s.emitted < s.received) {
    s.filled = block_;
    process_block(fx, fz);
  }
}

}  // namespace pvdf::restore
