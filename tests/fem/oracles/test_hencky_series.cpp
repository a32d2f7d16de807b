// Hencky's series computed from its recursion: Chien's corrected K(ν = 0.3) = 0.6534, the ODE and
// the rim condition hold, and the series has converged.
#include <catch2/catch.hpp>

#include "hencky.hpp"

using namespace pvdf::fem::oracles;

TEST_CASE("Hencky series reproduces Chien's corrected coefficient, not the textbook 0.662", "[oracle][hencky]") {
  const HenckySeries H = hencky_series(0.3);
  CHECK(H.K == Approx(0.6534).margin(1e-4));
  CHECK(std::abs(H.K - 0.662) / H.K > 0.01);  // the uncorrected value is ~1.3 % off
  CHECK(H.tail < 1e-12);
  // Rim condition u(a) = 0: (1 − ν) s(1) + s'(1) = 0.
  CHECK(std::abs((1 - 0.3) * H.s(1.0) + H.ds(1.0)) < 1e-12);
}

TEST_CASE("Hencky series satisfies s'' + 3 s'/rho + 1/s^2 = 0 inside the film", "[oracle][hencky]") {
  const HenckySeries H = hencky_series(0.25);
  for (double rho : {0.1, 0.4, 0.7, 0.95}) {
    const double d = 1e-4;
    const double s2 = (H.s(rho + d) - 2 * H.s(rho) + H.s(rho - d)) / (d * d);
    const double residual = s2 + 3 * H.ds(rho) / rho + 1 / (H.s(rho) * H.s(rho));
    CHECK(std::abs(residual) < 1e-5);
  }
}

TEST_CASE("Hencky series: the deflection integral matches its power series", "[oracle][hencky]") {
  // 1/s = Σ d_n ρ^{2n} by series division; K = Σ d_n / (2n + 2) must equal the quadrature.
  const HenckySeries H = hencky_series(0.3);
  const std::size_t n = H.b.size();
  std::vector<double> d(n, 0.0);
  d[0] = 1 / H.b[0];
  for (std::size_t k = 1; k < n; ++k) {
    double acc = 0;
    for (std::size_t i = 1; i <= k; ++i) acc += H.b[i] * d[k - i];
    d[k] = -acc / H.b[0];
  }
  double K_series = 0;
  for (std::size_t k = 0; k < n; ++k) K_series += d[k] / (2.0 * k + 2);
  CHECK(K_series == Approx(H.K).epsilon(1e-9));
  // K grows as ν grows? No: a larger ν stiffens the hoop direction, so the film deflects less.
  CHECK(hencky_series(0.45).K < hencky_series(0.1).K);
}
