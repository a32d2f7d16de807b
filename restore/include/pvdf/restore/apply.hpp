// Applying the inverse filters: offline (one FFT linear convolution) and streaming block by block
// (overlap-save) with a fixed latency, plus mu(x) where f_z is above a threshold.
#pragma once

#include "pvdf/restore/filter.hpp"
#include "pvdf/restore/scan_io.hpp"

#include <complex>
#include <memory>
#include <vector>

namespace pvdf::restore {

/// Offline restoration: f[n] = sum_t h[t] m[n + D - t] for every scan sample n (signals outside the
/// record are zero; linear, not circular, convolution). fx_N, fz_N get m1.size() values.
/// Throws InputError if m1 and m2 differ in length or are empty.
void restore_offline(const InverseFilter& filter, const std::vector<double>& m1_V, const std::vector<double>& m2_V,
                     std::vector<double>& fx_N, std::vector<double>& fz_N);

/// How a restored record is finished.
struct RestoreOptions {
  /// mu where the force per sample f_z exceeds this (N per sample); < 0: 30 % of the largest restored f_z.
  double mu_threshold_N = -1;
  /// Fix the zero level where the surface is flat (docs/restore.md, "the mean load"): the filter cannot
  /// restore what a stress-rate sensor does not see (the steady load and wavelengths beyond the low cut),
  /// so the restored record sags below zero around each feature. A smooth baseline is fitted through the
  /// samples that are flat (within the noise of the baseline, away from features) and subtracted.
  bool flat_baseline = true;
  /// Gaussian scale of that baseline (m); 0 = automatic: low_cut / 2 pi of the filter (else 4 x resolution,
  /// at least 1.5 mm).
  double baseline_scale_m = 0;
};

/// Restores a scan (checks its sample spacing against the filter's to 1 %), fixes the flat-surface level,
/// fills the line forces (N/m) and the forces per sample (N), and mu where f_z > threshold.
/// Throws NumericalError when the output is not finite (a filter out of range).
RestoredForces restore_scan(const InverseFilter& filter, const Scan& scan, const RestoreOptions& options);
/// The same with default options and a given mu threshold (N per sample; < 0 = 30 % of the largest f_z).
RestoredForces restore_scan(const InverseFilter& filter, const Scan& scan, double mu_threshold_N = -1);

/// Completes a record whose x_m, fx_N, fz_N (force per sample, straight from the filter) are set:
/// flat-surface level, line forces, mu. Used by restore_scan and after streaming.
void finish_forces(const InverseFilter& filter, RestoredForces& forces, const RestoreOptions& options);

/// mu = f_x / f_z where f_z > threshold (mu_valid = 1), else mu = 0, mu_valid = 0.
void friction_coefficient(RestoredForces& forces, double mu_threshold_N);

/// A scan recorded at another speed (sample spacing) than the filter's, resampled onto the filter's grid
/// by linear interpolation, its amplitude scaled by filter spacing / scan spacing (the stress-rate signal
/// is proportional to the scan speed at the same sample rate). The reference forces are re-binned.
Scan resample_scan(const Scan& scan, double sample_spacing_m);

/// Real-time restoration: push blocks of any size, get the restored forces in order. Internally
/// uniformly partitioned overlap-save: blocks of `block_samples` B, FFTs of 2B points, the taps cut
/// into ceil(taps / B) partitions.
/// Latency: the force at sample n is emitted once input sample n + D has arrived and its block is
/// complete, i.e. at most D + block_samples - 1 samples (latency_samples()) after it was scanned.
/// After flush() the output equals restore_offline() up to round-off.
class StreamingRestorer {
 public:
  StreamingRestorer(const InverseFilter& filter, std::size_t block_samples);
  ~StreamingRestorer();
  StreamingRestorer(const StreamingRestorer&) = delete;
  StreamingRestorer& operator=(const StreamingRestorer&) = delete;

  /// Feeds n samples of both channels; appends every force sample that became available.
  void push(const double* m1_V, const double* m2_V, std::size_t n, std::vector<double>& fx_N, std::vector<double>& fz_N);
  /// Ends the stream: emits the remaining force samples (the input is taken as zero after the end).
  void flush(std::vector<double>& fx_N, std::vector<double>& fz_N);
  /// Worst-case delay between scanning a sample and emitting its force, in samples.
  std::size_t latency_samples() const;
  std::size_t block_samples() const { return block_; }

 private:
  void process_block(std::vector<double>& fx_N, std::vector<double>& fz_N);
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::size_t block_;
};

}  // namespace pvdf::restore
