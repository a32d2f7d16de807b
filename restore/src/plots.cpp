// Figures (seed 000 Figs 11-14 analogues). Positions in mm, signals in V, line forces in N/m.
#include "pvdf/restore/plots.hpp"

#include "fft.hpp"
#include "pvdf/core/constants.hpp"
#include "pvdf/plot/plot.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <initializer_list>

#include <Eigen/Dense>

namespace pvdf::restore {

namespace {
std::vector<double> mm(const std::vector<double>& x) {
  std::vector<double> out(x.size());
  for (std::size_t i = 0; i < x.size(); ++i) out[i] = x[i] * 1e3;
  return out;
}
std::vector<double> gaussian_blur(const std::vector<double>& f, double resolution_m, double dx) {
  if (resolution_m <= 0 || f.empty()) return f;
  detail::RealFft fft(detail::good_fft_size(2 * f.size()));
  std::vector<std::complex<double>> F(fft.bins());
  fft.forward(f.data(), f.size(), F.data());
  const double s = resolution_m / 2.3548200450309493;
  for (std::size_t k = 0; k < F.size(); ++k) {
    const double w = 2 * pi * static_cast<double>(k) / (static_cast<double>(fft.size()) * dx);
    F[k] *= std::exp(-0.5 * w * w * s * s);
  }
  std::vector<double> out(fft.size());
  fft.inverse(F.data(), out.data());
  out.resize(f.size());
  return out;
}

// Per-sample forces (N) as a line force (N/m), blurred by a Gaussian of FWHM `resolution_m` (> 0).
std::vector<double> line_force(const std::vector<double>& f_N, double resolution_m, double dx) {
  auto out = gaussian_blur(f_N, resolution_m, dx);
  for (auto& v : out) v /= dx;
  return out;
}

std::string fmt(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, format, v);
  return buf;
}

// y-limits holding every curve, with a 6 % margin.
void fit_y(plot::Axes& ax, std::initializer_list<const std::vector<double>*> curves) {
  double lo = 0, hi = 0;
  for (const auto* c : curves)
    for (double v : *c)
      if (std::isfinite(v)) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
  if (hi > lo) ax.ylim(lo - 0.06 * (hi - lo), hi + 0.06 * (hi - lo));
}

// Display resolution of a reference that has no target (concentrated edges are one sample wide).
constexpr double display_resolution_m = 0.5e-3;

}  // namespace

void plot_scan(const std::string& path, const Scan& scan, const std::string& title) {
  const bool ref = scan.fx_N.size() == scan.size();
  plot::Figure fig(1200, ref ? 900 : 550, ref ? 2 : 1, 1);
  fig.suptitle(title);
  const auto x = mm(scan.x_m);
  fig.axes(0, 0)
      .line(x, scan.m1_V, "m1 (strip 1)")
      .line(x, scan.m2_V, "m2 (strip 2)")
      .title("Strip signals (stress rate), seed 000 Figs 11-12")
      .xlabel("scanner position x (mm)")
      .ylabel("signal (V)")
      .grid_lines()
      .legend("best");
  if (ref) {
    const double dx = scan.sample_spacing_m();
    fig.axes(1, 0)
        .line(x, line_force(scan.fx_N, display_resolution_m, dx), "$f_x$ (simulated)")
        .line(x, line_force(scan.fz_N, display_resolution_m, dx), "$f_z$ (simulated)")
        .title("Surface line force, shown blurred by a 0.5 mm Gaussian (edges are concentrated)")
        .xlabel("surface position x (mm)")
        .ylabel("line force (N/m)")
        .grid_lines()
        .legend("best");
  }
  // The scan's own x range on every panel (no padding beyond the scanned stretch).
  if (!x.empty()) {
    fig.axes(0, 0).xlim(x.front(), x.back());
    if (ref) fig.axes(1, 0).xlim(x.front(), x.back());
  }
  fig.save_png(path);
}

void plot_filters(const std::string& path, const InverseFilter& f) {
  plot::Figure fig(1200, 900, 2, 2);
  fig.suptitle("Inverse filters (seed 000 Fig. 13), " + f.regularization + " regularization, β (" + f.beta_policy +
               ") = " + fmt("%.3g", f.beta) + " relative");
  std::vector<double> lag(f.taps);
  for (std::size_t t = 0; t < f.taps; ++t) lag[t] = (static_cast<double>(t) - static_cast<double>(f.delay_samples)) * f.sample_spacing_m * 1e3;
  const char* names[2][2] = {{"$h_{11}$ ($f_x$ from $m_1$)", "$h_{12}$ ($f_x$ from $m_2$)"},
                             {"$h_{21}$ ($f_z$ from $m_1$)", "$h_{22}$ ($f_z$ from $m_2$)"}};
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      fig.axes(i, j)
          .line(lag, f.h[i][j])
          .title(names[i][j])
          .xlabel("lag minus modelling delay (mm)")
          .ylabel("tap (N/V)")
          .grid_lines();
    }
  fig.save_png(path);
}

