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
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace {

// The library names quantities, not flags: where one of its messages is about a quantity a flag of
// this command sets, the flag is added here.
template <class Call>
auto naming_flag(Call call, const char* phrase, const std::string& flag_hint) {
  try {
    return call();
  } catch (const pvdf::InputError& e) {
    const std::string what = e.what();
    if (what.find(phrase) == std::string::npos) throw;
    throw pvdf::InputError(what + "; " + flag_hint);
  }
}

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
  std::string output, plot_dir, beta = "auto", policy, window = "tukey", resolution = "auto", low_cut = "auto";
  std::string regularization = "isotropic";
  double speed = 0, corner = 0;
  long taps = 8192, g_window = 0, delay = -1;
  CLI::Option* delay_flag = nullptr;
};

struct ApplyOptions {
  std::string filter, scan, output, plot;
  double speed = 0, mu_threshold = -1, baseline_scale = 0;
  long block = 0;
  bool no_baseline = false, resample = false;
  CLI::Option* threshold_flag = nullptr;
  CLI::Option* block_flag = nullptr;
  CLI::Option* scale_flag = nullptr;
};

// Figure titles name files without their folders.
std::string file_name(const std::string& path) { return std::filesystem::path(path).filename().string(); }

// Bad flag values exit 2 with the flag, the value (%g), the rule and the fix.
void check_range(const char* flag, double value, double lo, double hi, const char* fix) {
  if (std::isfinite(value) && value >= lo && value <= hi) return;
  char buf[400];
  std::snprintf(buf, sizeof buf, "%s = %g must be in [%g, %g]; %s", flag, value, lo, hi, fix);
  throw pvdf::InputError(buf);
}

