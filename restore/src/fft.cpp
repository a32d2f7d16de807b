// FFTW wrapper (see fft.hpp).
#include "fft.hpp"

#include "pvdf/core/assert.hpp"

#include <fftw3.h>

#include <algorithm>
#include <cstring>
#include <mutex>
#include <new>

namespace pvdf::restore::detail {

namespace {
std::mutex& planner_mutex() {
  static std::mutex m;
  return m;
}
}  // namespace

RealFft::RealFft(std::size_t n, bool measure) : n_(n) {
  real_ = fftw_alloc_real(n);
  auto* c = fftw_alloc_complex(n / 2 + 1);
  complex_ = c;
  if (real_ == nullptr || c == nullptr) throw std::bad_alloc();
  std::lock_guard<std::mutex> lock(planner_mutex());
  const unsigned flags = measure ? FFTW_MEASURE : FFTW_ESTIMATE;  // MEASURE overwrites the buffers: none yet
  plan_forward_ = fftw_plan_dft_r2c_1d(static_cast<int>(n), real_, c, flags);
  plan_inverse_ = fftw_plan_dft_c2r_1d(static_cast<int>(n), c, real_, flags);
}

RealFft::~RealFft() {
  std::lock_guard<std::mutex> lock(planner_mutex());
  fftw_destroy_plan(static_cast<fftw_plan>(plan_forward_));
  fftw_destroy_plan(static_cast<fftw_plan>(plan_inverse_));
  fftw_free(real_);
  fftw_free(complex_);
}

void RealFft::forward(const double* in, std::size_t count, std::complex<double>* out) {
  PVDF_ASSERT(count <= n_, "a transform must hold all its samples (they would be cut off silently)");
  count = std::min(count, n_);
  std::copy(in, in + count, real_);
  std::fill(real_ + count, real_ + n_, 0.0);
  fftw_execute(static_cast<fftw_plan>(plan_forward_));
  std::memcpy(static_cast<void*>(out), complex_, sizeof(fftw_complex) * bins());
}

void RealFft::inverse(const std::complex<double>* in, double* out) {
  std::memcpy(complex_, static_cast<const void*>(in), sizeof(fftw_complex) * bins());
  fftw_execute(static_cast<fftw_plan>(plan_inverse_));  // c2r destroys its input: it is our copy
  const double scale = 1.0 / static_cast<double>(n_);
  for (std::size_t i = 0; i < n_; ++i) out[i] = real_[i] * scale;
}

std::size_t good_fft_size(std::size_t n) {
  std::size_t best = 1;
  while (best < n) best *= 2;
  for (std::size_t p5 = 1; p5 < best; p5 *= 5) {
    for (std::size_t p3 = p5; p3 < best; p3 *= 3) {
      std::size_t v = p3;
      while (v < n) v *= 2;
      best = std::min(best, v);
    }
  }
  PVDF_ASSERT(best >= n, "the transform size must hold the n samples asked for");
  return best;
}

std::vector<double> linear_convolution(const std::vector<double>& a, const std::vector<double>& b) {
  PVDF_ASSERT(!a.empty() && !b.empty(), "a linear convolution needs two non-empty sequences");
  const std::size_t n_out = a.size() + b.size() - 1;
  RealFft fft(good_fft_size(n_out));
  std::vector<std::complex<double>> A(fft.bins()), B(fft.bins());
  fft.forward(a.data(), a.size(), A.data());
  fft.forward(b.data(), b.size(), B.data());
  for (std::size_t k = 0; k < A.size(); ++k) A[k] *= B[k];
  std::vector<double> y(fft.size());
  fft.inverse(A.data(), y.data());
  y.resize(n_out);
  return y;
}

}  // namespace pvdf::restore::detail
