// The tension-field (wrinkling) membrane (docs/fem.md §3.3): the relaxed law of an orthotropic film
// (tension_field.hpp), the film's natural (stress-free) state for pretension of either sign or a
// slack strain, the continuation that brings a slack film from the flat state to equilibrium, and
// the wrinkled and slack area of a solution.
#include "pvdf/core/constants.hpp"
#include "film_solver.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/membrane_scaling.hpp"

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/dofs/dof_tools.h>
#include <deal.II/fe/fe_values.h>
#include <deal.II/fe/mapping.h>

#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

namespace pvdf::fem::detail {

using namespace dealii;

// The natural state: the trial stress of the flat film is S0 = N0·I for a pretension N0 of either
// sign, or −C·(s, s, 0) for a slack strain s (stress-free film (1 + s) times the hole). Slack films
// always use the relaxed law; taut films when the scene asks (membrane.tension_field).
void FilmSolver::setup_natural_state() {
  const auto& m = scene_.membrane;
  Eigen::Matrix3d C;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) C(i, j) = membrane_C_.c[i][j];
  const Eigen::Matrix3d Ci = C.inverse();
  Eigen::Vector3d S0(m.pretension_N_per_m, m.pretension_N_per_m, 0.0);
  if (m.slack_strain > 0) S0 = -C * Eigen::Vector3d(m.slack_strain, m.slack_strain, 0.0);
  const Eigen::Vector3d cs = Ci * S0, cu = Ci * Eigen::Vector3d(1, 1, 0);
  for (int i = 0; i < 3; ++i) {
    initial_stress_[i] = S0[i];
    compliance_initial_stress_[i] = cs[i];
    unit_compliance_[i] = cu[i];
  }
  tension_field_ = m.tension_field || m.pretension_N_per_m < 0 || m.slack_strain > 0;
  residual_stiffness_ = tension_field_ ? std::clamp(options_.tension_field_residual_stiffness, 0.0, 1.0) : 0.0;
  if (residual_stiffness_ > 0) tangent_regularization_ = 0;  // the tangent of the ε-law is exact and regular
}

// The relaxed law at the Green–Lagrange strain E with the artificial isotropic tension t of the
// continuation: elastic strain e = E + C⁻¹(S0 + t·I).
RelaxedMembrane FilmSolver::membrane_law(const std::array<double, 3>& E, double artificial_tension,
                                         bool want_tangent) const {
  std::array<double, 3> e;
  for (int i = 0; i < 3; ++i) e[i] = E[i] + compliance_initial_stress_[i] + artificial_tension * unit_compliance_[i];
  RelaxedMembrane L = relaxed_membrane(membrane_C_.c, e, want_tangent);
  const double eps = residual_stiffness_;
  if (eps > 0 && L.state != MembraneState::taut) {
    // Residual stiffness (Options::tension_field_residual_stiffness): W_ε = (1 − ε)·W_relaxed + ε·½e·C·e,
    // S_ε and D_ε likewise; the law is unchanged where taut.
    const std::array<double, 3> Ce = membrane_C_.apply(e);
    L.W = (1 - eps) * L.W + eps * 0.5 * (Ce[0] * e[0] + Ce[1] * e[1] + Ce[2] * e[2]);
    for (int i = 0; i < 3; ++i) L.S[i] = (1 - eps) * L.S[i] + eps * Ce[i];
    if (want_tangent)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) L.D[i][j] = (1 - eps) * L.D[i][j] + eps * membrane_C_.c[i][j];
  }
  return L;
}

// Membrane force of a converged state at the strain E (N/m): C·E + S0, relaxed when wrinkling is modelled.
std::array<double, 3> FilmSolver::membrane_stress(const std::array<double, 3>& E) const {
  if (tension_field_) return membrane_law(E, 0.0, false).S;
  std::array<double, 3> S = membrane_C_.apply(E);
  for (int i = 0; i < 3; ++i) S[i] += initial_stress_[i];
  return S;
}

// ε of the tangent regularization (tension_field.hpp): tangent_regularization_ times the tension
// scale of the current force over E·h — the Hencky-type scale N*(F) of a taut film, or for a slack
// film the rim force of the inextensible cone its excess length makes, F/(2πa·√(2s)) with s ≈ |N0|/(E·h).
double FilmSolver::tension_field_regularization() const {
  const double F = total_force_ * load_factor_;
  if (F == regularization_force_) return regularization_eta_;
  const double Eh = std::sqrt(membrane_C_.c[0][0] * membrane_C_.c[1][1]);
  const double n0 = 0.5 * (initial_stress_[0] + initial_stress_[1]);
  double scale = pvdf::membrane_force_scale_N_per_m(Eh, F, radius_) + std::max(0.0, n0);
  if (n0 < 0) scale = std::min(scale, F / (2 * pvdf::pi * radius_ * std::sqrt(-2 * n0 / Eh)));
  regularization_force_ = F;
  regularization_eta_ = tangent_regularization_ * scale / Eh;
  return regularization_eta_;
}