// "auto" (negative: the design picks it from G) or a length in [0, hi] m.
double auto_or_length(const char* flag, const std::string& text, double hi, const char* fix) {
  if (text == "auto") return -1;
  double v = 0;
  if (!pvdf::parse_finite(text, v)) {
    throw pvdf::InputError(std::string(flag) + " = '" + text + "' must be 'auto' or a length in m; " + fix);
  }
  check_range(flag, v, 0, hi, fix);
  return v;
}


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
  const double p1 = scan.peak_m1_V(), p2 = scan.peak_m2_V();
  std::printf("simulated %zu samples, dx = %.4g m (%.4g mm/s at %.4g Hz), peak |m1| = %.4g V, |m2| = %.4g V -> %s\n",
              scan.size(), scene.sample_spacing_m(), scene.speed_m_per_s * 1e3, scene.sample_rate_Hz, p1, p2,
              o.output.c_str());
  if (p1 >= scene.adc_range_V || p2 >= scene.adc_range_V) pvdf::app::warn("the signal reaches the ADC range (clipped)");
  if (!o.plot.empty()) {
    r::plot_scan(o.plot, scan, "Simulated scan: " + file_name(o.scene));
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
  check_range("--taps", static_cast<double>(o.taps), 64, 4194304, "give an even FIR length such as 8192");
  if (o.g_window != 0) check_range("--g-window", static_cast<double>(o.g_window), 64, 4194304, "give an even number of lags or omit it");
  if (o.taps % 2 != 0) throw pvdf::InputError("--taps = " + std::to_string(o.taps) + " must be even; give an even FIR length such as 8192");
  if (o.g_window % 2 != 0) throw pvdf::InputError("--g-window = " + std::to_string(o.g_window) + " must be even; give an even number of lags or omit it");
  if (o.delay_flag->count() > 0) check_range("--delay-samples", static_cast<double>(o.delay), 0, static_cast<double>(o.taps - 1), "omit it for taps/2");
  check_range("--speed-m-per-s", o.speed, 0, 10, "give the scan speed in m/s (seed 000: 0.01-0.1)");
  check_range("--beta-corner-m", o.corner, 0, 1, "give a wavelength in m, or 0 for none");
  for (double e : o.edges) check_range("--edge-x-m", e, -10, 10, "give the edge position in m on the scan's x_m axis");
  r::DesignOptions d;
  d.taps = static_cast<std::size_t>(o.taps);
  d.delay_samples = o.delay;
  d.window = o.window;
  d.corner_wavelength_m = o.corner;
  std::string policy = o.policy;
  d.resolution_m = auto_or_length("--resolution-m", o.resolution, 1, "0 = no target (seed 000), auto = 1.5 x the strips' effective depth");
  d.low_cut_wavelength_m = auto_or_length("--low-cut-m", o.low_cut, 100, "0 = off (seed 000), auto = 10 x the strips' effective depth");
  d.g_window = static_cast<std::size_t>(o.g_window);
  if (o.regularization != "isotropic" && o.regularization != "tikhonov") {
    throw pvdf::InputError("--regularization = '" + o.regularization + "' must be isotropic (default) or tikhonov (seed 000 eq. 4)");
  }
  d.isotropic = o.regularization == "isotropic";
  if (!d.isotropic) d.predicted_beta_scale = 0.25;
  const std::map<std::string, std::string> named = {{"auto", "predicted"},         {"predicted", "predicted"},
                                                    {"gcv", "gcv"},                {"lcurve", "lcurve"},
                                                    {"morozov", "morozov"},        {"noise-floor", "discrepancy"},
                                                    {"discrepancy", "discrepancy"}};
  if (named.count(o.beta)) {
    const std::string chosen = named.at(o.beta);
    if (!policy.empty() && policy != chosen) throw pvdf::InputError("--beta " + o.beta + " contradicts --beta-policy " + policy);
    policy = chosen;
  } else {
    double b = 0;
    if (!pvdf::parse_finite(o.beta, b)) {
      throw pvdf::InputError("--beta = '" + o.beta + "' must be a number (relative, seed 000 used 1e-4) or auto, predicted, "
                             "gcv, lcurve, morozov, noise-floor");
    }
    check_range("--beta", b, 1e-15, 1e6, "give a relative beta (seed 000 used 1e-4) or 'auto'");
    d.beta = b;
    if (policy.empty()) policy = o.corner > 0 ? "frequency" : "constant";
  }
  if (policy == "constant") d.beta_policy = r::BetaPolicy::constant;
  else if (policy == "frequency") d.beta_policy = r::BetaPolicy::frequency;
  else if (policy == "gcv") d.beta_policy = r::BetaPolicy::gcv;
  else if (policy == "discrepancy") d.beta_policy = r::BetaPolicy::discrepancy;
  else if (policy == "lcurve") d.beta_policy = r::BetaPolicy::lcurve;
  else if (policy == "morozov") d.beta_policy = r::BetaPolicy::morozov;
  else if (policy == "predicted") d.beta_policy = r::BetaPolicy::predicted;
  else throw pvdf::InputError("--beta-policy = " + policy + " must be constant, frequency, gcv, discrepancy, lcurve, morozov or predicted");

  std::vector<r::IdentificationScan> scans;
  for (std::size_t i = 0; i < o.scans.size(); ++i) {
    r::IdentificationScan s;
    s.scan = naming_flag([&] { return r::read_scan_csv(o.scans[i], o.speed); }, "scan speed", "give it with --speed-m-per-s");
    const auto f = pvdf::parse_number_list(o.forces[i], "--force (FX,FZ in N)", 2);
    check_range("--force FX", f[0], -1e6, 1e6, "give the edge's forces in N");
    check_range("--force FZ", f[1], -1e6, 1e6, "give the edge's forces in N");
    s.fx_N = f[0];
    s.fz_N = f[1];
    s.edge_x_m = o.edges.empty() ? 0.0 : o.edges[i];
    scans.push_back(std::move(s));
  }
  const r::TransferMatrix t = r::identify_transfer(scans, d);
  for (const auto& w : t.warnings) pvdf::app::warn(w);
  const r::InverseFilter f = naming_flag([&] { return r::design_inverse(t, scans, d); }, "beta policy", "see --beta");
  r::save_filter(o.output, f);
  std::printf("identified G from %zu scans: cond(F) = %.3g, noise rms = %.3g / %.3g V, SNR =", scans.size(),
              t.force_condition_number, t.noise_rms_V[0], t.noise_rms_V[1]);
  for (double s : t.scan_snr) std::printf(" %.3g", s);
  std::printf("\nG conditioning over %.0f %% of the band: min %.3g, median %.3g, max %.3g\n", 100 * f.conditioning.band_fraction,
              f.conditioning.min, f.conditioning.median, f.conditioning.max);
  std::printf("inverse (%s regularization): beta (%s) = %.3g relative (%.3g V^2/N^2): %s\n", f.regularization.c_str(),
              f.beta_policy.c_str(), f.beta, f.beta_abs, f.beta_reason.c_str());
  std::printf("target resolution %.3g mm, low cut %.3g mm (effective strip depth %.3g mm), %zu taps, delay %ld samples = "
              "%.4g mm, design FFT %zu, truncated energy %.2e -> %s\n",
              f.resolution_m * 1e3, f.low_cut_wavelength_m * 1e3, f.effective_depth_m * 1e3, f.taps, f.delay_samples,
              f.delay_samples * f.sample_spacing_m * 1e3, f.design_fft_length, f.truncated_energy_fraction, o.output.c_str());
  std::printf("an isolated sharp feature restores to a peak of %.2f of the target's and keeps %.2f of its force within "
              "+-3 resolutions of it (the rest spreads as shallow side lobes: long wavelengths are damped)\n",
              f.peak_fraction, f.lobe_force_fraction);
  if (f.truncated_energy_fraction > 0.1) {
    pvdf::app::warn("more than 10 % of the inverse filter's energy lies outside its taps; raise --taps or beta");
  }
  if (!o.plot_dir.empty()) {
    // What identify computes, not its inputs: the scans' signals are drawn once, by whoever made
    // them (`restore simulate --plot`), not again by every identification from them.
    pvdf::make_directories(o.plot_dir);
    r::plot_filters(o.plot_dir + "/fig13_inverse_filters.png", f);
    r::plot_transfer(o.plot_dir + "/transfer_G.png", f);
    for (std::size_t i = 0; i < scans.size(); ++i) {
      const auto forces = r::restore_scan(f, scans[i].scan);
      r::plot_restored(o.plot_dir + "/fig14_restored" + std::to_string(i + 1) + ".png", forces, scans[i].scan,
                       "Restored forces, identification scan " + std::to_string(i + 1), f);
    }
    std::printf("plots written to %s\n", o.plot_dir.c_str());
  }
  return pvdf::exit_code::success;
}

