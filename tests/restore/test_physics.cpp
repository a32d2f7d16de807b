// Physics oracles for the scanner model: Flamant equilibrium, the closed-form stress-rate signal against a
// finite difference of the Flamant charge, and seed 000 eq. 1 (corrected) against the model.
#include "pvdf/restore/physics.hpp"
#include "pvdf/restore/scanner.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace pvdf::restore;

namespace {
Strip horizontal(double depth) {
  Strip s;
  s.depth_m = depth;
  return s;
}
}  // namespace

TEST_CASE("Flamant stresses balance the applied line loads on every horizontal cut", "[restore][physics]") {
  // Integral over x of szz and txz at any depth equals -p and -q (equilibrium of the slab above the cut).
  for (double z : {0.5e-3, 2e-3}) {
    const double p = 40.0, q = -15.0;
    double szz = 0, txz = 0;
    const double L = 4000 * z, h = z / 200;
    for (double x = -L; x <= L; x += h) {
      const auto s = flamant_stress(p, q, x, z);
      szz += s.szz_Pa * h;
      txz += s.txz_Pa * h;
    }
    CHECK(szz == Approx(-p).epsilon(1e-3));
    CHECK(txz == Approx(-q).epsilon(1e-3));
  }
}

TEST_CASE("The closed-form strip signal is speed x R_f x area x d/dx of the Flamant charge", "[restore][physics]") {
  Strip a = horizontal(1e-3);
  Strip b;  // vertical film: poled along x
  b.depth_m = 1.7e-3;
  b.k1_C_per_N = -33e-12;
  b.k2_C_per_N = 23e-12;
  b.k3_C_per_N = 3e-12;
  const double R = 1e9, v = 0.05;
  for (const Strip& s : {a, b}) {
    for (double nu : {0.3, 0.5}) {
      for (auto c : {ForceComponent::x, ForceComponent::z}) {
        for (double x : {-7e-3, -1.3e-3, -2e-4, 0.0, 3e-4, 1e-3, 2.5e-3, 9e-3}) {
          const double h = 1e-7;
          const double dq = (strip_charge_density_per_N(s, nu, c, x + h) - strip_charge_density_per_N(s, nu, c, x - h)) / (2 * h);
          const double expected = s.area_m2() * R * v * dq;
          const double got = strip_signal_per_N(s, nu, R, v, c, x);
          const double scale = std::abs(strip_signal_per_N(s, nu, R, v, ForceComponent::x, 0.0));
          CHECK(std::abs(got - expected) < 1e-6 * scale);
        }
      }
    }
  }
}

TEST_CASE("Seed 000 eq. 1, repaired, is the model for nu = 1/2 with x mirrored and an inverting amplifier", "[restore][physics]") {
  const Strip s = horizontal(1.2e-3);
  const double R = 1e8, v = 0.02;
  for (double mu : {0.0, 0.3, 0.8}) {
    for (double x : {-4e-3, -1e-3, -3e-4, 2e-4, 1.1e-3, 5e-3}) {
      // Eq. 1's x = load - strip = -x_rel; its sign is that of v = -R_f dq/dt.
      const double model = strip_signal_per_N(s, 0.5, R, v, ForceComponent::z, -x) +
                           mu * strip_signal_per_N(s, 0.5, R, v, ForceComponent::x, -x);
      const double eq1 = howe_cutkosky_eq1(s, R, v, mu, x);
      CHECK(eq1 == Approx(-model).epsilon(1e-6).margin(1e-9 * std::abs(strip_signal_per_N(s, 0.5, R, v, ForceComponent::x, 0.0))));
    }
  }
}

TEST_CASE("The strip signal scales with speed and 1/depth^2 and its tangential tail decays as 1/x^2", "[restore][physics]") {
  const Strip s = horizontal(1e-3);
  for (auto c : {ForceComponent::x, ForceComponent::z}) {
    Strip deeper = s;
    deeper.depth_m = 2e-3;
    CHECK(strip_signal_per_N(deeper, 0.5, 1e9, 0.05, c, 0.7e-3 * 2) ==
          Approx(strip_signal_per_N(s, 0.5, 1e9, 0.05, c, 0.7e-3) / 4).epsilon(1e-12));
    CHECK(strip_signal_per_N(s, 0.5, 1e9, 0.1, c, 0.4e-3) == Approx(2 * strip_signal_per_N(s, 0.5, 1e9, 0.05, c, 0.4e-3)));
  }
  // sxx of a line load decays as 1/r (Flamant), so its rate decays as 1/x^2: the long tail identification must keep.
  const double far1 = strip_signal_per_N(s, 0.5, 1e9, 0.05, ForceComponent::x, 0.1);
  const double far2 = strip_signal_per_N(s, 0.5, 1e9, 0.05, ForceComponent::x, 0.2);
  CHECK(far1 / far2 == Approx(4.0).epsilon(1e-3));
}