// The assembly hook: replaces the plain stress of a quadrature point by the relaxed one and the
// material tangent by the relaxed tangent (+ the regularization where wrinkled or slack); returns
// the change of the energy density (relaxed − plain, J/m²; the plain density is ½E·C·E + N_tot tr E).
double FilmSolver::relax_membrane_point(const Kinematics& k, Model model, double artificial_tension,
                                        bool want_tangent, std::array<double, 3>& S, Stiffness3& D) const {
  const std::array<double, 3> E = membrane_strain(k, model);
  const RelaxedMembrane L = membrane_law(E, artificial_tension, want_tangent);
  const std::array<double, 3> CE = membrane_C_.apply(E);
  const double n_tot = pretension_ + artificial_tension;
  const double plain = 0.5 * (CE[0] * E[0] + CE[1] * E[1] + CE[2] * E[2]) + n_tot * (E[0] + E[1]);
  // The relaxed density ½e·C·e is measured from the natural (stress-free) state, not from the flat
  // film: it differs from the plain one by a constant where nothing wrinkles, and it stays small
  // when a slack film carries a small load (the line search compares energies to round-off).
  S = L.S;
  if (convexified_tangent_ && want_tangent) {
    // The convexified tangent (newton.cpp): the force's compressive principal part dropped, so the
    // geometric stiffness S:(∇δu)ᵀ∇δu is positive semidefinite. Only ε·C·e can compress (the relaxed
    // force is tension: taut, or σ n⊗n with σ > 0). S₊ = λ₁ n₁⊗n₁ = λ₁ (S − λ₂I)/(λ₁ − λ₂).
    const auto [l1, l2] = principal_values(S[0], S[1], S[2]);
    if (l2 < 0) {
      const double f = l1 > 0 ? l1 / (l1 - l2) : 0.0;
      S = {f * (S[0] - l2), f * (S[1] - l2), f * S[2]};
    }
  }
  if (want_tangent) {
    const double eta = L.state == MembraneState::taut ? 0.0 : tension_field_regularization();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) D.c[i][j] = L.D[i][j] + eta * membrane_C_.c[i][j];
  }
  return L.W - plain;
}

namespace {
// Scales the load vectors by `factor` for a force continuation and restores them on destruction.
struct LoadScale {
  Vector<double>& load;
  Vector<double>& load_raw;
  Vector<double> saved, saved_raw;
  LoadScale(Vector<double>& l, Vector<double>& lr, double& f)
      : load(l), load_raw(lr), saved(l), saved_raw(lr), load_factor(f) {}
  double& load_factor;
  void set(double factor) {
    load_factor = factor;
    load = saved;
    load *= factor;
    load_raw = saved_raw;
    load_raw *= factor;
  }
  ~LoadScale() {
    load_factor = 1;
    load = saved;
    load_raw = saved_raw;
  }
};
}  // namespace

// Rim slope α of a slack film hanging as a cone from the probe to the rim, at natural strain s and
// the current force: α² = 2(s + N/(E·h)) with the mean tension N = F/(π·L·α) (twice the rim value
// F/(2π·L·α)), L the distance from the probe to the nearest rim point. For s = 0 it is the taut
// film's α ∝ (F/(E·h·L))^(1/3); for large s the inextensible cone's √(2s).
double FilmSolver::slack_cone_slope(double s) const {
  double L = radius_;
  if (!loads_.empty()) {
    L = std::numeric_limits<double>::max();
    const Point<dim> p = loads_.front().center;
    for (const auto& cell : triangulation_.active_cell_iterators())
      for (unsigned int f = 0; f < cell->n_faces(); ++f)
        if (cell->face(f)->at_boundary())
          for (unsigned int v = 0; v < 2; ++v) L = std::min(L, p.distance(cell->face(f)->vertex(v)));
    L = std::max(L, 1e-3 * radius_);
  }
  const double Eh = std::sqrt(membrane_C_.c[0][0] * membrane_C_.c[1][1]);
  const double k = 2 * total_force_ * load_factor_ / (pvdf::pi * L * Eh);
  double lo = 0, hi = 1;  // α³ − 2sα − k is increasing where it changes sign
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (mid * mid * mid - 2 * s * mid - k > 0 ? hi : lo) = mid;
  }
  return 0.5 * (lo + hi);
}

