// Shared by the FEM accuracy tests: isotropic centred-probe scenes that the axisymmetric oracle
// (tests/fem/oracles) describes exactly, the oracle problem of such a scene, FEM samples along a ray,
// and the acceptance rule used throughout: on the finer of two nested meshes (one uniform refinement
// apart) the error against the oracle must not exceed twice the change of the FEM answer between
// the two meshes, or a small floor for the oracle's own accuracy (~1e-6) and the Newton tolerance.
// For a method converging with order p in its asymptotic range the fine-mesh error is the change
// divided by 2^p − 1 (≤ the change for p ≥ 1); the factor 2 admits pre-asymptotic meshes down to an
// observed order of ~0.6. A wrong model converges to the wrong answer, and then the error exceeds
// the (small) mesh change: that is what the rule catches. Nothing here is tuned to a measured result.
#pragma once

#include "pvdf/fem/solver.hpp"

#include "axisymmetric_plate.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace pvdf::fem::testing {

/// An isotropic circular film (no electrodes) with one centred probe of force F, radius c.
inline pvdf::Scene centred_probe_scene(double radius_m, double thickness_m, double E_Pa, double nu, double force_N,
                                       double probe_radius_m, double pretension_N_per_m = 0.0) {
  pvdf::Scene s = pvdf::default_scene();
  s.source = "oracle comparison";
  s.membrane.outline.shape = pvdf::FilmOutline::Shape::circle;
  s.membrane.outline.radius_m = radius_m;
  s.membrane.thickness_m = thickness_m;
  s.membrane.pretension_N_per_m = pretension_N_per_m;
  s.material.isotropic = true;
  s.material.E1_Pa = s.material.E2_Pa = E_Pa;
  s.material.nu12 = nu;
  s.material.G12_Pa = E_Pa / (2 * (1 + nu));
  s.material.draw_angle_rad = 0;
  s.electrodes.clear();
  s.probe.radius_m = probe_radius_m;
  pvdf::Load l;
  l.kind = pvdf::Load::Kind::probe;
  l.position_m = {0, 0};
  l.force_N = force_N;
  s.loads = {l};
  return s;
}

/// The oracle problem of a centred_probe_scene.
inline oracles::AxisymmetricProblem oracle_problem(const pvdf::Scene& s, bool bending, oracles::Kinematics k) {
  oracles::AxisymmetricProblem p;
  p.radius_m = s.membrane.outline.radius_m;
  p.thickness_m = s.membrane.thickness_m;
  p.youngs_modulus_Pa = s.material.E1_Pa;
  p.poisson_ratio = s.material.nu12;
  p.force_N = s.loads.at(0).force_N;
  p.load_radius_m = s.probe.radius_m;
  p.pretension_N_per_m = s.membrane.pretension_N_per_m;
  p.bending = bending;
  p.kinematics = k;
  return p;
}

/// Direction of the sampling ray: oblique to the mesh's symmetry lines (0.3 rad from x).
inline constexpr double ray_angle_rad = 0.3;

/// FEM answers at the probe centre and along the ray.
struct RaySamples {
  bool usable = false;
  std::string status;
  double centre_deflection_m = 0;
  std::vector<double> w_m, Nr_N_per_m, Nt_N_per_m;
  std::size_t n_dofs = 0;
  double wall_s = 0;
};

inline RaySamples solve_on_ray(const pvdf::Scene& s, pvdf::fem::Options o, const std::vector<double>& radii_m) {
  o.sample_points_m.clear();
  for (double r : radii_m) o.sample_points_m.push_back({r * std::cos(ray_angle_rad), r * std::sin(ray_angle_rad)});
  const auto res = pvdf::fem::solve(s, o);
  RaySamples out;
  out.status = pvdf::fem::status_name(res.summary.status) + " " + res.summary.message + " (" +
               pvdf::fem::model_name(res.summary.model) + ")";
  out.usable = pvdf::fem::usable(res.summary.status);
  if (!out.usable) return out;
  out.centre_deflection_m = res.deflection_at_load_m;
  for (const auto& sm : res.samples) {
    out.w_m.push_back(sm.w_m);
    out.Nr_N_per_m.push_back(sm.membrane_force.polar[0]);
    out.Nt_N_per_m.push_back(sm.membrane_force.polar[1]);
  }
  out.n_dofs = res.summary.n_dofs;
  out.wall_s = res.summary.wall_s;
  return out;
}

