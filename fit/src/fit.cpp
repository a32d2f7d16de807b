// fit_film: Levenberg–Marquardt (Ceres) on FEM predictions. Only pretension and E_scale need
// FEM solves (Predictor, warm-started, derivatives by differences on the rescaled problem);
// the charges are linear in d31, d32 and the gains, whose derivatives are exact.
#include "pvdf/fit/fit.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/piezo.hpp"

#include <ceres/ceres.h>

#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>

namespace pvdf::fit {

namespace {

using Clock = std::chrono::steady_clock;
constexpr double pC = 1e-12;  // internal unit of d31, d32 (keeps the parameters near 1)

// The slackest film the fit tries: N0 = −E·h/10 with E = √(E1·E2), a natural strain of about 7 %
// (pretension of either sign is one parameter: negative = slack, docs/fem-vs-experiment.md).
double slack_bound_N_per_m(const pvdf::Scene& scene) {
  return -0.1 * std::sqrt(scene.material.E1_Pa * scene.material.E2_Pa) * scene.membrane.thickness_m;
}

enum class Kind { pretension, log_E, d31, d32, gain };

struct ParamSpec {
  std::string name;
  Kind kind;
  int electrode = -1;
};

/// Every film value, fitted or fixed.
struct Values {
  double T = 0, E = 1, d31 = 0, d32 = 0;
  std::vector<double> gains;
};

std::string fmt(double x, int precision = 4) {
  std::ostringstream os;
  os.precision(precision);
  os << x;
  return os.str();
}

std::string join(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ",") + x;
  return s;
}

/// The least-squares problem: residuals (predicted − measured)/σ of every observation.
class Problem {
 public:
  Problem(Predictor& predictor, const MeasuredTable& m, std::vector<ParamSpec> specs, Values fixed,
          std::vector<std::vector<double>> sigma)
      : predictor_(predictor), m_(m), specs_(std::move(specs)), fixed_(std::move(fixed)), sigma_(std::move(sigma)) {
    for (std::size_t i = 0; i < m_.n_rows(); ++i)
      for (std::size_t c = 0; c < m_.observed.size(); ++c)
        if (!std::isnan(m_.observed[c].value[i])) obs_.push_back({i, c});
    for (const auto& s : specs_) {
      if (s.kind == Kind::pretension) want_[0] = true;
      if (s.kind == Kind::log_E) want_[1] = true;
    }
  }

  std::size_t n_residuals() const { return obs_.size(); }
  /// (row, observed column) of residual r.
  std::pair<std::size_t, std::size_t> where(std::size_t r) const { return obs_[r]; }
  std::size_t n_params() const { return specs_.size(); }

  Values decode(const double* p) const {
    Values v = fixed_;
    for (std::size_t j = 0; j < specs_.size(); ++j) {
      switch (specs_[j].kind) {
        case Kind::pretension: v.T = p[j]; break;
        case Kind::log_E: v.E = std::exp(p[j]); break;
        case Kind::d31: v.d31 = p[j] * pC; break;
        case Kind::d32: v.d32 = p[j] * pC; break;
        case Kind::gain: v.gains[specs_[j].electrode] = p[j]; break;
      }
    }
    return v;
  }

