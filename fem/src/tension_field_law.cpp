// The tension-field (wrinkling) law of an orthotropic membrane (tension_field.hpp, docs/fem.md §3.3):
// state, relaxed stress, relaxed energy and its exact tangent at one point. No deal.II.
#include "pvdf/core/constants.hpp"
#include "tension_field.hpp"

#include <algorithm>
#include <cmath>

namespace pvdf::fem::detail {

namespace {

double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
void mul3(const double C[3][3], const double* x, double* y) {
  for (int i = 0; i < 3; ++i) y[i] = C[i][0] * x[0] + C[i][1] * x[1] + C[i][2] * x[2];
}

// The wrinkle strain direction m(θ) = t⊗t in engineering Voigt form, t = (−sin θ, cos θ), and its
// first two θ-derivatives. m·S = t·S·t for a stress S; β m is the strain β t⊗t.
struct Direction {
  double m[3], m1[3], m2[3];
  explicit Direction(double th) {
    const double s = std::sin(th), c = std::cos(th), s2 = std::sin(2 * th), c2 = std::cos(2 * th);
    m[0] = s * s, m[1] = c * c, m[2] = -2 * s * c;
    m1[0] = s2, m1[1] = -s2, m1[2] = -2 * c2;
    m2[0] = 2 * c2, m2[1] = -2 * c2, m2[2] = 4 * s2;
  }
};

// h(θ) = g²/(2k) with g = m·C·e (normal stress across the wrinkles before relaxation) and
// k = m·C·m: the energy the wrinkles release at angle θ (when g < 0), and h', h''.
struct Release {
  double g, g1, k, k1, h, h1, h2;
  double a[3], a1[3];  // C m, C m'
};

Release release(const double C[3][3], const double* Se, const Direction& d) {
  Release r{};
  mul3(C, d.m, r.a);
  mul3(C, d.m1, r.a1);
  r.g = dot3(d.m, Se);
  r.g1 = dot3(d.m1, Se);
  const double g2 = dot3(d.m2, Se);
  r.k = dot3(d.m, r.a);
  r.k1 = 2 * dot3(d.m1, r.a);
  const double k2 = 2 * (dot3(d.m2, r.a) + dot3(d.m1, r.a1));
  const double k = r.k, g = r.g, g1 = r.g1, k1 = r.k1;
  r.h = g < 0 ? 0.5 * g * g / k : 0.0;
  r.h1 = g < 0 ? g * g1 / k - 0.5 * g * g * k1 / (k * k) : 0.0;
  r.h2 = g < 0 ? (g1 * g1 + g * g2) / k - 2 * g * g1 * k1 / (k * k) - 0.5 * g * g * k2 / (k * k) +
                     g * g * k1 * k1 / (k * k * k)
               : 0.0;
  return r;
}

}  // namespace

RelaxedMembrane relaxed_membrane(const double C[3][3], const std::array<double, 3>& e, bool want_tangent) {
  RelaxedMembrane L;
  double Se[3];
  mul3(C, e.data(), Se);
  const double W_plain = 0.5 * dot3(e.data(), Se);
  // Taut: the smaller principal stress of C·e is positive.
  if (principal_values(Se[0], Se[1], Se[2])[1] > 0) {
    L.state = MembraneState::taut;
    L.S = {Se[0], Se[1], Se[2]};
    L.W = W_plain;
    if (want_tangent)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) L.D[i][j] = C[i][j];
    return L;
  }
  // Slack: the larger principal strain is not positive.
  const double em = 0.5 * (e[0] + e[1]), er = std::hypot(0.5 * (e[0] - e[1]), 0.5 * e[2]);
  if (em + er <= 0) {
    L.state = MembraneState::slack;
    return L;
  }
  // Wrinkled: maximise the released energy h(θ) over θ ∈ [0, π): a scan, then Newton on h' = 0.
  L.state = MembraneState::wrinkled;
  constexpr int n_scan = 24;
  // Candidates: t along the smaller principal stress of C·e (most compressed; the compressive window
  // of θ can be narrower than the scan's spacing near the taut state) and a scan of [0, π).
  const double phi = 0.5 * std::atan2(2 * Se[2], Se[0] - Se[1]) + 0.5 * pvdf::pi;  // smaller principal direction
  double best = release(C, Se, Direction(std::atan2(-std::cos(phi), std::sin(phi)))).h, th = std::atan2(-std::cos(phi), std::sin(phi));
  for (int i = 0; i < n_scan; ++i) {
    const double t = pvdf::pi * i / n_scan;
    const Release r = release(C, Se, Direction(t));
    if (r.h > best) best = r.h, th = t;
  }
  Release r = release(C, Se, Direction(th));
  // Newton on h'(θ) = 0 from the best scanned angle; a step is kept when it releases more energy or,
  // at round-off level of h, when it reduces |h'| (so θ is found to round-off, not to √ε).
  const double h1_scale = 1e-15 * (std::abs(r.g * r.g1) / r.k + std::abs(r.g * r.g * r.k1) / (r.k * r.k)) + 1e-300;
  for (int it = 0; it < 60 && std::abs(r.h1) > h1_scale; ++it) {
    double step = r.h2 < 0 ? -r.h1 / r.h2 : (r.h1 > 0 ? 1.0 : -1.0) * pvdf::pi / (4 * n_scan);
    step = std::clamp(step, -pvdf::pi / (2 * n_scan), pvdf::pi / (2 * n_scan));
    Release trial = release(C, Se, Direction(th + step));
    auto better = [&](const Release& x) {
      return x.h > r.h * (1 + 1e-14) || (x.h >= r.h * (1 - 1e-14) && std::abs(x.h1) < std::abs(r.h1));
    };
    while (!better(trial) && std::abs(step) > 1e-16) {
      step *= 0.5;
      trial = release(C, Se, Direction(th + step));
    }
    if (!better(trial)) break;
    th += step;
    r = trial;
  }
  L.wrinkle_angle_rad = th;
  const double beta = -r.g / r.k;  // ≥ 0: the strain the wrinkles take up
  for (int i = 0; i < 3; ++i) L.S[i] = Se[i] + beta * r.a[i];
  if (L.S[0] + L.S[1] <= 0) {  // no tension left along n either: slack
    L = RelaxedMembrane{};
    L.state = MembraneState::slack;
    return L;
  }
  L.W = std::max(0.0, W_plain - r.h);
  if (want_tangent) {
    // D = C − a aᵀ/k − v vᵀ/f'' with f(e, θ) = W(e) − h, v = ∂²f/∂e∂θ, f'' = −h'' (> 0 at the optimum).
    double v[3];
    const double c1 = -(r.g1 / r.k - r.g * r.k1 / (r.k * r.k)), c2 = -r.g / r.k;
    for (int i = 0; i < 3; ++i) v[i] = c1 * r.a[i] + c2 * r.a1[i];
    const double fthth = -r.h2;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        L.D[i][j] = C[i][j] - r.a[i] * r.a[j] / r.k;
        if (fthth > 1e-12 * r.k * std::abs(beta) + 1e-300) L.D[i][j] -= v[i] * v[j] / fthth;
      }
  }
  return L;
}

}  // namespace pvdf::fem::detail
