// Identification of G (seed 000 eq. 6, least squares for more scans) and the regularized inverse (eq. 4).
#include "fft.hpp"
#include "select_beta.hpp"
#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/restore/filter.hpp"
#include "pvdf/version.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <sstream>

namespace pvdf::restore {

namespace {
using cd = std::complex<double>;

std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// Tukey window of length n with cosine tapers over `fraction` of the length at each end.
std::vector<double> tukey(std::size_t n, double fraction) {
  std::vector<double> w(n, 1.0);
  const double taper = fraction * static_cast<double>(n);
  if (taper < 1) return w;
  for (std::size_t i = 0; i < n; ++i) {
    const double d = std::min(static_cast<double>(i), static_cast<double>(n - 1 - i));
    if (d < taper) w[i] = 0.5 * (1 - std::cos(pi * d / taper));
  }
  return w;
}

std::vector<double> taper(const std::string& kind, std::size_t n) {
  if (kind == "none") return std::vector<double>(n, 1.0);
  if (kind == "hann") return tukey(n, 0.5);
  return tukey(n, 0.125);
}

// m(first + l + frac) for l in [0, count): the record on a grid shifted by frac (|frac| <= 1/2 sample),
// band-limited interpolation by FFT over the window padded by 512 samples on each side (samples outside
// the record are 0). frac = 0 copies.
std::vector<double> aligned_window(const std::vector<double>& m, long first, long count, double frac) {
  const long n = static_cast<long>(m.size());
  std::vector<double> out(static_cast<std::size_t>(count), 0.0);
  if (std::abs(frac) < 1e-9) {
    for (long l = 0; l < count; ++l)
      if (first + l >= 0 && first + l < n) out[static_cast<std::size_t>(l)] = m[static_cast<std::size_t>(first + l)];
    return out;
  }
  const long pad = 512;
  detail::RealFft fft(detail::good_fft_size(static_cast<std::size_t>(count + 2 * pad)));
  const std::size_t L = fft.size();
  std::vector<double> seg(L, 0.0);
  for (long q = 0; q < count + 2 * pad; ++q) {
    const long k = first - pad + q;
    if (k >= 0 && k < n) seg[static_cast<std::size_t>(q)] = m[static_cast<std::size_t>(k)];
  }
  std::vector<cd> S(fft.bins());
  fft.forward(seg.data(), L, S.data());
  for (std::size_t k = 0; k < S.size(); ++k) {
    S[k] *= std::polar(1.0, 2 * pi * static_cast<double>(k) * frac / static_cast<double>(L));
  }
  if (L % 2 == 0) S.back() = cd(S.back().real() * std::cos(pi * frac), 0.0);  // Nyquist bin stays real
  fft.inverse(S.data(), seg.data());
  for (long l = 0; l < count; ++l) out[static_cast<std::size_t>(l)] = seg[static_cast<std::size_t>(l + pad)];
  return out;
}

// In the far field of an edge at sample ne (|lag| >= N/4): the slow signal tails removed by a 513-sample
// running mean, the sum of squared sums over blocks of 64 consecutive samples, divided by 64, is added to
// `sum` and the number of blocks to `count` (their ratio: the low-frequency noise power per sample).
void far_field_block_power(const std::vector<double>& m, long ne, long N, double& sum, std::size_t& count) {
  const long n = static_cast<long>(m.size()), block = 64, half = 256;
  std::vector<double> prefix(static_cast<std::size_t>(n) + 1, 0.0);
  for (long q = 0; q < n; ++q) prefix[q + 1] = prefix[q] + m[q];
  double ss = 0;
  std::size_t nb = 0;
  for (long k = half; k + block + half <= n; k += block) {
    bool far = true;
    double total = 0;
    for (long q = k; q < k + block; ++q) {
      if (std::labs(q - ne) < N / 4) {
        far = false;
        break;
      }
      total += m[q] - (prefix[q + half + 1] - prefix[q - half]) / (2 * half + 1);
    }
    if (far) {
      ss += total * total;
      ++nb;
    }
  }
  if (nb > 0) {
    sum += ss / block;
    count += nb;
  }
}

}  // namespace

std::string to_string(BetaPolicy policy) {
  switch (policy) {
    case BetaPolicy::constant: return "constant";
    case BetaPolicy::frequency: return "frequency";
    case BetaPolicy::gcv: return "gcv";
    case BetaPolicy::discrepancy: return "discrepancy";
    case BetaPolicy::lcurve: return "lcurve";
    case BetaPolicy::morozov: return "morozov";
    case BetaPolicy::predicted: return "predicted";
  }
  return "constant";
}

namespace {

/// The checks of the scans and of the tap count, the sample spacing and the force matrix's
/// conditioning (into `t`); returns the pseudo-inverse F^+ (S x 2) of the 2 x S force matrix F.
Eigen::MatrixXd force_pseudo_inverse(const std::vector<IdentificationScan>& scans, const DesignOptions& o,
                                     TransferMatrix& t) {
  if (scans.size() < 2) {
    throw InputError("identification needs at least 2 scans with independent force vectors (seed 000 eq. 6); got " +
                     std::to_string(scans.size()) + "; give two scans or more, each with its force vector");
  }
  if (o.taps < 64 || o.taps > (1u << 22) || o.taps % 2 != 0) {
    throw InputError("identification: " + std::to_string(o.taps) + " taps must be even and in [64, 4194304] (DesignOptions::taps)");
  }
  const double dx = scans[0].scan.sample_spacing_m();
  for (const auto& s : scans) {
    const double d = s.scan.sample_spacing_m();
    if (std::abs(d - dx) > 0.005 * dx) {
      throw InputError(s.scan.source + ": sample spacing " + num(d) + " m differs from " + scans[0].scan.source +
                       "'s " + num(dx) + " m; all scans must share speed / sample_rate");
    }
    if (!(std::abs(s.fx_N) + std::abs(s.fz_N) > 0)) {
      throw InputError(s.scan.source + ": force vector (0, 0) carries no information; give the edge's FX,FZ in N");
    }
  }
  // Eq. 6's conditioning is that of the 2 x S force matrix F (the same at every frequency: the forces are
  // impulses at known positions, so F(k) = F up to the delay removed below).
  const Eigen::Index S = static_cast<Eigen::Index>(scans.size());
  Eigen::MatrixXd F(2, S);
  for (Eigen::Index s = 0; s < S; ++s) {
    F(0, s) = scans[s].fx_N;
    F(1, s) = scans[s].fz_N;
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(F);
  const auto sv = svd.singularValues();
  t.sample_spacing_m = dx;
  t.force_condition_number = sv(1) > 0 ? sv(0) / sv(1) : std::numeric_limits<double>::infinity();
  if (!(t.force_condition_number <= o.max_force_condition)) {
    std::ostringstream msg;
    msg << "the identification force vectors are (nearly) parallel: cond(F) = "
        << (std::isfinite(t.force_condition_number) ? num(t.force_condition_number) : std::string("inf")) << " > "
        << o.max_force_condition
        << "; G cannot be separated into its f_x and f_z columns. Scan edges with different friction, e.g. seed 000's "
           "[0.6, 0.9] and [0.2, 1.0] (cond 5.1)";
    throw InputError(msg.str());
  }
  return F.transpose() * (F * F.transpose()).inverse();
}

/// Energy of a scan's two channels near the edge at sample `ne` (|lag| < N/8) and far from it
/// (|lag| >= N/4, the noise; also per channel).
struct EdgeEnergy {
  double sig = 0, noise = 0;
  std::size_t n_sig = 0, n_noise = 0;
  double ch_noise[2] = {0, 0};
};

EdgeEnergy edge_energy(const Scan& scan, long ne, long N) {
  EdgeEnergy r;
  const long n = static_cast<long>(scan.size());
  for (long k = 0; k < n; ++k) {
    const long lag = k - ne;
    const double e = scan.m1_V[k] * scan.m1_V[k] + scan.m2_V[k] * scan.m2_V[k];
    if (std::labs(lag) < N / 8) {
      r.sig += e;
      ++r.n_sig;
    } else if (std::labs(lag) >= N / 4) {
      r.noise += e;
      r.ch_noise[0] += scan.m1_V[k] * scan.m1_V[k];
      r.ch_noise[1] += scan.m2_V[k] * scan.m2_V[k];
      ++r.n_noise;
    }
  }
  return r;
}

}  // namespace

TransferMatrix identify_transfer(const std::vector<IdentificationScan>& scans, const DesignOptions& o) {
  TransferMatrix t;
  const Eigen::MatrixXd Fpinv = force_pseudo_inverse(scans, o, t);  // S x 2
  const double dx = t.sample_spacing_m;
  const Eigen::Index S = static_cast<Eigen::Index>(scans.size());

  const std::size_t n_window = o.g_window > 0 ? o.g_window : o.taps;
  if (n_window < 64 || n_window % 2 != 0) {
    throw InputError("identification: a window of " + std::to_string(n_window) + " lags of G must be even and >= 64 (DesignOptions::g_window)");
  }
  const long N = static_cast<long>(n_window);
  t.lag_min = -N / 2;
  for (auto& row : t.g)
    for (auto& g : row) g.assign(n_window, 0.0);
  double noise_sum[2] = {0, 0};
  std::size_t noise_count = 0;
  double psd_sum[2] = {0, 0};
  std::size_t psd_count[2] = {0, 0};
  for (Eigen::Index s = 0; s < S; ++s) {
    const Scan& scan = scans[s].scan;
    const long n = static_cast<long>(scan.size());
    const double pos = (scans[s].edge_x_m - scan.x_m.front()) / dx;
    if (pos < -0.5 || pos > static_cast<double>(n) - 0.5) {
      throw InputError(scan.source + ": edge position " + num(scans[s].edge_x_m) + " m lies outside the scan [" +
                       num(scan.x_m.front()) + ", " + num(scan.x_m.back()) + "] m; give the edge position on the scan's x_m axis");
    }
    const long ne = std::lround(pos);
    const EdgeEnergy en = edge_energy(scan, ne, N);
    const double sig_rms = en.n_sig ? std::sqrt(en.sig / en.n_sig) : 0.0;
    const double noise_rms = en.n_noise ? std::sqrt(en.noise / en.n_noise) : 0.0;
    const double snr = noise_rms > 0 ? sig_rms / noise_rms : (sig_rms > 0 ? 1e300 : 0.0);
    t.scan_snr.push_back(std::min(snr, 1e300));
    if (!(sig_rms > 0) || snr < o.min_snr) {
      throw InputError(scan.source + ": carries no signal at the edge x = " + num(scans[s].edge_x_m) +
                       " m (signal rms " + num(sig_rms) + " V vs noise rms " + num(noise_rms) + " V, ratio " + num(snr) +
                       " < " + num(o.min_snr) + "); check the edge position, the force and the recording");
    }
    // Low-frequency noise power (the band of G lies below the moving average's first null), per channel.
    for (int c = 0; c < 2; ++c) far_field_block_power(c == 0 ? scan.m1_V : scan.m2_V, ne, N, psd_sum[c], psd_count[c]);
    noise_sum[0] += en.ch_noise[0];
    noise_sum[1] += en.ch_noise[1];
    noise_count += en.n_noise;
    if (ne + t.lag_min < 0 || ne + t.lag_min + N > n) {
      t.warnings.push_back(scan.source + ": the scan does not cover the whole identification window of " +
                           std::to_string(N) + " samples around the edge; missing lags are taken as 0");
    }
    // Least squares G = M F^+ (eq. 6 when S = 2), lag by lag: the forces are impulses at the edge, taken at
    // its exact position (the records are shifted by the fraction of a sample between edge and grid).
    const auto w1 = aligned_window(scan.m1_V, ne + t.lag_min, N, pos - static_cast<double>(ne));
    const auto w2 = aligned_window(scan.m2_V, ne + t.lag_min, N, pos - static_cast<double>(ne));
    for (long l = 0; l < N; ++l) {
      for (int j = 0; j < 2; ++j) {
        t.g[0][j][static_cast<std::size_t>(l)] += Fpinv(s, j) * w1[static_cast<std::size_t>(l)];
        t.g[1][j][static_cast<std::size_t>(l)] += Fpinv(s, j) * w2[static_cast<std::size_t>(l)];
      }
    }
    t.forces.push_back({scans[s].fx_N, scans[s].fz_N, scans[s].edge_x_m});
  }
  for (int i = 0; i < 2; ++i) {
    t.noise_rms_V[i] = noise_count ? std::sqrt(noise_sum[i] / noise_count) : 0.0;
    t.noise_psd_V2[i] = psd_count[i] ? psd_sum[i] / psd_count[i] : t.noise_rms_V[i] * t.noise_rms_V[i];
  }
  // Taper the lag window's ends (noise there is all that is left of the response).
  const auto w = tukey(n_window, 0.125);
  for (auto& row : t.g)
    for (auto& g : row)
      for (std::size_t l = 0; l < g.size(); ++l) g[l] *= w[l];
  // Noise power of G per bin: g_ij = sum_s F+_sj m_i^s, so E|dG_ij(k)|^2 = P_i sum_s F+_sj^2 sum_l w_l^2.
  double w2 = 0;
  for (double v : w) w2 += v * v;
  t.g_noise_power = 0;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) t.g_noise_power += t.noise_psd_V2[i] * Fpinv.col(j).squaredNorm() * w2;
  return t;
}

namespace detail {
std::array<std::array<std::vector<std::complex<double>>, 2>, 2> transfer_spectrum(const TransferMatrix& t, RealFft& fft) {
  const std::size_t L = fft.size();
  std::array<std::array<std::vector<cd>, 2>, 2> G;
  std::vector<double> buf(L);
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < 2; ++j) {
      std::fill(buf.begin(), buf.end(), 0.0);
      const auto& g = t.g[i][j];
      for (std::size_t l = 0; l < g.size(); ++l) {
        const long lag = t.lag_min + static_cast<long>(l);
        const long idx = ((lag % static_cast<long>(L)) + static_cast<long>(L)) % static_cast<long>(L);
        buf[static_cast<std::size_t>(idx)] += g[l];
      }
      G[i][j].resize(fft.bins());
      fft.forward(buf.data(), L, G[i][j].data());
    }
  }
  return G;
}
}  // namespace detail

