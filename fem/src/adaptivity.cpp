// Adaptivity and the output-error estimate (docs/fem.md §6): the outputs compared between meshes,
// Kelly-indicator refinement with solution transfer, and the refinement loop whose estimate is
// the change of the outputs between meshes, extrapolated with the observed contraction.
#include "film_solver.hpp"

#include "pvdf/core/constants.hpp"

#include "pvdf/core/material.hpp"

#include <deal.II/base/quadrature_lib.h>
#include <deal.II/grid/grid_refinement.h>
#include <deal.II/numerics/error_estimator.h>
#include <deal.II/numerics/solution_transfer.h>
#include <deal.II/numerics/vector_tools.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace pvdf::fem::detail {

using namespace dealii;

double relative_difference(const OutputVector& a, const OutputVector& b) {
  double d = 0;
  if (a.forces.size() == b.forces.size() && a.force_scale > 0) {
    for (std::size_t i = 0; i < a.forces.size(); ++i) d = std::max(d, std::abs(a.forces[i] - b.forces[i]) / a.force_scale);
  }
  if (a.deflections.size() == b.deflections.size() && a.deflection_scale > 0) {
    for (std::size_t i = 0; i < a.deflections.size(); ++i)
      d = std::max(d, std::abs(a.deflections[i] - b.deflections[i]) / a.deflection_scale);
  }
  return d;
}

// The outputs whose change between meshes (and models) estimates the error: the electrodes' mean
// membrane forces (material axes) and w under each load.
OutputVector FilmSolver::outputs(const Vector<double>& u, Model model) const {
  OutputVector o;
  for (std::size_t k = 0; k < electrode_polygons_.size(); ++k) {
    const auto g = electrode_mean_force(u, model, k);
    const Eigen::Vector3d m = pvdf::stress_to_material(draw_angle_) * Eigen::Vector3d(g[0], g[1], g[2]);
    for (int c = 0; c < 3; ++c) {
      o.forces.push_back(m[c]);
      o.force_scale = std::max(o.force_scale, std::abs(m[c]));
    }
  }
  for (const auto& l : loads_) {
    std::vector<Tensor<1, dim>> dummy;
    Vector<double> value(3);
    VectorTools::point_value(*mapping_, dof_handler_, u, l.center, value);
    o.deflections.push_back(value[2]);
    o.deflection_scale = std::max(o.deflection_scale, std::abs(value[2]));
  }
  return o;
}

// One refinement cycle, the top 30 % of cells by indicator refined and the solution transferred.
// Indicators: the goal-oriented ones when given (goal_error.cpp), else Kelly's for (u_x, u_y) and
// for w, each normalised by its l2 norm so that neither field dominates.
void FilmSolver::refine_mesh(Vector<double>& u, const Vector<float>* goal_indicators) {
  const unsigned int p = options_.fe_degree;
  Vector<float> indicator(triangulation_.n_active_cells());
  if (goal_indicators) {
    indicator = *goal_indicators;
  } else {
    Vector<float> est_u(triangulation_.n_active_cells()), est_w(triangulation_.n_active_cells());
    const ComponentMask mask_u = fe_->component_mask(FEValuesExtractors::Vector(0));
    const ComponentMask mask_w = fe_->component_mask(FEValuesExtractors::Scalar(2));
    KellyErrorEstimator<dim>::estimate(*mapping_, dof_handler_, QGauss<dim - 1>(p + 1), {}, u, est_u, mask_u);
    KellyErrorEstimator<dim>::estimate(*mapping_, dof_handler_, QGauss<dim - 1>(p + 1), {}, u, est_w, mask_w);
    const double nu = est_u.l2_norm(), nw = est_w.l2_norm();
    for (unsigned int i = 0; i < indicator.size(); ++i) {
      indicator(i) = static_cast<float>((nu > 0 ? est_u(i) / nu : 0.0) + (nw > 0 ? est_w(i) / nw : 0.0));
    }
  }
  enriched_.reset();
  GridRefinement::refine_and_coarsen_fixed_number(triangulation_, indicator, 0.3, 0.0);
  SolutionTransfer<dim, Vector<double>> transfer(dof_handler_);
  triangulation_.prepare_coarsening_and_refinement();
  transfer.prepare_for_coarsening_and_refinement(u);
  triangulation_.execute_coarsening_and_refinement();
  set_material_ids();
  setup_system();
  Vector<double> u_new(dof_handler_.n_dofs());
  transfer.interpolate(u, u_new);
  constraints_.distribute(u_new);
  u = u_new;
}

