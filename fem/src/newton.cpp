// Nonlinear solution (docs/fem.md §5): the sparse linear solves (tangent_factorization.hpp:
// CHOLMOD supernodal Cholesky with a kept symbolic analysis, chord steps, UMFPACK or GMRES as
// fallbacks), Newton–Raphson with a line search on the potential, and the artificial-pretension
// continuation from the flat film.
#include "film_solver.hpp"

#include "pvdf/core/assert.hpp"
#include "pvdf/core/membrane_scaling.hpp"

#include <deal.II/lac/precondition.h>
#include <deal.II/lac/solver_control.h>
#include <deal.II/lac/solver_gmres.h>
#include <deal.II/lac/sparse_direct.h>
#include <deal.II/lac/sparse_ilu.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace pvdf::fem::detail {

using namespace dealii;

bool FilmSolver::solve_linear(const Vector<double>& rhs, Vector<double>& x, std::string& message, bool factorize,
                              const SparseMatrix<double>* matrix, TangentFactorization* factorization) {
  const auto t0 = Clock::now();
  const SparseMatrix<double>& A = matrix ? *matrix : tangent_;
  TangentFactorization& F = factorization ? *factorization : factorization_;
  PVDF_ASSERT(rhs.size() == dof_handler_.n_dofs() && x.size() == rhs.size(),
              "a linear solve's right-hand side and solution must have one value per DOF");
  bool ok = true;
  try {
    if (options_.iterative_solver && dof_handler_.n_dofs() > 0) {
      SparseILU<double> ilu;
      ilu.initialize(A, SparseILU<double>::AdditionalData(0, 0));
      SolverControl control(2000, 1e-12 * rhs.l2_norm());
      SolverGMRES<Vector<double>> gmres(control, SolverGMRES<Vector<double>>::AdditionalData(100));
      x = 0;
      gmres.solve(A, x, rhs, ilu);
    } else if (!factorize && F.usable()) {
      // Chord step: the factorization of an earlier tangent of the same pattern.
      F.solve(rhs.begin(), x.begin(), x.size());
    } else {
      bool good = F.factorize(A);
      if (good) {
        F.solve(rhs.begin(), x.begin(), x.size());
        Vector<double> check(x.size());
        A.vmult(check, x);
        check -= rhs;
        good = std::isfinite(check.l2_norm()) && check.l2_norm() <= 1e-6 * rhs.l2_norm() + 1e-300;
        if (!good) F.invalidate();
      }
      if (!good) {  // indefinite or ill-conditioned pivots: pivoting LU
        const auto blas = blas_turn();  // UMFPACK calls the BLAS too
        SparseDirectUMFPACK direct;
        direct.initialize(A);
        direct.vmult(x, rhs);
      }
    }
  } catch (const std::exception& e) {
    message = std::string("linear solve failed: ") + e.what();
    ok = false;
  }
  if (ok) {
    for (double v : x) {
      if (!std::isfinite(v)) {
        message = "linear solve gave non-finite values (singular tangent)";
        ok = false;
        break;
      }
    }
  }
  summary_.linear_solve_s += seconds_since(t0);
  return ok;
}

