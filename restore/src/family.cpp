// The randomized scene family: an independent forward model of a two-strip scanner (Flamant stresses
// differentiated numerically, finite electrodes, contact patches) and the scores of a restoration.
#include "pvdf/restore/family.hpp"

#include "fft.hpp"
#include "pvdf/core/constants.hpp"
#include "pvdf/restore/physics.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <random>
#include <sstream>

namespace pvdf::restore::family {

namespace {

// Charge density (C/m^2) on strip i per N of force component c at x_rel (strip minus load), point strip.
double charge_point(const FamilyScanner& s, int i, int c, double x_rel) {
  const double line = 1.0 / s.length_m;
  // Drag f_x opposes the motion: tangential line load q = -f_x / length.
  const FlamantStress st = c == 1 ? flamant_stress(line, 0.0, x_rel, s.depth_m[i]) : flamant_stress(0.0, -line, x_rel, s.depth_m[i]);
  const double syy = s.poisson_ratio * (st.sxx_Pa + st.szz_Pa);
  return s.k_C_per_N[i][0] * st.sxx_Pa + s.k_C_per_N[i][1] * syy + s.k_C_per_N[i][2] * st.szz_Pa;
}

// The model's charge density: averaged over the electrode width or over a Hertz contact patch.
double charge(const FamilyScanner& s, int i, int c, double x_rel) {
  switch (s.model) {
    case KernelModel::point_strip: return charge_point(s, i, c, x_rel);
    case KernelModel::wide_electrode: {
      // Gauss-Legendre, 8 points on [-w/2, w/2].
      static const double t[4] = {0.1834346424956498, 0.5255324099163290, 0.7966664774136267, 0.9602898564975363};
      static const double w[4] = {0.3626837833783620, 0.3137066458778873, 0.2223810344533745, 0.1012285362903763};
      double sum = 0;
      for (int q = 0; q < 4; ++q) {
        sum += w[q] * (charge_point(s, i, c, x_rel + 0.5 * s.width_m * t[q]) + charge_point(s, i, c, x_rel - 0.5 * s.width_m * t[q]));
      }
      return 0.5 * sum;
    }
    case KernelModel::contact_patch: {
      // Gauss-Chebyshev (second kind) for the semi-elliptic pressure sqrt(1 - t^2), normalized.
      const int n = 12;
      double sum = 0, norm = 0;
      for (int q = 1; q <= n; ++q) {
        const double th = q * pi / (n + 1);
        const double wq = std::sin(th) * std::sin(th);
        sum += wq * charge_point(s, i, c, x_rel - s.patch_m * std::cos(th));
        norm += wq;
      }
      return sum / norm;
    }
  }
  return 0.0;
}

// Stress-rate signal (V per N): A R_f V d/dx_rel of the charge density, central difference.
double signal(const FamilyScanner& s, int i, int c, double x_rel) {
  const double h = 1e-3 * s.depth_m[i];
  const double area = s.width_m * s.length_m, rf = 1e9;
  return area * rf * s.speed_m_per_s * (charge(s, i, c, x_rel + h) - charge(s, i, c, x_rel - h)) / (2 * h);
}


std::size_t n_samples(const FamilyScene& s) {
  return static_cast<std::size_t>(std::floor((s.x_end_m - s.x_start_m) / s.scanner.sample_spacing_m())) + 1;
}

// Fraction of an edge's force falling into [a, b].
double edge_fraction(const FamilyEdge& e, double a, double b) {
  switch (e.shape) {
    case EdgeShape::impulse: return 0.0;  // handled by linear splitting
    case EdgeShape::gaussian: {
      const double s = e.width_m / 2.3548200450309493;
      return 0.5 * (std::erf((b - e.x_m) / (s * std::sqrt(2.0))) - std::erf((a - e.x_m) / (s * std::sqrt(2.0))));
    }
    case EdgeShape::rectangle: {
      const double lo = e.x_m - 0.5 * e.width_m, hi = e.x_m + 0.5 * e.width_m;
      return std::max(0.0, std::min(b, hi) - std::max(a, lo)) / e.width_m;
    }
  }
  return 0.0;
}

const char* model_name(KernelModel m) {
  switch (m) {
    case KernelModel::point_strip: return "point strip";
    case KernelModel::wide_electrode: return "wide electrode";
    case KernelModel::contact_patch: return "contact patch";
  }
  return "?";
}
}  // namespace

std::string FamilyScene::describe() const {
  std::ostringstream s;
  s << "seed " << seed << ": " << model_name(scanner.model) << ", depths " << scanner.depth_m[0] * 1e3 << "/"
    << scanner.depth_m[1] * 1e3 << " mm, speed " << scanner.speed_m_per_s * 1e3 << " mm/s, SNR " << scanner.snr_dB
    << " dB, moving average " << scanner.moving_average;
  return s.str();
}

FamilyScene draw_scene(std::uint64_t seed) {
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull + 12345);
  auto U = [&](double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); };
  FamilyScene sc;
  sc.seed = seed;
  FamilyScanner& s = sc.scanner;
  const bool two_horizontal = U(0, 1) < 0.4;
  s.depth_m[0] = U(0.6e-3, 1.6e-3);
  if (two_horizontal) {
    // Two horizontal films at clearly different depths (a full-rank G needs different depths or constants).
    s.depth_m[1] = std::min(2.4e-3, s.depth_m[0] * U(1.5, 2.2));
    for (int q = 0; q < 3; ++q) s.k_C_per_N[1][q] = s.k_C_per_N[0][q];
  } else {
    s.depth_m[1] = U(0.6e-3, 1.6e-3);
  }
  for (auto& row : s.k_C_per_N)
    for (double& k : row) k *= U(0.8, 1.2);
  s.offset_m[0] = 0;
  s.offset_m[1] = U(0.5e-3, 3e-3);
  s.model = static_cast<KernelModel>(std::min(2, static_cast<int>(U(0, 3))));
  s.width_m = U(0.5e-3, 1.5e-3);
  s.patch_m = U(0.05e-3, 0.3e-3);
  s.poisson_ratio = U(0.45, 0.5);
  s.speed_m_per_s = U(0.025, 0.08);
  s.snr_dB = U(20, 60);
  s.moving_average = 1 + static_cast<int>(U(0, 12));
  s.adc_headroom = U(1.3, 3.0);
  // Identification: two sharp edges near the middle, one with much and one with little friction.
  for (int e = 0; e < 2; ++e) {
    FamilyEdge ed;
    ed.x_m = U(-5e-3, 5e-3);
    ed.fz_N = U(0.7, 1.2);
    ed.fx_N = ed.fz_N * (e == 0 ? U(0.5, 0.8) : U(0.05, 0.3));
    ed.shape = U(0, 1) < 0.5 ? EdgeShape::impulse : EdgeShape::gaussian;
    ed.width_m = U(20e-6, 60e-6);
    sc.identification.push_back(ed);
  }
  const double centres[3] = {-28e-3, -12e-3, 22e-3};
  for (double c : centres) {
    FamilyEdge ed;
    ed.x_m = c + U(-3e-3, 3e-3);
    ed.fz_N = U(0.4, 1.5);
    ed.fx_N = ed.fz_N * U(0.1, 0.9);
    ed.shape = static_cast<EdgeShape>(std::min(2, static_cast<int>(U(0, 3))));
    ed.width_m = U(0.1e-3, 0.5e-3);
    sc.edges.push_back(ed);
  }
  if (U(0, 1) < 0.5) {
    FamilyTexture t;
    t.period_m = U(1.5e-3, 3e-3);
    t.ridge_width_m = t.period_m * U(0.4, 0.6);
    t.x_start_m = 1e-3;
    t.x_end_m = 12e-3;
    t.fz_N = U(0.1, 0.4);
    t.mu = U(0.1, 0.9);
    sc.textures.push_back(t);
  }
  return sc;
}

