// Seed 001 §2.3 triangulation from eq. 6 fits, as a baseline.
#include "pvdf/mapping/triangulation.hpp"

#include "pvdf/core/error.hpp"

#include <Eigen/Dense>

#include <cmath>

namespace pvdf::mapping {

namespace {
constexpr double two_pi = 6.283185307179586;
}

Triangulation::Triangulation(const Locator& locator, const ChargeMap& map, const TriangulationOptions& options)
    : centers_(map.electrode_centers_m), options_(options) {
  if (!(options.ray_step_deg > 0) || !(options.min_distance_m > 0) || !(options.max_distance_m > options.min_distance_m) ||
      !(options.sample_step_m > 0) || !(options.reference_force_N > 0)) {
    throw InputError("triangulation options: need ray_step_deg > 0, 0 < min_distance_m < max_distance_m, sample_step_m > 0");
  }
  radius_m_ = std::min({-map.x_m.front(), map.x_m.back(), -map.y_m.front(), map.y_m.back()});
  p_ = locator.interpolant().force_exponent();
  const int n_rays = std::max(1, int(std::lround(360.0 / options.ray_step_deg)));
  std::array<double, max_electrodes> q{};
  rays_.resize(map.ne());
  for (std::size_t k = 0; k < map.ne(); ++k) {
    for (int r = 0; r < n_rays; ++r) {
      RayFit fit;
      fit.beta_rad = two_pi * r / n_rays;
      // Least squares of ln Q = ln C1 + C2 ln d over the samples along the ray.
      double s1 = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
      std::vector<std::array<double, 2>> samples;
      for (double d = options.min_distance_m; d <= options.max_distance_m + 1e-12; d += options.sample_step_m) {
        const double x = centers_[k][0] + d * std::cos(fit.beta_rad), y = centers_[k][1] + d * std::sin(fit.beta_rad);
        if (!locator.predict(x, y, options.reference_force_N, q.data()) || !(q[k] > 0)) continue;
        const double lx = std::log(d), ly = std::log(q[k]);
        samples.push_back({lx, ly});
        s1 += 1;
        sx += lx;
        sy += ly;
        sxx += lx * lx;
        sxy += lx * ly;
      }
      fit.n_samples = int(samples.size());
      if (fit.n_samples < 4) continue;
      const double det = s1 * sxx - sx * sx;
      if (!(det > 0)) continue;
      fit.C2 = (s1 * sxy - sx * sy) / det;
      fit.C1 = std::exp((sy - fit.C2 * sx) / s1);
      double e2 = 0;
      for (const auto& s : samples) {
        const double e = s[1] - (std::log(fit.C1) + fit.C2 * s[0]);
        e2 += e * e;
      }
      fit.rms_log_error = std::sqrt(e2 / s1);
      rays_[k].push_back(fit);
    }
    if (rays_[k].empty()) {
      throw InputError("triangulation: electrode " + map.electrode_names[k] +
                       " has no ray with 4 map samples between min and max distance; the map is too small");
    }
  }
}

double Triangulation::distance(std::size_t k, double beta, double q, double l) const {
  // Interpolate ln C1 and C2 linearly in β between the neighbouring fitted rays (periodic).
  const auto& rays = rays_[k];
  beta = std::fmod(beta, two_pi);
  if (beta < 0) beta += two_pi;
  std::size_t hi = 0;
  while (hi < rays.size() && rays[hi].beta_rad < beta) ++hi;
  const RayFit& b = rays[hi % rays.size()];
  const RayFit& a = rays[(hi + rays.size() - 1) % rays.size()];
  double span = b.beta_rad - a.beta_rad;
  double t = beta - a.beta_rad;
  if (span <= 0) span += two_pi;
  if (t < 0) t += two_pi;
  const double w = rays.size() == 1 ? 0.0 : std::clamp(t / span, 0.0, 1.0);
  const double lnC1 = (1 - w) * std::log(a.C1) + w * std::log(b.C1);
  const double C2 = (1 - w) * a.C2 + w * b.C2;
  // q = C1 d^C2 (F/F_ref)^p  →  d = (q / (C1 (F/F_ref)^p))^(1/C2)
  const double scaled = std::log(std::max(q, 1e-300)) - lnC1 - p_ * (l - std::log(options_.reference_force_N));
  return std::exp(scaled / C2);
}

Location Triangulation::solve(const double* q, bool fixed_force, double log_force) const {
  Location out;
  const std::size_t ne = centers_.size();
  for (std::size_t k = 0; k < ne; ++k) {
    if (!std::isfinite(q[k]) || !(q[k] > 0)) {
      out.flags = flag::outside_map;
      return out;
    }
  }
  // Start at the electrodes' centroid.
  Eigen::Vector3d u(0, 0, fixed_force ? log_force : std::log(options_.reference_force_N));
  for (const auto& c : centers_) {
    u[0] += c[0] / double(ne);
    u[1] += c[1] / double(ne);
  }
  auto residual = [&](const Eigen::Vector3d& v, Eigen::VectorXd& r) {
    r.resize(Eigen::Index(ne));
    for (std::size_t k = 0; k < ne; ++k) {
      const double dx = v[0] - centers_[k][0], dy = v[1] - centers_[k][1];
      r[Eigen::Index(k)] = std::hypot(dx, dy) - distance(k, std::atan2(dy, dx), q[k], v[2]);
    }
  };
  Eigen::VectorXd r, rp, rm;
  residual(u, r);
  double cost = r.squaredNorm(), lambda = 1e-3;
  int it = 0;
  bool converged = false;
  const int n_unknowns = fixed_force ? 2 : 3;
  for (; it < options_.max_iterations; ++it) {
    Eigen::MatrixXd J(Eigen::Index(ne), 3);
    J.setZero();
    for (int d = 0; d < n_unknowns; ++d) {
      const double h = d < 2 ? 1e-7 : 1e-6;
      Eigen::Vector3d a = u, b = u;
      a[d] += h;
      b[d] -= h;
      residual(a, rp);
      residual(b, rm);
      J.col(d) = (rp - rm) / (2 * h);
    }
    Eigen::Matrix3d A = J.transpose() * J;
    for (int d = 0; d < 3; ++d) A(d, d) = d < n_unknowns ? A(d, d) * (1 + lambda) + 1e-300 : 1.0;
    const Eigen::Vector3d step = A.ldlt().solve(-J.transpose() * r);
    const Eigen::Vector3d trial = u + step;
    Eigen::VectorXd rt;
    residual(trial, rt);
    if (step.allFinite() && rt.allFinite() && rt.squaredNorm() < cost) {
      u = trial;
      r = rt;
      const bool small = std::abs(step[0]) < 1e-9 && std::abs(step[1]) < 1e-9 && std::abs(step[2]) < 1e-9;
      cost = rt.squaredNorm();
      lambda = std::max(lambda * 0.2, 1e-9);
      if (small) {
        converged = true;
        break;
      }
    } else {
      lambda *= 10;
      if (lambda > 1e10) {
        converged = true;
        break;
      }
    }
  }
  out.iterations = it;
  out.n_starts = 1;
  out.n_solutions = 1;
  if (std::hypot(u[0], u[1]) > radius_m_ || !u.allFinite()) {
    out.flags = flag::outside_map;
    return out;
  }
  out.x_m = u[0];
  out.y_m = u[1];
  out.force_N = std::exp(u[2]);
  out.residual = std::sqrt(cost);  // metres: RMS distance mismatch of the circles
  if (!converged) out.flags |= flag::not_converged;
  return out;
}

Location Triangulation::locate(const double* charges_C) const { return solve(charges_C, false, 0.0); }

Location Triangulation::locate(const double* charges_C, double known_force_N) const {
  if (!(known_force_N > 0)) {
    Location out;
    out.flags = flag::outside_map;
    return out;
  }
  return solve(charges_C, true, std::log(known_force_N));
}

}  // namespace pvdf::mapping
