// Tracking a press through a sample stream (docs/lookup.md §1.9).
#include "pvdf/mapping/tracker.hpp"

#include "pvdf/core/error.hpp"

namespace pvdf::mapping {

Tracker::Tracker(const Locator& locator, const TrackerOptions& options) : locator_(&locator), options_(options) {
  if (options.search_interval < 1) {
    throw InputError("tracker search_interval = " + std::to_string(options.search_interval) + " must be >= 1 (samples)");
  }
}

void Tracker::reset() {
  n_starts_ = 0;
  since_search_ = 0;
  bin_ = -1;
}

void Tracker::remember(const Location& r) {
  n_starts_ = 0;
  if (!r.has_position()) return;
  starts_[0] = {r.x_m, r.y_m, r.force_N};
  for (int a = 0; a < r.n_alternatives && a + 1 < Location::max_solutions; ++a) {
    const auto& alt = r.alternatives[std::size_t(a)];
    starts_[std::size_t(a + 1)] = {alt.x_m, alt.y_m, alt.force_N};
  }
  n_starts_ = 1 + r.n_alternatives;
}

Location Tracker::next(const double* charges_C) {
  ++summary_.samples;
  const std::int64_t bin = options_.search_on_bin_change ? locator_->search_bin(charges_C) : 0;
  bool search = false;
  if (n_starts_ == 0) {
    search = true;
    ++summary_.onsets;
  } else if (since_search_ + 1 >= options_.search_interval) {
    search = true;
    ++summary_.intervals;
  } else if (bin != bin_) {
    search = true;
    ++summary_.bin_changes;
  }
  Location r;
  if (!search) {
    r = locator_->locate_from(charges_C, starts_.data(), n_starts_);
    // Residual test: a tracked solution that no longer fits (it met another at a fold and
    // vanished, or the press jumped), one that merged into another, or a fit that did not
    // converge — the full search decides.
    const bool degraded = !r.has_position() || (r.flags & (flag::poor_fit | flag::not_converged)) != 0 ||
                          r.n_solutions != n_starts_;
    if (degraded) {
      search = true;
      ++summary_.degraded;
    }
  }
  if (search) {
    r = locator_->locate(charges_C);
    ++summary_.full_searches;
    since_search_ = 0;
  } else {
    ++summary_.tracked;
    ++since_search_;
  }
  bin_ = bin;
  remember(r);
  return r;
}

}  // namespace pvdf::mapping