void sampled_forces(const FamilyScene& scene, const std::vector<FamilyEdge>& edges,
                    const std::vector<FamilyTexture>& textures, const std::vector<double>& x,
                    std::vector<double>& fx, std::vector<double>& fz) {
  const std::size_t n = x.size();
  const double dx = scene.scanner.sample_spacing_m();
  fx.assign(n, 0.0);
  fz.assign(n, 0.0);
  for (const auto& e : edges) {
    if (e.shape == EdgeShape::impulse) {
      // A point force between two samples is split linearly (its centroid stays at x_m).
      const double p = (e.x_m - x.front()) / dx;
      const auto k = static_cast<long>(std::floor(p));
      const double a = p - static_cast<double>(k);
      for (const auto& [idx, w] : {std::pair<long, double>{k, 1 - a}, {k + 1, a}}) {
        if (idx < 0 || idx >= static_cast<long>(n)) continue;
        fx[static_cast<std::size_t>(idx)] += w * e.fx_N;
        fz[static_cast<std::size_t>(idx)] += w * e.fz_N;
      }
      continue;
    }
    const double reach = 3 * e.width_m + 2 * dx;
    for (std::size_t k = 0; k < n; ++k) {
      if (std::abs(x[k] - e.x_m) > reach) continue;
      const double f = edge_fraction(e, x[k] - dx / 2, x[k] + dx / 2);
      fx[k] += f * e.fx_N;
      fz[k] += f * e.fz_N;
    }
  }
  for (const auto& t : textures) {
    const double w = t.ridge_width_m;
    auto primitive = [&](double a, double xx) {  // of the Hann ridge (1 - cos(2 pi (x - a)/w)) / w
      const double s = std::clamp(xx, a, a + w) - a;
      return (s - w / (2 * pi) * std::sin(2 * pi * s / w)) / w;
    };
    for (double a = t.x_start_m; a + w <= t.x_end_m + 1e-12; a += t.period_m) {
      for (std::size_t k = 0; k < n; ++k) {
        if (x[k] < a - dx || x[k] > a + w + dx) continue;
        const double f = t.fz_N * (primitive(a, x[k] + dx / 2) - primitive(a, x[k] - dx / 2));
        fz[k] += f;
        fx[k] += t.mu * f;
      }
    }
  }
}

