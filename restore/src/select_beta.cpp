// The choice of beta: generalized cross-validation, the L-curve and the discrepancy principle on the
// identification scans, the noise floor of G, and the predicted mu error (the default; docs/restore.md
// section 4 compares them on a randomized family of scanners).
#include "select_beta.hpp"

#include "fft.hpp"
#include "pvdf/core/assert.hpp"
#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace pvdf::restore::detail {

namespace {
using cd = std::complex<double>;

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3g", v);
  return buf;
}

std::vector<double> candidates(const DesignOptions& o) {
  const int n = std::max(2, o.gcv_points);
  std::vector<double> b(static_cast<std::size_t>(n));
  for (int p = 0; p < n; ++p) b[static_cast<std::size_t>(p)] = o.gcv_beta_min * std::pow(o.gcv_beta_max / o.gcv_beta_min, p / double(n - 1));
  return b;
}

// Power of the identification records along the left singular vectors of G, per bin of a grid long
// enough for the records: p1[k] = sum_s |u1^H M_s(k)|^2, p2 likewise.
struct RecordPower {
  DesignGrid grid;
  std::vector<double> p1, p2;
  double n_samples = 0;  ///< total samples over the scans
};

RecordPower record_power(const TransferMatrix& t, const std::vector<IdentificationScan>& scans, const DesignOptions& o) {
  std::size_t n_max = 0;
  for (const auto& s : scans) n_max = std::max(n_max, s.scan.size());
  if (n_max == 0) throw InputError("this choice of beta needs the identification scans");
  RealFft big(good_fft_size(n_max + t.g[0][0].size()));
  RecordPower r;
  r.grid = design_grid(t, big, o);
  const std::size_t B = big.bins();
  PVDF_ASSERT(r.grid.s1.size() == B && r.grid.U.size() == B, "the design grid has one entry per bin of the records' transform");
  r.p1.assign(B, 0.0);
  r.p2.assign(B, 0.0);
  std::vector<cd> M1(B), M2(B);
  for (const auto& s : scans) {
    big.forward(s.scan.m1_V.data(), s.scan.size(), M1.data());
    big.forward(s.scan.m2_V.data(), s.scan.size(), M2.data());
    r.n_samples += static_cast<double>(s.scan.size());
    for (std::size_t k = 0; k < B; ++k) {
      const Eigen::Vector2cd um = r.grid.U[k].adjoint() * Eigen::Vector2cd(M1[k], M2[k]);
      r.p1[k] += std::norm(um(0));
      r.p2[k] += std::norm(um(1));
    }
  }
  return r;
}

// GCV(b) = sum |(I - A) M|^2 / (sum tr(I - A))^2 with A = T G H (the data's influence matrix).
BetaChoice gcv(const RecordPower& r, const DesignOptions& o, double n_scans) {
  BetaChoice c;
  c.criterion = "GCV";
  double best = std::numeric_limits<double>::infinity();
  const auto& g = r.grid;
  for (double b_rel : candidates(o)) {
    double resid = 0, trace = 0;
    for (std::size_t k = 0; k < g.s1.size(); ++k) {
      const double b = b_rel * g.smax * g.smax * g.shape[k];
      double a[2], d[2];
      g.gains(k, b, a, d);
      const double r1 = 1 - g.target[k] * a[0], r2 = 1 - g.target[k] * a[1];
      resid += g.weight(k) * (r1 * r1 * r.p1[k] + r2 * r2 * r.p2[k]);
      trace += g.weight(k) * n_scans * (r1 + r2);
    }
    const double v = trace > 0 ? resid / (trace * trace) : std::numeric_limits<double>::infinity();
    c.curve.emplace_back(b_rel, v);
    if (v < best) {
      best = v;
      c.beta = b_rel;
    }
  }
  c.reason = "minimum of generalized cross-validation on the identification scans";
  return c;
}

// Residual rho(b)^2 = sum |(I - G H) M|^2 and solution size eta(b)^2 = sum |T H M|^2 of the records.
void residual_and_size(const RecordPower& r, double b_rel, double& rho2, double& eta2) {
  const auto& g = r.grid;
  rho2 = eta2 = 0;
  for (std::size_t k = 0; k < g.s1.size(); ++k) {
    const double b = b_rel * g.smax * g.smax * g.shape[k];
    double a[2], d[2];
    g.gains(k, b, a, d);
    const double r1 = 1 - a[0], r2 = 1 - a[1], d1 = d[0], d2 = d[1];
    rho2 += g.weight(k) * (r1 * r1 * r.p1[k] + r2 * r2 * r.p2[k]);
    eta2 += g.weight(k) * g.target[k] * g.target[k] * (d1 * d1 * r.p1[k] + d2 * d2 * r.p2[k]);
  }
}

