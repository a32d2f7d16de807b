// Tracking a press through a sample stream: each sample is fitted from the previous sample's
// solutions (Locator::locate_from) and the full search runs only where it can find something
// new — at press onset, when the tracked fit degrades, when the charges' direction moves to
// another bin of the coarse table, and at a fixed interval (docs/lookup.md §1.9).
#pragma once

#include "pvdf/mapping/locator.hpp"

#include <array>
#include <cstdint>

namespace pvdf::mapping {

/// Settings of the tracker (public members with defaults).
struct TrackerOptions {
  /// Full search at least every this many samples of a press (1 = every sample: the full
  /// search's answers exactly). 200 samples = 20 ms at 10 kHz.
  int search_interval = 200;
  /// Full search when the coarse table's direction bin of the charges changes (the search's
  /// candidate cells change with it).
  bool search_on_bin_change = true;
};

/// What the tracker did (counts since construction or reset()).
struct TrackerSummary {
  std::uint64_t samples = 0;         ///< samples given to next()
  std::uint64_t full_searches = 0;   ///< samples answered by the full search (Locator::locate)
  std::uint64_t tracked = 0;         ///< samples answered from the previous solutions
  std::uint64_t onsets = 0;          ///< full searches because no solution was being tracked
  std::uint64_t degraded = 0;        ///< full searches because the tracked fit degraded
  std::uint64_t bin_changes = 0;     ///< full searches because the direction bin changed
  std::uint64_t intervals = 0;       ///< full searches because the interval elapsed
};

/// One stream's tracker: not thread-safe (one per stream); the Locator is shared and must
/// outlive it. No allocation in next().
class Tracker {
 public:
  explicit Tracker(const Locator& locator, const TrackerOptions& options = {});

  /// Locates the next sample of the stream (charges in the map's electrode order, C).
  Location next(const double* charges_C);
  /// Forgets the tracked solutions (e.g. after a gap in the stream): the next sample is searched.
  void reset();
  const TrackerSummary& summary() const { return summary_; }

 private:
  /// Keeps the result's solutions as the next sample's starts.
  void remember(const Location& result);

  const Locator* locator_;
  TrackerOptions options_;
  TrackerSummary summary_;
  std::array<std::array<double, 3>, Location::max_solutions> starts_{};
  int n_starts_ = 0;
  int since_search_ = 0;
  std::int64_t bin_ = -1;
};

}  // namespace pvdf::mapping