Scan scan_surface(const FamilyScene& scene, const std::vector<FamilyEdge>& edges,
                  const std::vector<FamilyTexture>& textures, std::uint64_t noise_seed) {
  const FamilyScanner& s = scene.scanner;
  const std::size_t n = n_samples(scene);
  const double dx = s.sample_spacing_m();
  Scan scan;
  scan.source = "family scene " + std::to_string(scene.seed);
  scan.x_m.resize(n);
  for (std::size_t k = 0; k < n; ++k) scan.x_m[k] = scene.x_start_m + static_cast<double>(k) * dx;
  sampled_forces(scene, edges, textures, scan.x_m, scan.fx_N, scan.fz_N);
  // Kernels at lags -(n-1) .. n-1 (signal sample minus force sample).
  std::vector<double> kern[2][2];
  for (int i = 0; i < 2; ++i)
    for (int c = 0; c < 2; ++c) {
      kern[i][c].resize(2 * n - 1);
      for (std::size_t l = 0; l < 2 * n - 1; ++l) {
        const double lag = static_cast<double>(l) - static_cast<double>(n - 1);
        kern[i][c][l] = signal(s, i, c, lag * dx + s.offset_m[i]);
      }
    }
  // Noise level from the peak response to the first identification force (fixed per scanner).
  double peak = 0;
  const auto& e0 = scene.identification.front();
  for (std::size_t l = 0; l < 2 * n - 1; ++l)
    for (int i = 0; i < 2; ++i) peak = std::max(peak, std::abs(e0.fx_N * kern[i][0][l] + e0.fz_N * kern[i][1][l]));
  const double noise_rms = peak * std::pow(10.0, -s.snr_dB / 20);
  // The ADC range fits the strongest edge of the family (1.5 N at mu 0.9), with the scanner's headroom.
  double strongest = peak;
  for (std::size_t l = 0; l < 2 * n - 1; ++l)
    for (int i = 0; i < 2; ++i) strongest = std::max(strongest, std::abs(1.35 * kern[i][0][l] + 1.5 * kern[i][1][l]));
  const double range = s.adc_headroom * strongest;
  std::mt19937_64 rng(noise_seed * 0x2545F4914F6CDD1Dull + 7);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> v[2];
  for (int i = 0; i < 2; ++i) {
    const auto yx = detail::linear_convolution(scan.fx_N, kern[i][0]);
    const auto yz = detail::linear_convolution(scan.fz_N, kern[i][1]);
    v[i].resize(n);
    const double half_codes = std::ldexp(1.0, s.adc_bits - 1), lsb = range / half_codes;
    for (std::size_t k = 0; k < n; ++k) {
      const double clean = yx[k + n - 1] + yz[k + n - 1];
      const double code = std::clamp(std::round((clean + noise_rms * normal(rng)) / lsb), -half_codes, half_codes - 1);
      v[i][k] = code * lsb;
    }
    if (s.moving_average > 1) {
      std::vector<double> out(n);
      double run = 0;
      for (std::size_t k = 0; k < n; ++k) {
        run += v[i][k];
        if (k >= static_cast<std::size_t>(s.moving_average)) run -= v[i][k - static_cast<std::size_t>(s.moving_average)];
        out[k] = run / s.moving_average;
      }
      v[i] = std::move(out);
    }
  }
  scan.m1_V = std::move(v[0]);
  scan.m2_V = std::move(v[1]);
  return scan;
}