// Refines the cells near the rim, within half_angle_rad of the direction angle_rad as seen from the
// film centre (>= pi: the whole rim), until each is no larger than max(size_m, grading x distance
// to the rim); u, when given, is carried over (DOFs distributed, constraints not yet rebuilt).
// Returns whether anything was refined. Shared by the map's rim model (prepare_sweep, one arc) and
// grade_toward_rim (the whole rim).
bool FilmSolver::refine_toward_rim(double size_m, double grading, double angle_rad, double half_angle_rad,
                                   Vector<double>* u, const std::vector<RimLayerPoint>* widths) {
  const auto& outline = scene_.membrane.outline;
  // The layer's width at the rim point nearest to c (size_m without widths).
  auto layer_at = [&](const Point<dim>& c) {
    if (!widths || widths->empty()) return size_m;
    double best = std::numeric_limits<double>::infinity(), width = size_m;
    for (const RimLayerPoint& p : *widths) {
      const double d2 = (p.x_m - c[0]) * (p.x_m - c[0]) + (p.y_m - c[1]) * (p.y_m - c[1]);
      if (d2 < best) {
        best = d2;
        width = p.width_m;
      }
    }
    return std::max(size_m, width);
  };
  bool refined = false;
  for (int pass = 0; pass < 30; ++pass) {
    bool marked = false;
    for (const auto& cell : triangulation_.active_cell_iterators()) {
      const Point<dim> c = cell->center();
      const double off = std::remainder(std::atan2(c[1], c[0]) - angle_rad, 2 * pvdf::pi);
      if (std::abs(off) > half_angle_rad) continue;
      const double d = std::max(0.0, outline.inside_distance_m({c[0], c[1]}) - 0.5 * cell->diameter());
      const double h = cell->diameter() / std::sqrt(2.0);
      // layer_at(c) >= size_m: the first test only spares the nearest-point search for cells that
      // are fine enough anyway (most of the film).
      if (h > 1.3 * std::max(size_m, grading * d) && h > 1.3 * std::max(layer_at(c), grading * d)) {
        cell->set_refine_flag();
        marked = true;
      }
    }
    if (!marked) break;
    refined = true;
    enriched_.reset();
    if (!u) {
      triangulation_.execute_coarsening_and_refinement();
      continue;
    }
    SolutionTransfer<dim, Vector<double>> transfer(dof_handler_);
    triangulation_.prepare_coarsening_and_refinement();
    transfer.prepare_for_coarsening_and_refinement(*u);
    triangulation_.execute_coarsening_and_refinement();
    dof_handler_.distribute_dofs(*fe_);
    Vector<double> u_new(dof_handler_.n_dofs());
    transfer.interpolate(*u, u_new);
    *u = u_new;
  }
  return refined;
}

// With bending the clamp carries a boundary layer of width l_b = sqrt(D/N) (0.2 mm on seed 001
// at 1 N) that a first mesh with cells of a/6 at the rim does not resolve. Primal and adjoint both
// miss it there, so the goal-oriented loop neither sees nor finds it (docs/fem.md §6), while it
// moves the charges everywhere by tenths of a percent (0.5 % at r = 24 mm on seed 001). So
// the cells are refined toward the whole rim until their size is at most max(l_b, distance / 2).
// Before a solve (bending kept from the start) l_b is the centred press's (rim_boundary_layer_m at
// the total load) all around. From a solved state u it is the layer's own width along the rim,
// sqrt(D_nn/N_nn) with the rim's normal force: a press near one stretch of the clamp leaves the rest
// of it barely stretched, where the layer is wider and so may be its cells — never finer than the
// centred press's l_b (the goal-oriented loop refines further) and never coarser than
// kWidestRimCell of it (docs/fem.md §6.1 "The rim graded to its own layer": coarser rims lifted the
// discretization estimate past the tolerance at (−32, 28) mm on seed 001 and the refined re-solve
// then stagnated).
void FilmSolver::grade_toward_rim(Vector<double>* u, Model model) {
  constexpr double kWidestRimCell = 4.0;  // × the centred press's l_b
  if (!options_.grade_rim_for_bending || rim_graded_ || !(total_force_ > 0)) return;
  // The linear plate carries no membrane force: no layer (unless pretensioned).
  if (options_.model == Model::linear && !(pretension_ > 0)) return;
  rim_graded_ = true;
  const auto& outline = scene_.membrane.outline;
  const double a = outline.characteristic_radius_m();
  // The layer acts like a clamp moved inward by about l_b: its effect on the outputs is ~l_b/a
  // (0.4 % on seed 001: 0.2 mm of 45 mm; measured 0.1-0.6 % on the charges). Below a tenth of the
  // tolerance it is left unresolved; cells are never made smaller than a/1000 (films of ~1 µm).
  const double layer = std::max(rim_boundary_layer_m(scene_, total_force_), a / 1000);
  if (rim_boundary_layer_m(scene_, total_force_) / a <= 0.1 * options_.tolerance) return;
  summary_.clamp_layer = "rim-graded";
  std::vector<RimLayerPoint> widths;
  if (u && !rim_grading_uniform()) widths = rim_layer_widths(*u, model, kWidestRimCell * layer);
  if (!widths.empty()) {
    double widest = 0;
    for (const RimLayerPoint& p : widths) widest = std::max(widest, p.width_m);
    clamp_reason_ += "; rim graded to the layer's own width (" + fmt(layer * 1e3, 3) + " to " + fmt(widest * 1e3, 3) +
                     " mm along the rim)";
  }
  const bool refined = refine_toward_rim(layer, 0.5, 0.0, 4.0, u, widths.empty() ? nullptr : &widths);
  if (refined && u) {
    set_material_ids();
    setup_system();
    constraints_.distribute(*u);
  }
}