// Newton–Raphson with a backtracking line search (on Π, else on ‖r‖: line_search). Stops when
// ‖r‖ ≤ rtol·‖f‖ + atol AND ‖Δu‖ ≤ increment_tol·‖u‖ (both), or after max_newton_iterations
// (no_convergence), or earlier when Newton has stagnated (no_convergence, `stagnated`): over the
// last k = stagnation_iterations iterations neither the smallest ‖r‖ fell below stagnation_factor
// × the smallest before them, nor the smallest Newton decrement −r·du of descent steps below
// stagnation_factor² (final stage) or stagnation_factor⁴ (full steps of stepping-stone stages and
// slack films) × the smallest before them (the decrement r·K⁻¹·r scales as ‖r‖²). A
// converging Newton (quadratic, or chord steps contracting 10x) halves ‖r‖ in one or two steps.
// Films near the physical limits (nu12 -> -1, E2 -> 0, |N0| huge in compression) instead stir
// ‖r‖ at one level for hundreds of iterations, minutes each at 127k DOFs (issue 30).
// Why the decrement too (round 17, docs/bench-fem.md): the line search lowers Π, not ‖r‖, and
// ‖r‖ is dominated by the stiff in-plane equations; near the clamp of seed 001 (0.01 N* stage,
// 125k DOFs) Π-descent steps raised ‖r‖ from 0.016 to 1.0 N and it was back at 0.019 N after 8
// iterations — "stagnated" — while the decrement had fallen 700x (8e-5 → 1.2e-7 J) on full steps,
// i.e. Newton was entering its quadratic phase.
NewtonOutcome FilmSolver::newton(Model model, double artificial_tension, Vector<double>& u, double stage_rtol) {
  NewtonOutcome out;
  PVDF_ASSERT(u.size() == dof_handler_.n_dofs() && load_.size() == u.size(),
              "Newton's iterate and the load vector must have one value per DOF");
  const double f_norm = load_.l2_norm();
  const double r_tol = options_.residual_rtol * f_norm + options_.residual_atol;
  Vector<double> r(u.size()), du(u.size()), trial(u.size()), r_trial(u.size()), rhs(u.size());
  constraints_.distribute(u);
  if (clamp_layer_) apply_clamp_shift(u);  // the rim's in-plane values (clamp_layer.cpp)
  double last_increment = std::numeric_limits<double>::max();
  // Chord steps (reuse_factorization_, probe sweeps): while a step contracts the residual by 10x or
  // more, the next step reuses the factorized tangent (one back substitution instead of assembly
  // of the tangent + factorization); a weaker contraction refactorizes.
  bool refactorize = !(reuse_factorization_ && chord_first_step_ && factorization_.usable());
  chord_first_step_ = false;
  bool have_r = false;  // r and last_energy_ already belong to u (the accepted line-search trial)
  const int k_stag = options_.stagnation_iterations;
  std::vector<double> best_so_far;  // best_so_far[i] = min ‖r‖ over iterations 0..i
  // best_decrement[i] = min Newton decrement −r·du over the descent steps 0..i (+inf before the
  // first). In a stepping-stone stage only full (α = 1) steps count, as damped ones far from the
  // solution (the slack films of issue 30, |r| ~ 1e6 N) also shrink −r·du while ‖r‖ stays put; in
  // the stage that must meet the tolerance (no artificial tension, no stage tolerance) every
  // descent step counts and a first window with any descent step is progress (see below).
  std::vector<double> best_decrement;
  // Slack films (tension_field.cpp) keep the strict rule in every stage: their final stages crawl
  // linearly for hundreds of iterations (issue 30, test_fem_stagnation).
  const bool stepping_stone = artificial_tension > 0 || stage_rtol > 0 || tension_field_;
  double first_full_decrement = std::numeric_limits<double>::infinity();
  const auto record_step = [&](double slope, double alpha) {
    const double d = slope < 0 && (alpha == 1.0 || !stepping_stone) ? -slope : std::numeric_limits<double>::infinity();
    if (!std::isfinite(first_full_decrement) && stepping_stone) first_full_decrement = d;
    best_decrement.push_back(std::min(d, best_decrement.empty() ? d : best_decrement.back()));
  };
  // Residual-stiffness slack films: the tangent of a stationary point that is not a minimum is
  // indefinite (see convexify_if_indefinite below).
  const bool convexify = tension_field_ && residual_stiffness_ > 0 && !options_.iterative_solver;
  Vector<double> r_scratch;
  bool step_convexified = false;  // this step's tangent was convexified (verbose output)
  // With the residual stiffness ε the wrinkled and slack regions keep the compressive force ε·C·e
  // (about ε·N0), a compressed plate there: along the pretension steps and the probe walk the
  // equilibrium followed can turn unstable (a fold or a bifurcation of the ε-model), where the exact
  // tangent is indefinite and its Newton step neither descends Π nor reaches an equilibrium
  // (measured on the seed-001 sweep mesh at N0 = −2800 N/m: Newton stalled with r·du > 0 at
  // artificial tension 912.9 N/m, docs/fem.md §3.3). So each new tangent is first tried by the
  // Cholesky; where it meets a non-positive pivot, the tangent is assembled again with only the
  // tensile part of each point's force in the geometric stiffness (positive semidefinite: the relaxed
  // law's tangent is, ε·C is, the bending is), whose step is a descent direction of Π: the line
  // search then leads to a minimum of Π (a stable equilibrium) instead of stalling at a saddle. Where
  // the exact tangent is positive definite it is used as is (quadratic convergence at the end).
  // It leaves the factorization held; the caller solves with it (no residual check of that solve).
  const auto convexify_if_indefinite = [&]() {
    const auto t0 = Clock::now();
    factorization_.forget_history();  // the Cholesky first every time: its failure is the test
    // No LDLᵀ of the exact tangent after a failed Cholesky: it would be thrown away (3–8 s on the
    // 126k-DOF rim-graded slack film).
    if (!factorization_.factorize(tangent_, TangentFactorization::Fallback::none)) {
      summary_.linear_solve_s += seconds_since(t0);
      const double energy = last_energy_;
      convexified_tangent_ = true;
      assemble(u, model, artificial_tension, true, r_scratch);
      convexified_tangent_ = false;
      last_energy_ = energy;
      const auto t1 = Clock::now();
      factorization_.forget_history();
      factorization_.factorize(tangent_);
      summary_.linear_solve_s += seconds_since(t1);
      step_convexified = true;
    } else {
      summary_.linear_solve_s += seconds_since(t0);
    }
  };
  for (int it = 0; it <= options_.max_newton_iterations; ++it) {
    if (!have_r || refactorize) assemble(u, model, artificial_tension, refactorize, r);
    have_r = false;
    const double r_norm = r.l2_norm();
    out.residual_norm = r_norm;
    if (!std::isfinite(r_norm)) {
      out.status = Status::not_finite;
      out.message = "residual became non-finite at Newton iteration " + std::to_string(it);
      return out;
    }
    if (options_.verbose) {
      std::printf("    newton %2d  |r| = %.3e  (tol %.3e)  N_art = %.3e N/m  dofs %u  t %.2f s  Pi %.6e J  ldlt %d/%d\n",
                  it, r_norm, r_tol, artificial_tension, dof_handler_.n_dofs(),
                  summary_.assembly_s + summary_.linear_solve_s, last_energy_, factorization_.n_ldlt_fallbacks(),
                  factorization_.n_factorizations());
      std::fflush(stdout);
    }
    const double u_norm = u.l2_norm();
    const bool small_increment = it == 0 || last_increment <= options_.increment_tol * std::max(u_norm, 1e-300);
    // Round-off floor: the stiffness ratio membrane/bending reaches 1e12 for thin films, so the
    // residual cannot always reach rtol; an update at round-off level with ‖r‖ ≤ 1e-6‖f‖ is converged.
    const bool roundoff_floor = it > 0 && last_increment <= 1e-11 * std::max(u_norm, 1e-300) && r_norm <= 1e-6 * f_norm;
    const bool stage_done = stage_rtol > 0 && r_norm <= stage_rtol * f_norm;
    if ((r_norm <= r_tol && small_increment) || roundoff_floor || stage_done) {
      out.status = Status::converged;
      return out;
    }
    best_so_far.push_back(std::min(r_norm, best_so_far.empty() ? r_norm : best_so_far.back()));
    PVDF_ASSERT(best_so_far.size() == std::size_t(it) + 1, "one smallest residual per Newton iteration");
    PVDF_ASSERT(best_decrement.size() == std::size_t(it), "one smallest decrement per Newton step taken");
    if (k_stag > 0 && it >= k_stag) {
      const double f = options_.stagnation_factor;
      const bool residual_fell = best_so_far[it] <= f * best_so_far[it - k_stag];
      // Steps it−k..it−1 against the steps before them; with no full step before the window,
      // against the first full step (a stage whose first steps were damped).
      const double decrement_before = it > k_stag && std::isfinite(best_decrement[it - 1 - k_stag])
                                          ? best_decrement[it - 1 - k_stag]
                                          : first_full_decrement;
      // The decrement r·K⁻¹·r scales as ‖r‖²: f² is the residual's pace. A stepping-stone stage
      // (artificial tension, or a stage tolerance) must do twice that, f⁴ (16x for f = 0.5), which
      // the quadratic phase beats by far (700x near the clamp) and the linear crawl of the slack
      // films of issue 30 (2-3x per window, at artificial tension) does not. The stage that must
      // meet the tolerance (no artificial tension) gets f²: near the clamp its tangent is still
      // indefinite for ~15 iterations (r·du > 0 on some steps) before the quadratic phase.
      const double f_decrement = stepping_stone ? f * f * f * f : f * f;
      const bool decrement_fell =
          std::isfinite(best_decrement[it - 1]) && best_decrement[it - 1] <= f_decrement * decrement_before;
      if (!residual_fell && !decrement_fell) {
        out.status = Status::no_convergence;
        out.stagnated = true;
        const std::string decrement = stepping_stone ? "the Newton decrement of full steps" : "the Newton decrement";
        out.message = "Newton stagnated: over " + std::to_string(k_stag) + " iterations neither the residual fell by " +
                      fmt(1 / f) + "x nor " + decrement + " by " + fmt(1 / f_decrement) + "x (|r| = " + fmt(r_norm) +
                      " N after " + std::to_string(it) + " iterations, tolerance " + fmt(r_tol) + " N)";
        return out;
      }
    }
    if (it == options_.max_newton_iterations) break;
    rhs = r;
    rhs *= -1.0;
    std::string msg;
    bool factorize = refactorize;
    step_convexified = false;
    if (convexify && refactorize) {
      convexify_if_indefinite();
      factorize = !factorization_.usable();
    }
    if (!solve_linear(rhs, du, msg, factorize)) {
      out.status = Status::linear_solver_failed;
      out.message = msg;
      return out;
    }
    constraints_.distribute(du);
    ++out.iterations;
    const double energy0 = last_energy_;
    const double s0 = r * du;
    // At round-off level the energy cannot resolve the step (|r·du| ≤ 1e-12|Π|): take it whole.
    if (s0 < 0 && -s0 <= 1e-12 * std::abs(energy0)) {
      u.add(1.0, du);
      record_step(s0, 1.0);
      last_increment = du.l2_norm();
      // Newton decrement −r·du at round-off with a small residual: the round-off floor (thick
      // plates, where ε·Σ|K_ij u_j| exceeds rtol·‖f‖); further steps only stir round-off.
      if (r_norm <= 1e-6 * f_norm) {
        out.status = Status::converged;
        return out;
      }
      if (reuse_factorization_) refactorize = false;
      continue;
    }
    const LineSearch ls = line_search(model, artificial_tension, u, du, s0, energy0, r_norm, trial, r_trial);
    const double best_alpha = ls.alpha, best_norm = ls.residual_norm, last_alpha = ls.last_alpha;
    if (!(best_norm < std::numeric_limits<double>::max())) {
      out.status = Status::not_finite;
      out.message = "every line-search trial gave a non-finite residual";
      return out;
    }
    PVDF_ASSERT(best_alpha > 0 && best_alpha <= 1 && std::isfinite(best_norm) && last_alpha > 0,
                "an accepted line-search step has 0 < alpha <= 1 and a finite residual");
    u.add(best_alpha, du);
    record_step(s0, best_alpha);
    last_increment = best_alpha * du.l2_norm();
    if (reuse_factorization_ && !options_.iterative_solver) {
      refactorize = !(best_alpha == 1.0 && best_norm <= 0.1 * r_norm);
      if (last_alpha == best_alpha) {
        r.swap(r_trial);
        have_r = true;
      }
    }
    if (options_.verbose) {
      std::printf("      step alpha = %.3g, |du| = %.3e, slope r.du = %.3e%s\n", best_alpha, du.l2_norm(), s0,
                  step_convexified ? " (convexified tangent)" : "");
    }
  }
  out.status = Status::no_convergence;
  out.message = "Newton did not converge in " + std::to_string(options_.max_newton_iterations) +
                " iterations (|r| = " + fmt(out.residual_norm) + " N, tolerance " + fmt(r_tol) + " N)";
  return out;
}