  /// Predicted value of every (row, column) and, when `jac` is given, d/dp (row-major m × n).
  /// Throws pvdf::NumericalError from the FEM.
  std::vector<double> predict(const double* p, std::vector<double>* jac) {
    const Values v = decode(p);
    const bool need_d = jac != nullptr && (want_[0] || want_[1]);
    const auto& r = responses(v, need_d);
    const auto& areas = predictor_.electrode_areas_m2();
    const double h = predictor_.scene().membrane.thickness_m;
    const std::size_t n = specs_.size();
    std::vector<double> out(n_residuals());
    if (jac) jac->assign(n_residuals() * n, 0.0);
    for (std::size_t row = 0; row < obs_.size(); ++row) {
      const std::size_t i = obs_[row].first;
      {
        const ObservedColumn& col = m_.observed[obs_[row].second];
        if (col.electrode < 0) {
          out[row] = r[i].deflection_m;
          if (!jac) continue;
          for (std::size_t j = 0; j < n; ++j) {
            if (specs_[j].kind == Kind::pretension) (*jac)[row * n + j] = r[i].d_deflection[0];
            if (specs_[j].kind == Kind::log_E) (*jac)[row * n + j] = r[i].d_deflection[1] * v.E;
          }
          continue;
        }
        const int k = col.electrode;
        const double a = areas[k] / h, g = v.gains[k];
        const auto& b = r[i].force_basis_N_per_m[k];
        const double q_unit = pvdf::piezo_charge_C(areas[k], b[0], b[1], h, v.d31, v.d32);
        out[row] = g * q_unit;
        if (!jac) continue;
        for (std::size_t j = 0; j < n; ++j) {
          double d = 0;
          switch (specs_[j].kind) {
            case Kind::pretension: {
              const auto& db = r[i].d_force_basis[0][k];
              d = g * pvdf::piezo_charge_C(areas[k], db[0], db[1], h, v.d31, v.d32);
              break;
            }
            case Kind::log_E: {
              const auto& db = r[i].d_force_basis[1][k];
              d = g * pvdf::piezo_charge_C(areas[k], db[0], db[1], h, v.d31, v.d32) * v.E;
              break;
            }
            case Kind::d31: d = g * a * b[0] * pC; break;
            case Kind::d32: d = g * a * b[1] * pC; break;
            case Kind::gain: d = specs_[j].electrode == k ? q_unit : 0.0; break;
          }
          (*jac)[row * n + j] = d;
        }
      }
    }
    return out;
  }

  double sigma(std::size_t r) const { return sigma_[obs_[r].second][obs_[r].first]; }
  double measured(std::size_t r) const { return m_.observed[obs_[r].second].value[obs_[r].first]; }
  std::string last_error;

 private:
  /// FEM responses at (T, E), cached: LM asks for the same point twice (cost, then Jacobian).
  const std::vector<PressResponse>& responses(const Values& v, bool derivatives) {
    if (cache_valid_ && cache_T_ == v.T && cache_E_ == v.E && (cache_d_ || !derivatives)) return cache_;
    cache_ = predictor_.predict(FilmState{v.T, v.E}, {derivatives && want_[0], derivatives && want_[1]});
    cache_valid_ = true;
    cache_T_ = v.T;
    cache_E_ = v.E;
    cache_d_ = derivatives;
    return cache_;
  }

  Predictor& predictor_;
  const MeasuredTable& m_;
  std::vector<ParamSpec> specs_;
  Values fixed_;
  std::vector<std::vector<double>> sigma_;  ///< [column][row]
  std::vector<std::pair<std::size_t, std::size_t>> obs_;  ///< (row, column) of every measured value
  bool want_[2] = {false, false};
  bool cache_valid_ = false, cache_d_ = false;
  double cache_T_ = 0, cache_E_ = 0;
  std::vector<PressResponse> cache_;
};

class Cost : public ceres::CostFunction {
 public:
  explicit Cost(Problem& p) : p_(p) {
    set_num_residuals(static_cast<int>(p.n_residuals()));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(p.n_params()));
  }
  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    try {
      std::vector<double> jac;
      const bool want_jac = jacobians != nullptr && jacobians[0] != nullptr;
      const std::vector<double> pred = p_.predict(parameters[0], want_jac ? &jac : nullptr);
      const std::size_t n = p_.n_params();
      for (std::size_t r = 0; r < pred.size(); ++r) {
        const double s = p_.sigma(r);
        residuals[r] = (pred[r] - p_.measured(r)) / s;
        if (want_jac)
          for (std::size_t j = 0; j < n; ++j) jacobians[0][r * n + j] = jac[r * n + j] / s;
      }
      return true;
    } catch (const pvdf::NumericalError& e) {
      p_.last_error = e.what();
      return false;  // the minimizer shrinks its step
    }
  }

 private:
  Problem& p_;
};

class IterationLog : public ceres::IterationCallback {
 public:
  IterationLog(const std::function<void(const std::string&)>& log, Predictor& predictor, Clock::time_point t0)
      : log_(log), predictor_(predictor), t0_(t0) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (log_) {
      std::ostringstream os;
      os << "fit: iteration " << s.iteration << "  chi2 " << fmt(2 * s.cost, 6) << "  step "
         << (s.step_is_successful ? "accepted" : "rejected") << "  " << predictor_.stats().n_solves << " FEM solves, "
         << fmt(std::chrono::duration<double>(Clock::now() - t0_).count(), 3) << " s";
      log_(os.str());
    }
    return ceres::SOLVER_CONTINUE;
  }

 private:
  const std::function<void(const std::string&)>& log_;
  Predictor& predictor_;
  Clock::time_point t0_;
};

}  // namespace