// The reference path instead of the clamp-layer condition: plain clamp, bending kept, the rim graded
// to l_b (docs/fem.md §3.4), solved from the current state (from flat if that fails).
NewtonOutcome FilmSolver::leave_clamp_layer_for_graded_rim(Model model) {
  Summary& s = summary_;
  set_clamp_layer(false, solution_);
  enable_bending();
  s.clamp_layer = "none";
  grade_toward_rim(&solution_, model);  // "rim-graded" when it grades
  NewtonOutcome o = newton(model, 0.0, solution_);
  ++s.load_steps;
  s.newton_iterations += o.iterations;
  if (o.status != Status::converged) o = solve_from_flat(model, solution_);
  return o;
}

// Output-driven refinement (docs/fem.md §6), the steps of run()'s cycle: on every mesh the
// dual-weighted residual estimates of the outputs (goal_error.cpp); when `auto` left bending out,
// the bending estimate decides first (bending_may_be_left_out, model_choice.cpp) and bending is
// switched on, on the same mesh, when it matters (adapt_model). Then refine (goal or Kelly
// indicators) and re-solve from the transferred solution (solve_on_refined_mesh) until the
// discretization estimate meets what the model error leaves of the tolerance, the refinement cap
// or the DOF cap (accurate_enough). The estimates are left in summary_ and goal_.
void FilmSolver::describe_estimator() {
  const std::string q = "Q" + std::to_string(options_.fe_degree + 1);
  summary_.error_estimator = "dual-weighted residual: adjoint of the converged tangent, solved in " + q +
                             " on the same mesh for the charges, " + q + " patch extrapolation of the Q" +
                             std::to_string(options_.fe_degree) + " adjoint for the deflections; residual in " + q +
                             "; " + (options_.refinement == Refinement::goal ? "goal-oriented" : "Kelly") + " refinement";
}

