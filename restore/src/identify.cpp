// Identification of G (seed 000 eq. 6, least squares for more scans) and the regularized inverse (eq. 4).
#include "fft.hpp"
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
constexpr double pi = 3.14159265358979323846;
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

// G(k) on an FFT grid of length L from impulse responses starting at lag_min (placed circularly).
std::array<std::array<std::vector<cd>, 2>, 2> spectrum(const TransferMatrix& t, detail::RealFft& fft) {
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

Eigen::Matrix2cd at(const std::array<std::array<std::vector<cd>, 2>, 2>& G, std::size_t k) {
  Eigen::Matrix2cd m;
  m << G[0][0][k], G[0][1][k], G[1][0][k], G[1][1][k];
  return m;
}

double target(const DesignOptions& o, std::size_t bin, std::size_t L, double dx) {
  if (o.resolution_m <= 0) return 1.0;
  const double k = 2 * pi * static_cast<double>(bin) / (static_cast<double>(L) * dx);
  const double s = o.resolution_m / 2.3548200450309493;
  return std::exp(-0.5 * k * k * s * s);
}

double shape(const DesignOptions& o, std::size_t bin, std::size_t L, double dx) {
  double s = 1.0;
  if (o.corner_wavelength_m > 0) {
    const double r = static_cast<double>(bin) * o.corner_wavelength_m / (static_cast<double>(L) * dx);
    s *= 1.0 + r * r;
  }
  if (o.low_cut_wavelength_m > 0) {
    // k_low / k = (L dx / lambda_low) / bin; at bin 0 the factor is infinite (H(0) = 0 anyway: G(0) = 0).
    if (bin == 0) return 1e300;
    const double r = static_cast<double>(L) * dx / (o.low_cut_wavelength_m * static_cast<double>(bin));
    s *= 1.0 + r * r;
  }
  return s;
}

}  // namespace

std::string to_string(BetaPolicy policy) {
  switch (policy) {
    case BetaPolicy::constant: return "constant";
    case BetaPolicy::frequency: return "frequency";
    case BetaPolicy::gcv: return "gcv";
    case BetaPolicy::discrepancy: return "discrepancy";
  }
  return "constant";
}