std::string status_name(FitStatus status) {
  switch (status) {
    case FitStatus::converged: return "converged";
    case FitStatus::ill_conditioned: return "ill-conditioned";
    case FitStatus::no_convergence: return "no-convergence";
    case FitStatus::failed: return "failed";
  }
  return "unknown";
}

std::vector<std::string> parameter_names(const pvdf::Scene& scene) {
  std::vector<std::string> names{"pretension_N_per_m", "E_scale", "d31_C_per_N", "d32_C_per_N"};
  for (const auto& e : scene.electrodes) names.push_back("gain_" + e.name);
  return names;
}

std::vector<std::string> default_parameters(const MeasuredTable& measured) {
  bool deflection = false, charge = false;
  for (const auto& c : measured.observed) (c.electrode < 0 ? deflection : charge) = true;
  std::vector<std::string> p;
  if (deflection) p.push_back("E_scale");
  if (charge) p.push_back("d31_C_per_N");
  return p;
}

pvdf::Scene apply_parameters(const pvdf::Scene& scene, double T, double E, double d31, double d32) {
  pvdf::Scene s = scene;
  s.membrane.pretension_N_per_m = T;
  s.material.E1_Pa *= E;
  s.material.E2_Pa *= E;
  s.material.G12_Pa *= E;
  s.material.d31_C_per_N = d31;
  s.material.d32_C_per_N = d32;
  return s;
}

namespace {

/// Column-scaled covariance analysis of the free parameters at the fit.
struct Covariance {
  Eigen::MatrixXd cov;        ///< internal parameters (free ones), scaled by the reduced chi² when needed
  double condition = 0;
  Eigen::MatrixXd V;          ///< right singular vectors of the scaled Jacobian
  Eigen::VectorXd s;          ///< singular values, descending
};

Covariance analyse(const Eigen::MatrixXd& J, double scale) {
  Covariance c;
  const Eigen::Index n = J.cols();
  Eigen::VectorXd d(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const double norm = J.col(j).norm();
    d(j) = norm > 0 ? 1.0 / norm : 1.0;
  }
  const Eigen::MatrixXd Js = J * d.asDiagonal();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(Js, Eigen::ComputeThinV);
  c.s = svd.singularValues();
  c.V = svd.matrixV();
  c.condition = c.s(n - 1) > 0 ? c.s(0) / c.s(n - 1) : std::numeric_limits<double>::infinity();
  Eigen::VectorXd inv2(n);
  for (Eigen::Index j = 0; j < n; ++j) inv2(j) = c.s(j) > 0 ? 1.0 / (c.s(j) * c.s(j)) : std::numeric_limits<double>::infinity();
  c.cov = d.asDiagonal() * c.V * inv2.asDiagonal() * c.V.transpose() * d.asDiagonal() * scale;
  return c;
}

}  // namespace