// After the estimate goal_ of this mesh: the clamp-layer condition, bending, or the reference path
// (plain clamp, bending kept, rim graded) where the estimates ask for them, solved on this mesh.
FilmSolver::ModelStep FilmSolver::adapt_model(Model model, NewtonOutcome& o, std::string& where) {
  Summary& s = summary_;
  if (goal_.model_estimated && bending_switchable_) {
    const bool leave_out = bending_may_be_left_out(goal_.relative_model, options_.tolerance, bending_reason_);
    if (!leave_out && !clamp_layer_ && !rim_graded_ && !clamp_failed_ && clamp_layer_wanted()) {
      // Most of bending's effect near the clamp is its layer there: first as a boundary condition
      // (clamp_layer.cpp), then bending's remaining effect is estimated again (rim terms dropped).
      const Vector<double> clamped = solution_;
      o = switch_to_clamp_layer(model, solution_);
      if (o.status != Status::converged) {  // the reference path instead (below, on this same cycle)
        solution_ = clamped;
        set_clamp_layer(false, solution_);
        clamp_correction_ = 0;
        summary_.clamp_layer = "none";
        clamp_reason_ = "the clamp-layer condition did not converge (" + o.message + "): rim graded instead";
        clamp_failed_ = true;
      } else {
        clamp_reason_ = bending_reason_ + " with the plain clamp; the clamp's layer as a boundary condition "
                        "changed the charges by " + fmt(clamp_correction_) + " (l_b up to " +
                        fmt(summary_.clamp_layer_width_m * 1e3, 3) + " mm)";
        return ModelStep::changed;
      }
    }
    if (!leave_out) {  // the richer model, from the membrane solution on this mesh
      enable_bending();
      if (!clamp_layer_) grade_toward_rim(&solution_, model);
      o = clamp_layer_ ? solve_with_clamp_layer(model, solution_) : newton(model, 0.0, solution_);
      ++s.load_steps;
      s.newton_iterations += o.iterations;
      if (o.status != Status::converged) o = solve_from_flat(model, solution_);  // the condition's passes again
      if (o.status != Status::converged && clamp_layer_) {  // bending beside the condition failed: the reference path
        clamp_reason_ += "; bending switched on beside the condition did not converge (" + o.message +
                         "): rim graded to l_b instead";
        o = leave_clamp_layer_for_graded_rim(model);
      }
      if (o.status != Status::converged) {
        where = "solve with bending switched on";
        return ModelStep::failed;
      }
      return ModelStep::changed;
    }
  }
  // The clamp-layer condition's own estimate against its share of the tolerance: what bending's
  // remaining effect and the kinematics leave of 3/4 of it (a quarter is kept for the
  // discretization). Beyond it the reference path takes over: plain clamp, bending kept, rim
  // graded to l_b.
  const double clamp_estimate = clamp_layer_estimate();
  const double other_model =
      (goal_.model_estimated && std::isfinite(goal_.relative_model) ? goal_.relative_model : 0.0) + kinematics_model_error_;
  const double clamp_share = clamp_layer_share(options_.tolerance, other_model);
  if (clamp_layer_ && clamp_estimate > clamp_share && !clamp_layer_accepted()) {
    clamp_reason_ += "; its estimated error " + fmt(clamp_estimate) + " > its share of the tolerance " +
                     fmt(clamp_share) + ": bending kept, rim graded to l_b instead";
    o = leave_clamp_layer_for_graded_rim(model);
    if (o.status != Status::converged) {
      where = "solve with bending on the rim-graded mesh";
      return ModelStep::failed;
    }
    return ModelStep::changed;
  }
  s.estimated_clamp_layer_error = clamp_estimate;
  if (clamp_layer_) clamp_share_reason_ = "clamp-layer estimate " + fmt(clamp_estimate) + " <= its share " + fmt(clamp_share);
  return ModelStep::kept;
}

// The summary's estimates from goal_ (and the clamp-layer estimate adapt_model left there); true
// when they meet the tolerance, or the refinement cap or the DOF cap stops the cycles.
bool FilmSolver::accurate_enough() {
  Summary& s = summary_;
  const int max_cycles = options_.adaptive ? options_.max_refinements : 0;
  const double disc = std::isfinite(goal_.relative_discretization) ? goal_.relative_discretization : 1.0;
  const double bending_model = goal_.model_estimated && std::isfinite(goal_.relative_model) ? goal_.relative_model : 0.0;
  s.estimated_discretization_error = disc;
  s.estimated_model_error = bending_model + kinematics_model_error_ + s.estimated_clamp_layer_error;
  s.estimated_relative_error = disc + s.estimated_model_error;
  if (options_.verbose)
    std::printf("  mesh %d: %u dofs, estimated discretization error %.3e, model error %.3e\n", s.refinement_cycles,
                dof_handler_.n_dofs(), disc, s.estimated_model_error);
  if (s.estimated_relative_error <= options_.tolerance || s.refinement_cycles >= max_cycles) return true;
  if (2 * static_cast<std::size_t>(dof_handler_.n_dofs()) > options_.max_dofs) {
    dof_cap_reached_ = true;
    return true;
  }
  return false;
}

// Newton from the state refine_mesh transferred; from flat when that fails (with the condition's
// lagged passes again, solve_from_flat), and the reference path when the condition fails here.
NewtonOutcome FilmSolver::solve_on_refined_mesh(Model model, std::string& where) {
  Summary& s = summary_;
  NewtonOutcome o = clamp_layer_ ? solve_with_clamp_layer(model, solution_) : newton(model, 0.0, solution_);
  ++s.load_steps;
  s.newton_iterations += o.iterations;
  if (o.status == Status::converged) return o;
  o = solve_from_flat(model, solution_);
  if (o.status != Status::converged && clamp_layer_) {  // the condition failed here: the reference path
    clamp_reason_ += "; the condition did not converge on refinement cycle " + std::to_string(s.refinement_cycles + 1) +
                     " (" + o.message + "): bending kept, rim graded to l_b instead";
    o = leave_clamp_layer_for_graded_rim(model);
  }
  if (o.status != Status::converged) where = "refinement cycle " + std::to_string(s.refinement_cycles + 1);
  return o;
}

}  // namespace pvdf::fem::detail