void plot_transfer(const std::string& path, const InverseFilter& f) {
  const auto& g = f.transfer.g;
  const std::size_t N = g[0][0].size();
  if (N == 0) return;
  detail::RealFft fft(N);
  std::array<std::array<std::vector<std::complex<double>>, 2>, 2> G;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      G[i][j].resize(fft.bins());
      fft.forward(g[i][j].data(), N, G[i][j].data());
    }
  const double dx = f.sample_spacing_m;
  // Wavenumbers up to where the target has fallen to 1e-3 (or an eighth of the band without a target).
  std::size_t shown = std::max<std::size_t>(4, fft.bins() / 8);
  if (f.resolution_m > 0) {
    const double s = f.resolution_m / 2.3548200450309493, k_max = std::sqrt(2 * std::log(1e3)) / s;
    shown = std::min(fft.bins(), static_cast<std::size_t>(k_max * static_cast<double>(N) * dx / (2 * pi)) + 2);
  }
  std::vector<double> k(shown - 1);
  for (std::size_t b = 1; b < shown; ++b) k[b - 1] = static_cast<double>(b) / (static_cast<double>(N) * dx * 1e3);
  const bool curve = !f.selection_curve.empty();
  plot::Figure fig(curve ? 1500 : 1200, 550, 1, curve ? 3 : 2);
  fig.suptitle("Identified transfer matrix G (seed 000 eq. 6) and its regularization");
  auto& ax = fig.axes(0, 0);
  const char* names[2][2] = {{"$|G_{11}|$ ($m_1$ from $f_x$)", "$|G_{12}|$ ($m_1$ from $f_z$)"},
                             {"$|G_{21}|$ ($m_2$ from $f_x$)", "$|G_{22}|$ ($m_2$ from $f_z$)"}};
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      std::vector<double> a(shown - 1);
      for (std::size_t b = 1; b < shown; ++b) a[b - 1] = std::abs(G[i][j][b]);
      ax.line(k, a, names[i][j]);
    }
  ax.title("Entries of G").xlabel("spatial frequency 1/λ (1/mm)").ylabel("|G| (V/N)").log_y().grid_lines().legend("best");
  // Singular values against the regularization level sqrt(beta(k)): inverted above it, damped below.
  std::vector<double> s1(shown - 1), s2(shown - 1), reg(shown - 1);
  for (std::size_t b = 1; b < shown; ++b) {
    Eigen::Matrix2cd m;
    m << G[0][0][b], G[0][1][b], G[1][0][b], G[1][1][b];
    const auto sv = Eigen::JacobiSVD<Eigen::Matrix2cd>(m).singularValues();
    s1[b - 1] = sv(0);
    s2[b - 1] = sv(1);
    double shape = 1;
    const double lambda = 1.0 / (k[b - 1] * 1e3);
    if (f.corner_wavelength_m > 0) shape *= 1 + std::pow(f.corner_wavelength_m / lambda, 2);
    if (f.low_cut_wavelength_m > 0) shape *= 1 + std::pow(lambda / f.low_cut_wavelength_m, 2);
    reg[b - 1] = std::sqrt(f.beta_abs * shape);
  }
  fig.axes(0, 1)
      .line(k, s1, "$s_1$ (strong direction)")
      .line(k, s2, "$s_2$ (weak direction)")
      .line(k, reg, "√β(k)", plot::Color{0, 0, 0}, plot::LineStyle::dashed)
      .title(f.regularization == "isotropic" ? "Singular values of G and √β(k): both directions get s₂'s gain"
                                             : "Singular values of G and √β(k): each direction damped below it")
      .xlabel("spatial frequency 1/λ (1/mm)")
      .ylabel("V/N")
      .log_y()
      .grid_lines()
      .legend("best");
  if (curve) {
    std::vector<double> b, v;
    for (const auto& [bb, vv] : f.selection_curve) {
      b.push_back(bb);
      v.push_back(vv);
    }
    const bool positive = *std::min_element(v.begin(), v.end()) > 0;
    auto& sel = fig.axes(0, 2);
    // The criterion is plain ASCII in the filter file ("predicted rms mu error"); the figure writes μ.
    std::string label = f.selection_criterion;
    if (const auto at = label.find("mu error"); at != std::string::npos) label.replace(at, 2, "μ");
    sel.line(b, v, label).title("Choice of β: " + f.beta_policy).xlabel("β (relative)").ylabel(label).log_x().grid_lines();
    if (positive) sel.log_y();
    sel.vline(f.beta, plot::Color{200, 0, 0}, plot::LineStyle::dashed, "chosen β = " + fmt("%.3g", f.beta)).legend("best");
  }
  fig.save_png(path);
}