// Line search on the potential Π (r = ∇Π; Π = membrane + bending energy − load work):
// Armijo backtracking Π(u + α du) ≤ Π(u) + 1e-4·α·(r·du), halving α, keeping the lowest Π seen.
// The slope r·du is negative whenever the tangent is positive definite (tension); otherwise
// (compressed, indefinite tangent), or when no trial gave a finite Π, backtrack on ‖r‖ instead:
// ‖r(u + α du)‖ ≤ (1 − 1e-4·α)‖r(u)‖. r_trial and last_energy_ are left at the last trial.
FilmSolver::LineSearch FilmSolver::line_search(Model model, double artificial_tension, const Vector<double>& u,
                                               const Vector<double>& du, double slope, double energy0, double r_norm,
                                               Vector<double>& trial, Vector<double>& r_trial) {
  LineSearch ls;
  ls.residual_norm = std::numeric_limits<double>::max();
  if (slope < 0) {
    double alpha = 1.0, best_energy = std::numeric_limits<double>::max();
    for (int step = 0; step < 16; ++step) {
      trial = u;
      trial.add(alpha, du);
      assemble(trial, model, artificial_tension, false, r_trial);
      ls.last_alpha = alpha;
      const double e = last_energy_;
      const double tn = r_trial.l2_norm();
      if (std::isfinite(e) && std::isfinite(tn) && e < best_energy) {
        best_energy = e;
        ls.alpha = alpha;
        ls.residual_norm = tn;
      }
      if (std::isfinite(e) && e <= energy0 + 1e-4 * alpha * slope) break;
      alpha *= 0.5;
    }
  }
  if (slope >= 0 || !(ls.residual_norm < std::numeric_limits<double>::max())) {
    ls.residual_norm = std::numeric_limits<double>::max();
    double alpha = 1.0;
    for (int step = 0; step < 12; ++step) {
      trial = u;
      trial.add(alpha, du);
      assemble(trial, model, artificial_tension, false, r_trial);
      ls.last_alpha = alpha;
      const double tn = r_trial.l2_norm();
      if (std::isfinite(tn) && tn < ls.residual_norm) {
        ls.residual_norm = tn;
        ls.alpha = alpha;
      }
      if (std::isfinite(tn) && tn <= (1 - 1e-4 * alpha) * r_norm) break;
      alpha *= 0.5;
    }
  }
  return ls;
}

