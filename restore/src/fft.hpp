// Internal: a real-to-complex FFT of fixed length on FFTW (plans made once, under a lock).
#pragma once

#include <complex>
#include <cstddef>
#include <vector>

namespace pvdf::restore::detail {

/// Real FFT of length n (any n; FFTW is fastest for 2^a 3^b 5^c). forward: n reals -> n/2+1 bins;
/// inverse: n/2+1 bins -> n reals, normalized (inverse(forward(x)) == x).
class RealFft {
 public:
  /// `measure`: let FFTW time candidate algorithms once (slower to build, faster to run; for streaming).
  explicit RealFft(std::size_t n, bool measure = false);
  ~RealFft();
  RealFft(const RealFft&) = delete;
  RealFft& operator=(const RealFft&) = delete;

  std::size_t size() const { return n_; }
  std::size_t bins() const { return n_ / 2 + 1; }
  /// `in` has `count` <= n values; the rest is zero-padded.
  void forward(const double* in, std::size_t count, std::complex<double>* out);
  void inverse(const std::complex<double>* in, double* out);

 private:
  std::size_t n_;
  double* real_;
  void* complex_;
  void* plan_forward_;
  void* plan_inverse_;
};

/// Smallest 2^a 3^b 5^c >= n.
std::size_t good_fft_size(std::size_t n);

/// Linear (not circular) convolution y[n] = sum_k a[k] b[n - k], n in [0, a.size() + b.size() - 1), by FFT.
std::vector<double> linear_convolution(const std::vector<double>& a, const std::vector<double>& b);

}  // namespace pvdf::restore::detail
