// Figures (seed 000 Figs 11-14 analogues). Positions in mm, signals in V, forces in N per sample.
#include "pvdf/restore/plots.hpp"

#include "fft.hpp"
#include "pvdf/plot/plot.hpp"

#include <algorithm>
#include <cmath>
#include <complex>

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
    const double w = 2 * 3.14159265358979323846 * static_cast<double>(k) / (static_cast<double>(fft.size()) * dx);
    F[k] *= std::exp(-0.5 * w * w * s * s);
  }
  std::vector<double> out(fft.size());
  fft.inverse(F.data(), out.data());
  out.resize(f.size());
  return out;
}

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
    fig.axes(1, 0)
        .line(x, scan.fx_N, "f_x reference")
        .line(x, scan.fz_N, "f_z reference")
        .title("Surface force per sample (simulated reference)")
        .xlabel("surface position x (mm)")
        .ylabel("force per sample (N)")
        .grid_lines()
        .legend("best");
  }
  fig.save_png(path);
}

void plot_filters(const std::string& path, const InverseFilter& f) {
  plot::Figure fig(1200, 900, 2, 2);
  fig.suptitle("Inverse filters (seed 000 Fig. 13), beta " + f.beta_policy + " = " + std::to_string(f.beta));
  std::vector<double> lag(f.taps);
  for (std::size_t t = 0; t < f.taps; ++t) lag[t] = (static_cast<double>(t) - static_cast<double>(f.delay_samples)) * f.sample_spacing_m * 1e3;
  const char* names[2][2] = {{"h11 (f_x from m1)", "h12 (f_x from m2)"}, {"h21 (f_z from m1)", "h22 (f_z from m2)"}};
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      fig.axes(i, j)
          .line(lag, f.h[i][j], names[i][j])
          .title(names[i][j])
          .xlabel("lag minus modelling delay (mm)")
          .ylabel("tap (N/V)")
          .grid_lines()
          .legend("upper right");
    }
  fig.save_png(path);
}

void plot_transfer(const std::string& path, const InverseFilter& f) {
  const auto& g = f.transfer.g;
  const std::size_t N = g[0][0].size();
  if (N == 0) return;
  detail::RealFft fft(N);
  std::vector<std::complex<double>> G(fft.bins());
  std::vector<double> k(fft.bins());
  for (std::size_t b = 0; b < k.size(); ++b) k[b] = static_cast<double>(b) / (static_cast<double>(N) * f.sample_spacing_m * 1e3);
  plot::Figure fig(1200, 550, 1, 2);
  fig.suptitle("Identified transfer matrix G (seed 000 eq. 6)");
  auto& ax = fig.axes(0, 0);
  const char* names[2][2] = {{"|G11| (m1 from f_x)", "|G12| (m1 from f_z)"}, {"|G21| (m2 from f_x)", "|G22| (m2 from f_z)"}};
  const std::size_t shown = std::max<std::size_t>(2, k.size() / 8);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      fft.forward(g[i][j].data(), N, G.data());
      std::vector<double> a(shown), kk(k.begin(), k.begin() + static_cast<long>(shown));
      for (std::size_t b = 0; b < shown; ++b) a[b] = std::abs(G[b]);
      ax.line(kk, a, names[i][j]);
    }
  ax.title("|G(k)|").xlabel("spatial frequency (1/mm)").ylabel("|G| (V/N)").grid_lines().legend("upper right");
  if (!f.gcv_curve.empty()) {
    std::vector<double> b, v;
    for (const auto& [bb, vv] : f.gcv_curve) {
      b.push_back(std::log10(bb));
      v.push_back(std::log10(vv));
    }
    fig.axes(0, 1).line(b, v, "GCV(beta)").title("GCV choice of beta").xlabel("log10 beta (relative)").ylabel("log10 GCV").grid_lines().legend("best");
  }
  fig.save_png(path);
}

void plot_restored(const std::string& path, const RestoredForces& r, const Scan& scan, const std::string& title,
                   double resolution_m) {
  plot::Figure fig(1200, 900, 2, 1);
  fig.suptitle(title);
  const auto x = mm(r.x_m);
  auto& ax = fig.axes(0, 0);
  ax.line(x, r.fx_N, "f_x restored").line(x, r.fz_N, "f_z restored");
  if (scan.fx_N.size() == r.x_m.size()) {
    const double dx = scan.sample_spacing_m();
    const std::string what = resolution_m > 0 ? " reference at the target resolution" : " reference";
    ax.line(x, gaussian_blur(scan.fx_N, resolution_m, dx), "f_x" + what, std::nullopt, plot::LineStyle::dashed);
    ax.line(x, gaussian_blur(scan.fz_N, resolution_m, dx), "f_z" + what, std::nullopt, plot::LineStyle::dashed);
  }
  ax.title("Restored forces (seed 000 Fig. 14)").xlabel("surface position x (mm)").ylabel("force per sample (N)").grid_lines().legend("best");
  std::vector<double> xm, mu;
  for (std::size_t i = 0; i < r.mu.size(); ++i) {
    xm.push_back(x[i]);
    mu.push_back(r.mu_valid[i] ? r.mu[i] : std::nan(""));
  }
  fig.axes(1, 0).line(xm, mu, "mu = f_x / f_z where f_z > threshold").title("Friction coefficient").xlabel("surface position x (mm)").ylabel("mu (-)").grid_lines().legend("best");
  fig.save_png(path);
}

}  // namespace pvdf::restore