int run_apply(const ApplyOptions& o) {
  check_range("--speed-m-per-s", o.speed, 0, 10, "give the scan speed in m/s (seed 000: 0.01-0.1)");
  if (o.threshold_flag->count() > 0) {
    check_range("--mu-threshold-N", o.mu_threshold, 0, 1e6, "give a force per sample in N, or omit it for 30 % of the largest f_z");
  }
  if (o.block_flag->count() > 0) check_range("--block", static_cast<double>(o.block), 1, 16777216, "give a block length in samples, or omit it for offline");
  if (o.scale_flag->count() > 0) check_range("--baseline-scale-m", o.baseline_scale, 1e-6, 1, "give a length in m, or omit it for the filter's low cut / 2 pi");
  const r::InverseFilter f = r::load_filter(o.filter);
  r::Scan scan = naming_flag([&] { return r::read_scan_csv(o.scan, o.speed); }, "scan speed", "give it with --speed-m-per-s");
  if (o.resample && std::abs(scan.sample_spacing_m() - f.sample_spacing_m) > 1e-6 * f.sample_spacing_m) {
    std::printf("resampled from dx = %.4g m to the filter's %.4g m (amplitude x %.4g: the signal is proportional to the "
                "speed)\n", scan.sample_spacing_m(), f.sample_spacing_m, f.sample_spacing_m / scan.sample_spacing_m());
    scan = r::resample_scan(scan, f.sample_spacing_m);
  }
  r::RestoreOptions ro;
  ro.mu_threshold_N = o.threshold_flag->count() > 0 ? o.mu_threshold : -1;
  ro.flat_baseline = !o.no_baseline;
  ro.baseline_scale_m = o.baseline_scale;
  r::RestoredForces forces;
  if (o.block > 0) {
    // Streaming path (as a real-time loop would run it), then the flat level and mu as offline.
    forces = naming_flag([&] { return r::restore_scan(f, scan, ro); }, "sample spacing", "--resample does it");  // checks the spacing
    r::StreamingRestorer s(f, static_cast<std::size_t>(o.block));
    std::vector<double> fx, fz;
    const auto block = static_cast<std::size_t>(o.block);
    for (std::size_t i = 0; i < scan.size(); i += block) {
      const std::size_t n = std::min(block, scan.size() - i);
      s.push(scan.m1_V.data() + i, scan.m2_V.data() + i, n, fx, fz);
    }
    s.flush(fx, fz);
    forces.fx_N = fx;
    forces.fz_N = fz;
    r::finish_forces(f, forces, ro);
    std::printf("streaming: block %ld samples, latency %zu samples = %.4g mm of scan\n", o.block, s.latency_samples(),
                static_cast<double>(s.latency_samples()) * f.sample_spacing_m * 1e3);
  } else {
    forces = naming_flag([&] { return r::restore_scan(f, scan, ro); }, "sample spacing", "--resample does it");
  }
  r::write_forces_csv(o.output, forces, "pvdfkit restore apply " + o.filter + " " + o.scan +
                                            ": line forces in N/m (fx_N_per_m, fz_N_per_m) and per sample in N (fx_N, fz_N)");
  std::printf("restored %zu samples: peak f_z = %.4g N/m; integral f_x = %.4g N, f_z = %.4g N; mu threshold %.3g N per "
              "sample -> %s\n",
              forces.x_m.size(), forces.peak_fz_N_per_m(), forces.total_fx_N(), forces.total_fz_N(), forces.mu_threshold_N,
              o.output.c_str());
  if (ro.flat_baseline) {
    std::printf("forces are in excess of the flat-surface level (zero where %.0f %% of the scan is flat): a stress-rate "
                "sensor cannot see a steady load, so the scan's contact load is not included\n",
                100 * forces.flat_fraction);
  } else {
    std::printf("no flat-surface level fixed: a stress-rate sensor cannot see a steady load, so the record has (nearly) "
                "zero mean over the filter length and sags below zero around each feature\n");
  }
  if (f.lobe_force_fraction > 0) {
    std::printf("an isolated sharp feature keeps about %.2f of its force within +-3 resolutions of it before the "
                "flat-surface level is fixed (%s regularization; the rest spreads as shallow side lobes)\n",
                f.lobe_force_fraction, f.regularization.c_str());
  }
  if (!o.plot.empty()) {
    // The title names the filter file and what it is (regularization, beta, target resolution):
    // two figures restoring one scan with two filters must be told apart by their titles.
    r::plot_restored(o.plot, forces, scan, "Restored forces: " + file_name(o.scan) + " with " + file_name(o.filter), f);
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
  sim->add_option("-o,--output", so->output, "Scan CSV to write: x_m,m1_V,m2_V,fx_ref_N,fz_ref_N")
      ->required()
      ->check(pvdf::app::output_file());
  sim->add_option("--plot", so->plot, "Also write the signals as PNG (seed 000 Figs 11-12)")
      ->check(pvdf::app::output_file());
  sim->add_flag("--no-noise", so->no_noise, "Leave out the white noise (ADC and moving average stay)");

  auto io = std::make_shared<IdentifyOptions>();
  auto* id = sub->add_subcommand("identify", "Identify G from scans of known forces (eq. 6) and design the inverse "
                                              "filters H = (G^H G + beta I)^-1 G^H (eq. 4)");
  id->add_option("--scan", io->scans, "Scan CSV of one raised edge (repeat: at least 2)")->required();
  id->add_option("--force-N,--force", io->forces, "Known forces FX,FZ (N) of the preceding --scan (seed 000: 0.6,0.9 and 0.2,1.0)")->required();
  id->add_option("--edge-x-m", io->edges, "Edge position (m) of each --scan, in order (default 0 for all)");
  id->add_option("--speed-m-per-s", io->speed, "Scan speed (m/s), needed for scans given in t_s");
  id->add_option("-o,--output", io->output, "Filter file to write (JSON)")->required()->check(pvdf::app::output_file());
  id->add_option("--taps", io->taps, "FIR length N of h11..h22 and of the G window (default 8192)");
  io->delay_flag = id->add_option("--delay-samples", io->delay, "Modelling delay D in samples (default taps/2)");
  id->add_option("--beta", io->beta, "Regularization: auto (= predicted: the beta minimizing the predicted mu error; "
                                     "docs/restore.md), a relative beta (seed 000: 1e-4), gcv, lcurve, morozov or "
                                     "noise-floor (default auto)");
  id->add_option("--beta-policy", io->policy, "constant | frequency | gcv | discrepancy | lcurve | morozov | predicted "
                                              "(default from --beta)");
  id->add_option("--resolution-m", io->resolution, "Target resolution (Gaussian FWHM, m) applied to both forces; 0 = none "
                                                   "(seed 000); auto = 1.5 x the strips' effective depth (default auto)");
  id->add_option("--low-cut-m", io->low_cut, "Damp wavelengths beyond this (m): beta(k) *= 1 + (k_low/k)^2; the sensor "
                                            "cannot see the mean load. 0 = off (seed 000); auto = 10 x the effective depth (default auto)");
  id->add_option("--regularization", io->regularization,
                 "isotropic (default): both singular directions of G get the weak one's gain, so f_x and f_z are "
                 "blurred alike and mu is unbiased, at the price of the long-wavelength part of the forces (the lowest "
                 "mu error on the randomized scanner study); tikhonov: (G^H G + beta I)^-1 G^H as in seed 000 eq. 4, "
                 "keeps more of an isolated feature's force but biases mu (docs/restore.md section 4)");
  id->add_option("--g-window", io->g_window, "Lags of G kept by identification (default --taps)");
  id->add_option("--beta-corner-m", io->corner, "Wavelength L (m) of beta(k) = beta (1 + (k L/2pi)^2)");
  id->add_option("--window", io->window, "Taper of the FIR taps: tukey, hann, none (default tukey)");
  id->add_option("--plot-dir", io->plot_dir, "Write Fig 13-14 analogues (inverse filters, |G|, the identification scans restored) as PNG here; "
                 "the scans' signals (Figs 11-12) are drawn by `restore simulate --plot`")
      ->check(pvdf::app::output_folder());

  auto ao = std::make_shared<ApplyOptions>();
  auto* ap = sub->add_subcommand("apply", "Restore f_x, f_z and mu from a scan with a filter: x_m,fx_N,fz_N,mu,mu_valid,fx_N_per_m,fz_N_per_m");
  ap->add_option("FILTER", ao->filter, "Filter file from 'restore identify'")->required();
  ap->add_option("SCAN", ao->scan, "Scan CSV x_m,m1_V,m2_V (or t_s with --speed-m-per-s)")->required();
  ap->add_option("-o,--output", ao->output, "Forces CSV to write")->required()->check(pvdf::app::output_file());
  ap->add_option("--speed-m-per-s", ao->speed, "Scan speed (m/s), needed for scans given in t_s");
  ao->threshold_flag = ap->add_option("--mu-threshold-N", ao->mu_threshold, "mu where f_z exceeds this (N per sample) (default 30 % of the largest f_z)");
  ao->block_flag = ap->add_option("--block", ao->block, "Use the streaming restorer with blocks of this many samples (same result) (default: offline, one block)");
  ap->add_flag("--no-baseline", ao->no_baseline, "Do not fix the zero level where the surface is flat (docs/restore.md)");
  ao->scale_flag = ap->add_option("--baseline-scale-m", ao->baseline_scale, "Gaussian scale of the flat-surface level (m) (default the low cut / 2 pi)");
  ap->add_flag("--resample", ao->resample, "Resample a scan taken at another speed onto the filter's grid (amplitude scaled "
                                          "by the speed ratio, same sample rate assumed)");
  ap->add_option("--plot", ao->plot, "Also write the restored forces as PNG (seed 000 Fig. 14)")
      ->check(pvdf::app::output_file());

  return pvdf::app::Subcommand{sub, [sim, id, ap, so, io, ao]() -> int {
                                 if (sim->parsed()) return run_simulate(*so);
                                 if (id->parsed()) return run_identify(*io);
                                 if (ap->parsed()) return run_apply(*ao);
                                 throw pvdf::InputError("restore: choose simulate, identify or apply");
                               }};
});