TEST_CASE("Simulated edge scan without noise equals the closed form at every sample", "[restore][simulate]") {
  ScannerScene scene = default_scanner_scene();
  scene.x_start_m = -0.01;
  scene.x_end_m = 0.01;
  scene.edges.push_back({-0.002, 0.3, 0.7});
  scene.moving_average_samples = 1;
  SimulateOptions o;
  o.noise = false;
  o.adc = false;
  const Scan scan = simulate_scan(scene, o);
  REQUIRE(scan.size() == scene.n_samples());
  for (std::size_t k = 0; k < scan.size(); k += 97) {
    for (int i = 0; i < 2; ++i) {
      const Strip& s = scene.sensor.strips[i];
      const double xr = scan.x_m[k] + s.offset_m + 0.002;
      const double expected = 0.3 * strip_signal_per_N(s, 0.5, 1e9, scene.speed_m_per_s, ForceComponent::x, xr) +
                              0.7 * strip_signal_per_N(s, 0.5, 1e9, scene.speed_m_per_s, ForceComponent::z, xr);
      CHECK((i == 0 ? scan.m1_V[k] : scan.m2_V[k]) == Approx(expected).margin(1e-12));
    }
  }
  // The reference force sits on the edge's sample.
  double total = 0;
  for (double f : scan.fz_N) total += f;
  CHECK(total == Approx(0.7));
}

TEST_CASE("A texture's per-sample forces integrate to its ridge forces and follow mu(x)", "[restore][simulate]") {
  ScannerScene scene = default_scanner_scene();
  scene.textures.push_back({0.0, 0.02, 0.005, 0.002, 0.5, 0.2, 0.6});
  std::vector<double> x(scene.n_samples());
  for (std::size_t k = 0; k < x.size(); ++k) x[k] = scene.x_start_m + k * scene.sample_spacing_m();
  std::vector<double> fx, fz;
  surface_forces(scene, x, fx, fz);
  double total = 0;
  for (double f : fz) total += f;
  CHECK(total == Approx(4 * 0.5).epsilon(1e-9));  // ridges at 0, 5, 10, 15 mm
  for (std::size_t k = 0; k < x.size(); ++k) {
    if (fz[k] > 1e-6) CHECK(fx[k] / fz[k] == Approx(0.2 + 0.4 * x[k] / 0.02).margin(1e-9));
  }
}

TEST_CASE("Texture signals by convolution match the closed form summed over the texture's samples", "[restore][simulate]") {
  ScannerScene scene = default_scanner_scene();
  scene.x_start_m = -0.004;
  scene.x_end_m = 0.004;
  scene.moving_average_samples = 1;
  scene.textures.push_back({-0.001, 0.001, 0.002, 0.002, 0.4, 0.5, 0.5});
  SimulateOptions o;
  o.noise = false;
  o.adc = false;
  const Scan scan = simulate_scan(scene, o);
  for (std::size_t k = 0; k < scan.size(); k += 211) {
    double expected = 0;
    for (std::size_t q = 0; q < scan.size(); ++q) {
      if (scan.fz_N[q] == 0) continue;
      const double xr = scan.x_m[k] + scene.sensor.strips[0].offset_m - scan.x_m[q];
      expected += scan.fx_N[q] * strip_signal_per_N(scene.sensor.strips[0], 0.5, 1e9, scene.speed_m_per_s, ForceComponent::x, xr) +
                  scan.fz_N[q] * strip_signal_per_N(scene.sensor.strips[0], 0.5, 1e9, scene.speed_m_per_s, ForceComponent::z, xr);
    }
    CHECK(scan.m1_V[k] == Approx(expected).margin(1e-9));
  }
}