TransferMatrix identify_transfer(const std::vector<IdentificationScan>& scans, const DesignOptions& o) {
  if (scans.size() < 2) {
    throw InputError("identification needs at least 2 scans with independent force vectors (seed 000 eq. 6); got " +
                     std::to_string(scans.size()) + "; pass --scan A.csv --force FX,FZ twice or more");
  }
  if (o.taps < 64 || o.taps > (1u << 22) || o.taps % 2 != 0) {
    throw InputError("--taps = " + std::to_string(o.taps) + " must be even and in [64, 4194304]");
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
  TransferMatrix t;
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
  const Eigen::MatrixXd Fpinv = F.transpose() * (F * F.transpose()).inverse();  // S x 2

  const std::size_t n_window = o.g_window > 0 ? o.g_window : o.taps;
  if (n_window < 64 || n_window % 2 != 0) {
    throw InputError("--g-window = " + std::to_string(n_window) + " must be even and >= 64");
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
                       num(scan.x_m.front()) + ", " + num(scan.x_m.back()) + "] m; pass its position with --edge-x-m");
    }
    const long ne = std::lround(pos);
    // Signal near the edge (|lag| < N/8) against the noise far from it (|lag| >= N/4).
    double sig = 0, noise = 0;
    std::size_t n_sig = 0, n_noise = 0;
    double ch_noise[2] = {0, 0};
    for (long k = 0; k < n; ++k) {
      const long lag = k - ne;
      const double e = scan.m1_V[k] * scan.m1_V[k] + scan.m2_V[k] * scan.m2_V[k];
      if (std::labs(lag) < N / 8) {
        sig += e;
        ++n_sig;
      } else if (std::labs(lag) >= N / 4) {
        noise += e;
        ch_noise[0] += scan.m1_V[k] * scan.m1_V[k];
        ch_noise[1] += scan.m2_V[k] * scan.m2_V[k];
        ++n_noise;
      }
    }
    const double sig_rms = n_sig ? std::sqrt(sig / n_sig) : 0.0;
    const double noise_rms = n_noise ? std::sqrt(noise / n_noise) : 0.0;
    const double snr = noise_rms > 0 ? sig_rms / noise_rms : (sig_rms > 0 ? 1e300 : 0.0);
    t.scan_snr.push_back(std::min(snr, 1e300));
    if (!(sig_rms > 0) || snr < o.min_snr) {
      throw InputError(scan.source + ": carries no signal at the edge x = " + num(scans[s].edge_x_m) +
                       " m (signal rms " + num(sig_rms) + " V vs noise rms " + num(noise_rms) + " V, ratio " + num(snr) +
                       " < " + num(o.min_snr) + "); check the edge position, the force and the recording");
    }
    // Low-frequency noise power (the band of G lies below the moving average's first null): in the far
    // field, remove the slow signal tails with a 513-sample running mean, then take the variance of sums
    // over blocks of 64 consecutive samples, divided by 64.
    {
      const long block = 64, half = 256;
      for (int c = 0; c < 2; ++c) {
        const auto& m = c == 0 ? scan.m1_V : scan.m2_V;
        std::vector<double> prefix(static_cast<std::size_t>(n) + 1, 0.0);
        for (long q = 0; q < n; ++q) prefix[q + 1] = prefix[q] + m[q];
        double ss = 0;
        std::size_t nb = 0;
        for (long k = half; k + block + half <= n; k += block) {
          bool far = true;
          double sum = 0;
          for (long q = k; q < k + block; ++q) {
            if (std::labs(q - ne) < N / 4) {
              far = false;
              break;
            }
            sum += m[q] - (prefix[q + half + 1] - prefix[q - half]) / (2 * half + 1);
          }
          if (far) {
            ss += sum * sum;
            ++nb;
          }
        }
        if (nb > 0) {
          psd_sum[c] += ss / block;
          psd_count[c] += nb;
        }
      }
    }
    noise_sum[0] += ch_noise[0];
    noise_sum[1] += ch_noise[1];
    noise_count += n_noise;
    if (ne + t.lag_min < 0 || ne + t.lag_min + N > n) {
      t.warnings.push_back(scan.source + ": the scan does not cover the whole identification window of " +
                           std::to_string(N) + " samples around the edge; missing lags are taken as 0");
    }
    // Least squares G = M F^+ (eq. 6 when S = 2), lag by lag: the forces are impulses at the edge.
    for (long l = 0; l < N; ++l) {
      const long k = ne + t.lag_min + l;
      if (k < 0 || k >= n) continue;
      for (int j = 0; j < 2; ++j) {
        t.g[0][j][static_cast<std::size_t>(l)] += Fpinv(s, j) * scan.m1_V[k];
        t.g[1][j][static_cast<std::size_t>(l)] += Fpinv(s, j) * scan.m2_V[k];
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

InverseFilter design_inverse(const TransferMatrix& t, const std::vector<IdentificationScan>& scans,
                             const DesignOptions& o_in) {
  DesignOptions o = o_in;
  const std::size_t N = o.taps;
  const std::size_t n_g = t.g[0][0].size();
  if (N < 64 || n_g < 64) throw InputError("design: need >= 64 taps and >= 64 lags of G");
  if (o.delay_samples < 0) o.delay_samples = static_cast<long>(N / 2);
  if (o.delay_samples >= static_cast<long>(N)) {
    throw InputError("--delay-samples = " + std::to_string(o.delay_samples) + " must be < --taps = " + std::to_string(N));
  }
  if (o.beta_policy == BetaPolicy::frequency && !(o.corner_wavelength_m > 0)) {
    throw InputError("--beta-policy frequency needs --beta-corner-m > 0 (the wavelength where beta has doubled)");
  }
  if ((o.beta_policy == BetaPolicy::constant || o.beta_policy == BetaPolicy::frequency) && !(o.beta > 0)) throw InputError("--beta = " + num(o.beta) + " must be > 0");
  if (o.window != "tukey" && o.window != "hann" && o.window != "none") {
    throw InputError("--window = " + o.window + " must be tukey, hann or none");
  }
  const double dx = t.sample_spacing_m;
  // Design grid >= 2N: H sampled on it has an impulse response whose wrap-around is measured below.
  detail::RealFft fft(detail::good_fft_size(2 * std::max(N, n_g)));
  const std::size_t L = fft.size();
  const auto G = spectrum(t, fft);

  std::vector<Eigen::JacobiSVD<Eigen::Matrix2cd>> svds;
  svds.reserve(fft.bins());
  double smax = 0;
  for (std::size_t k = 0; k < fft.bins(); ++k) {
    svds.emplace_back(at(G, k), Eigen::ComputeFullU | Eigen::ComputeFullV);
    smax = std::max(smax, svds.back().singularValues()(0));
  }
  if (!(smax > 0)) throw NumericalError("design: the identified G is zero at every frequency");

  InverseFilter f;
  f.sample_spacing_m = dx;
  f.taps = N;
  f.delay_samples = o.delay_samples;
  f.design_fft_length = L;
  f.beta_policy = to_string(o.beta_policy);
  f.corner_wavelength_m = o.corner_wavelength_m;
  f.resolution_m = o.resolution_m;
  f.low_cut_wavelength_m = o.low_cut_wavelength_m;
  if (o.resolution_m < 0) throw InputError("--resolution-m = " + num(o.resolution_m) + " must be >= 0");
  f.window = o.window;
  f.transfer = t;
  f.pvdfkit_version = pvdf::version_string;

  // Conditioning over the band where G carries signal.
  {
    std::vector<double> conds;
    for (const auto& s : svds) {
      const auto v = s.singularValues();
      if (v(0) >= 1e-3 * smax) conds.push_back(v(1) > 0 ? v(0) / v(1) : 1e300);
    }
    std::sort(conds.begin(), conds.end());
    if (!conds.empty()) {
      f.conditioning.min = conds.front();
      f.conditioning.max = std::min(conds.back(), 1e300);
      f.conditioning.median = conds[conds.size() / 2];
      f.conditioning.band_fraction = static_cast<double>(conds.size()) / static_cast<double>(svds.size());
    }
  }

  double beta = o.beta;
  if (o.beta_policy == BetaPolicy::gcv) {
    // GCV on the identification records: the data m = G f + e, influence A(k) = G H = U diag(s^2/(s^2+b)) U^H,
    // GCV(b) = sum |(I - A) M|^2 / (sum tr(I - A))^2, summed over frequencies (half spectrum, weighted) and scans.
    std::size_t n_max = 0;
    for (const auto& s : scans) n_max = std::max(n_max, s.scan.size());
    if (n_max == 0) throw InputError("--beta gcv needs the identification scans");
    detail::RealFft big(detail::good_fft_size(n_max + N));
    const auto Gb = spectrum(t, big);
    const std::size_t B = big.bins();
    std::vector<double> s1(B), s2(B), p1(B, 0.0), p2(B, 0.0), wk(B, 2.0), sh(B), tk(B);
    wk[0] = 1.0;
    if (big.size() % 2 == 0) wk[B - 1] = 1.0;
    std::vector<Eigen::Matrix2cd> U(B);
    for (std::size_t k = 0; k < B; ++k) {
      Eigen::JacobiSVD<Eigen::Matrix2cd> sv(at(Gb, k), Eigen::ComputeFullU);
      s1[k] = sv.singularValues()(0) * sv.singularValues()(0);
      s2[k] = sv.singularValues()(1) * sv.singularValues()(1);
      U[k] = sv.matrixU();
      sh[k] = shape(o, k, big.size(), dx);
      tk[k] = target(o, k, big.size(), dx);
    }
    std::vector<cd> M1(B), M2(B);
    for (const auto& s : scans) {
      big.forward(s.scan.m1_V.data(), s.scan.size(), M1.data());
      big.forward(s.scan.m2_V.data(), s.scan.size(), M2.data());
      for (std::size_t k = 0; k < B; ++k) {
        const Eigen::Vector2cd m(M1[k], M2[k]);
        const Eigen::Vector2cd um = U[k].adjoint() * m;
        p1[k] += std::norm(um(0));
        p2[k] += std::norm(um(1));
      }
    }
    const double n_scans = static_cast<double>(scans.size());
    double best = std::numeric_limits<double>::infinity();
    const int n_pts = std::max(2, o.gcv_points);
    for (int p = 0; p < n_pts; ++p) {
      const double b_rel = o.gcv_beta_min * std::pow(o.gcv_beta_max / o.gcv_beta_min, p / double(n_pts - 1));
      double resid = 0, trace = 0;
      for (std::size_t k = 0; k < B; ++k) {
        const double b = b_rel * smax * smax * sh[k];
        // I - A = U diag(1 - T s^2/(s^2 + b)) U^H
        const double r1 = 1 - tk[k] * s1[k] / (s1[k] + b), r2 = 1 - tk[k] * s2[k] / (s2[k] + b);
        resid += wk[k] * (r1 * r1 * p1[k] + r2 * r2 * p2[k]);
        trace += wk[k] * n_scans * (r1 + r2);
      }
      const double gcv = trace > 0 ? resid / (trace * trace) : std::numeric_limits<double>::infinity();
      f.gcv_curve.emplace_back(b_rel, gcv);
      if (gcv < best) {
        best = gcv;
        beta = b_rel;
      }
    }
  }
  if (o.beta_policy == BetaPolicy::discrepancy) {
    if (!(t.g_noise_power > 0)) {
      throw InputError("--beta auto needs a noise estimate: the scans must extend beyond taps/4 on a side of the edge "
                       "(or give a numeric --beta)");
    }
    beta = t.g_noise_power / (smax * smax);
  }
  f.beta = beta;
  f.beta_abs = beta * smax * smax;

  // Eq. 4 per frequency with the modelling delay exp(-i 2 pi k D / L); H = V diag(s/(s^2+b)) U^H.
  std::array<std::array<std::vector<cd>, 2>, 2> H;
  for (auto& row : H)
    for (auto& v : row) v.resize(fft.bins());
  for (std::size_t k = 0; k < fft.bins(); ++k) {
    const auto& s = svds[k];
    const double b = f.beta_abs * shape(o, k, L, dx);
    Eigen::Vector2d d;
    for (int q = 0; q < 2; ++q) {
      const double sq = s.singularValues()(q);
      d(q) = sq / (sq * sq + b);
    }
    const Eigen::Matrix2cd Hk = s.matrixV() * d.asDiagonal() * s.matrixU().adjoint();
    const cd phase = target(o, k, L, dx) * std::polar(1.0, -2 * pi * static_cast<double>(k) * static_cast<double>(o.delay_samples) / L);
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
  return f;
}

}  // namespace pvdf::restore