namespace {

/// Validated parameters, starting values and uncertainties of a fit.
struct Prepared {
  std::vector<ParamSpec> specs;
  Values start;
  std::vector<std::vector<double>> sigma;
  std::size_t m = 0;
  bool sigmas_given = false;
};

Prepared prepare(const pvdf::Scene& scene, const MeasuredTable& measured, const FitOptions& options) {
  Prepared res;
  std::vector<ParamSpec>& specs = res.specs;
  Values& start = res.start;
  std::vector<std::vector<double>>& sigma = res.sigma;
  const std::vector<std::string> known = parameter_names(scene);
  std::vector<std::string> names = options.parameters.empty() ? default_parameters(measured) : options.parameters;

  // 1. Parameters and starting values.
  for (const auto& n : names) {
    if (std::find(known.begin(), known.end(), n) == known.end()) {
      throw pvdf::InputError("fit: parameter '" + n + "' (FitOptions::parameters) is not a parameter of this scene; choose from " + join(known));
    }
    for (const auto& s : specs)
      if (s.name == n) throw pvdf::InputError("fit: parameter '" + n + "' is listed twice (FitOptions::parameters); list each parameter once");
    ParamSpec s{n, Kind::gain, -1};
    if (n == "pretension_N_per_m") s.kind = Kind::pretension;
    else if (n == "E_scale") s.kind = Kind::log_E;
    else if (n == "d31_C_per_N") s.kind = Kind::d31;
    else if (n == "d32_C_per_N") s.kind = Kind::d32;
    else s.electrode = static_cast<int>(std::find(known.begin() + 4, known.end(), n) - (known.begin() + 4));
    specs.push_back(s);
  }
  start.T = scene.membrane.pretension_N_per_m;
  start.d31 = scene.material.d31_C_per_N;
  start.d32 = scene.material.d32_C_per_N;
  start.gains.assign(scene.electrodes.size(), 1.0);
  for (const auto& [n, value] : options.start) {
    if (std::find(known.begin(), known.end(), n) == known.end()) {
      throw pvdf::InputError("fit: starting value of '" + n + "' (FitOptions::start): not a parameter of this scene; choose from " + join(known));
    }
    if (!std::isfinite(value)) throw pvdf::InputError("fit: starting value " + n + " = " + fmt(value) + " must be finite (FitOptions::start)");
    if (n == "pretension_N_per_m") {
      if (value < slack_bound_N_per_m(scene)) {
        throw pvdf::InputError("fit: starting value pretension_N_per_m = " + fmt(value) + " is slacker than the fit allows (" +
                               fmt(slack_bound_N_per_m(scene)) + " N/m, a slack strain of about 7 %); give a larger value");
      }
      start.T = value;
    } else if (n == "E_scale") {
      if (!(value > 0)) throw pvdf::InputError("fit: starting value E_scale = " + fmt(value) + " must be > 0 (FitOptions::start)");
      start.E = value;
    } else if (n == "d31_C_per_N") start.d31 = value;
    else if (n == "d32_C_per_N") start.d32 = value;
    else start.gains[std::find(known.begin() + 4, known.end(), n) - (known.begin() + 4)] = value;
  }
  std::size_t& m = res.m;
  for (const auto& c : measured.observed)
    for (double x : c.value) m += std::isnan(x) ? 0 : 1;
  const std::size_t n = specs.size();
  res.sigmas_given = measured.sigmas_given();
  if (n == 0) throw pvdf::InputError("fit: no parameter to fit (FitOptions::parameters); name at least one of " + join(known));
  if (m < n + (res.sigmas_given ? 0 : 1)) {
    throw pvdf::InputError(measured.source + ": " + std::to_string(m) + " observed values cannot determine " +
                           std::to_string(n) + " parameters" + (res.sigmas_given ? "" : " and their scatter") +
                           "; add presses or fit fewer parameters");
  }

  // 2. Uncertainties: given, or one relative uncertainty s estimated from the scatter (σ = s·|value|).
  for (const auto& c : measured.observed) {
    if (c.has_sigma) {
      sigma.push_back(c.sigma);
      continue;
    }
    double scale = 0;
    for (double v : c.value)
      if (!std::isnan(v)) scale = std::max(scale, std::abs(v));
    if (!(scale > 0)) throw pvdf::InputError(measured.source + ": column " + c.name + " is zero everywhere; nothing to fit");
    std::vector<double> s;
    for (double v : c.value) s.push_back(std::max(std::abs(v), 1e-3 * scale));
    sigma.push_back(s);
  }
  return res;
}

/// Covariance, correlations and the identifiability verdict of the free parameters (§2 of
/// docs/fem-vs-experiment.md): fills res.correlation and res.condition_number.
struct Identifiability {
  std::vector<double> sigma_internal;  ///< [n] 1-σ of the internal parameters (NaN for bound ones)
  std::vector<bool> determined;        ///< [n]
  std::vector<std::string> why;        ///< [n] reason when not determined
  bool ill = false;
};

Identifiability identify(const Eigen::MatrixXd& J, const std::vector<Eigen::Index>& free, double cov_scale,
                         const std::vector<ParamSpec>& specs, const FitOptions& options, FitResult& res) {
  const std::size_t n = specs.size();
  res.correlation.assign(n, std::vector<double>(n, std::numeric_limits<double>::quiet_NaN()));
  Identifiability out;
  std::vector<double>& sigma_internal = out.sigma_internal;
  std::vector<bool>& determined = out.determined;
  std::vector<std::string>& why = out.why;
  sigma_internal.assign(n, std::numeric_limits<double>::quiet_NaN());
  determined.assign(n, true);
  why.assign(n, "");
  if (!free.empty()) {
    Eigen::MatrixXd Jf(J.rows(), static_cast<Eigen::Index>(free.size()));
    for (std::size_t a = 0; a < free.size(); ++a) Jf.col(static_cast<Eigen::Index>(a)) = J.col(free[a]);
    const Covariance c = analyse(Jf, cov_scale);
    res.condition_number = c.condition;
    const Eigen::Index nf = static_cast<Eigen::Index>(free.size());
    for (Eigen::Index a = 0; a < nf; ++a) {
      sigma_internal[free[a]] = std::sqrt(c.cov(a, a));
      for (Eigen::Index b = 0; b < nf; ++b)
        res.correlation[free[a]][free[b]] = c.cov(a, b) / std::sqrt(c.cov(a, a) * c.cov(b, b));
    }
    // A parameter is not determined when it takes part (component > 0.1) in a direction the data
    // resolve condition_limit times worse than the best one, or when it is correlated beyond
    // correlation_limit with another: the data then fix only a combination of the two.
    for (Eigen::Index k = 0; k < nf; ++k) {
      if (!(c.s(k) * options.condition_limit < c.s(0))) continue;
      for (Eigen::Index a = 0; a < nf; ++a) {
        if (std::abs(c.V(a, k)) > 0.1 && determined[free[a]]) {
          determined[free[a]] = false;
          why[free[a]] = "the data fix only a combination of parameters here (column-scaled condition number " +
                         fmt(c.condition, 3) + " > " + fmt(options.condition_limit, 3) + ")";
        }
      }
    }
    for (Eigen::Index a = 0; a < nf; ++a) {
      for (Eigen::Index b = 0; b < nf; ++b) {
        const double r = res.correlation[free[a]][free[b]];
        if (a != b && std::abs(r) > options.correlation_limit) {
          determined[free[a]] = false;
          if (why[free[a]].empty() || why[free[a]].rfind("the data fix", 0) == 0) {
            why[free[a]] = "indistinguishable from " + specs[free[b]].name + " (correlation " + fmt(r, 6) +
                           ", column-scaled condition number " + fmt(c.condition, 3) + ")";
          }
        }
      }
    }
    for (std::size_t j = 0; j < n; ++j) out.ill = out.ill || !determined[j];
  }

  return out;
}

}  // namespace