/// The charge of a rectangular electrode of a centred_probe_scene from the oracle's fields: Q = ∫
/// (d31 N11 + d32 N22)/h dA (docs/charge-model.md) with N in the film's material axes. For the
/// isotropic film under a centred probe N is diagonal in polar axes; at polar angle φ with the draw
/// direction at θ and β = φ − θ, N11 = N_r cos²β + N_θ sin²β and N22 = N_r sin²β + N_θ cos²β.
/// Integrated over the electrode rectangle in its own axes with `n_sub` × `n_sub` cells of 6 × 6
/// Gauss points: a rule independent of the FEM's.
inline double oracle_electrode_charge(const oracles::AxisymmetricSolution& oracle, const pvdf::Scene& s,
                                      const pvdf::Electrode& el, int n_sub = 4) {
  const double gx[3] = {0.2386191860831969, 0.6612093864662645, 0.9324695142031521};
  const double gw[3] = {0.4679139345726910, 0.3607615730481386, 0.1713244923791703};
  const double h = s.membrane.thickness_m, theta = s.material.draw_angle_rad;
  const double w = el.size_m[0], hgt = el.size_m[1], ca = std::cos(el.angle_rad), sa = std::sin(el.angle_rad);
  double q = 0;
  for (int i = 0; i < n_sub; ++i)
    for (int j = 0; j < n_sub; ++j)
      for (int gi = 0; gi < 6; ++gi)
        for (int gj = 0; gj < 6; ++gj) {
          const double xi = (i + 0.5 + 0.5 * (gi < 3 ? -gx[gi] : gx[gi - 3])) / n_sub - 0.5;
          const double eta = (j + 0.5 + 0.5 * (gj < 3 ? -gx[gj] : gx[gj - 3])) / n_sub - 0.5;
          const double weight = 0.25 * gw[gi % 3] * gw[gj % 3] * w * hgt / (n_sub * n_sub);
          const double lx = xi * w, ly = eta * hgt;
          const double x = el.center_m[0] + ca * lx - sa * ly, y = el.center_m[1] + sa * lx + ca * ly;
          const double r = std::hypot(x, y), beta = std::atan2(y, x) - theta;
          const double nr = oracle.radial_force_N_per_m(r), nt = oracle.hoop_force_N_per_m(r);
          const double cb = std::cos(beta), sb = std::sin(beta);
          const double n11 = nr * cb * cb + nt * sb * sb, n22 = nr * sb * sb + nt * cb * cb;
          q += weight * (s.material.d31_C_per_N * n11 + s.material.d32_C_per_N * n22) / h;
        }
  return q;
}

/// The acceptance rule of the header comment for one output. `what` names it in the report.
/// Returns the fine-mesh relative error against the oracle (for tables).
inline double check_converges_to(const std::string& what, double coarse, double fine, double oracle,
                                 double floor_rel = 2e-4) {
  const double err = std::abs(fine - oracle), change = std::abs(fine - coarse);
  const double allowed = std::max(2 * change, floor_rel * std::abs(oracle));
  INFO(what << ": FEM " << coarse << " -> " << fine << " (mesh change " << change / std::abs(oracle)
            << " rel.), oracle " << oracle << ", error " << err / std::abs(oracle) << " rel., allowed "
            << allowed / std::abs(oracle));
  CHECK(std::isfinite(fine));
  CHECK(err <= allowed);
  return err / std::abs(oracle);
}

}  // namespace pvdf::fem::testing