BetaChoice lcurve(const RecordPower& r, const DesignOptions& o) {
  BetaChoice c;
  c.criterion = "L-curve curvature";
  const auto b = candidates(o);
  std::vector<double> x(b.size()), y(b.size());
  for (std::size_t i = 0; i < b.size(); ++i) {
    double rho2 = 0, eta2 = 0;
    residual_and_size(r, b[i], rho2, eta2);
    x[i] = 0.5 * std::log(std::max(rho2, 1e-300));
    y[i] = 0.5 * std::log(std::max(eta2, 1e-300));
  }
  double best = -std::numeric_limits<double>::infinity();
  c.beta = b[b.size() / 2];
  for (std::size_t i = 1; i + 1 < b.size(); ++i) {
    // Curvature of (x(t), y(t)), t = log beta, by central differences.
    const double x1 = (x[i + 1] - x[i - 1]) / 2, y1 = (y[i + 1] - y[i - 1]) / 2;
    const double x2 = x[i + 1] - 2 * x[i] + x[i - 1], y2 = y[i + 1] - 2 * y[i] + y[i - 1];
    const double den = std::pow(x1 * x1 + y1 * y1, 1.5);
    const double kappa = den > 0 ? (x1 * y2 - x2 * y1) / den : 0.0;
    c.curve.emplace_back(b[i], kappa);
    if (kappa > best) {
      best = kappa;
      c.beta = b[i];
    }
  }
  c.reason = "corner (largest curvature) of the L-curve of the identification scans";
  return c;
}

BetaChoice morozov(const RecordPower& r, const TransferMatrix& t, const DesignOptions& o) {
  BetaChoice c;
  c.criterion = "residual / noise power";
  // Parseval with an unnormalized DFT: sum_k |E(k)|^2 = L sum_n e_n^2.
  const double noise = static_cast<double>(r.grid.L) * r.n_samples *
                       (t.noise_rms_V[0] * t.noise_rms_V[0] + t.noise_rms_V[1] * t.noise_rms_V[1]);
  if (!(noise > 0)) throw InputError("beta policy morozov needs a noise estimate: the scans must extend beyond taps/4 of the edge");
  c.beta = o.gcv_beta_min;
  for (double b : candidates(o)) {
    double rho2 = 0, eta2 = 0;
    residual_and_size(r, b, rho2, eta2);
    c.curve.emplace_back(b, rho2 / noise);
    if (rho2 <= noise) c.beta = b;  // the largest beta whose residual stays within the noise
  }
  c.reason = "largest beta whose residual on the identification scans stays within their noise power";
  return c;
}

// Predicted mu error at an edge carrying each identification force F: restored peak (t0 F + bias) with
// bias = (1/L) sum_k T (Re A(k) - I) F, A = H G; variance (1/L^2) sum_k T^2 |H_ij|^2 (L P_j + E|dG F|^2).
BetaChoice predicted(const DesignGrid& g, const TransferMatrix& t, const DesignOptions& o) {
  BetaChoice c;
  c.criterion = "predicted rms mu error";
  const double L = static_cast<double>(g.L);
  double t0 = 0;
  for (std::size_t k = 0; k < g.s1.size(); ++k) t0 += g.weight(k) * g.target[k] / L;
  if (t.forces.empty()) throw InputError("beta policy predicted needs the identification forces");
  double best = std::numeric_limits<double>::infinity(), best_bias = 0, best_sd = 0, best_fraction = 1;
  c.beta = o.gcv_beta_min;
  for (double b_rel : candidates(o)) {
    Eigen::Matrix2d M = Eigen::Matrix2d::Zero(), S = Eigen::Matrix2d::Zero();
    for (std::size_t k = 0; k < g.s1.size(); ++k) {
      const double b = b_rel * g.smax * g.smax * g.shape[k];
      double ak[2], dk[2];
      g.gains(k, b, ak, dk);
      const Eigen::Vector2d a(ak[0], ak[1]), d(dk[0], dk[1]);
      const Eigen::Matrix2cd A = g.V[k] * a.asDiagonal() * g.V[k].adjoint();
      const Eigen::Matrix2cd H = g.V[k] * d.asDiagonal() * g.U[k].adjoint();
      const double w = g.weight(k), T = g.target[k];
      M += (w * T / L) * A.real();
      S += (w * T * T / (L * L)) * H.cwiseAbs2();
    }
    double sum = 0, sum_bias = 0, sum_sd = 0;
    for (const auto& f : t.forces) {
      const Eigen::Vector2d F(f[0], f[1]);
      const Eigen::Vector2d peak = M * F;  // t0 F + bias
      const double gdf = 0.25 * t.g_noise_power * F.squaredNorm();
      const Eigen::Vector2d var = S * Eigen::Vector2d(L * t.noise_psd_V2[0] + gdf, L * t.noise_psd_V2[1] + gdf);
      const double mu = F(0) / F(1);
      const double mu_hat = peak(1) > 0 ? peak(0) / peak(1) : 10.0;
      const double bias = mu_hat - mu;
      const double sd2 = peak(1) > 0 ? (var(0) + mu_hat * mu_hat * var(1)) / (peak(1) * peak(1)) : 100.0;
      sum += bias * bias + sd2;
      sum_bias += std::abs(bias);
      sum_sd += std::sqrt(sd2);
    }
    const double n = static_cast<double>(t.forces.size());
    const double v = std::sqrt(sum / n);
    c.curve.emplace_back(b_rel, v);
    // The resolution target: a sharp edge's f_z peak keeps min_peak_fraction of the target's.
    const double fraction = t0 > 0 ? M(1, 1) / t0 : 0.0;
    if (fraction < o.min_peak_fraction) continue;
    if (v < best) {
      best_fraction = fraction;
      best = v;
      c.beta = b_rel;
      best_bias = sum_bias / n;
      best_sd = sum_sd / n;
    }
  }
  c.reason = (o.predicted_beta_scale == 1.0 ? std::string("the beta minimizing") : fmt(o.predicted_beta_scale) + " x the beta minimizing") + " the mu error predicted at the identification forces (" +
             fmt(best) + " rms: bias " + fmt(best_bias) + ", noise " + fmt(best_sd) + ") among those keeping >= " +
             fmt(o.min_peak_fraction) + " of the target's peak (" + fmt(best_fraction) + ")";
  c.beta *= o.predicted_beta_scale;
  return c;
}

}  // namespace