void check_measured_for_fit(const MeasuredTable& m, const std::string& source) {
  for (std::size_t i = 0; i < m.force_N.size(); ++i) {
    // The rule of loads[].force_N: a press of 1e-300 N would "fit" with a prediction of zero.
    const double f = m.force_N[i];
    if (!(f >= 1e-9 && f <= 1e4)) {
      throw InputError(source + ": press " + std::to_string(i + 1) + ": force_N = " + pvdf::format_g(f) +
                       " must lie in [1e-9, 1e4] N (the rule of loads[].force_N); fix or remove the row");
    }
  }
  for (const auto& column : m.observed) {
    // A 1-sigma finer than 1 ppm of the column's scale is no bench measurement, and a denormal one
    // (1e-320) overflows the weighted residuals inside the solver.
    if (!column.has_sigma) continue;
    double scale = 0;
    for (const double v : column.value) scale = std::max(scale, std::abs(v));
    for (std::size_t i = 0; i < column.sigma.size(); ++i) {
      if (i < column.value.size() && std::isnan(column.value[i])) continue;  // not observed in this row
      if (!(column.sigma[i] >= 1e-6 * scale) || !(column.sigma[i] >= 1e-300)) {
        throw InputError(source + ":" + std::to_string(m.line[i]) + ": sigma_" + column.name + " = " +
                         pvdf::format_g(column.sigma[i]) + " is below 1e-6 of the column's largest value (" +
                         pvdf::format_g(scale) + "): no bench measures to 1 ppm; give the real 1-sigma");
      }
    }
  }
}

