// Tracking a press through a sample stream: every sample gets the full search's coarse search,
// fits and fold twins; what a stream adds is its memory — when nothing fits within noise (a
// press weaker than the force range at its onset and release, or off the map), the last
// sample's held fit is refitted first and, if it is still held outside, the expensive angular
// fallback of the full search is skipped (docs/lookup.md §1.9).
#pragma once

#include "pvdf/mapping/locator.hpp"

#include <array>
#include <cstdint>

namespace pvdf::mapping {

/// Settings of the tracker (public members with defaults).
struct TrackerOptions {
  /// A full search without the stream's memory at least every this many samples (1 = every
  /// sample: Locator::locate's answers exactly). 200 samples = 20 ms at 10 kHz.
  int search_interval = 200;
};

/// What the tracker did (counts since construction or reset()).
struct TrackerSummary {
  std::uint64_t samples = 0;         ///< samples given to next()
  std::uint64_t full_searches = 0;   ///< samples answered by Locator::locate (no memory)
  std::uint64_t tracked = 0;         ///< samples answered with the last sample's answer as hints
  std::uint64_t onsets = 0;          ///< full searches because nothing was remembered
  std::uint64_t intervals = 0;       ///< full searches because the interval elapsed
};

/// One stream's tracker: not thread-safe (one per stream); the Locator is shared and must
/// outlive it. No allocation in next().
class Tracker {
 public:
  explicit Tracker(const Locator& locator, const TrackerOptions& options = {});

  /// Locates the next sample of the stream (charges in the map's electrode order, C).
  Location next(const double* charges_C);
  /// Forgets the remembered answer (e.g. after a gap in the stream): the next sample is searched.
  void reset();
  const TrackerSummary& summary() const { return summary_; }

 private:
  /// Keeps the result's solutions (or its held fit) as the next sample's hints.
  void remember(const Location& result);

  const Locator* locator_;
  TrackerOptions options_;
  TrackerSummary summary_;
  std::array<std::array<double, 3>, Location::max_solutions> hints_{};
  int n_hints_ = 0;
  bool held_ = false;  ///< the hint is the last sample's held fit (outside_map), not a solution
  int since_search_ = 0;
};

}  // namespace pvdf::mapping
