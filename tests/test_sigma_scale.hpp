// PVDF_TEST_SIGMA_SCALE, read by the coverage tests only (never by the library): a factor applied
// to every reported σ before the coverage count, to show that the two-sided bands fail for a σ
// that is half or twice the truth (docs/testing.md, "Coverage tests").
#pragma once

#include <cmath>
#include <cstdlib>

namespace pvdf::testing {

/// The factor, or 1 when the variable is unset, empty, not a number or not positive and finite.
inline double test_sigma_scale() {
  const char* text = std::getenv("PVDF_TEST_SIGMA_SCALE");
  if (text == nullptr || *text == '\0') return 1.0;
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || !(v > 0) || !std::isfinite(v)) return 1.0;
  return v;
}

}  // namespace pvdf::testing
