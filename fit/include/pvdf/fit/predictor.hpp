// FEM predictions of a bench measurement (deflection under the probe, electrode charges) as
// functions of the film's effective parameters, with their derivatives, on one prepared mesh.
#pragma once

#include "pvdf/core/scene.hpp"
#include "pvdf/fem/probe_sweep.hpp"

#include <array>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace pvdf::fit {

/// One press of the probe: centre (m) and vertical force (N, > 0).
struct Press {
  double x_m = 0, y_m = 0, force_N = 0;
};

/// The mechanical state variables the FEM has to be solved for. Every stiffness of the film
/// (membrane and bending) is multiplied by `E_scale`; `pretension_N_per_m` is the isotropic
/// pre-tension N0 (>= 0).
struct FilmState {
  double pretension_N_per_m = 0;
  double E_scale = 1;
};

/// The FEM response of one press at one FilmState, with derivatives with respect to the two
/// state variables (filled when requested).
///
/// `force_basis_N_per_m[k]` = [∫N11 dA, ∫N22 dA] / area_k over electrode k: the mean membrane
/// force in material axes caused by the press (the pre-tension's own, static part removed: a
/// charge amplifier sees only the change). Electrode k's charge is then
///   Q_k = gain_k · area_k / h · (d31 · basis[k][0] + d32 · basis[k][1]),
/// linear in d31, d32 and the gains, so those need no FEM solves.
struct PressResponse {
  double deflection_m = 0;                                     ///< w at the probe centre
  std::vector<std::array<double, 2>> force_basis_N_per_m;      ///< [electrode][11, 22]
  /// d/d(pretension_N_per_m) and d/d(E_scale) of the above (same shapes); empty unless asked.
  double d_deflection[2] = {0, 0};
  std::vector<std::array<double, 2>> d_force_basis[2];
};

/// Settings of the predictor.
struct PredictorOptions {
  /// FEM settings of the sweep mesh (model, tolerance...). Default: the scene's model section.
  /// `sweep.solver.tension_field_residual_stiffness` (ε, in [0, 1)) is the tension-field residual
  /// stiffness of slack films (docs/fem.md §3.3); ε > 0 also keeps bending (large-rotation kinematics
  /// when the scene's are `auto`): the combination on which strongly slack films converge.
  fem::SweepOptions sweep;
  bool use_scene_model = true;          ///< take model/tolerance from the scene's `model` section
  /// Relative step of the force finite difference and of a pretension difference (scaled by
  /// max(N0, pretension_floor_N_per_m)).
  double relative_step = 1e-4;
  double pretension_floor_N_per_m = 1.0;
  /// Called after every FEM solve with (solves done, solves planned in this batch); never from
  /// two threads at once.
  std::function<void(std::size_t, std::size_t)> progress;
  /// Split the presses between two worker threads (each with its own sweeps) when the machine
  /// has more than one core.
  bool parallel = true;
};

/// What the predictor measured about its own accuracy and cost.
struct PredictorStats {
  std::size_t n_solves = 0;             ///< probe solves so far (all sweeps)
  std::size_t n_sweeps = 0;             ///< sweep meshes prepared (one per distinct N0/E_scale ratio and worker thread)
  double setup_s = 0, solve_s = 0;      ///< time in sweep setups and in probe solves (summed over threads)
  fem::SweepSetup reference_setup;      ///< model, mesh and charge-error estimate of the first sweep
  double residual_stiffness = 0;        ///< ε of the tension-field law the sweeps use
};

/// FEM predictions for a fixed list of presses, for any FilmState.
///
/// Exact rescaling used (verified in tests/fit): the residual of the film equations is linear
/// in (E_scale, N0, F) — membrane and bending stresses are proportional to E_scale at a given
/// displacement, the pre-tension and the load enter linearly — so the displacement under
/// (E_scale, N0, F) equals the one under (1, N0/E_scale, F/E_scale), and the membrane forces
/// are E_scale times those (also with the residual stiffness ε·C, which scales with E_scale). All solves therefore run on sweeps of the scene's own material,
/// one per value of N0/E_scale (the same mesh each, so warm starts carry over between them).
/// With N0 = 0 a change of E_scale is a change of force on one sweep.
class Predictor {
 public:
  /// Prepares the reference sweep (model, mesh, error check) for the scene and these presses.
  /// Throws pvdf::InputError for presses outside the served region.
  Predictor(const pvdf::Scene& scene, std::vector<Press> presses, const PredictorOptions& options = {});
  ~Predictor();
  Predictor(const Predictor&) = delete;
  Predictor& operator=(const Predictor&) = delete;

  /// Responses of every press. `derivatives[0]` asks for d/dN0, `derivatives[1]` for d/dE_scale.
  /// Throws pvdf::NumericalError (naming the press) when a solve does not converge.
  std::vector<PressResponse> predict(const FilmState& state, std::array<bool, 2> derivatives = {false, false});

  const std::vector<Press>& presses() const;
  const pvdf::Scene& scene() const;
  /// Electrode areas (m²) as the solver integrates charges, scene order.
  const std::vector<double>& electrode_areas_m2() const;
  PredictorStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Charges (C) of one response for given piezo constants and gains (scene electrode order).
std::vector<double> charges_C(const PressResponse& response, const std::vector<double>& areas_m2, double thickness_m,
                              double d31_C_per_N, double d32_C_per_N, const std::vector<double>& gains);

}  // namespace pvdf::fit