std::vector<IdentificationScan> identification_scans(const FamilyScene& scene) {
  std::vector<IdentificationScan> ids;
  for (int pass = 0; pass < std::max(1, scene.identification_passes); ++pass) {
    for (std::size_t e = 0; e < scene.identification.size(); ++e) {
      IdentificationScan id;
      id.scan = scan_surface(scene, {scene.identification[e]}, {}, scene.seed * 64 + 32 + static_cast<std::uint64_t>(pass) * 2 + e);
      id.fx_N = scene.identification[e].fx_N;
      id.fz_N = scene.identification[e].fz_N;
      id.edge_x_m = scene.identification[e].x_m;
      ids.push_back(std::move(id));
    }
  }
  return ids;
}

Scan test_scan(const FamilyScene& scene) { return scan_surface(scene, scene.edges, scene.textures, scene.seed * 64 + 9); }

std::vector<EdgeScore> score_edges(const RestoredForces& r, const std::vector<FamilyEdge>& edges, double search_m) {
  std::vector<EdgeScore> out;
  for (const auto& e : edges) {
    std::size_t ip = 0;
    double pk = -1e300;
    for (std::size_t i = 0; i < r.x_m.size(); ++i)
      if (std::abs(r.x_m[i] - e.x_m) < search_m && r.fz_N_per_m[i] > pk) pk = r.fz_N_per_m[ip = i];
    std::size_t lo = ip, hi = ip;
    while (lo > 0 && r.fz_N_per_m[lo - 1] > 0.5 * pk) --lo;
    while (hi + 1 < r.x_m.size() && r.fz_N_per_m[hi + 1] > 0.5 * pk) ++hi;
    double c0 = 0, c1 = 0;
    for (std::size_t i = lo; i <= hi; ++i) {
      c0 += r.fz_N_per_m[i];
      c1 += r.fz_N_per_m[i] * r.x_m[i];
    }
    EdgeScore sc;
    sc.mu_error = pk > 0 ? std::abs(r.fx_N_per_m[ip] / pk - e.fx_N / e.fz_N) : 1.0;
    sc.position_error_m = c0 > 0 ? std::abs(c1 / c0 - e.x_m) : search_m;
    sc.peak_N_per_m = pk;
    out.push_back(sc);
  }
  return out;
}

double force_l2_error(const RestoredForces& r, const Scan& scan, double resolution_m) {
  const std::size_t n = r.x_m.size();
  const double dx = scan.sample_spacing_m();
  std::vector<double> t[2] = {scan.fx_N, scan.fz_N};
  if (resolution_m > 0) {
    detail::RealFft fft(detail::good_fft_size(2 * n));
    std::vector<std::complex<double>> F(fft.bins());
    const double s = resolution_m / 2.3548200450309493;
    for (auto& v : t) {
      fft.forward(v.data(), n, F.data());
      for (std::size_t k = 0; k < F.size(); ++k) {
        const double w = 2 * pi * static_cast<double>(k) / (static_cast<double>(fft.size()) * dx);
        F[k] *= std::exp(-0.5 * w * w * s * s);
      }
      std::vector<double> out(fft.size());
      fft.inverse(F.data(), out.data());
      v.assign(out.begin(), out.begin() + static_cast<long>(n));
    }
  }
  // Central 80 % of the scan (the ends lack half of the filter's support).
  const std::size_t lo = n / 10, hi = n - n / 10;
  const std::vector<double>* rr[2] = {&r.fx_N, &r.fz_N};
  double e = 0, nn = 0;
  for (int c = 0; c < 2; ++c) {
    double mr = 0, mt = 0;
    for (std::size_t i = lo; i < hi; ++i) {
      mr += (*rr[c])[i];
      mt += t[c][i];
    }
    mr /= static_cast<double>(hi - lo);
    mt /= static_cast<double>(hi - lo);
    for (std::size_t i = lo; i < hi; ++i) {
      e += std::pow((*rr[c])[i] - mr - t[c][i] + mt, 2);
      nn += std::pow(t[c][i] - mt, 2);
    }
  }
  return nn > 0 ? std::sqrt(e / nn) : 0.0;
}

}  // namespace pvdf::restore::family