namespace {
void check_design_options(const DesignOptions& o, std::size_t n_g) {
  const std::size_t N = o.taps;
  if (N < 64 || n_g < 64) throw InputError("design: need >= 64 taps and >= 64 lags of G");
  if (o.delay_samples >= static_cast<long>(N)) {
    throw InputError("design: delay of " + std::to_string(o.delay_samples) + " samples must be < the " + std::to_string(N) + " taps (DesignOptions::delay_samples)");
  }
  if (o.beta_policy == BetaPolicy::frequency && !(o.corner_wavelength_m > 0)) {
    throw InputError("design: the frequency beta policy needs a corner wavelength > 0 (DesignOptions::corner_wavelength_m, the wavelength where beta has doubled)");
  }
  if ((o.beta_policy == BetaPolicy::constant || o.beta_policy == BetaPolicy::frequency) && !(o.beta > 0 && o.beta < 1e6)) {
    throw InputError("design: beta " + num(o.beta) + " must be in (0, 1e6) (DesignOptions::beta)");
  }
  if (o.window != "tukey" && o.window != "hann" && o.window != "none") {
    throw InputError("design: window '" + o.window + "' must be tukey, hann or none (DesignOptions::window)");
  }
  if (!(o.predicted_beta_scale > 0 && o.predicted_beta_scale <= 1) || !(o.gcv_beta_min > 0 && o.gcv_beta_min < o.gcv_beta_max) ||
      o.gcv_points < 3 || o.gcv_points > 10000) {
    throw InputError("design: predicted_beta_scale = " + num(o.predicted_beta_scale) + " must be in (0, 1], the beta search range (" +
                     num(o.gcv_beta_min) + ", " + num(o.gcv_beta_max) + ") increasing and positive, its points in [3, 10000]");
  }
  if (!(o.resolution_m <= 1.0) || !(o.low_cut_wavelength_m <= 100.0) || !(o.corner_wavelength_m >= 0 && o.corner_wavelength_m <= 1.0)) {
    throw InputError("design: resolution " + num(o.resolution_m) + " m, low cut " + num(o.low_cut_wavelength_m) +
                     " m, corner wavelength " + num(o.corner_wavelength_m) + " m: lengths must be <= 1, 100 and 1 m");
  }
}

// Depth of a Flamant strip whose stress-rate response peaks at the same wavenumber as s_max(G(k)):
// |k| (1 + |k| z) e^{-|k| z} peaks at k z = (1 + sqrt 5) / 2.
double effective_depth(const detail::DesignGrid& g) {
  std::size_t kp = 1;
  for (std::size_t k = 1; k < g.s1.size(); ++k)
    if (g.s1[k] > g.s1[kp]) kp = k;
  const double k_peak = 2 * pi * static_cast<double>(kp) / (static_cast<double>(g.L) * g.dx);
  return 1.6180339887498949 / k_peak;
}
// The force an isolated sharp feature keeps within +-3 resolutions (no target: 1.5 effective depths) of
// it: the integral of the f_z resolution kernel, whose spectrum is `kernel` (T Re A_zz, no delay), over
// that window. The kernel is per sample: a unit force on one sample restores as kernel[l] on sample l.
double lobe_force_fraction(detail::RealFft& fft, const std::vector<std::complex<double>>& kernel, std::size_t L, double dx,
                           double resolution_m, double effective_depth_m) {
  std::vector<double> r(L);
  fft.inverse(kernel.data(), r.data());
  const double width = resolution_m > 0 ? resolution_m : 1.5 * effective_depth_m;
  const auto reach = static_cast<std::size_t>(std::min(3 * width / dx, static_cast<double>(L / 2 - 1)));
  double sum = r[0];
  for (std::size_t l = 1; l <= reach; ++l) sum += r[l] + r[L - l];
  return sum;
}
}  // namespace

