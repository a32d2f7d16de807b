// Benchmark of pvdf::restore on one core: (1) identification + inverse design time against the FIR
// length N, with the restoration error it buys (mu at the f_z peak, edge position); (2) streaming
// throughput against block size, in samples/s and multiples of real time at 10 kHz, with the
// difference to the offline result. Run: build/bench/restore/bench_restore
#include "pvdf/restore/apply.hpp"
#include "pvdf/restore/filter.hpp"
#include "pvdf/restore/scanner.hpp"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <cstdio>
#include <string>
#include <vector>

using namespace pvdf::restore;
namespace {
// Process CPU time, not wall time: the benchmark machine is shared, and one core's work is what we measure.
struct clock_type {
  using time_point = std::clock_t;
  static time_point now() { return std::clock(); }
};
double seconds_since(clock_type::time_point t0) {
  return static_cast<double>(std::clock() - t0) / CLOCKS_PER_SEC;
}

ScannerScene scene(const std::string& name) {
  return load_scanner_scene(std::string(PVDF_SOURCE_DIR) + "/examples/restore/" + name);
}

// Largest |mu error| at the f_z peaks and largest |shift| (samples) of the f_z main lobes.
void edge_errors(const RestoredForces& r, const ScannerScene& s, double& mu_err, double& shift) {
  mu_err = shift = 0;
  const double dx = s.sample_spacing_m();
  for (const auto& e : s.edges) {
    std::size_t ip = 0;
    double pk = -1;
    for (std::size_t i = 0; i < r.x_m.size(); ++i)
      if (std::abs(r.x_m[i] - e.x_m) < 1e-3 && r.fz_N[i] > pk) pk = r.fz_N[ip = i];
    std::size_t lo = ip, hi = ip;
    while (lo > 0 && r.fz_N[lo - 1] > 0.5 * pk) --lo;
    while (hi + 1 < r.fz_N.size() && r.fz_N[hi + 1] > 0.5 * pk) ++hi;
    double c0 = 0, c1 = 0;
    for (std::size_t i = lo; i <= hi; ++i) {
      c0 += r.fz_N[i];
      c1 += r.fz_N[i] * r.x_m[i];
    }
    mu_err = std::max(mu_err, std::abs(r.fx_N[ip] / r.fz_N[ip] - e.fx_N / e.fz_N));
    shift = std::max(shift, std::abs((c1 / c0 - e.x_m) / dx));
  }
}
// Relative L2 error of the restored texture `r` against the truth of `tscan` blurred by the filter's
// target (none: the truth itself) over the texture, means removed: the sensor cannot see the mean load.
double texture_error(const InverseFilter& f, const RestoredForces& r, const Scan& tscan) {
  std::vector<double> tx = tscan.fx_N, tz = tscan.fz_N;
  if (f.resolution_m > 0) {
    const double s = f.resolution_m / 2.3548200450309493, dx = tscan.sample_spacing_m();
    const long half = static_cast<long>(5 * s / dx);
    std::vector<double> w(2 * half + 1);
    double sum = 0;
    for (long k = -half; k <= half; ++k) sum += w[k + half] = std::exp(-0.5 * std::pow(k * dx / s, 2));
    for (auto& v : w) v /= sum;
    auto blur = [&](const std::vector<double>& f) {
      std::vector<double> out(f.size(), 0.0);
      for (std::size_t i = 0; i < f.size(); ++i) {
        if (f[i] == 0) continue;
        for (long k = -half; k <= half; ++k) {
          const long j = static_cast<long>(i) + k;
          if (j >= 0 && j < static_cast<long>(f.size())) out[j] += f[i] * w[k + half];
        }
      }
      return out;
    };
    tx = blur(tx);
    tz = blur(tz);
  }
  double mx = 0, mz = 0, ax = 0, az = 0;
  int n = 0;
  for (std::size_t i = 0; i < r.x_m.size(); ++i)
    if (r.x_m[i] > -0.012 && r.x_m[i] < 0.022) {
      mx += r.fx_N[i], mz += r.fz_N[i], ax += tx[i], az += tz[i];
      ++n;
    }
  mx /= n, mz /= n, ax /= n, az /= n;
  double e = 0, nn = 0;
  for (std::size_t i = 0; i < r.x_m.size(); ++i)
    if (r.x_m[i] > -0.012 && r.x_m[i] < 0.022) {
      e += std::pow(r.fx_N[i] - mx - tx[i] + ax, 2) + std::pow(r.fz_N[i] - mz - tz[i] + az, 2);
      nn += std::pow(tx[i] - ax, 2) + std::pow(tz[i] - az, 2);
    }
  return std::sqrt(e / nn);
}

// (1) identification + inverse design time against the FIR length; returns the N = 8192 filter.
InverseFilter time_against_length(const std::vector<IdentificationScan>& ids, const Scan& scan, const ScannerScene& test) {
  std::printf("(1) identification + design (CPU time), 2 scans of %zu samples, noise-floor beta, 1.5 mm target, 10 mm low cut\n", ids[0].scan.size());
  std::printf("%8s %12s %12s %12s %14s %14s\n", "N", "identify_ms", "design_ms", "beta_rel", "max|mu err|", "max|shift|smp");
  InverseFilter kept;
  for (std::size_t N : {2048u, 4096u, 8192u, 16384u}) {
    DesignOptions o;
    o.taps = N;
    o.isotropic = false;  // Tikhonov, as the table in docs/restore.md section 6
    o.beta_policy = BetaPolicy::discrepancy;
    o.resolution_m = 1.5e-3;
    o.low_cut_wavelength_m = 0.01;
    const int reps = 5;
    auto t0 = clock_type::now();
    TransferMatrix t;
    for (int r = 0; r < reps; ++r) t = identify_transfer(ids, o);
    const double t_id = seconds_since(t0) / reps;
    t0 = clock_type::now();
    InverseFilter f;
    for (int r = 0; r < reps; ++r) f = design_inverse(t, ids, o);
    const double t_design = seconds_since(t0) / reps;
    double mu_err = 0, shift = 0;
    edge_errors(restore_scan(f, scan), test, mu_err, shift);
    std::printf("%8zu %12.2f %12.2f %12.3g %14.4f %14.2f\n", N, 1e3 * t_id, 1e3 * t_design, f.beta, mu_err, shift);
    if (N == 8192) kept = f;
  }
  return kept;
}

// (2) streaming throughput against block size, and the difference to the offline result.
void streaming_throughput(const InverseFilter& kept, const Scan& scan) {
  std::vector<double> ox, oz;
  auto t0 = clock_type::now();
  restore_offline(kept, scan.m1_V, scan.m2_V, ox, oz);
  const double t_off = seconds_since(t0);
  std::printf("\n(2) applying the N = 8192 filters to %zu samples (one core, CPU time)\n", scan.size());
  std::printf("%10s %14s %14s %14s %16s\n", "block", "samples/s", "x real time", "latency_ms", "max|stream-off|");
  std::printf("%10s %14.3g %14.0f %14s %16s\n", "offline", scan.size() / t_off, scan.size() / t_off / 1e4, "-", "-");
  // Repeat the scan to get a long stream (60 s of scanning at 10 kHz).
  const std::size_t repeat = 30;
  for (std::size_t block : {256u, 1024u, 4096u, 8192u, 32768u}) {
    StreamingRestorer s(kept, block);
    std::vector<double> fx, fz;
    fx.reserve(scan.size() * repeat + block);
    fz.reserve(scan.size() * repeat + block);
    t0 = clock_type::now();
    for (std::size_t r = 0; r < repeat; ++r) {
      for (std::size_t i = 0; i < scan.size(); i += block) {
        const std::size_t n = std::min(block, scan.size() - i);
        s.push(scan.m1_V.data() + i, scan.m2_V.data() + i, n, fx, fz);
      }
    }
    s.flush(fx, fz);
    const double t = seconds_since(t0);
    double diff = 0;
    for (std::size_t i = 0; i + kept.taps < scan.size(); ++i) {  // first copy: equals the offline restoration
      diff = std::max(diff, std::abs(fz[i] - oz[i]) + std::abs(fx[i] - ox[i]));
    }
    const double rate = static_cast<double>(scan.size() * repeat) / t;
    std::printf("%10zu %14.3g %14.0f %14.1f %16.2e\n", block, rate, rate / 1e4, 1e3 * s.latency_samples() / 1e4, diff);
  }
  std::printf("\nlatency = (delay D + block - 1) samples at 10 kHz; target: >= 1000x real time (1e7 samples/s)\n");
}

// (3) beta policies: edges (mu at the f_z peak, lobe shift) and a texture (texture_error).
void beta_policies(const std::vector<IdentificationScan>& ids, const Scan& scan, const ScannerScene& test) {
  ScannerScene tex = scene("edge_a.json");
  tex.seed = 77;
  tex.edges.clear();
  tex.textures.push_back({-0.01, 0.02, 0.005, 0.0025, 0.5, 0.2, 0.7});
  const Scan tscan = simulate_scan(tex);
  std::printf("\n(3) beta policies (N = 8192; Tikhonov unless stated); forces with the flat-surface level fixed\n%-38s %10s %12s %14s %12s\n", "policy", "beta_rel", "max|mu err|",
              "max|shift|smp", "texture L2");
  struct Case {
    const char* name;
    BetaPolicy policy;
    double beta, resolution, low_cut;
    bool isotropic = false;  // Tikhonov (seed 000 eq. 4) unless stated
  };
  for (const Case& c : {Case{"constant 1e-4, no target (paper)", BetaPolicy::constant, 1e-4, 0.0, 0.0},
                        Case{"constant 1e-8, target, low cut", BetaPolicy::constant, 1e-8, 1.5e-3, 0.01},
                        Case{"constant 1e-4, target, low cut", BetaPolicy::constant, 1e-4, 1.5e-3, 0.01},
                        Case{"constant 10, target, low cut", BetaPolicy::constant, 10.0, 1.5e-3, 0.01},
                        Case{"gcv, target, low cut", BetaPolicy::gcv, 0.0, 1.5e-3, 0.01},
                        Case{"lcurve, target, low cut", BetaPolicy::lcurve, 0.0, 1.5e-3, 0.01},
                        Case{"morozov, target, low cut", BetaPolicy::morozov, 0.0, 1.5e-3, 0.01},
                        Case{"noise floor, target, no low cut", BetaPolicy::discrepancy, 0.0, 1.5e-3, 0.0},
                        Case{"noise floor, target, low cut", BetaPolicy::discrepancy, 0.0, 1.5e-3, 0.01},
                        Case{"predicted, target, low cut", BetaPolicy::predicted, 0.0, 1.5e-3, 0.01},
                        Case{"Tikhonov predicted, auto, auto", BetaPolicy::predicted, 0.0, -1.0, -1.0},
                        Case{"isotropic predicted, target, low cut", BetaPolicy::predicted, 0.0, 1.5e-3, 0.01, true},
                        Case{"defaults (isotropic, predicted, auto)", BetaPolicy::predicted, 0.0, -1.0, -1.0, true}}) {
    DesignOptions o;
    o.isotropic = c.isotropic;
    o.predicted_beta_scale = c.isotropic ? 1.0 : 0.25;
    o.beta_policy = c.policy;
    o.beta = c.beta;
    o.resolution_m = c.resolution;
    o.low_cut_wavelength_m = c.low_cut;
    const auto f = design_inverse(identify_transfer(ids, o), ids, o);
    double mu_err = 0, shift = 0;
    edge_errors(restore_scan(f, scan), test, mu_err, shift);
    const double texture = texture_error(f, restore_scan(f, tscan), tscan);
    std::printf("%-38s %10.3g %12.4f %14.2f %12.3f\n", c.name, f.beta, mu_err, shift, texture);
  }
}

}  // namespace

int main() {
  std::vector<IdentificationScan> ids(2);
  const char* names[2] = {"edge_a.json", "edge_b.json"};
  for (int i = 0; i < 2; ++i) {
    const auto s = scene(names[i]);
    ids[i].scan = simulate_scan(s);
    ids[i].fx_N = s.edges[0].fx_N;
    ids[i].fz_N = s.edges[0].fz_N;
    ids[i].edge_x_m = s.edges[0].x_m;
  }
  ScannerScene test = scene("edge_a.json");
  test.seed = 99;
  test.edges = {{-0.03, 0.45, 0.9}, {0.015, 0.15, 1.0}};
  const Scan scan = simulate_scan(test);

  const InverseFilter kept = time_against_length(ids, scan, test);
  streaming_throughput(kept, scan);
  beta_policies(ids, scan, test);
  return 0;
}
