// Internal: the frequency grid of the inverse design and the choice of beta on it.
#pragma once

#include "pvdf/restore/filter.hpp"

#include <Eigen/Dense>

#include <array>
#include <complex>
#include <string>
#include <utility>
#include <vector>

namespace pvdf::restore::detail {

/// G(k) = U diag(s1, s2) V^H per bin of a real FFT of length L, with the design's shape and target.
struct DesignGrid {
  std::size_t L = 0;
  double dx = 0;
  double smax = 0;                      ///< max over k of s1
  std::vector<double> s1, s2;           ///< singular values (s1 >= s2)
  std::vector<Eigen::Matrix2cd> U, V;
  std::vector<double> shape, target;    ///< beta shape(k) and target T(k)
  bool isotropic = false;               ///< one gain for both directions (DesignOptions::isotropic)
  double weight(std::size_t k) const { return (k == 0 || (L % 2 == 0 && k == L / 2)) ? 1.0 : 2.0; }
  /// The regularized inverse at bin k for absolute beta b: H = V diag(d) U^H, its resolution A = H G =
  /// V diag(a) V^H. Tikhonov: a_i = s_i^2 / (s_i^2 + b), d_i = s_i / (s_i^2 + b). Isotropic: both directions
  /// get the weak one's gain w = s_2^2 / (s_2^2 + b), a_i = w, d_i = w / s_i, so A = w I.
  void gains(std::size_t k, double b, double a[2], double d[2]) const {
    const double s[2] = {s1[k], s2[k]};
    const double w = s[1] * s[1] / (s[1] * s[1] + b);
    for (int i = 0; i < 2; ++i) {
      if (isotropic) {
        a[i] = w;
        d[i] = s[i] > 0 ? w / s[i] : 0.0;
      } else {
        a[i] = s[i] * s[i] / (s[i] * s[i] + b);
        d[i] = s[i] / (s[i] * s[i] + b);
      }
    }
  }
};

/// The chosen relative beta, the criterion's curve over the candidates and a sentence saying why.
struct BetaChoice {
  double beta = 0;
  std::string criterion, reason;
  std::vector<std::pair<double, double>> curve;
};

class RealFft;

/// beta's shape(k) at `bin` of an FFT of length L (frequency corner and low cut) and the target T(k).
double beta_shape(const DesignOptions& o, std::size_t bin, std::size_t L, double dx);
double target_gain(const DesignOptions& o, std::size_t bin, std::size_t L, double dx);
/// G(k) of an identified transfer matrix on the bins of `fft` (impulse responses placed circularly).
std::array<std::array<std::vector<std::complex<double>>, 2>, 2> transfer_spectrum(const TransferMatrix& t, RealFft& fft);
/// The SVDs, shape and target of G on an FFT grid.
DesignGrid design_grid(const TransferMatrix& t, RealFft& fft, const DesignOptions& o);

/// Chooses beta for the data-driven policies (gcv, lcurve, morozov, predicted, discrepancy).
BetaChoice choose_beta(const DesignGrid& grid, const TransferMatrix& transfer,
                       const std::vector<IdentificationScan>& scans, const DesignOptions& options);

}  // namespace pvdf::restore::detail
