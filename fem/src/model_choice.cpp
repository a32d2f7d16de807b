// The `auto` model rule (docs/fem.md §2), in one place for pvdf::fem::solve and ProbeSweep:
// a priori, whether bending is negligible for the loads; then, on the first mesh, the cheapest of
// linear / von Kármán / large rotation whose outputs stay within the tolerance.
#include "film_solver.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/membrane_scaling.hpp"

#include <algorithm>
#include <cmath>

namespace pvdf::fem::detail {

namespace {

// Model only what the scene needs: is the bending stiffness negligible for the outputs?
// Bending acts in boundary layers of width l_b = sqrt(D/N) at the probe edge and the rim
// (D = E h^3/12, N the membrane force). With the pure-membrane scaling N ~ E h (F/(E h a))^(2/3)
// the layer relative to the probe radius c is eta = l_b / c. Against the independent
// axisymmetric oracle (tests/fem/oracles) the seed-001 film (eta = 0.095) changes its centre
// deflection by 0.18 % and its electrode forces by less when bending is added: the effect is
// ~eta/50. Bending is neglected when that estimate is below tolerance/4. Returns the reason
// (empty when bending must be kept).
std::string bending_negligible_reason(const pvdf::Scene& scene, const Options& options) {
  if (options.model != Model::automatic || !options.include_bending) return {};
  double force_N = 0, radius_m = 1e300;
  for (const auto& l : scene.loads) {
    if (l.kind == pvdf::Load::Kind::probe) {
      force_N += std::abs(l.force_N);
      radius_m = std::min(radius_m, l.radius_m > 0 ? l.radius_m : scene.probe.radius_m);
    } else {
      force_N += std::abs(l.pressure_Pa) * scene.membrane.outline.area_m2();
      radius_m = std::min(radius_m, scene.membrane.outline.inscribed_radius_m());
    }
  }
  if (!(force_N > 0) || !(radius_m < 1e300)) return {};
  const auto& m = scene.material;
  const double E = std::min(m.E1_Pa, m.E2_Pa), h = scene.membrane.thickness_m;
  const double a = scene.membrane.outline.characteristic_radius_m();
  const double D = std::max(m.E1_Pa, m.E2_Pa) * h * h * h / 12.0;
  const double N = pvdf::membrane_force_scale_N_per_m(E * h, force_N, a) + std::max(0.0, scene.membrane.pretension_N_per_m);
  const double eta = std::sqrt(D / N) / radius_m;
  const double effect = eta / 50.0;
  if (effect > 0.25 * options.tolerance) return {};
  return "bending neglected: boundary layer sqrt(D/N)/c = " + fmt(eta) + ", estimated effect " + fmt(effect) +
         " <= tolerance/4 = " + fmt(0.25 * options.tolerance) + ": large-rotation membrane without bending (docs/fem.md)";
}

}  // namespace

// The bending boundary layer at the clamp: sqrt(D/N) with N the rim membrane force of the
// point-loaded membrane, from equilibrium N sin(a) 2 pi R = F and the membrane strain
// N/(E h) = a^2/2: N = (F/(2 pi R))^(2/3) (E h/2)^(1/3), or the pretension when larger.
double rim_boundary_layer_m(const pvdf::Scene& scene, double force_N) {
  const double h = scene.membrane.thickness_m;
  const double E = std::max(scene.material.E1_Pa, scene.material.E2_Pa);
  const double R = scene.membrane.outline.characteristic_radius_m();
  const double D = E * h * h * h / 12.0;
  const double n = std::max(scene.membrane.pretension_N_per_m,
                            pvdf::membrane_force_scale_N_per_m(E * h, force_N / (2 * pvdf::pi), R) * 0.7937005259840998);  // x 2^(-1/3)
  return std::sqrt(D / n);
}

// Steps 2–3 of the rule on the current mesh, from the flat film: the linear plate first; if its
// deflection is not small against the thickness (membrane coupling changes the outputs by
// ~(w/h)²), von Kármán and large rotation, and von Kármán is kept when both agree within
// tolerance/4. u receives the solution of the chosen model (the start of the refinement).
FilmSolver::KinematicsChoice FilmSolver::choose_kinematics(Vector<double>& u) {
  KinematicsChoice c;
  Summary& s = summary_;
  if (tension_field_) {  // a wrinkling film has no linear response to compare with: the general kinematics
    c.model = Model::large_rotation;
    c.reason = "tension-field (wrinkling) membrane: large rotation, no linear trial";
    c.outcome = solve_from_flat(c.model, u);
    c.where = "large-rotation solve of the wrinkling film";
    return c;
  }
  const NewtonOutcome o = solve_from_flat(Model::linear, u);
  if (o.status != Status::converged) {
    c.outcome = o;
    c.where = "linear trial solve";
    return c;
  }
  const double ratio = std::abs(deflection_extremum(u)) / thickness_;
  const double limit = std::sqrt(options_.tolerance) * 0.5;
  if (ratio <= limit && std::isfinite(pretension_) && options_.include_bending) {
    c.model = Model::linear;
    c.relative_model_error = ratio * ratio;
    c.reason = "linear plate deflection w_max/h = " + fmt(ratio) + " <= 0.5*sqrt(tolerance) = " + fmt(limit) +
               " (membrane coupling changes the outputs by ~(w/h)^2)";
    return c;
  }
  const NewtonOutcome ovk = solve_from_flat(Model::von_karman, u);
  if (ovk.status != Status::converged) {
    c.outcome = ovk;
    c.where = "von Karman solve";
    return c;
  }
  const OutputVector q_vk = outputs(u, Model::von_karman);
  Vector<double> u_lr = u;
  NewtonOutcome olr = newton(Model::large_rotation, 0.0, u_lr);
  ++s.load_steps;
  s.newton_iterations += olr.iterations;
  if (olr.status != Status::converged) {
    olr = solve_from_flat(Model::large_rotation, u_lr);
    if (olr.status != Status::converged) {
      c.outcome = olr;
      c.where = "large-rotation solve";
      return c;
    }
  }
  const OutputVector q_lr = outputs(u_lr, Model::large_rotation);
  const double d = relative_difference(q_lr, q_vk);
  if (d <= 0.25 * options_.tolerance) {
    c.model = Model::von_karman;
    c.relative_model_error = d;
    c.reason = "linear w_max/h = " + fmt(ratio) + " too large; von Karman and large-rotation outputs differ by " +
               fmt(d) + " <= tolerance/4 on the first mesh";
  } else {
    c.model = Model::large_rotation;
    u = u_lr;
    c.reason = "linear w_max/h = " + fmt(ratio) + " too large; von Karman differs from large-rotation by " + fmt(d) +
               " > tolerance/4 on the first mesh";
  }
  return c;
}

// Steps 2–3 for a solver of its own (a sweep's centred probe): the first mesh as a solve would
// build it, then choose_kinematics.
FilmSolver::KinematicsChoice FilmSolver::choose_kinematics_on_first_mesh() {
  reuse_factorization_ = true;  // as in run(): chord steps while Newton contracts >= 10x per step
  setup_system();
  Vector<double> u(dof_handler_.n_dofs());
  return choose_kinematics(u);
}

bool bending_may_be_left_out(double relative_bending_effect, double tolerance, std::string& reason) {
  const double share = 0.5 * tolerance;
  const bool ok = std::isfinite(relative_bending_effect) && relative_bending_effect <= share;
  reason = std::string(ok ? "bending left out" : "bending kept") +
           ": adjoint-weighted estimate of its effect on the outputs, max relative " + fmt(relative_bending_effect) +
           (ok ? " <= " : " > ") + "tolerance/2 = " + fmt(share);
  return ok;
}

ModelChoice choose_model(const pvdf::Scene& scene, const Options& options, const ForceRange* sweep) {
  ModelChoice choice;
  choice.include_bending = options.include_bending;
  if (options.model != Model::automatic) {
    choice.model = options.model;
    choice.reason = "requested";
    return choice;
  }
  // Step 1 (a priori).
  const pvdf::Scene bending_scene = sweep ? pvdf::with_probe_load(scene, 0, 0, sweep->smallest_N) : scene;
  choice.reason = bending_negligible_reason(bending_scene, options);
  if (!choice.reason.empty()) {
    choice.model = Model::large_rotation;
    choice.include_bending = false;
    if (sweep) choice.reason += " (evaluated at the smallest force, " + fmt(sweep->smallest_N, 3) + " N)";
    return choice;
  }
  if (!sweep) return choice;  // steps 2–3 on the solve's own first mesh (FilmSolver::run)

  // A sweep: steps 2–3 now, on a centred probe at the largest force. Bending negligible there
  // (but not at the smallest force): membrane-dominated at the top of the range, so the most
  // general kinematics, with bending.
  const std::string at = "auto solve at " + fmt(sweep->largest_N, 3) + " N";
  const pvdf::Scene top = pvdf::with_probe_load(scene, 0, 0, sweep->largest_N);
  const std::string top_reason = bending_negligible_reason(top, options);
  choice.model = Model::large_rotation;
  if (!top_reason.empty()) {
    choice.reason = at + ", centred probe: " + top_reason;
    return choice;
  }
  Options trial_options = options;
  trial_options.adaptive = false;
  FilmSolver trial(top, trial_options);
  trial.make_grid();
  const FilmSolver::KinematicsChoice c = trial.choose_kinematics_on_first_mesh();
  if (c.outcome.status != Status::converged) {
    choice.reason = at + " did not converge (" + c.where + ": " + c.outcome.message +
                    "); using the most general kinematics, large rotation with bending";
    return choice;
  }
  choice.model = c.model;
  choice.reason = at + ", centred probe: " + c.reason;
  return choice;
}

}  // namespace pvdf::fem::detail
