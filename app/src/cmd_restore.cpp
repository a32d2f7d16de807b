// `pvdfkit restore simulate|identify|apply`: the seed-000 scanner simulator, identification of the 2x2
// transfer matrix with the regularized inverse filters, and restoration of (f_x, f_z, mu) from scans.
#include "command.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/restore/apply.hpp"
#include "pvdf/restore/filter.hpp"
#include "pvdf/restore/plots.hpp"
#include "pvdf/restore/scan_io.hpp"
#include "pvdf/restore/scanner.hpp"

#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace {

namespace r = pvdf::restore;

struct SimulateOptions {
  std::string scene;
  std::string output;
  std::string plot;
  bool no_noise = false;
};

struct IdentifyOptions {
  std::vector<std::string> scans, forces;
  std::vector<double> edges;
  std::string output, plot_dir, beta = "1e-4", policy, window = "tukey";
  double speed = 0, corner = 0, resolution = 0, low_cut = 0;
  std::size_t taps = 8192, g_window = 0;
  long delay = -1;
};

struct ApplyOptions {
  std::string filter, scan, output, plot;
  double speed = 0, mu_threshold = -1;
  std::size_t block = 0;
};

int run_simulate(const SimulateOptions& o) {
  const r::ScannerScene scene = r::load_scanner_scene(o.scene);
  for (const auto& w : scene.warnings) pvdf::app::warn(w);
  r::SimulateOptions so;
  if (o.no_noise) so.noise = false;
  const r::Scan scan = r::simulate_scan(scene, so);
  char comment[256];
  std::snprintf(comment, sizeof comment, "pvdfkit restore simulate %s: speed %.6g m/s, %.6g Hz, dx %.6g m", o.scene.c_str(),
                scene.speed_m_per_s, scene.sample_rate_Hz, scene.sample_spacing_m());
  r::write_scan_csv(o.output, scan, comment);
  double p1 = 0, p2 = 0;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    p1 = std::max(p1, std::abs(scan.m1_V[i]));
    p2 = std::max(p2, std::abs(scan.m2_V[i]));
  }
  std::printf("simulated %zu samples, dx = %.4g m (%.4g mm/s at %.4g Hz), peak |m1| = %.4g V, |m2| = %.4g V -> %s\n",
              scan.size(), scene.sample_spacing_m(), scene.speed_m_per_s * 1e3, scene.sample_rate_Hz, p1, p2,
              o.output.c_str());
  if (p1 >= scene.adc_range_V || p2 >= scene.adc_range_V) pvdf::app::warn("the signal reaches the ADC range (clipped)");
  if (!o.plot.empty()) {
    r::plot_scan(o.plot, scan, "Simulated scan: " + o.scene);
    std::printf("plot written to %s\n", o.plot.c_str());
  }
  return pvdf::exit_code::success;
}