// A tension scale for the continuation: twice the Hencky-type membrane force scale
// N* = 2·E·h·(F/(E·h·a))^(2/3) (pvdf/core/membrane_scaling.hpp): a few times the membrane forces
// of a clamped membrane carrying F, so that the first (tensioned, linear) step undershoots the
// deflection rather than overshoots it.
double FilmSolver::estimate_tension() const {
  const double E = std::sqrt(membrane_C_.c[0][0] * membrane_C_.c[1][1]);  // h·E-like (N/m)
  return 2.0 * pvdf::membrane_force_scale_N_per_m(E, total_force_, radius_);
}

// From the flat film: the continuation below (a slack film's in tension_field.cpp). With the
// clamp-layer condition on, its lagged passes are run again from the converged state: a flat start
// has no held rim values (a new mesh's setup_system clears them, and u = 0 has no slope to take
// them from), so it would return the plain clamp's answer under the condition's name and estimate.
// (Found in r18: seed 001 at (−35.97, 18.98) mm, 1 N, came back 2.6 % off the bending-kept
// reference while stating 0.61 %.)
NewtonOutcome FilmSolver::solve_from_flat(Model model, Vector<double>& u) {
  NewtonOutcome o = tension_field_ ? solve_slack_from_flat(model, u) : solve_by_continuation(model, u);
  if (o.status == Status::converged && clamp_layer_) o = solve_with_clamp_layer(model, u);
  return o;
}