double beta_shape(const DesignOptions& o, std::size_t bin, std::size_t L, double dx) {
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

double target_gain(const DesignOptions& o, std::size_t bin, std::size_t L, double dx) {
  if (o.resolution_m <= 0) return 1.0;
  const double k = 2 * pi * static_cast<double>(bin) / (static_cast<double>(L) * dx);
  const double s = o.resolution_m / 2.3548200450309493;
  return std::exp(-0.5 * k * k * s * s);
}

DesignGrid design_grid(const TransferMatrix& t, RealFft& fft, const DesignOptions& o) {
  const auto G = transfer_spectrum(t, fft);
  DesignGrid g;
  g.L = fft.size();
  g.dx = t.sample_spacing_m;
  const std::size_t B = fft.bins();
  g.s1.resize(B);
  g.s2.resize(B);
  g.U.resize(B);
  g.V.resize(B);
  g.shape.resize(B);
  g.target.resize(B);
  g.isotropic = o.isotropic;
  for (std::size_t k = 0; k < B; ++k) {
    Eigen::Matrix2cd m;
    m << G[0][0][k], G[0][1][k], G[1][0][k], G[1][1][k];
    Eigen::JacobiSVD<Eigen::Matrix2cd> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
    g.s1[k] = svd.singularValues()(0);
    g.s2[k] = svd.singularValues()(1);
    g.U[k] = svd.matrixU();
    g.V[k] = svd.matrixV();
    // gains() gives the weak direction's gain by s2: the singular values come sorted, s1 >= s2 >= 0.
    PVDF_ASSERT(!(g.s2[k] > g.s1[k]) && !(g.s2[k] < 0), "the singular values of G must be sorted, s1 >= s2 >= 0");
    g.smax = std::max(g.smax, g.s1[k]);
    g.shape[k] = beta_shape(o, k, g.L, g.dx);
    g.target[k] = target_gain(o, k, g.L, g.dx);
  }
  return g;
}

BetaChoice choose_beta(const DesignGrid& grid, const TransferMatrix& t, const std::vector<IdentificationScan>& scans,
                       const DesignOptions& o) {
  switch (o.beta_policy) {
    case BetaPolicy::gcv: {
      BetaChoice c = gcv(record_power(t, scans, o), o, static_cast<double>(scans.size()));
      return c;
    }
    case BetaPolicy::lcurve: return lcurve(record_power(t, scans, o), o);
    case BetaPolicy::morozov: return morozov(record_power(t, scans, o), t, o);
    case BetaPolicy::predicted: return predicted(grid, t, o);
    case BetaPolicy::discrepancy: {
      if (!(t.g_noise_power > 0)) {
        throw InputError("beta policy noise-floor needs a noise estimate: the scans must extend beyond taps/4 on a side of "
                         "the edge (or give a numeric beta)");
      }
      BetaChoice c;
      c.beta = t.g_noise_power / (grid.smax * grid.smax);
      c.reason = "noise floor of the identified G: beta_abs = E|dG(k)|^2 = " + fmt(t.g_noise_power) + " V^2/N^2";
      return c;
    }
    case BetaPolicy::constant:
    case BetaPolicy::frequency: break;
  }
  BetaChoice c;
  c.beta = o.beta;
  c.reason = "given (" + to_string(o.beta_policy) + ")";
  return c;
}

}  // namespace pvdf::restore::detail
