// Private to the lookup's sources (locator*.cpp): the small inline helpers they share.
#pragma once

#include "pvdf/mapping/interpolant.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>


// The hot paths of the lookup are compiled twice, for any x86-64 and for x86-64-v3 (AVX2, FMA:
// +6 % locates/s measured, docs/lookup.md §3), and the loader picks the one the CPU runs (GCC
// function multiversioning). AVX-512 clones measured slower (−3 %): not built.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define PVDF_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define PVDF_CLONES
#endif

// Small helpers of the hot paths are inlined into their (cloned) callers: a helper compiled
// for the default target is otherwise called out of line from the x86-64-v3 clone.
#if defined(__GNUC__)
#define PVDF_INLINE inline __attribute__((always_inline))
#else
#define PVDF_INLINE inline
#endif

// No fused multiply-add contraction in the lookup's sources: with it the compiler's choice of
// where to fuse depends on how the code is cut into functions (a helper compiled for the default
// target is not inlined into a clone), and the answers would change in the last bits with
// every refactoring (docs/lookup.md §3).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC optimize("fp-contract=off")
#endif

namespace pvdf::mapping::detail {

using Vec = std::array<double, max_electrodes>;

/// The coarse table's key of a direction: two pseudo-angles of its first three components,
/// no atan2 or sqrt. φ is the "diamond angle" of (n0, n1) (monotone in atan2(n1, n0), in
/// (−2, 2], cut at n0 < 0, n1 = 0 like atan2), θ = n2 / (|n0| + |n1| + |n2|) (monotone in
/// the elevation for a fixed φ). Any continuous key serves: the table is built with this one.
inline void direction_key(const double* n, double& phi, double& theta) {
  const double a0 = std::abs(n[0]), a1 = std::abs(n[1]);
  const double l1 = a0 + a1 + 1e-300;
  const double r = n[1] / l1;
  phi = n[0] >= 0 ? r : (n[1] >= 0 ? 2.0 - r : -2.0 - r);
  theta = n[2] / (l1 + std::abs(n[2]));
}

/// Solves the symmetric positive definite 3×3 system A x = b by cofactors (Cramer's rule): the
/// six cofactors and the determinant are independent products and one reciprocal follows, where
/// an LDLᵀ chains three reciprocals on the critical path (measured: the solve sat on the fit's
/// critical path). Positive definite ⇔ the leading minors A00, A00·A11 − A01² and det are > 0.
/// Returns a non-finite x if A is not SPD (a minor ≤ 0 or NaN).
inline std::array<double, 3> solve_spd3(const std::array<double, 6>& A, const std::array<double, 3>& b) {
  // A: upper triangle 00 01 02 11 12 22.
  const double c00 = A[3] * A[5] - A[4] * A[4], c01 = A[2] * A[4] - A[1] * A[5], c02 = A[1] * A[4] - A[2] * A[3];
  const double c11 = A[0] * A[5] - A[2] * A[2], c12 = A[1] * A[2] - A[0] * A[4], c22 = A[0] * A[3] - A[1] * A[1];
  const double det = A[0] * c00 + A[1] * c01 + A[2] * c02;
  if (!(A[0] > 0 && c22 > 0 && det > 0)) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    return {nan, nan, nan};
  }
  const double inv = 1.0 / det;
  return {(c00 * b[0] + c01 * b[1] + c02 * b[2]) * inv, (c01 * b[0] + c11 * b[1] + c12 * b[2]) * inv,
          (c02 * b[0] + c12 * b[1] + c22 * b[2]) * inv};
}

/// The coarse search's test of one candidate cell against the query direction (compact float
/// record, Locator::scan_): the offset δ its linear model predicts (cell units), the model's
/// residual² there and the force of a start; false when the cell cannot hold a solution.
struct CandidateTest {
  double dt, ds, res2, l;
};
template <std::size_t NE>
inline bool test_candidate(const float* sc, std::size_t ne_runtime, const double* q_unit, double log_q_norm,
                           double noise2, bool fixed_force, double log_force, double log_lo, double log_hi,
                           double p_exp, double inv_p, CandidateTest& out) {
  const std::size_t ne = NE > 0 ? NE : ne_runtime;
  const float* tail = sc + 6 * ne;
  // Level: the known force, or the force that makes the cell's mean |G| match |q|.
  const double l = std::clamp(fixed_force ? log_force : (log_q_norm - double(tail[1])) * inv_p, log_lo, log_hi);
  // The cell's linear model carried to l predicts the offset δ.
  const double dl = l - double(tail[0]);
  double e[NE > 0 ? NE : 8];
  double dt = 0, ds = 0;
  for (std::size_t n = 0; n < ne; ++n) {
    e[n] = q_unit[n] - double(sc[n]) - double(sc[3 * ne + n]) * dl;
    dt += double(sc[ne + n]) * e[n];
    ds += double(sc[2 * ne + n]) * e[n];
  }
  if (!(std::abs(dt) <= 1.0 && std::abs(ds) <= 1.0)) return false;  // predicted beyond the neighbours
  double res2 = 0;
  for (std::size_t n = 0; n < ne; ++n) {
    const double r = e[n] - double(sc[4 * ne + n]) * dt - double(sc[5 * ne + n]) * ds;
    res2 += r * r;
  }
  // Within what the model's own error and the noise allow: a solution may be here.
  if (res2 > 4.0 * double(tail[6]) + 9.0 * noise2 + 1e-14) return false;
  // Force at the predicted point: |q| = F^p |G(δ, l)| with ln |G| linear in δ and l.
  const double log_g = double(tail[2]) + double(tail[3]) * dt + double(tail[4]) * ds + double(tail[5]) * dl;
  double l1 = l;
  if (fixed_force) {
    // The known force must also explain the magnitude (else: an unknown-force twin).
    if (std::abs(log_q_norm - p_exp * l - log_g) > 0.05 + 3.0 * std::sqrt(std::max(noise2, 0.0))) return false;
  } else {
    l1 = (log_q_norm - log_g) * inv_p;
    // A solution needs a plausible force: far outside the range, this is not one.
    if (l1 < log_lo - 0.25 || l1 > log_hi + 0.25) return false;
    l1 = std::clamp(l1, log_lo, log_hi);
  }
  out = {dt, ds, res2, l1};
  return true;
}

inline double normalize(double* v, std::size_t n) {
  double s = 0;
  for (std::size_t k = 0; k < n; ++k) s += v[k] * v[k];
  s = std::sqrt(s);
  if (s > 0) {
    for (std::size_t k = 0; k < n; ++k) v[k] /= s;
  }
  return s;
}


}  // namespace pvdf::mapping::detail
