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
  n_hints_ = 0;
  held_ = false;
  since_search_ = 0;
}

void Tracker::remember(const Location& r) {
  n_hints_ = 0;
  held_ = false;
  if ((r.flags & flag::outside_map) && !(r.flags & (flag::no_press | flag::saturated)) && r.held[2] > 0) {
    hints_[0] = r.held;  // held by the map's edge or the force range: where to look next
    n_hints_ = 1;
    held_ = true;
    return;
  }
  if (!r.has_position()) return;
  hints_[0] = {r.x_m, r.y_m, r.force_N};
  for (int a = 0; a < r.n_alternatives && a + 1 < Location::max_solutions; ++a) {
    const auto& alt = r.alternatives[std::size_t(a)];
    hints_[std::size_t(a + 1)] = {alt.x_m, alt.y_m, alt.force_N};
  }
  n_hints_ = 1 + r.n_alternatives;
}

Location Tracker::next(const double* charges_C) {
  ++summary_.samples;
  bool search = false;
  if (n_hints_ == 0) {
    search = true;
    ++summary_.onsets;
  } else if (since_search_ + 1 >= options_.search_interval) {
    search = true;
    ++summary_.intervals;
  }
  const Location r = search ? locator_->locate(charges_C) : locator_->locate_near(charges_C, hints_.data(), n_hints_, held_);
  if (search) {
    ++summary_.full_searches;
    since_search_ = 0;
  } else {
    ++summary_.tracked;
    ++since_search_;
  }
  remember(r);
  return r;
}

}  // namespace pvdf::mapping
