// Fit a film's effective physics (pre-tension, stiffness scale, piezo constants, electrode
// gains) to bench measurements by Levenberg–Marquardt on FEM predictions, with 1-σ intervals,
// correlations and an identifiability verdict for every parameter.
#pragma once

#include "pvdf/core/scene.hpp"
#include "pvdf/fem/probe_sweep.hpp"
#include "pvdf/fit/measured.hpp"
#include "pvdf/fit/predictor.hpp"

#include <functional>
#include <map>
#include <string>
#include <vector>

namespace pvdf::fit {

/// Names of the parameters a scene offers: pretension_N_per_m, E_scale, d31_C_per_N,
/// d32_C_per_N, gain_<electrode> per electrode.
std::vector<std::string> parameter_names(const pvdf::Scene& scene);

/// The default parameter list for a measured table: E_scale when deflections are given,
/// d31_C_per_N when charges are given (docs/fem-vs-experiment.md §2).
std::vector<std::string> default_parameters(const MeasuredTable& measured);

/// Settings (public members with defaults).
struct FitOptions {
  std::vector<std::string> parameters;       ///< names to fit (empty = default_parameters)
  std::map<std::string, double> start;       ///< starting values (default: the scene's, E_scale 1, gains 1)
  PredictorOptions predictor;                ///< FEM settings
  int max_iterations = 40;                   ///< Levenberg–Marquardt iterations
  double function_tolerance = 1e-7;          ///< stop when the relative cost change is below this
  double parameter_tolerance = 1e-8;         ///< stop when the relative step is below this
  /// Column-scaled condition number of the Jacobian above which the fit is ill-conditioned.
  double condition_limit = 1e6;
  /// |correlation| above which two parameters cannot be told apart by the data.
  double correlation_limit = 0.999;
  /// Called with one line per Levenberg–Marquardt iteration (progress on stderr).
  std::function<void(const std::string&)> log;
};

/// Outcome. Stopping rules: `converged` = Ceres reported convergence (relative cost change,
/// gradient or step below tolerance) and every parameter is determined; `ill_conditioned` =
/// converged but some parameter is not determined by the data (see ParameterEstimate);
/// `no_convergence` = iteration cap reached; `failed` = the FEM or the minimizer failed.
enum class FitStatus { converged, ill_conditioned, no_convergence, failed };
/// "converged", "ill-conditioned", "no-convergence", "failed".
std::string status_name(FitStatus status);

struct ParameterEstimate {
  std::string name;
  double start = 0;
  double value = 0;
  double sigma = 0;          ///< 1-σ (delta method for E_scale, fitted as ln E_scale); NaN when not determined
  bool at_bound = false;     ///< ended on its bound (pretension 0): held fixed for the intervals
  bool determined = true;    ///< false: in a direction the data do not constrain (see warning)
  std::string warning;       ///< empty, or why the value is not (well) determined
};

/// One observed value (row × observed column).
struct ObservationResult {
  std::size_t row = 0, line = 0;
  std::string column;        ///< deflection_m or charge_<name>_C
  int electrode = -1;
  double measured = 0, sigma = 0;              ///< sigma used (given, or relative: |measured| × s)
  double predicted_start = 0, predicted = 0;   ///< at the start and at the fit
  double normalized_residual = 0;              ///< (predicted − measured) / sigma
};

struct FitResult {
  FitStatus status = FitStatus::failed;
  std::string message;                          ///< one line: why the status
  std::vector<ParameterEstimate> parameters;
  std::vector<std::vector<double>> correlation; ///< [n][n] over the fitted parameters (NaN rows for bound ones)
  double condition_number = 0;                  ///< of the column-scaled Jacobian at the fit (free parameters)
  bool sigmas_given = false;                    ///< false: covariance scaled by the reduced chi²
  double chi2_start = 0, chi2 = 0;              ///< Σ normalized residual² at the start and the fit
  int degrees_of_freedom = 0;                   ///< observations − free parameters
  double reduced_chi2 = 0;
  /// Without sigma columns: the relative uncertainty of one value the scatter implies (s).
  double relative_sigma_estimated = 0;
  int iterations = 0;
  std::vector<ObservationResult> observations;
  std::vector<std::string> warnings;            ///< every caveat, one line each
  pvdf::Scene fitted_scene;                     ///< the scene with the fitted values (gains are not scene keys)
  double pretension_N_per_m = 0, E_scale = 1, d31_C_per_N = 0, d32_C_per_N = 0;
  std::vector<double> gains;                    ///< [electrode]
  PredictorStats fem;                           ///< solves, sweeps, timing, FEM error estimate
  double wall_s = 0;
};

/// The rules a measured table must meet before a fit, checked before any solve: every press's
/// force in [1e-9, 1e4] N (the rule of loads[].force_N), every given 1-sigma at least 1e-6 of its
/// column's largest value (no bench measures to 1 ppm; a denormal sigma overflows the weighted
/// residuals). Throws pvdf::InputError naming `source`, the row or line, the value and the fix.
void check_measured_for_fit(const MeasuredTable& measured, const std::string& source);

/// Fits `options.parameters` to `measured`. Throws pvdf::InputError for an unknown parameter
/// name, a negative pre-tension start, fewer observations than parameters, or presses outside
/// the film. Numerical outcomes are the status.
FitResult fit_film(const pvdf::Scene& scene, const MeasuredTable& measured, const FitOptions& options = {});

/// Same on a prepared predictor (its presses must be the table's rows, in order): repeated fits
/// to data at the same presses reuse its mesh, model choice and warm starts.
FitResult fit_film(Predictor& predictor, const MeasuredTable& measured, const FitOptions& options = {});

/// The scene with the film parameters applied: stiffnesses × E_scale, pretension, d31, d32.
pvdf::Scene apply_parameters(const pvdf::Scene& scene, double pretension_N_per_m, double E_scale, double d31_C_per_N,
                             double d32_C_per_N);

}  // namespace pvdf::fit