InverseFilter design_inverse(const TransferMatrix& t, const std::vector<IdentificationScan>& scans,
                             const DesignOptions& o_in) {
  DesignOptions o = o_in;
  const std::size_t N = o.taps;
  const std::size_t n_g = t.g[0][0].size();
  check_design_options(o, n_g);
  if (o.delay_samples < 0) o.delay_samples = static_cast<long>(N / 2);
  const double dx = t.sample_spacing_m;
  // Design grid >= 2N: H sampled on it has an impulse response whose wrap-around is measured below.
  detail::RealFft fft(detail::good_fft_size(2 * std::max(N, n_g)));
  const std::size_t L = fft.size();
  detail::DesignGrid grid = detail::design_grid(t, fft, o);
  if (!(grid.smax > 0)) throw NumericalError("design: the identified G is zero at every frequency");
  const double depth = effective_depth(grid);
  if (o.resolution_m < 0 || o.low_cut_wavelength_m < 0) {
    if (o.resolution_m < 0) o.resolution_m = 1.5 * depth;
    if (o.low_cut_wavelength_m < 0) o.low_cut_wavelength_m = 10 * depth;
    grid = detail::design_grid(t, fft, o);
  }

  InverseFilter f;
  f.sample_spacing_m = dx;
  f.taps = N;
  f.delay_samples = o.delay_samples;
  f.design_fft_length = L;
  f.beta_policy = to_string(o.beta_policy);
  f.regularization = o.isotropic ? "isotropic" : "tikhonov";
  f.corner_wavelength_m = o.corner_wavelength_m;
  f.resolution_m = o.resolution_m;
  f.low_cut_wavelength_m = o.low_cut_wavelength_m;
  f.effective_depth_m = depth;
  f.window = o.window;
  f.transfer = t;
  f.pvdfkit_version = pvdf::version_string;

  // Conditioning over the band where G carries signal.
  {
    std::vector<double> conds;
    for (std::size_t k = 0; k < grid.s1.size(); ++k) {
      if (grid.s1[k] >= 1e-3 * grid.smax) conds.push_back(grid.s2[k] > 0 ? grid.s1[k] / grid.s2[k] : 1e300);
    }
    std::sort(conds.begin(), conds.end());
    if (!conds.empty()) {
      f.conditioning.min = conds.front();
      f.conditioning.max = std::min(conds.back(), 1e300);
      f.conditioning.median = conds[conds.size() / 2];
      f.conditioning.band_fraction = static_cast<double>(conds.size()) / static_cast<double>(grid.s1.size());
    }
  }

  const detail::BetaChoice choice = detail::choose_beta(grid, t, scans, o);
  f.beta = choice.beta;
  f.beta_abs = choice.beta * grid.smax * grid.smax;
  f.beta_reason = choice.reason;
  f.selection_criterion = choice.criterion;
  f.selection_curve = choice.curve;
  if (o.beta_policy == BetaPolicy::gcv) f.gcv_curve = choice.curve;

  // Eq. 4 per frequency with the modelling delay exp(-i 2 pi k D / L); H = V diag(s/(s^2+b)) U^H.
  std::array<std::array<std::vector<cd>, 2>, 2> H;
  for (auto& row : H)
    for (auto& v : row) v.resize(fft.bins());
  double peak_sum = 0, target_sum = 0;
  std::vector<cd> kernel_z(fft.bins());  // T Re A_zz: the f_z resolution kernel's spectrum
  for (std::size_t k = 0; k < fft.bins(); ++k) {
    const double b = f.beta_abs * grid.shape[k];
    double ak[2], dk[2];
    grid.gains(k, b, ak, dk);
    const Eigen::Vector2d d(dk[0], dk[1]);
    const Eigen::Vector2d a(ak[0], ak[1]);
    kernel_z[k] = grid.target[k] * (grid.V[k] * a.asDiagonal() * grid.V[k].adjoint())(1, 1).real();
    peak_sum += grid.weight(k) * kernel_z[k].real();
    target_sum += grid.weight(k) * grid.target[k];
    const Eigen::Matrix2cd Hk = grid.V[k] * d.asDiagonal() * grid.U[k].adjoint();
    const cd phase = grid.target[k] * std::polar(1.0, -2 * pi * static_cast<double>(k) * static_cast<double>(o.delay_samples) / static_cast<double>(L));
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j) H[i][j][k] = Hk(i, j) * phase;
  }
  const auto w = taper(o.window, N);
  double total = 0, outside = 0;
  std::vector<double> full(L);
  for (int i = 0; i < 2; ++i) {
    for (int j = 0; j < 2; ++j) {
      fft.inverse(H[i][j].data(), full.data());
      f.h[i][j].resize(N);
      for (std::size_t l = 0; l < L; ++l) {
        total += full[l] * full[l];
        if (l >= N) outside += full[l] * full[l];
      }
      for (std::size_t l = 0; l < N; ++l) f.h[i][j][l] = full[l] * w[l];
    }
  }
  f.truncated_energy_fraction = total > 0 ? outside / total : 0.0;
  f.peak_fraction = target_sum > 0 ? peak_sum / target_sum : 0.0;
  f.lobe_force_fraction = lobe_force_fraction(fft, kernel_z, L, f.sample_spacing_m, f.resolution_m, f.effective_depth_m);
  return f;
}

}  // namespace pvdf::restore