FitResult fit_film(const pvdf::Scene& scene, const MeasuredTable& measured, const FitOptions& options) {
  prepare(scene, measured, options);  // bad names and values fail before any FEM work
  std::vector<Press> presses;
  for (std::size_t i = 0; i < measured.n_rows(); ++i) presses.push_back({measured.x_m[i], measured.y_m[i], measured.force_N[i]});
  for (std::size_t i = 0; i < presses.size(); ++i) {
    const double margin = scene.probe.radius_m;
    if (!scene.membrane.outline.contains({presses[i].x_m, presses[i].y_m}, margin)) {
      throw pvdf::InputError(measured.source + ":" + std::to_string(measured.line[i]) + ": press (" +
                             fmt(presses[i].x_m) + ", " + fmt(presses[i].y_m) +
                             ") m is not inside the film at least a probe radius from the rim; fix or remove the row");
    }
  }
  Predictor predictor(scene, presses, options.predictor);
  return fit_film(predictor, measured, options);
}

namespace {

/// The internal parameter vector at the starting values (ln E, d in pC/N).
std::vector<double> initial_parameters(const std::vector<ParamSpec>& specs, const Values& start) {
  const std::size_t n = specs.size();
  std::vector<double> p(n);
  for (std::size_t j = 0; j < n; ++j) {
    switch (specs[j].kind) {
      case Kind::pretension: p[j] = start.T; break;
      case Kind::log_E: p[j] = std::log(start.E); break;
      case Kind::d31: p[j] = start.d31 / pC; break;
      case Kind::d32: p[j] = start.d32 / pC; break;
      case Kind::gain: p[j] = start.gains[specs[j].electrode]; break;
    }
  }
  return p;
}

/// Step 4: Levenberg–Marquardt from `p` (updated in place), with the pretension above the slack
/// bound and E within 1e-4..1e4 of the scene's.
ceres::Solver::Summary minimize(Problem& problem, std::vector<double>& p, const std::vector<ParamSpec>& specs,
                                const pvdf::Scene& scene, const FitOptions& options, Predictor& predictor,
                                Clock::time_point t0) {
  const std::size_t n = specs.size();
  ceres::Problem cp;
  cp.AddResidualBlock(new Cost(problem), nullptr, p.data());
  for (std::size_t j = 0; j < n; ++j) {
    if (specs[j].kind == Kind::pretension)
      cp.SetParameterLowerBound(p.data(), static_cast<int>(j), slack_bound_N_per_m(scene));
    if (specs[j].kind == Kind::log_E) {
      cp.SetParameterLowerBound(p.data(), static_cast<int>(j), std::log(1e-4));
      cp.SetParameterUpperBound(p.data(), static_cast<int>(j), std::log(1e4));
    }
  }
  ceres::Solver::Options so;
  so.minimizer_type = ceres::TRUST_REGION;
  so.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = options.function_tolerance;
  so.parameter_tolerance = options.parameter_tolerance;
  so.gradient_tolerance = 1e-12;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  so.num_threads = 1;
  IterationLog log(options.log, predictor, t0);
  so.callbacks.push_back(&log);
  ceres::Solver::Summary summary;
  ceres::Solve(so, &cp, &summary);
  return summary;
}

/// Step 6: the estimates in external units, with a warning for each undetermined, bounded or
/// weakly determined one.
void add_estimates(const std::vector<ParamSpec>& specs, const std::vector<bool>& at_bound, const Identifiability& id,
                   const Values& v, const Values& v0, FitResult& res) {
  const std::size_t n = specs.size();
  const std::vector<double>& sigma_internal = id.sigma_internal;
  const std::vector<bool>& determined = id.determined;
  const std::vector<std::string>& why = id.why;
  for (std::size_t j = 0; j < n; ++j) {
    ParameterEstimate e;
    e.name = specs[j].name;
    e.at_bound = at_bound[j];
    e.determined = determined[j];
    const double si = sigma_internal[j];
    switch (specs[j].kind) {
      case Kind::pretension: e.start = v0.T; e.value = v.T; e.sigma = si; break;
      case Kind::log_E: e.start = v0.E; e.value = v.E; e.sigma = v.E * si; break;
      case Kind::d31: e.start = v0.d31; e.value = v.d31; e.sigma = si * pC; break;
      case Kind::d32: e.start = v0.d32; e.value = v.d32; e.sigma = si * pC; break;
      case Kind::gain: e.start = v0.gains[specs[j].electrode]; e.value = v.gains[specs[j].electrode]; e.sigma = si; break;
    }
    if (!determined[j]) {
      e.warning = e.name + " is not determined by these data: " + why[j];
      e.sigma = std::numeric_limits<double>::quiet_NaN();
    } else if (e.at_bound) {
      e.warning = e.name + " ended on its bound (" + fmt(e.value) +
                  "): the data push it beyond what the model allows; held there for the other intervals" +
                  (specs[j].kind == Kind::pretension ? " (a slack strain of about 7 %: check the film, or fit E_scale too)" : "");
    } else if (e.value != 0 && e.sigma > 0.5 * std::abs(e.value)) {
      e.warning = e.name + " is weakly determined: 1-sigma " + fmt(e.sigma, 3) + " is " +
                  fmt(100 * e.sigma / std::abs(e.value), 3) + " % of its value";
    }
    if (!e.warning.empty()) res.warnings.push_back(e.warning);
    res.parameters.push_back(e);
  }
}

/// Step 7: every observation with its starting and fitted prediction and normalized residual.
void add_observations(const Problem& problem, const MeasuredTable& measured, const std::vector<double>& pred_start,
                      const std::vector<double>& pred, FitResult& res) {
  for (std::size_t r = 0; r < pred.size(); ++r) {    ObservationResult o;
    o.row = problem.where(r).first;
    o.line = measured.line[o.row];
    o.column = measured.observed[problem.where(r).second].name;
    o.electrode = measured.observed[problem.where(r).second].electrode;
    o.measured = problem.measured(r);
    o.sigma = problem.sigma(r) * (res.sigmas_given ? 1.0 : res.relative_sigma_estimated);
    o.predicted_start = pred_start[r];
    o.predicted = pred[r];
    o.normalized_residual = (pred[r] - o.measured) / o.sigma;
    res.observations.push_back(o);
  }
}

/// Step 8: the status from the minimizer's termination and the identifiability.
void set_status(const ceres::Solver::Summary& summary, const Problem& problem, bool ill, FitResult& res) {
  const bool converged = summary.termination_type == ceres::CONVERGENCE;
  if (summary.termination_type == ceres::FAILURE || !summary.IsSolutionUsable()) {
    res.status = FitStatus::failed;
    res.message = "the minimizer failed: " + summary.message + (problem.last_error.empty() ? "" : "; last FEM error: " + problem.last_error);
  } else if (!converged) {
    res.status = FitStatus::no_convergence;
    res.message = "no convergence after " + std::to_string(res.iterations) + " iterations (" + summary.message +
                  "); allow more iterations or start nearer the solution";
  } else if (ill) {
    res.status = FitStatus::ill_conditioned;
    std::string which;
    for (const auto& e : res.parameters)
      if (!e.determined) which += (which.empty() ? "" : ", ") + e.name;
    res.message = "the data do not determine " + which + " (column-scaled condition number " +
                  fmt(res.condition_number, 3) + "); fit fewer parameters or add data that separate them";
  } else {
    res.status = FitStatus::converged;
    res.message = "converged after " + std::to_string(res.iterations) + " iterations: " + summary.message;
  }
}

}  // namespace

