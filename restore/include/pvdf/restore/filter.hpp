// Identification of the 2x2 transfer matrix G (seed 000 eqs 2, 5, 6) from scans of known forces, and
// the regularized inverse FIR filters H = (G^H G + beta I)^-1 G^H (eq. 4) with a modelling delay.
#pragma once

#include "pvdf/restore/scanner.hpp"

#include <array>
#include <string>
#include <utility>
#include <vector>

namespace pvdf::restore {

/// One identification scan: a raised edge at world position edge_x_m with known force (fx_N, fz_N).
struct IdentificationScan {
  Scan scan;
  double fx_N = 0, fz_N = 0;
  double edge_x_m = 0;
};

/// How beta is chosen. beta is relative: beta_abs(k) = beta * shape(k) * max_k s_max(G(k))^2.
enum class BetaPolicy {
  constant,   ///< seed 000: one beta for every frequency (shape = 1)
  frequency,  ///< shape(k) = 1 + (k * corner_wavelength_m / 2 pi)^2: more damping at short wavelengths
  gcv,        ///< generalized cross-validation on the identification scans; over-regularizes (docs/restore.md)
  discrepancy,///< noise floor of G: beta_abs = E||dG(k)||_F^2, the noise power of the identified G per bin
  lcurve,     ///< corner (largest curvature) of the L-curve of the identification scans
  morozov,    ///< discrepancy principle: residual of the identification scans = their noise power
  predicted   ///< default: the beta that minimizes the mu error predicted at the identification forces
              ///< from G, its noise and the scans' noise (bias + variance of the restored peak; docs/restore.md)
};

/// Identification and design settings. The defaults are the recommended settings (docs/restore.md
/// section 4: chosen by the randomized study of bench_restore_selectors); seed 000's own choices are
/// beta_policy = constant, beta = 1e-4, resolution_m = 0, low_cut_wavelength_m = 0.
struct DesignOptions {
  std::size_t taps = 8192;            ///< N: length of each FIR filter h11..h22
  std::size_t g_window = 0;           ///< lags of G kept by identification (0 = taps); noise in G grows with it
  long delay_samples = -1;            ///< modelling delay D; -1 = taps / 2 (the inverse is two-sided)
  BetaPolicy beta_policy = BetaPolicy::predicted;
  double beta = 1e-4;                 ///< relative beta for constant and frequency (seed 000 section 5.2)
  double corner_wavelength_m = 0;     ///< for BetaPolicy::frequency (required > 0) and optionally gcv
  /// Low-frequency damping (any policy): beta(k) *= 1 + (k_low / k)^2, k_low = 2 pi / low_cut_wavelength_m.
  /// A stress-rate sensor cannot see the mean load; its inverse integrates white noise into a random
  /// walk, which this cuts at wavelengths beyond low_cut_wavelength_m. 0 = off (seed 000);
  /// < 0 = automatic: 10 x the effective depth of the strips (estimated from G).
  double low_cut_wavelength_m = -1;
  std::string window = "tukey";       ///< taper of the FIR taps: tukey (25 %), hann, none
  /// Target resolution (FWHM of a Gaussian, m): H = T(k) (G^H G + beta I)^-1 G^H with
  /// T(k) = exp(-(k s)^2 / 2), s = resolution_m / 2.3548, so both forces come out with the same blur
  /// (the target response of multichannel inversion). 0 = T = 1, seed 000's choice;
  /// < 0 = automatic: 1.5 x the effective depth of the strips (estimated from G).
  double resolution_m = -1;
  double max_force_condition = 100;   ///< refuse identification force sets with cond(F) above this
  double min_snr = 3;                 ///< refuse scans whose signal rms near the edge is below min_snr x noise rms
  double gcv_beta_min = 1e-9, gcv_beta_max = 1.0;  ///< search range of the selectors (relative)
  /// BetaPolicy::predicted takes this multiple of the beta that minimizes its prediction: 1 with the isotropic
  /// regularization (the default); with Tikhonov the prediction over-regularizes by about 4x against the best
  /// constant beta in hindsight, and 0.25 served best on the study's tuning seeds 1000-1047 (set it to 0.25
  /// with isotropic = false; docs/restore.md section 4).
  double predicted_beta_scale = 1.0;
  /// Resolution target of BetaPolicy::predicted: beta may not blur a sharp edge's restored f_z peak below this
  /// fraction of the target's own peak (the filter must deliver the resolution asked for; without this bound
  /// the isotropic regularization, whose mu is unbiased at any beta, would be driven to ever wider blur).
  double min_peak_fraction = 0.8;
  int gcv_points = 73;
  /// Regularize both singular directions of G with the weak one's gain w(k) = s_2^2 / (s_2^2 + beta(k)), so the
  /// resolution matrix H G = w(k) T(k) I stays diagonal: f_x and f_z are blurred alike and never mixed, and mu
  /// at a peak is unbiased for any beta (beta then only trades resolution against noise). false = Tikhonov
  /// per direction, s_i^2 / (s_i^2 + beta) (seed 000 eq. 4), which damps the weak direction more and mixes them.
  /// Default true: the lowest mu error of the automatic rules on the randomized scanner study; its price is the
  /// long-wavelength part of isolated features (InverseFilter::lobe_force_fraction says how much).
  bool isotropic = true;
};

/// Identified transfer matrix: g[i][j][l] = response of strip i to unit force j (0 = x, 1 = z) at lag
/// l + lag_min samples (signal sample minus force sample).
struct TransferMatrix {
  double sample_spacing_m = 0;
  long lag_min = 0;
  std::array<std::array<std::vector<double>, 2>, 2> g;
  double force_condition_number = 0;   ///< cond of the 2 x S force matrix (eq. 6's conditioning)
  std::array<double, 2> noise_rms_V{}; ///< per channel, from samples far from the edges
  std::array<double, 2> noise_psd_V2{}; ///< per channel, low-frequency noise power per sample (block-sum variance)
  double g_noise_power = 0;            ///< E||dG(k)||_F^2 per frequency bin, (V/N)^2, from the noise above
  std::vector<double> scan_snr;        ///< per scan: signal rms near the edge / noise rms
  std::vector<std::array<double, 3>> forces;  ///< per scan: fx_N, fz_N, edge_x_m
  std::vector<std::string> warnings;
};

/// Conditioning of G(k) over the band where its largest singular value exceeds 1e-3 of the maximum.
struct ConditioningSummary {
  double min = 0, median = 0, max = 0;
  double band_fraction = 0;  ///< fraction of the frequency bins in that band
};

/// A designed inverse filter (what `pvdfkit restore identify` writes; docs/restore.md shows the file).
struct InverseFilter {
  double sample_spacing_m = 0;
  std::size_t taps = 0;
  long delay_samples = 0;
  std::size_t design_fft_length = 0;  ///< >= 2 taps: the frequency grid H is sampled on (no wrap-around)
  std::string beta_policy = "constant";
  std::string regularization = "tikhonov";  ///< tikhonov or isotropic (DesignOptions::isotropic)
  double beta = 0;                    ///< relative beta (chosen one for gcv)
  double beta_abs = 0;                ///< beta * max s^2, in (V/N)^2
  double corner_wavelength_m = 0;
  double resolution_m = 0;            ///< target Gaussian FWHM (0 = none)
  double low_cut_wavelength_m = 0;    ///< low-frequency damping wavelength (0 = none)
  std::string window = "tukey";
  /// h[i][j]: restored force i (0 = f_x, 1 = f_z) from signal j (0 = m1, 1 = m2); h[0][0] is seed 000's h11.
  std::array<std::array<std::vector<double>, 2>, 2> h;
  TransferMatrix transfer;
  ConditioningSummary conditioning;
  double truncated_energy_fraction = 0;  ///< energy of the ideal delayed inverse outside the N taps
  /// Restored f_z peak of a sharp edge as a fraction of the target's peak: sum_k T Re A_zz / sum_k T (1 = the
  /// target resolution is met; lower = beta blurs beyond it).
  double peak_fraction = 0;
  /// Force of an isolated sharp feature that the restored f_z holds within +-3 resolutions of it, as a
  /// fraction of the true force: the integral of the f_z resolution kernel (inverse transform of T Re A_zz)
  /// over that window. Below 1 because the long wavelengths (|G| -> 0 as k -> 0, the low cut) are damped:
  /// the rest of the force is spread as shallow negative side lobes over about the low-cut wavelength.
  double lobe_force_fraction = 0;
  std::vector<std::pair<double, double>> gcv_curve;  ///< (beta, GCV) when beta_policy = gcv
  /// (beta, criterion) of the selector (gcv, lcurve, morozov, predicted), and what the criterion is.
  std::vector<std::pair<double, double>> selection_curve;
  std::string selection_criterion;
  std::string beta_reason;            ///< one sentence: why this beta
  /// Depth of a Flamant strip whose stress-rate response peaks where |G| does (1.618 / k_peak); sets the
  /// automatic resolution and low cut.
  double effective_depth_m = 0;
  std::string pvdfkit_version;
};

/// Identifies G from >= 2 scans by least squares (eq. 6 for exactly two). Throws InputError when fewer
/// than two scans are given, the sample spacings differ, an edge lies outside its scan, the force
/// vectors are (nearly) parallel (cond(F) > max_force_condition) or a scan carries no signal.
TransferMatrix identify_transfer(const std::vector<IdentificationScan>& scans, const DesignOptions& options);

/// Designs the inverse FIR filters from G (eq. 4 per frequency on a grid of >= 2 taps points, modelling
/// delay, window). `scans` feed the GCV choice of beta (unused for the other policies).
InverseFilter design_inverse(const TransferMatrix& transfer, const std::vector<IdentificationScan>& scans,
                             const DesignOptions& options);

/// Writes the filter as self-describing JSON, atomically.
void save_filter(const std::string& path, const InverseFilter& filter);
/// Reads a filter file strictly: a missing, mistyped or malformed key is an InputError naming it; taps
/// must be finite with |tap| <= 1e12 N/V.
InverseFilter load_filter(const std::string& path);

std::string to_string(BetaPolicy policy);

}  // namespace pvdf::restore
