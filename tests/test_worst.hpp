// The running worst of a test's errors, NaN-propagating: std::max(worst, e) returns worst when e is
// NaN, so a comparison that produced NaN would pass as "no error". worst_of keeps the NaN, and the
// test's `CHECK(worst <= bound)` then fails, as it must.
#pragma once

#include <algorithm>
#include <cmath>

namespace pvdf::testing {

/// max(worst, e), or NaN when either is NaN.
inline double worst_of(double worst, double e) {
  if (std::isnan(worst) || std::isnan(e)) return std::nan("");
  return std::max(worst, e);
}

}  // namespace pvdf::testing