FitResult fit_film(Predictor& predictor, const MeasuredTable& measured, const FitOptions& options) {
  const auto t0 = Clock::now();
  FitResult res;
  const pvdf::Scene& scene = predictor.scene();
  if (predictor.presses().size() != measured.n_rows()) {
    throw pvdf::InputError("fit: the predictor serves " + std::to_string(predictor.presses().size()) +
                           " presses, the measured table has " + std::to_string(measured.n_rows()));
  }
  Prepared prep = prepare(scene, measured, options);
  const std::vector<ParamSpec>& specs = prep.specs;
  const Values& start = prep.start;
  const std::size_t m = prep.m, n = specs.size();
  res.sigmas_given = prep.sigmas_given;
  Problem problem(predictor, measured, specs, start, prep.sigma);

  std::vector<double> p = initial_parameters(specs, start);
  const std::vector<double> p_start = p;
  std::vector<double> pred_start;
  try {
    pred_start = problem.predict(p.data(), nullptr);
  } catch (const pvdf::NumericalError& e) {
    res.status = FitStatus::failed;
    res.message = std::string("the FEM failed at the starting values: ") + e.what();
    res.fem = predictor.stats();
    return res;
  }

  // 4. Levenberg–Marquardt.
  const ceres::Solver::Summary summary = minimize(problem, p, specs, scene, options, predictor, t0);
  res.iterations = static_cast<int>(summary.iterations.size()) - 1;

  // 5. Jacobian at the fit, covariance, identifiability.
  std::vector<double> pred, jac;
  try {
    pred = problem.predict(p.data(), &jac);
  } catch (const pvdf::NumericalError& e) {
    res.status = FitStatus::failed;
    res.message = std::string("the FEM failed at the fitted values: ") + e.what();
    res.fem = predictor.stats();
    return res;
  }
  Eigen::MatrixXd J(m, n);
  for (std::size_t r = 0; r < m; ++r)
    for (std::size_t j = 0; j < n; ++j) J(r, j) = jac[r * n + j] / problem.sigma(r);
  double chi2 = 0, chi2_start = 0;
  for (std::size_t r = 0; r < m; ++r) {
    chi2 += std::pow((pred[r] - problem.measured(r)) / problem.sigma(r), 2);
    chi2_start += std::pow((pred_start[r] - problem.measured(r)) / problem.sigma(r), 2);
  }
  std::vector<bool> at_bound(n, false);
  std::vector<Eigen::Index> free;
  for (std::size_t j = 0; j < n; ++j) {
    at_bound[j] = (specs[j].kind == Kind::pretension && p[j] <= slack_bound_N_per_m(scene) * (1 - 1e-9)) ||
                  (specs[j].kind == Kind::log_E && (p[j] <= std::log(1e-4) + 1e-12 || p[j] >= std::log(1e4) - 1e-12));
    if (!at_bound[j]) free.push_back(static_cast<Eigen::Index>(j));
  }
  res.degrees_of_freedom = static_cast<int>(m) - static_cast<int>(free.size());
  res.chi2 = chi2;
  res.chi2_start = chi2_start;
  res.reduced_chi2 = res.degrees_of_freedom > 0 ? chi2 / res.degrees_of_freedom : std::numeric_limits<double>::quiet_NaN();
  const double cov_scale = res.sigmas_given ? 1.0 : res.reduced_chi2;
  if (!res.sigmas_given) res.relative_sigma_estimated = std::sqrt(res.reduced_chi2);

  const Values v = problem.decode(p.data());
  res.pretension_N_per_m = v.T;
  res.E_scale = v.E;
  res.d31_C_per_N = v.d31;
  res.d32_C_per_N = v.d32;
  res.gains = v.gains;
  res.fitted_scene = apply_parameters(scene, v.T, v.E, v.d31, v.d32);
  const Values v0 = problem.decode(p_start.data());

  Identifiability id = identify(J, free, cov_scale, specs, options, res);
  const bool ill = id.ill;

  // 6. Estimates in external units.
  add_estimates(specs, at_bound, id, v, v0, res);
  if (!res.sigmas_given) {
    res.warnings.push_back("no sigma columns: every value was given the same relative uncertainty, estimated from the "
                           "scatter as " + fmt(100 * res.relative_sigma_estimated, 3) +
                           " %; the intervals are scaled by the reduced chi-square (" + fmt(res.reduced_chi2, 4) + ")");
  } else if (res.degrees_of_freedom > 0 && res.reduced_chi2 > 3) {
    res.warnings.push_back("reduced chi-square " + fmt(res.reduced_chi2, 4) +
                           " >> 1: the model does not explain the data within their sigmas; the intervals assume it does");
  }
  const double fem_err = predictor.stats().reference_setup.estimated_relative_error;
  res.fem = predictor.stats();
  if (fem_err >= 0.01) {
    res.warnings.push_back("the FEM charges carry an estimated relative error of " + fmt(100 * fem_err, 3) +
                           " %, not included in the intervals; tighten the FEM tolerance if the data are that precise");
  }

  // 7. Observations.
  add_observations(problem, measured, pred_start, pred, res);

  // 8. Status.
  set_status(summary, problem, ill, res);
  res.wall_s = std::chrono::duration<double>(Clock::now() - t0).count();
  return res;
}

}  // namespace pvdf::fit