// A slack film (N0 < 0) from the flat state (docs/fem.md §5.2): an artificial isotropic tension
// t = |N0| cancels the slack, so the first solve is the ordinary stress-free membrane (its own
// continuation, solve_from_flat's schedule shifted by |N0|); then t steps down to 0. Each step
// predicts the deflection by the cone scaling w ∝ α(s_eff) (slack_cone_slope, with the natural
// strain s_eff = s·(1 − t/|N0|) left at t) and corrects by Newton; steps double after a success and
// shrink 4× after a failure. The pretension path stays near equilibrium throughout, instead of
// asking Newton to find the cone from a flat, slack film (which has no stiffness at all).
NewtonOutcome FilmSolver::solve_slack_by_pretension(Model model, Vector<double>& u) {
  NewtonOutcome total;
  u = 0;
  const double n0 = -0.5 * (initial_stress_[0] + initial_stress_[1]);  // |N0|
  const double s = std::max(0.0, -0.5 * (compliance_initial_stress_[0] + compliance_initial_stress_[1]));
  const double Eh = std::sqrt(membrane_C_.c[0][0] * membrane_C_.c[1][1]);
  const double n_star = 2.0 * pvdf::membrane_force_scale_N_per_m(Eh, total_force_, radius_);
  // Steps of (2) with artificial tension left are stepping stones, as in solve_by_continuation: each
  // stops at ‖r‖ ≤ 1e-5‖f‖; the last (t = 0) meets the Newton tolerance. Measured on the seed-001
  // sweep mesh at N0 = −4000 N/m: with the full tolerance at every step, the centre's continuation
  // stalled at t = 1196 N/m, the steps ending at ‖r‖ ≈ 1.4e-7 N (3e-7‖f‖, linear convergence on a
  // nearly singular stable equilibrium) but not at the tolerance 5e-10 N (docs/fem.md §3.3).
  auto stage = [&](double t, double stage_rtol) {
    NewtonOutcome o = newton(model, t, u, stage_rtol);
    ++summary_.load_steps;
    summary_.newton_iterations += o.iterations;
    total.residual_norm = o.residual_norm;
    return o;
  };
  // (1) The stress-free film: extra tension N*, 0.1 N*, 0.01 N*, 0 on top of |N0|.
  Vector<double> saved = u;
  for (double extra : {n_star, 0.1 * n_star, 0.01 * n_star, 0.0}) {
    const NewtonOutcome o = stage(n0 + extra, 0.0);
    if (o.status != Status::converged) {
      total.status = o.status;
      total.message = o.message + "; the slack film did not converge even with its slack cancelled by an artificial tension of " +
                      fmt(n0 + extra) + " N/m";
      return total;
    }
  }
  // (2) t = |N0| → 0, with the cone predictor on w.
  double f = 1, step = 0.25;  // f = t/|N0|
  saved = u;
  int failures = 0;
  while (f > 0) {
    const double next = f - step < 1e-3 ? 0.0 : f - step;
    const double ratio = slack_cone_slope(s * (1 - next)) / slack_cone_slope(s * (1 - f));
    scale_state(u, 1.0, ratio);
    const NewtonOutcome o = stage(next * n0, next > 0 ? 1e-5 : 0.0);
    if (o.status == Status::converged) {
      f = next;
      saved = u;
      step = std::min(2 * step, 0.5);
      continue;
    }
    u = saved;
    step *= 0.25;
    if (++failures > 2 * options_.max_cutbacks) {
      total.status = o.status;
      total.message = o.message + "; slack-film continuation gave up at " + fmt((1 - next) * n0) + " N/m of the " +
                      fmt(n0) + " N/m slack (artificial tension " + fmt(next * n0) + " N/m)";
      return total;
    }
  }
  total.status = Status::converged;
  return total;
}

