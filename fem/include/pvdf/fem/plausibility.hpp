// Physical bounds of a solved state (docs/fem.md "Physical bounds of an answer", issue 30): an
// answer that breaks one is never reported as converged, whatever Newton's residual said.
#pragma once

#include "pvdf/core/scene.hpp"
#include "pvdf/fem/solver.hpp"

#include <string>

namespace pvdf::fem {

/// Why `result` cannot be the answer for `scene`'s loads, or "" when it can. The bounds:
///  - the largest |deflection| must not exceed the film's size (its characteristic radius, m): a
///    clamped film sagging deeper than it is wide is strained by more than 40 %, far beyond any
///    polymer film's elastic range (E = 1e-30 Pa gave 3.8e10 m on a 45 mm film, "converged");
///  - a nonzero applied force (Σ probe forces + Σ pressure × film area, N) must meet a nonzero
///    rim reaction: |rim_reaction_N| > 1e-6 × |applied| (a press of 1e-300 N gave a
///    "converged" zero).
/// Only results whose status is usable() are examined.
std::string physical_bound_violation(const pvdf::Scene& scene, const Result& result);

/// Applies physical_bound_violation: a usable result that breaks a bound becomes
/// Status::no_convergence with the reason in summary.message and no fields (as every
/// non-usable result). Returns true when it changed the result.
bool enforce_physical_bounds(const pvdf::Scene& scene, Result& result);

}  // namespace pvdf::fem
