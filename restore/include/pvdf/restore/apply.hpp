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

/// Restores a scan (checks its sample spacing against the filter's to 1 %) and computes mu where
/// f_z > threshold; `mu_threshold_N` < 0 means 30 % of the largest restored f_z.
RestoredForces restore_scan(const InverseFilter& filter, const Scan& scan, double mu_threshold_N = -1);

/// mu = f_x / f_z where f_z > threshold (mu_valid = 1), else mu = 0, mu_valid = 0.
void friction_coefficient(RestoredForces& forces, double mu_threshold_N);

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