// From the flat, stress-free state the membrane tangent has no transverse stiffness (only the
// tiny bending one). By design the solver starts with an artificial isotropic pretension N*
// of the size of the expected membrane forces (its first Newton step is the linear
// tensioned-membrane solution −N*Δw = p, the cone-like w of the membrane scaling), then lowers
// it geometrically to zero, each stage a Newton solve from the last; a failed stage is retried
// with a smaller reduction (cutback).
NewtonOutcome FilmSolver::solve_by_continuation(Model model, Vector<double>& u) {
  NewtonOutcome total;
  u = 0;
  if (model == Model::linear || pretension_ >= estimate_tension()) {
    auto o = newton(model, 0.0, u);
    ++summary_.load_steps;
    summary_.newton_iterations += o.iterations;
    return o;
  }
  const double n_star = estimate_tension();
  std::vector<double> targets;
  // N* → 0.1 N* → 0.01 N* → 0 (docs/fem.md §5); measured on the seed-001 sweep mesh: 11
  // factorizations from flat instead of 16 with steps of 0.3, same result (cutbacks guard it).
  for (double t = n_star; t > 0.005 * n_star; t *= 0.1) targets.push_back(t);
  targets.push_back(0.0);
  double last_converged = -1;
  Vector<double> u_saved = u;
  int cutbacks = 0, stagnated_stages = 0;
  std::size_t k = 0;
  while (k < targets.size()) {
    const double target = targets[k];
    PVDF_ASSERT(target >= 0 && (last_converged < 0 || target < last_converged),
                "each continuation stage must lower the artificial pretension");
    // The stages with artificial pretension only lead to the last one, which alone must meet
    // the Newton tolerance: each stops at ‖r‖ ≤ 1e-3‖f‖ (measured on seed 001's centre solve:
    // 18 instead of 25 Newton iterations, outputs unchanged to 10 digits).
    auto o = newton(model, target, u, target > 0 ? 1e-3 : 0.0);
    ++summary_.load_steps;
    summary_.newton_iterations += o.iterations;
    total.residual_norm = o.residual_norm;
    if (o.status == Status::converged) {
      last_converged = target;
      u_saved = u;
      ++k;
      continue;
    }
    if (++cutbacks > options_.max_cutbacks) {
      total.status = o.status;
      total.message = o.message + "; gave up after " + std::to_string(options_.max_cutbacks) +
                      " continuation cutbacks at artificial pretension " + fmt(target) + " N/m";
      return total;
    }
    // A cut-back stage that stagnates again: smaller steps do not help (issue 30), stop now.
    if (o.stagnated && ++stagnated_stages >= options_.max_stagnated_stages) {
      total.status = o.status;
      total.message = o.message + "; gave up after " + std::to_string(stagnated_stages) +
                      " stagnated continuation stages (last at artificial pretension " + fmt(target) + " N/m)";
      return total;
    }
    u = u_saved;
    if (last_converged < 0) {
      // Even the first stage failed: start with a larger tension.
      targets.insert(targets.begin() + static_cast<long>(k), 10 * target);
    } else {
      const double mid = target > 0 ? std::sqrt(last_converged * target) : 0.3 * last_converged;
      targets.insert(targets.begin() + static_cast<long>(k), mid);
    }
  }
  total.status = Status::converged;
  return total;
}

}  // namespace pvdf::fem::detail