namespace {

/// How a filter's target resolution is named in titles.
std::string resolution_text(double resolution_m) {
  return resolution_m > 0 ? "filter with target resolution " + fmt("%.2g", resolution_m * 1e3) + " mm"
                          : "filter without a target resolution";
}

void plot_restored_figure(const std::string& path, const RestoredForces& r, const Scan& scan, const std::string& title,
                          double resolution_m) {
  plot::Figure fig(1200, 900, 2, 1);
  fig.suptitle(title);
  const auto x = mm(r.x_m);
  auto& ax = fig.axes(0, 0);
  const double dx = r.sample_spacing_m > 0 ? r.sample_spacing_m : scan.sample_spacing_m();
  std::vector<double> fx = r.fx_N_per_m, fz = r.fz_N_per_m;
  if (fx.size() != r.x_m.size()) {
    fx = r.fx_N;
    fz = r.fz_N;
    for (auto& v : fx) v /= dx;
    for (auto& v : fz) v /= dx;
  }
  ax.line(x, fx, "$f_x$ restored").line(x, fz, "$f_z$ restored");
  std::vector<double> rx, rz;
  if (scan.fx_N.size() == r.x_m.size()) {
    // The truth at the filter's target resolution (both are then on one scale); without a target the
    // concentrated edges are shown at a 0.5 mm display resolution.
    const double shown = resolution_m > 0 ? resolution_m : display_resolution_m;
    const std::string what = resolution_m > 0 ? " true, at the target resolution " + fmt("%.2g", shown * 1e3) + " mm"
                                              : " true, shown at " + fmt("%.2g", shown * 1e3) + " mm";
    rx = line_force(scan.fx_N, shown, dx);
    rz = line_force(scan.fz_N, shown, dx);
    ax.line(x, rx, "$f_x$" + what, std::nullopt, plot::LineStyle::dashed);
    ax.line(x, rz, "$f_z$" + what, std::nullopt, plot::LineStyle::dashed);
  }
  fit_y(ax, {&fx, &fz, &rx, &rz});
  ax.title("Restored line forces, in excess of the flat-surface level (seed 000 Fig. 14)")
      .xlabel("surface position x (mm)")
      .ylabel("line force (N/m)")
      .grid_lines()
      .legend("best");
  std::vector<double> xm, mu;
  for (std::size_t i = 0; i < r.mu.size(); ++i) {
    xm.push_back(x[i]);
    mu.push_back(r.mu_valid[i] ? r.mu[i] : std::nan(""));
  }
  auto& m = fig.axes(1, 0);
  m.line(xm, mu, "μ = $f_x$ / $f_z$ where $f_z$ > threshold");
  if (rz.size() == x.size() && !rz.empty()) {
    // The true μ where the true f_z (at the resolution shown above) carries a press: above 10 % of its peak.
    double peak = 0;
    for (double v : rz) peak = std::max(peak, v);
    std::vector<double> true_mu(x.size(), std::nan(""));
    for (std::size_t i = 0; i < x.size(); ++i)
      if (peak > 0 && rz[i] > 0.1 * peak) true_mu[i] = rx[i] / rz[i];
    m.line(x, true_mu, "μ true (where true $f_z$ > 10 % of its peak)", std::nullopt, plot::LineStyle::dashed);
  }
  m.title("Friction coefficient").xlabel("surface position x (mm)").ylabel("μ (–)").grid_lines().legend("best");
  // Stacked panels of one scan: the same x range, so that a feature lines up across them.
  if (!x.empty()) {
    m.xlim(x.front(), x.back());
    ax.xlim(x.front(), x.back());
  }
  fig.save_png(path);
}

}  // namespace

void plot_restored(const std::string& path, const RestoredForces& r, const Scan& scan, const std::string& title,
                   double resolution_m) {
  plot_restored_figure(path, r, scan, title + " (" + resolution_text(resolution_m) + ")", resolution_m);
}

void plot_restored(const std::string& path, const RestoredForces& r, const Scan& scan, const std::string& title,
                   const InverseFilter& filter) {
  const std::string beta = "β (" + filter.beta_policy + ") = " + fmt("%.3g", filter.beta);
  plot_restored_figure(path, r, scan,
                       title + " (" + filter.regularization + " filter, " + beta + ", " +
                           (filter.resolution_m > 0 ? "target resolution " + fmt("%.2g", filter.resolution_m * 1e3) + " mm"
                                                    : "no target resolution") + ")",
                       filter.resolution_m);
}

}  // namespace pvdf::restore