int run_identify(const IdentifyOptions& o) {
  if (o.scans.size() != o.forces.size()) {
    throw pvdf::InputError("identify: " + std::to_string(o.scans.size()) + " --scan but " + std::to_string(o.forces.size()) +
                           " --force; give one --force FX,FZ after each --scan");
  }
  if (!o.edges.empty() && o.edges.size() != o.scans.size()) {
    throw pvdf::InputError("identify: " + std::to_string(o.edges.size()) + " --edge-x-m for " + std::to_string(o.scans.size()) +
                           " scans; give one per scan or none (then every edge is at x = 0)");
  }
  r::DesignOptions d;
  d.taps = o.taps;
  d.delay_samples = o.delay;
  d.window = o.window;
  d.corner_wavelength_m = o.corner;
  std::string policy = o.policy;
  d.resolution_m = o.resolution;
  d.low_cut_wavelength_m = o.low_cut;
  d.g_window = o.g_window;
  if (o.beta == "auto" || o.beta == "gcv") {
    const std::string chosen = o.beta == "auto" ? "discrepancy" : "gcv";
    if (!policy.empty() && policy != chosen) throw pvdf::InputError("--beta " + o.beta + " contradicts --beta-policy " + policy);
    policy = chosen;
  } else {
    double b = 0;
    if (!pvdf::parse_finite(o.beta, b) || !(b > 0)) {
      throw pvdf::InputError("--beta = " + o.beta + " must be a number > 0 (relative, seed 000 used 1e-4) or 'auto' (GCV)");
    }
    d.beta = b;
    if (policy.empty()) policy = o.corner > 0 ? "frequency" : "constant";
  }
  if (policy == "constant") d.beta_policy = r::BetaPolicy::constant;
  else if (policy == "frequency") d.beta_policy = r::BetaPolicy::frequency;
  else if (policy == "gcv") d.beta_policy = r::BetaPolicy::gcv;
  else if (policy == "discrepancy") d.beta_policy = r::BetaPolicy::discrepancy;
  else throw pvdf::InputError("--beta-policy = " + policy + " must be constant, frequency, gcv or discrepancy");

  std::vector<r::IdentificationScan> scans;
  for (std::size_t i = 0; i < o.scans.size(); ++i) {
    r::IdentificationScan s;
    s.scan = r::read_scan_csv(o.scans[i], o.speed);
    const auto f = pvdf::parse_number_list(o.forces[i], "--force (FX,FZ in N)", 2);
    s.fx_N = f[0];
    s.fz_N = f[1];
    s.edge_x_m = o.edges.empty() ? 0.0 : o.edges[i];
    scans.push_back(std::move(s));
  }
  const r::TransferMatrix t = r::identify_transfer(scans, d);
  for (const auto& w : t.warnings) pvdf::app::warn(w);
  const r::InverseFilter f = r::design_inverse(t, scans, d);
  r::save_filter(o.output, f);
  std::printf("identified G from %zu scans: cond(F) = %.3g, noise rms = %.3g / %.3g V, SNR =", scans.size(),
              t.force_condition_number, t.noise_rms_V[0], t.noise_rms_V[1]);
  for (double s : t.scan_snr) std::printf(" %.3g", s);
  std::printf("\nG conditioning over %.0f %% of the band: min %.3g, median %.3g, max %.3g\n", 100 * f.conditioning.band_fraction,
              f.conditioning.min, f.conditioning.median, f.conditioning.max);
  std::printf("inverse: beta (%s) = %.3g relative (%.3g V^2/N^2), %zu taps, delay %ld samples = %.4g mm, design FFT %zu, "
              "truncated energy %.2e -> %s\n",
              f.beta_policy.c_str(), f.beta, f.beta_abs, f.taps, f.delay_samples, f.delay_samples * f.sample_spacing_m * 1e3,
              f.design_fft_length, f.truncated_energy_fraction, o.output.c_str());
  if (f.truncated_energy_fraction > 0.1) {
    pvdf::app::warn("more than 10 % of the inverse filter's energy lies outside its taps; raise --taps or beta");
  }
  if (!o.plot_dir.empty()) {
    pvdf::make_directories(o.plot_dir);
    for (std::size_t i = 0; i < scans.size(); ++i) {
      r::plot_scan(o.plot_dir + "/fig11_12_scan" + std::to_string(i + 1) + ".png", scans[i].scan,
                   "Identification scan " + std::to_string(i + 1) + ": " + o.scans[i] + ", force " + o.forces[i] + " N");
    }
    r::plot_filters(o.plot_dir + "/fig13_inverse_filters.png", f);
    r::plot_transfer(o.plot_dir + "/transfer_G.png", f);
    for (std::size_t i = 0; i < scans.size(); ++i) {
      const auto forces = r::restore_scan(f, scans[i].scan);
      r::plot_restored(o.plot_dir + "/fig14_restored" + std::to_string(i + 1) + ".png", forces, scans[i].scan,
                       "Restored forces, identification scan " + std::to_string(i + 1), f.resolution_m);
    }
    std::printf("plots written to %s\n", o.plot_dir.c_str());
  }
  return pvdf::exit_code::success;
}

int run_apply(const ApplyOptions& o) {
  const r::InverseFilter f = r::load_filter(o.filter);
  const r::Scan scan = r::read_scan_csv(o.scan, o.speed);
  r::RestoredForces forces;
  if (o.block > 0) {
    // Streaming path (as a real-time loop would run it), then mu as offline.
    forces = r::restore_scan(f, scan, o.mu_threshold);  // checks spacing, gives x and the threshold
    r::StreamingRestorer s(f, o.block);
    std::vector<double> fx, fz;
    for (std::size_t i = 0; i < scan.size(); i += o.block) {
      const std::size_t n = std::min(o.block, scan.size() - i);
      s.push(scan.m1_V.data() + i, scan.m2_V.data() + i, n, fx, fz);
    }
    s.flush(fx, fz);
    forces.fx_N = fx;
    forces.fz_N = fz;
    r::friction_coefficient(forces, forces.mu_threshold_N);
    std::printf("streaming: block %zu samples, latency %zu samples = %.4g mm of scan\n", o.block, s.latency_samples(),
                s.latency_samples() * f.sample_spacing_m * 1e3);
  } else {
    forces = r::restore_scan(f, scan, o.mu_threshold);
  }
  r::write_forces_csv(o.output, forces, "pvdfkit restore apply " + o.filter + " " + o.scan);
  double fz_max = 0, sum_x = 0, sum_z = 0;
  for (std::size_t i = 0; i < forces.fz_N.size(); ++i) {
    fz_max = std::max(fz_max, forces.fz_N[i]);
    sum_x += forces.fx_N[i];
    sum_z += forces.fz_N[i];
  }
  std::printf("restored %zu samples: max f_z = %.4g N/sample, sum f_x = %.4g N, sum f_z = %.4g N, mu threshold %.3g N -> %s\n",
              forces.x_m.size(), fz_max, sum_x, sum_z, forces.mu_threshold_N, o.output.c_str());
  if (!o.plot.empty()) {
    r::plot_restored(o.plot, forces, scan, "Restored forces: " + o.scan, f.resolution_m);
    std::printf("plot written to %s\n", o.plot.c_str());
  }
  return pvdf::exit_code::success;
}

}  // namespace

