// The paper's triangulation (seed 001 §2.3, eq. 6) as a baseline for the lookup: per electrode
// and ray, fit Q = C1(β)·d^C2(β) to the map, turn each charge into a distance, and intersect
// the three circles in the least-squares sense.
#pragma once

#include "pvdf/core/membrane_scaling.hpp"
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/map.hpp"

#include <vector>

namespace pvdf::mapping {

struct TriangulationOptions {
  double ray_step_deg = 10.0;      ///< seed 001: rays every 10° about each electrode
  double min_distance_m = 0.002;   ///< fit from here (outside the 2 mm electrode) ...
  double max_distance_m = 0.030;   ///< ... to here (or the map's edge)
  double sample_step_m = 0.0005;   ///< spacing of the map samples along a ray
  double reference_force_N = 1.0;  ///< force of the fitted curves (seed 001: 1 N); others by F^(2/3)
  int max_iterations = 30;         ///< Gauss–Newton iterations of the circle intersection
};

/// Eq. 6 fitted along one ray: Q(d) = C1·d^C2 at the reference force.
struct RayFit {
  double beta_rad = 0;   ///< ray direction from the x axis (draw direction for draw_angle 0)
  double C1 = 0;         ///< C·m^-C2
  double C2 = 0;         ///< exponent (negative: charge falls with distance)
  double rms_log_error = 0;  ///< RMS of ln Q − fit over the samples (how well eq. 6 holds)
  int n_samples = 0;
};

/// Triangulation baseline. Locates with the same Location output as Locator (σ's are 0: the
/// method has no noise model; flags: outside_map when the circles do not meet inside the
/// film, not_converged).
class Triangulation {
 public:
  /// Fits the rays from the locator's (calibrated) map. Throws InputError if an electrode has
  /// no ray with at least 4 samples.
  Triangulation(const Locator& locator, const ChargeMap& map, const TriangulationOptions& options = {});

  /// Unknown force: solves for (x, y, F) from the distances d_k(q_k, F).
  Location locate(const double* charges_C) const;
  /// Known force (the paper's setting): solves for (x, y).
  Location locate(const double* charges_C, double known_force_N) const;

  /// rays()[k] are electrode k's fits, in order of β.
  const std::vector<std::vector<RayFit>>& rays() const { return rays_; }

 private:
  Location solve(const double* q, bool fixed_force, double log_force) const;
  /// Distance from electrode k for charge q at direction β and force exp(l) by eq. 6.
  double distance(std::size_t k, double beta, double q, double l) const;
  std::vector<std::vector<RayFit>> rays_;
  std::vector<std::array<double, 2>> centers_;
  TriangulationOptions options_;
  double radius_m_ = 0;
  double p_ = pvdf::membrane_charge_exponent;
};

}  // namespace pvdf::mapping