// From the flat film to equilibrium with the relaxed law (docs/fem.md §5.2). A slack flat film has
// no stiffness at all, so (1) at a force F1 ≥ F large enough for the film's stretch to dominate its
// slack (membrane force scale N*(F1) ≥ |N0|), start taut under an artificial isotropic tension
// t0 = N*(F1) + |N0| and lower t to 0 in adaptive steps (doubling after a success, quartering after a
// failure), each a Newton solve from the last; then (2) lower the force from F1 to F in steps of 5×
// (halved in log after a failure). A stage that fails after max_cutbacks reductions ends the solve
// with its status (exit 3 in the app), never with a non-finite state.
NewtonOutcome FilmSolver::solve_slack_from_flat(Model model, Vector<double>& u) {
  NewtonOutcome total;
  if (residual_stiffness_ > 0 && 0.5 * (initial_stress_[0] + initial_stress_[1]) < 0)
    return solve_slack_by_pretension(model, u);
  u = 0;
  const double F = total_force_;
  const double Eh = std::sqrt(membrane_C_.c[0][0] * membrane_C_.c[1][1]);
  const double n0 = 0.5 * (initial_stress_[0] + initial_stress_[1]);
  double F1 = F;
  if (n0 < 0) F1 = std::max(F, Eh * radius_ * std::pow(-n0 / (2 * Eh), 1.5));
  LoadScale scale(load_, load_raw_, load_factor_);
  scale.set(F1 / F);
  const double t0 = 2.0 * pvdf::membrane_force_scale_N_per_m(Eh, F1, radius_) + std::max(0.0, -n0);
  auto stage = [&](double t) {
    NewtonOutcome o = newton(model, t, u);
    ++summary_.load_steps;
    summary_.newton_iterations += o.iterations;
    total.residual_norm = o.residual_norm;
    return o;
  };
  // (1) Artificial tension t0 → 0 at F1.
  double t = t0, step = 0.75 * t0;
  Vector<double> saved = u;
  int failures = 0;
  for (NewtonOutcome o = stage(t); o.status != Status::converged; o = stage(t)) {
    u = saved;
    t *= 4;  // even the first stage failed: more tension
    if (++failures > 3) {
      total.status = o.status;
      total.message = o.message + "; the slack film did not converge even under artificial tension " + fmt(t / 4) + " N/m";
      return total;
    }
  }
  saved = u;
  failures = 0;
  while (t > 0) {
    const double next = t - step < 1e-3 * t0 ? 0.0 : t - step;
    const NewtonOutcome o = stage(next);
    if (o.status == Status::converged) {
      t = next;
      saved = u;
      step *= 2;
      continue;
    }
    u = saved;
    step *= 0.25;
    if (++failures > 2 * options_.max_cutbacks) {
      total.status = o.status;
      total.message = o.message + "; slack-film continuation gave up at artificial tension " + fmt(next) +
                      " N/m (film slack by " + fmt(-n0) + " N/m at " + fmt(F1) + " N)";
      return total;
    }
  }
  // (2) Force F1 → F.
  double lambda = F1 / F, factor = 0.2;
  failures = 0;
  while (lambda > 1) {
    const double next = std::max(1.0, lambda * factor);
    scale.set(next);
    const NewtonOutcome o = stage(0.0);
    if (o.status == Status::converged) {
      lambda = next;
      saved = u;
      continue;
    }
    u = saved;
    factor = std::sqrt(factor);
    if (++failures > options_.max_cutbacks) {
      total.status = o.status;
      total.message = o.message + "; slack-film force continuation gave up at " + fmt(next * F) + " N";
      return total;
    }
  }
  total.status = Status::converged;
  return total;
}

// Share of the film's area that is wrinkled and slack, and each cell's state (the state of the
// largest share of its area) for the VTU.
WrinkleMap FilmSolver::wrinkle_map(const Vector<double>& u, Model model) const {
  WrinkleMap map;
  map.cell_state.assign(triangulation_.n_active_cells(), 0.0f);
  if (!tension_field_) return map;
  const QGauss<dim> quadrature(options_.fe_degree + 1);
  FEValues<dim> fe_values(*mapping_, *fe_, quadrature, update_gradients | update_JxW_values);
  const FEValuesExtractors::Vector inplane(0);
  const FEValuesExtractors::Scalar w(2);
  std::vector<Tensor<2, dim>> grad_u(quadrature.size());
  std::vector<Tensor<1, dim>> grad_w(quadrature.size());
  double total = 0, wrinkled = 0, slack = 0;
  for (const auto& cell : dof_handler_.active_cell_iterators()) {
    fe_values.reinit(cell);
    fe_values[inplane].get_function_gradients(u, grad_u);
    fe_values[w].get_function_gradients(u, grad_w);
    double area[3] = {0, 0, 0};
    for (unsigned int q = 0; q < quadrature.size(); ++q) {
      Kinematics k;
      for (int a = 0; a < 2; ++a) {
        k.g[a] = grad_w[q][a];
        for (int b = 0; b < 2; ++b) k.H[a][b] = grad_u[q][a][b];
      }
      const MembraneState st = membrane_law(membrane_strain(k, model), 0.0, false).state;
      area[static_cast<int>(st)] += fe_values.JxW(q);
    }
    total += area[0] + area[1] + area[2];
    wrinkled += area[1];
    slack += area[2];
    const int dominant = static_cast<int>(std::max_element(area, area + 3) - area);
    map.cell_state[cell->active_cell_index()] = static_cast<float>(dominant);
  }
  if (total > 0) {
    map.wrinkled_area_fraction = wrinkled / total;
    map.slack_area_fraction = slack / total;
  }
  return map;
}

}  // namespace pvdf::fem::detail