PVDF_COMMAND(60, [](CLI::App& root) {
  auto* sub = root.add_subcommand("restore", "Seed 000 cylindrical scanner: simulate scans, identify the 2x2 inverse "
                                             "filter, restore f_x, f_z and mu (docs/restore.md)");
  sub->require_subcommand(1);

  auto so = std::make_shared<SimulateOptions>();
  auto* sim = sub->add_subcommand("simulate", "Simulate a scan of a surface (raised edges, textures) from a scanner scene");
  sim->add_option("SCENE", so->scene, "Scanner scene JSON (examples/restore/scanner.json; keys in docs/restore.md)")->required();
  sim->add_option("-o,--output", so->output, "Scan CSV to write: x_m,m1_V,m2_V,fx_ref_N,fz_ref_N")->required();
  sim->add_option("--plot", so->plot, "Also write the signals as PNG (seed 000 Figs 11-12)");
  sim->add_flag("--no-noise", so->no_noise, "Leave out the white noise (ADC and moving average stay)");

  auto io = std::make_shared<IdentifyOptions>();
  auto* id = sub->add_subcommand("identify", "Identify G from scans of known forces (eq. 6) and design the inverse "
                                              "filters H = (G^H G + beta I)^-1 G^H (eq. 4)");
  id->add_option("--scan", io->scans, "Scan CSV of one raised edge (repeat: at least 2)")->required();
  id->add_option("--force", io->forces, "Known force FX,FZ in N of the preceding --scan (seed 000: 0.6,0.9 and 0.2,1.0)")->required();
  id->add_option("--edge-x-m", io->edges, "Edge position in m for each --scan, in order (default 0 for all)");
  id->add_option("--speed-m-per-s", io->speed, "Scan speed, needed for scans given in t_s");
  id->add_option("-o,--output", io->output, "Filter file to write (JSON)")->required();
  id->add_option("--taps", io->taps, "FIR length N of h11..h22 and of the G window")->capture_default_str();
  id->add_option("--delay-samples", io->delay, "Modelling delay D in samples (default taps/2)");
  id->add_option("--beta", io->beta, "Regularization: relative beta (seed 000: 1e-4), 'auto' (noise floor of G, "
                                     "discrepancy principle) or 'gcv'")->capture_default_str();
  id->add_option("--beta-policy", io->policy, "constant | frequency | gcv | discrepancy (default: constant, or frequency "
                                              "with --beta-corner-m)");
  id->add_option("--resolution-m", io->resolution, "Target resolution (Gaussian FWHM, m) applied to both forces; 0 = none "
                                                   "(seed 000). 1e-3 suits 1 mm deep strips");
  id->add_option("--low-cut-m", io->low_cut, "Damp wavelengths beyond this (m): beta(k) *= 1 + (k_low/k)^2; the sensor "
                                            "cannot see the mean load. 0 = off (seed 000); 0.01 suits the example");
  id->add_option("--g-window", io->g_window, "Lags of G kept by identification (default = --taps)");
  id->add_option("--beta-corner-m", io->corner, "Wavelength in m for beta(k) = beta (1 + (k L/2pi)^2)");
  id->add_option("--window", io->window, "Taper of the FIR taps: tukey, hann, none")->capture_default_str();
  id->add_option("--plot-dir", io->plot_dir, "Write Fig 11-14 analogues (signals, filters, |G|, restored) as PNG here");

  auto ao = std::make_shared<ApplyOptions>();
  auto* ap = sub->add_subcommand("apply", "Restore f_x, f_z and mu from a scan with a filter: x_m,fx_N,fz_N,mu,mu_valid");
  ap->add_option("FILTER", ao->filter, "Filter file from 'restore identify'")->required();
  ap->add_option("SCAN", ao->scan, "Scan CSV x_m,m1_V,m2_V (or t_s with --speed-m-per-s)")->required();
  ap->add_option("-o,--output", ao->output, "Forces CSV to write")->required();
  ap->add_option("--speed-m-per-s", ao->speed, "Scan speed, needed for scans given in t_s");
  ap->add_option("--mu-threshold-N", ao->mu_threshold, "mu where f_z exceeds this (N per sample; default 30 % of max f_z)");
  ap->add_option("--block", ao->block, "Use the streaming restorer with blocks of this many samples (same result)");
  ap->add_option("--plot", ao->plot, "Also write the restored forces as PNG (seed 000 Fig. 14)");

  return pvdf::app::Subcommand{sub, [sim, id, ap, so, io, ao]() -> int {
                                 if (sim->parsed()) return run_simulate(*so);
                                 if (id->parsed()) return run_identify(*io);
                                 if (ap->parsed()) return run_apply(*ao);
                                 throw pvdf::InputError("restore: choose simulate, identify or apply");
                               }};
});
