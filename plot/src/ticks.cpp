// Axis ticks: 1-2-5 steps with just enough decimals, common ×10^k multipliers, log decades.
#include "detail.hpp"

#include <algorithm>
#include <cstdio>

namespace pvdf::plot::detail {

std::string with_minus_sign(std::string s) {
  if (!s.empty() && s[0] == '-') s = "\xE2\x88\x92" + s.substr(1);  // U+2212 MINUS SIGN
  return s;
}

namespace {

/// A number (no '$' in it) followed by a superscript exponent, as markup: "10$^{−3}$".
std::string power_of_ten(const std::string& base, int exponent) {
  return base + "$^{" + with_minus_sign(std::to_string(exponent)) + "}$";
}

}  // namespace

double nice_step(double range, int target) {
  const double raw = range / std::max(target, 1);
  if (!(raw > 0) || !finite(raw)) return 0;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / mag;
  return (f <= 1.0001 ? 1 : f <= 2.0001 ? 2 : f <= 5.0001 ? 5 : 10) * mag;
}

/// 1-2-5 ticks within [lo, hi], about `target` of them, labelled with just enough decimals.
/// Very large or small values are labelled by mantissas and one common `multiplier` ("×10^k",
/// empty otherwise); without a `multiplier` to fill, each label carries its own power of ten.
std::vector<Tick> linear_ticks(double lo, double hi, int target, std::string* multiplier) {
  if (multiplier) multiplier->clear();
  std::vector<Tick> ticks;
  // The smallest 1-2-5 step that leaves at most `target` intervals between the ticks inside.
  double step = nice_step(hi - lo, target);
  if (!(step > 0)) return ticks;
  for (int k = 0; k < 3; ++k) {
    const double m = step / std::pow(10.0, std::floor(std::log10(step) + 1e-9));
    const double smaller = step * (m < 1.5 ? 0.5 : m < 3 ? 0.5 : 0.4);  // 1→0.5, 2→1, 5→2
    if (std::floor(hi / smaller + 1e-9) - std::ceil(lo / smaller - 1e-9) > target) break;
    step = smaller;
  }
  const double k0 = std::ceil(lo / step - 1e-9), k1 = std::floor(hi / step + 1e-9);
  if (!finite(k0) || !finite(k1) || k1 - k0 > 200) return ticks;
  const double maxabs = std::max(std::abs(lo), std::abs(hi));
  const bool sci = maxabs >= 1e5 || maxabs < 1e-3;
  int exponent = 0;
  double unit = 1;
  if (sci && maxabs > 0) {
    exponent = static_cast<int>(std::floor(std::log10(maxabs)));
    unit = std::pow(10.0, exponent);
  }
  const int decimals = std::clamp(static_cast<int>(-std::floor(std::log10(step / unit) + 1e-9)), 0, 12);
  for (double k = k0; k <= k1; k += 1) {
    double v = k * step;
    if (std::abs(v) < step * 1e-9) v = 0;
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v / unit);
    Tick t;
    t.value = v;
    if (sci && multiplier) {
      t.label = v == 0 ? "0" : with_minus_sign(buf);
      *multiplier = power_of_ten("\xC3\x97" "10", exponent);  // ×10^k
    } else if (sci && v != 0) {
      t.label = power_of_ten(with_minus_sign(buf) + "\xC3\x97" "10", exponent);  // m×10^k
    } else {
      t.label = sci ? "0" : with_minus_sign(buf);
      if (t.label == "\xE2\x88\x92" "0") t.label = "0";
    }
    ticks.push_back(t);
  }
  return ticks;
}

std::vector<Tick> integer_ticks(double lo, double hi, int target) {
  std::vector<Tick> out;
  for (const Tick& t : linear_ticks(lo, hi, target)) {
    const double r = std::round(t.value);
    if (std::abs(t.value - r) > 1e-9 * std::max(1.0, std::abs(r)) || std::abs(r) > 1e15) continue;
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.0f", r);
    out.push_back(Tick{r, with_minus_sign(buf)});
  }
  return out;
}

/// Decade ticks 10^k (every `stride` decades) with minor ticks at 2..9 × 10^k; spans shorter
/// than a decade fall back to 1-2-5 ticks.
std::vector<Tick> log_ticks(double lo, double hi, int target) {
  const double l0 = std::log10(lo), l1 = std::log10(hi);
  const int k0 = static_cast<int>(std::ceil(l0 - 1e-9)), k1 = static_cast<int>(std::floor(l1 + 1e-9));
  if (k1 - k0 + 1 < 2) {
    // Less than two decades: label 1, 2, 5 × 10^k (or 1, 2, 3, 5, or every mantissa, until
    // there are enough labels), minor ticks at the other mantissas, so that the labels stay
    // evenly spread on the log scale.
    const std::vector<int> sets[] = {{1, 2, 5}, {1, 2, 3, 5}, {1, 2, 3, 4, 5, 6, 7, 8, 9}};
    const int enough[] = {4, 3, 2};
    for (int s = 0; s < 3; ++s) {
      const std::vector<int>& labelled = sets[s];
      std::vector<Tick> ticks;
      int n_major = 0;
      for (int k = static_cast<int>(std::floor(l0)); k <= static_cast<int>(std::floor(l1)); ++k) {
        for (int m = 1; m <= 9; ++m) {
          const double v = m * std::pow(10.0, k);
          if (v < lo * (1 - 1e-9) || v > hi * (1 + 1e-9)) continue;
          const bool major = std::find(labelled.begin(), labelled.end(), m) != labelled.end();
          Tick t{v, {}, major};
          if (major) {
            char buf[32];
            if (k >= 5 || k < -3) {
              std::snprintf(buf, sizeof buf, "%d\xC3\x97" "10", m);  // m×10^k
              t.label = power_of_ten(buf, k);
            } else {
              std::snprintf(buf, sizeof buf, "%.*f", std::max(0, -k), v);
              t.label = buf;
            }
            ++n_major;
          }
          ticks.push_back(t);
        }
      }
      if (n_major >= enough[s]) return ticks;
    }
    auto t = linear_ticks(lo, hi, target);
    t.erase(std::remove_if(t.begin(), t.end(), [](const Tick& x) { return !(x.value > 0); }), t.end());
    return t;
  }
  const int stride = std::max(1, static_cast<int>(std::ceil((k1 - k0 + 1.0) / std::max(target, 2))));
  std::vector<Tick> ticks;
  for (int k = static_cast<int>(std::floor(l0)); k <= k1; ++k) {
    if (k >= k0 && (k - k0) % stride == 0) {
      Tick t;
      t.value = std::pow(10.0, k);
      t.label = power_of_ten("10", k);
      ticks.push_back(t);
    }
    if (stride == 1) {
      for (int m = 2; m <= 9; ++m) {
        const double v = m * std::pow(10.0, k);
        if (v >= lo * (1 - 1e-9) && v <= hi * (1 + 1e-9)) ticks.push_back({v, {}, false});
      }
    }
  }
  return ticks;
}

}  // namespace pvdf::plot::detail
