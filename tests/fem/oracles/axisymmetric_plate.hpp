// Independent oracle for the FEM verification: a clamped circular film (radius a, thickness h,
// isotropic E, ν) under a vertical load spread uniformly on a central disk (radius c ≤ a; c = a is a
// uniform pressure), optionally pre-tensioned and optionally with bending, solved to ~1e-6.
//
// What it models (state this whenever a number from here is quoted):
//  * axisymmetric deformation, unknowns u(r) (radial) and w(r) (vertical), clamped rim u = w = 0
//    (and w' = 0 with bending), regular centre u = 0, w' = 0;
//  * Kinematics::von_karman:     ε_r = u' + ½w'²,            ε_θ = u/r           (moderate rotation);
//    Kinematics::green_lagrange: ε_r = u' + ½u'² + ½w'²,     ε_θ = u/r + ½(u/r)² (the exact
//    Green–Lagrange strains of a surface of revolution), St Venant–Kirchhoff membrane law;
//  * membrane forces N_r, N_θ are second Piola–Kirchhoff forces per unit *undeformed* length:
//    N_r = N0 + A(ε_r + ν ε_θ), A = E h /(1 − ν²), N0 the uniform pretension;
//  * bending (optional) with linear curvatures κ_r = w'', κ_θ = w'/r and D = E h³/(12(1 − ν²))
//    (axisymmetric von Kármán plate; it is also used with the Green–Lagrange membrane strains);
//  * the load is a *dead vertical* load q = F/(π c²) per unit undeformed area on r < c (what a
//    force transducer measures), not a follower pressure;
//  * tension field (optional, for slack or wrinkling films): the relaxed membrane energy of Pipkin
//    (1986) / Steigmann (1990) — a compressive principal force is replaced by zero (the film wrinkles
//    at no cost instead of buckling), N0 may then be negative (a slack film: stress-free radius
//    a·(1 + s) with s = −N0 (1 − ν)/(E h) > 0). For an axisymmetric state r and θ are principal.
// Method: minimise the total potential energy over C¹ Hermite-cubic elements for both u and w on a
// graded grid with a node at r = c (the load edge), Newton with energy line search, and load
// continuation when bending or pretension is present. No deal.II: this is the independent check.
#pragma once

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <Eigen/SparseLU>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace pvdf::fem::oracles {

/// Which membrane strain measure the oracle uses.
enum class Kinematics {
  von_karman,      ///< ε_r = u' + ½w'², ε_θ = u/r
  green_lagrange,  ///< ε_r = u' + ½u'² + ½w'², ε_θ = u/r + ½(u/r)²
};

/// The physical problem, SI units.
struct AxisymmetricProblem {
  double radius_m = 45e-3;          ///< a, clamped rim
  double thickness_m = 25e-6;       ///< h
  double youngs_modulus_Pa = 2e9;   ///< E (isotropic)
  double poisson_ratio = 0.3;       ///< ν
  double force_N = 1.0;             ///< total vertical force F (downward = +w)
  double load_radius_m = 1e-3;      ///< c, radius of the loaded central disk; c = a: uniform pressure
  double pretension_N_per_m = 0.0;  ///< N0, uniform in-plane pretension (N/m); < 0 (slack) only with tension_field
  bool bending = false;             ///< add plate bending (clamped: w'(a) = 0)
  bool tension_field = false;       ///< relaxed (wrinkling) membrane energy: no compressive principal force
  Kinematics kinematics = Kinematics::von_karman;
};

/// Discretisation and solver settings.
struct AxisymmetricOptions {
  int n_elements = 400;           ///< total number of elements over [0, a]
  double inner_fraction = 0.15;   ///< share of the elements placed on [0, c] when c < a
  int max_newton_iterations = 200;
  double step_tolerance = 1e-10;  ///< stop when the last full Newton step is below this (relative)
};

/// The converged state and what can be evaluated from it.
class AxisymmetricSolution {
 public:
  bool converged = false;
  int newton_iterations = 0;  ///< total over all load steps
  int load_steps = 0;
  std::string message;        ///< why it failed, empty on success

  /// Vertical deflection w(r) in m, r in [0, a].
  double deflection_m(double r_m) const { return eval(r_m).w * a_; }
  /// Radial membrane force N_r(r) (2nd Piola–Kirchhoff, per undeformed length), N/m.
  double radial_force_N_per_m(double r_m) const { return eval(r_m).Nr * Eh_; }
  /// Hoop membrane force N_θ(r), N/m.
  double hoop_force_N_per_m(double r_m) const { return eval(r_m).Nt * Eh_; }
  /// Radial displacement u(r), m.
  double radial_displacement_m(double r_m) const { return eval(r_m).u * a_; }
  /// Slope w'(r), dimensionless.
  double slope(double r_m) const { return eval(r_m).wp; }
  /// w(0), m.
  double centre_deflection_m() const { return deflection_m(0.0); }
  /// Stored strain energy (membrane + bending, J), excluding the constant pretension energy.
  double strain_energy_J = 0.0;
  /// Work of the dead load at the final state, ∫ q w dA (J) = F × (load-weighted mean deflection).
  double load_work_J = 0.0;
  /// Vertical rim reaction from the rim stress resultants, N (should equal F).
  double rim_reaction_N = 0.0;
  /// Vertical force carried across the circle of radius r, 2πr[D(∇²w)' − N_r w'] (N): equals the
  /// load inside r (F for r ≥ c) at equilibrium; computed from the fields, so it converges with the grid.
  double vertical_force_N(double r_m) const {
    const Point P = eval(r_m);
    const double r = std::max(r_m / a_, 1e-12);
    const double shear = D_ * (P.wppp + P.wpp / r - P.wp / (r * r));
    return 2 * M_PI * r * (shear - P.Nr * P.wp) * Eh_ * a_;
  }
  /// Radius intervals [r0, r1] (m) where the hoop force vanishes (tension field: the film wrinkles
  /// radially there), located by bisection on the relaxed law's state between `n_samples` samples.
  std::vector<std::pair<double, double>> wrinkled_intervals_m(int n_samples = 2000) const;
  /// Smallest and largest hoop force over [0, a] sampled at `n_samples` points (N/m).
  std::pair<double, double> hoop_force_range_N_per_m(int n_samples = 2000) const {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (int i = 0; i <= n_samples; ++i) {
      const double n = hoop_force_N_per_m(a_ * i / n_samples);
      lo = std::min(lo, n);
      hi = std::max(hi, n);
    }
    return {lo, hi};
  }
  /// Node radii (m), for plotting or grading checks.
  std::vector<double> nodes_m() const {
    std::vector<double> out(nodes_.size());
    for (std::size_t i = 0; i < nodes_.size(); ++i) out[i] = nodes_[i] * a_;
    return out;
  }
  int n_dofs() const { return static_cast<int>(x_.size()); }

  // --- internals filled by solve_axisymmetric (dimensionless: r/a, u/a, w/a, N/(E h)) ---
  struct Point {
    double u, up, w, wp, wpp, wppp, Nr, Nt;
  };
  Point eval(double r_m) const;
  std::vector<double> nodes_;
  Eigen::VectorXd x_;
  double a_ = 1, Eh_ = 1, nu_ = 0.3, n0_ = 0, D_ = 0;
  bool gl_ = false, tf_ = false;
};

namespace detail {

// Cubic Hermite shape functions on [r0, r0 + h], ξ = (r − r0)/h; order: value0, slope0, value1, slope1.
struct Hermite {
  std::array<double, 4> f, d, dd, ddd;
  Hermite(double xi, double h) {
    ddd = {12 / (h * h * h), 6 / (h * h), -12 / (h * h * h), 6 / (h * h)};
    const double x2 = xi * xi, x3 = x2 * xi;
    f = {1 - 3 * x2 + 2 * x3, h * (xi - 2 * x2 + x3), 3 * x2 - 2 * x3, h * (-x2 + x3)};
    d = {(-6 * xi + 6 * x2) / h, 1 - 4 * xi + 3 * x2, (6 * xi - 6 * x2) / h, -2 * xi + 3 * x2};
    dd = {(-6 + 12 * xi) / (h * h), (-4 + 6 * xi) / h, (6 - 12 * xi) / (h * h), (-2 + 6 * xi) / h};
  }
};

// Local dof order per element: [u0, u0', w0, w0', u1, u1', w1, w1'] = global 4i .. 4i+7.
inline constexpr std::array<int, 4> u_dofs{0, 1, 4, 5};
inline constexpr std::array<int, 4> w_dofs{2, 3, 6, 7};

// 6-point Gauss–Legendre on [0, 1] (exact to degree 11).
inline const std::array<std::pair<double, double>, 6>& gauss6() {
  static const std::array<std::pair<double, double>, 6> g = [] {
    const double x[3] = {0.2386191860831969086305017, 0.6612093864662645136613996, 0.9324695142031520278123016};
    const double w[3] = {0.4679139345726910473898703, 0.3607615730481386075698335, 0.1713244923791703450402961};
    std::array<std::pair<double, double>, 6> out{};
    for (int k = 0; k < 3; ++k) {
      out[2 * k] = {0.5 * (1 - x[k]), 0.5 * w[k]};
      out[2 * k + 1] = {0.5 * (1 + x[k]), 0.5 * w[k]};
    }
    return out;
  }();
  return g;
}

// Dimensionless model: lengths / a, forces / (E h), energies / (E h a²).
struct Model {
  double A = 1, nu = 0.3, D = 0, n0 = 0, q = 0, c = 1;
  bool gl = false, bending = false, tf = false;
  std::vector<double> nodes;
};

// Relaxed (tension-field) plane-stress law of an isotropic film in its principal axes r, θ, forces
// per E h. Elastic strains e = ε − s (s the natural strain of the slack film). The four states of
// Pipkin's relaxed energy: taut (both forces > 0, the ordinary law), wrinkled with the hoop force
// zero (uniaxial tension N_r = e_r when e_θ ≤ −ν e_r), wrinkled with the radial force zero, slack
// (e_r, e_θ ≤ 0: no force). W and N are continuous across the states; C = ∂N/∂e is the tangent.
struct RelaxedLaw {
  enum State { taut, hoop_wrinkled, radial_wrinkled, slack } state = taut;
  double W = 0, Nr = 0, Nt = 0, C11 = 0, C12 = 0, C22 = 0;
};

inline RelaxedLaw relaxed_law(double er, double et, double nu) {
  const double A = 1.0 / (1 - nu * nu);
  RelaxedLaw L;
  const double nr = A * (er + nu * et), nt = A * (et + nu * er);
  if (nr > 0 && nt > 0) {
    L = {RelaxedLaw::taut, 0.5 * A * (er * er + 2 * nu * er * et + et * et), nr, nt, A, A * nu, A};
  } else if (er > 0 && et <= -nu * er) {
    L = {RelaxedLaw::hoop_wrinkled, 0.5 * er * er, er, 0, 1, 0, 0};
  } else if (et > 0 && er <= -nu * et) {
    L = {RelaxedLaw::radial_wrinkled, 0.5 * et * et, 0, et, 0, 0, 1};
  } else {
    L.state = RelaxedLaw::slack;
  }
  return L;
}

// Point-wise kinematics at radius r from element values.
struct Kin {
  double u, up, w, wp, wpp, wppp, er, et, kr, kt;
};

inline Kin kinematics(const Model& m, const Hermite& H, const double* xe, double r) {
  Kin k{};
  for (int i = 0; i < 4; ++i) {
    k.u += H.f[i] * xe[u_dofs[i]];
    k.up += H.d[i] * xe[u_dofs[i]];
    k.w += H.f[i] * xe[w_dofs[i]];
    k.wp += H.d[i] * xe[w_dofs[i]];
    k.wpp += H.dd[i] * xe[w_dofs[i]];
    k.wppp += H.ddd[i] * xe[w_dofs[i]];
  }
  // At r = 0 the hoop quantities take their limits u/r → u'(0), w'/r → w''(0).
  const double uor = r > 1e-14 ? k.u / r : k.up;
  const double wpor = r > 1e-14 ? k.wp / r : k.wpp;
  k.er = k.up + 0.5 * k.wp * k.wp + (m.gl ? 0.5 * k.up * k.up : 0.0);
  k.et = uor + (m.gl ? 0.5 * uor * uor : 0.0);
  k.kr = k.wpp;
  k.kt = wpor;
  return k;
}

// Total potential energy, and optionally its gradient and Hessian (dimensionless).
inline double energy(const Model& m, const Eigen::VectorXd& x, Eigen::VectorXd* grad,
                     std::vector<Eigen::Triplet<double>>* hess, double* strain_energy = nullptr,
                     double* load_work = nullptr) {
  const int n_el = static_cast<int>(m.nodes.size()) - 1;
  if (grad) grad->setZero(x.size());
  if (hess) hess->clear();
  double total = 0, stored = 0, work = 0;
  for (int e = 0; e < n_el; ++e) {
    const double r0 = m.nodes[e], h = m.nodes[e + 1] - r0;
    const double* xe = x.data() + 4 * e;
    const bool loaded = m.nodes[e + 1] <= m.c * (1 + 1e-12);
    Eigen::Matrix<double, 8, 1> ge = Eigen::Matrix<double, 8, 1>::Zero();
    Eigen::Matrix<double, 8, 8> He = Eigen::Matrix<double, 8, 8>::Zero();
    for (const auto& [xi, wq] : gauss6()) {
      const double r = r0 + xi * h;
      const double dA = 2 * M_PI * r * h * wq;
      const Hermite H(xi, h);
      const Kin k = kinematics(m, H, xe, r);
      // Tension field: the whole relaxed energy of the elastic strain e = ε − s, s = −N0 (1 − ν).
      const double s_nat = -m.n0 * (1 - m.nu);
      const RelaxedLaw L = m.tf ? relaxed_law(k.er - s_nat, k.et - s_nat, m.nu) : RelaxedLaw{};
      const double Nr = m.tf ? L.Nr : m.n0 + m.A * (k.er + m.nu * k.et);
      const double Nt = m.tf ? L.Nt : m.n0 + m.A * (k.et + m.nu * k.er);
      // Pretension energy N0 (ε_r + ε_θ) without its linear part u' + u/r, whose integral (r u)' vanishes
      // (u(0) = u(a) = 0): dropping it exactly keeps O(N0) rounding out of a gradient that may be O(F).
      const double uor_ = r > 1e-14 ? k.u / r : k.up;
      const double quad = 0.5 * k.wp * k.wp + (m.gl ? 0.5 * (k.up * k.up + uor_ * uor_) : 0.0);
      double W = m.tf ? L.W : m.n0 * quad + 0.5 * m.A * (k.er * k.er + 2 * m.nu * k.er * k.et + k.et * k.et);
      double Wb = 0;
      if (m.bending) Wb = 0.5 * m.D * (k.kr * k.kr + 2 * m.nu * k.kr * k.kt + k.kt * k.kt);
      const double load = loaded ? m.q * k.w : 0.0;
      // Stored energy measured from the (equilibrated) prestressed flat state.
      stored += (W + Wb) * dA;
      work += load * dA;
      total += (W + Wb - load) * dA;
      if (!grad && !hess) continue;
      Eigen::Matrix<double, 8, 1> der = Eigen::Matrix<double, 8, 1>::Zero(), det = der, dkr = der, dkt = der;
      Eigen::Matrix<double, 8, 1> dpu = der, dpw = der, fu_r = der, fw = der;
      const double uor = r > 1e-14 ? k.u / r : k.up;
      for (int i = 0; i < 4; ++i) {
        dpu[u_dofs[i]] = H.d[i];
        dpw[w_dofs[i]] = H.d[i];
        fu_r[u_dofs[i]] = r > 1e-14 ? H.f[i] / r : H.d[i];
        fw[w_dofs[i]] = H.f[i];
        dkr[w_dofs[i]] = H.dd[i];
        dkt[w_dofs[i]] = r > 1e-14 ? H.d[i] / r : H.dd[i];
      }
      der = (1 + (m.gl ? k.up : 0.0)) * dpu + k.wp * dpw;
      det = (1 + (m.gl ? uor : 0.0)) * fu_r;
      if (m.tf) {
        ge += (Nr * der + Nt * det) * dA;
      } else {
        ge += ((Nr - m.n0) * der + (Nt - m.n0) * det) * dA;
        ge += m.n0 * (k.wp * dpw + (m.gl ? Eigen::Matrix<double, 8, 1>(k.up * dpu + uor * fu_r) : Eigen::Matrix<double, 8, 1>::Zero())) * dA;
      }
      if (m.bending) {
        const double Mr = m.D * (k.kr + m.nu * k.kt), Mt = m.D * (k.kt + m.nu * k.kr);
        ge += (Mr * dkr + Mt * dkt) * dA;
      }
      if (loaded) ge -= m.q * fw * dA;
      if (hess) {
        if (m.tf)
          He += (L.C11 * der * der.transpose() + L.C12 * (der * det.transpose() + det * der.transpose()) +
                 L.C22 * det * det.transpose()) * dA;
        else
          He += m.A * (der * der.transpose() + m.nu * (der * det.transpose() + det * der.transpose()) +
                       det * det.transpose()) * dA;
        He += Nr * (dpw * dpw.transpose()) * dA;
        if (m.gl) He += (Nr * dpu * dpu.transpose() + Nt * fu_r * fu_r.transpose()) * dA;
        if (m.bending)
          He += m.D * (dkr * dkr.transpose() + m.nu * (dkr * dkt.transpose() + dkt * dkr.transpose()) +
                       dkt * dkt.transpose()) * dA;
      }
    }
    if (grad) grad->segment<8>(4 * e) += ge;
    if (hess)
      for (int i = 0; i < 8; ++i)
        for (int j = 0; j < 8; ++j)
          if (He(i, j) != 0.0) hess->emplace_back(4 * e + i, 4 * e + j, He(i, j));
  }
  if (strain_energy) *strain_energy = stored;
  if (load_work) *load_work = work;
  return total;
}

// Graded grid on [x0, x1]: 90 % Chebyshev–Lobatto clustering at both ends blended with 10 %
// uniform spacing, so the end elements are ~L/(10 n): fine enough for the bending boundary layers,
// not so fine that the bending stiffness D/h³ ruins the conditioning.
inline void append_graded(std::vector<double>& nodes, double x0, double x1, int n) {
  for (int i = (nodes.empty() ? 0 : 1); i <= n; ++i) {
    const double t = static_cast<double>(i) / n;
    nodes.push_back(x0 + (x1 - x0) * (0.9 * 0.5 * (1 - std::cos(M_PI * t)) + 0.1 * t));
  }
}

}  // namespace detail

inline AxisymmetricSolution::Point AxisymmetricSolution::eval(double r_m) const {
  const double r = std::clamp(r_m / a_, 0.0, 1.0);
  auto it = std::upper_bound(nodes_.begin(), nodes_.end(), r);
  int e = static_cast<int>(it - nodes_.begin()) - 1;
  e = std::clamp(e, 0, static_cast<int>(nodes_.size()) - 2);
  const double h = nodes_[e + 1] - nodes_[e];
  const detail::Hermite H((r - nodes_[e]) / h, h);
  detail::Model m;
  m.gl = gl_;
  const detail::Kin k = detail::kinematics(m, H, x_.data() + 4 * e, r);
  if (tf_) {
    const double s_nat = -n0_ * (1 - nu_);
    const detail::RelaxedLaw L = detail::relaxed_law(k.er - s_nat, k.et - s_nat, nu_);
    return Point{k.u, k.up, k.w, k.wp, k.wpp, k.wppp, L.Nr, L.Nt};
  }
  const double A = 1.0 / (1 - nu_ * nu_);
  return Point{k.u, k.up, k.w, k.wp, k.wpp, k.wppp, n0_ + A * (k.er + nu_ * k.et), n0_ + A * (k.et + nu_ * k.er)};
}

inline std::vector<std::pair<double, double>> AxisymmetricSolution::wrinkled_intervals_m(int n_samples) const {
  std::vector<std::pair<double, double>> out;
  if (!tf_) return out;
  // Hoop force exactly zero: the hoop-wrinkled or slack state of the relaxed law.
  auto wrinkled = [&](double r_m) { return eval(r_m).Nt == 0.0; };
  auto edge = [&](double lo, double hi) {  // state changes in (lo, hi): bisect to 1e-9 a
    const bool at_lo = wrinkled(lo);
    while (hi - lo > 1e-9 * a_) {
      const double mid = 0.5 * (lo + hi);
      (wrinkled(mid) == at_lo ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
  };
  double start = -1, prev_r = 0;
  bool prev = wrinkled(0.0);
  if (prev) start = 0.0;
  for (int i = 1; i <= n_samples; ++i) {
    const double r = a_ * i / n_samples;
    const bool now = wrinkled(r);
    if (now && !prev) start = edge(prev_r, r);
    if (!now && prev) out.emplace_back(start, edge(prev_r, r));
    prev = now;
    prev_r = r;
  }
  if (prev) out.emplace_back(start, a_);
  return out;
}

namespace detail {

// Newton with energy line search and Levenberg-type shift when the Hessian is not positive, on
// the dofs `x` of model `m` (loaded by q), fixed dofs held at their values. Counts its iterations
// in `newton_iterations`; true when converged.
struct Newton {
  Model& m;
  Eigen::VectorXd& x;
  const std::vector<bool>& fixed;
  const AxisymmetricOptions& o;
  int& newton_iterations;
  int n_nodes, n_dof;

  // The shifted, diagonally scaled Newton direction for gradient g and Hessian triplets `trip`;
  // empty when no shift up to 30 attempts gives a descent direction.
  Eigen::VectorXd direction(const Eigen::VectorXd& g, std::vector<Eigen::Triplet<double>>& trip) const {
    Eigen::SparseMatrix<double> K(n_dof, n_dof);
    std::vector<Eigen::Triplet<double>> kept;
    kept.reserve(trip.size());
    for (const auto& t : trip)
      if ((!fixed[t.row()] && !fixed[t.col()]) || t.row() == t.col()) kept.push_back(t);
    K.setFromTriplets(kept.begin(), kept.end());
    // Symmetric diagonal scaling: the dofs mix values and slopes, membrane and bending stiffness.
    Eigen::VectorXd scale(n_dof);
    for (int i = 0; i < n_dof; ++i) {
      const double d = std::abs(K.coeff(i, i));
      scale[i] = d > 0 ? 1.0 / std::sqrt(d) : 1.0;
    }
    Eigen::SparseMatrix<double> Kscaled = scale.asDiagonal() * K * scale.asDiagonal();
    double shift = 0;
    Eigen::VectorXd dx;
    for (int attempt = 0; attempt < 30; ++attempt) {
      Eigen::SparseMatrix<double> Ks = Kscaled;
      if (shift > 0)
        for (int i = 0; i < n_dof; ++i) Ks.coeffRef(i, i) += shift;
      Eigen::SparseLU<Eigen::SparseMatrix<double>> lu;
      lu.compute(Ks);
      if (lu.info() == Eigen::Success) {
        const Eigen::VectorXd rhs = -(scale.array() * g.array()).matrix();
        dx = (scale.array() * lu.solve(rhs).array()).matrix();
        if (lu.info() == Eigen::Success && dx.allFinite() && g.dot(dx) < 0) break;
      }
      dx.resize(0);
      shift = shift == 0 ? 1e-10 : shift * 10;
    }
    return dx;
  }

  // Step length: full step when it lowers the energy (or the gradient, once energies agree to
  // rounding), else halved; at most 1e-12 means no acceptable step.
  double step_length(double E0, const Eigen::VectorXd& g, const Eigen::VectorXd& dx) const {
    double alpha = 1;
    for (; alpha > 1e-12; alpha *= 0.5) {
      const Eigen::VectorXd xt = x + alpha * dx;
      Eigen::VectorXd gt;
      const double E1 = detail::energy(m, xt, &gt, nullptr);
      for (int i = 0; i < n_dof; ++i)
        if (fixed[i]) gt[i] = 0;
      if (!std::isfinite(E1)) continue;
      if (E1 <= E0 + 1e-4 * alpha * g.dot(dx)) break;
      if (std::abs(E1 - E0) <= 1e-13 * std::abs(E0) + 1e-300 && gt.norm() < g.norm()) break;
    }
    return alpha;
  }

  bool operator()(double q) {
    m.q = q;
    Eigen::VectorXd g;
    std::vector<Eigen::Triplet<double>> trip;
    for (int it = 0; it < o.max_newton_iterations; ++it) {
      const double E0 = detail::energy(m, x, &g, &trip);
      ++newton_iterations;
      for (int i = 0; i < n_dof; ++i)
        if (fixed[i]) {
          g[i] = 0;
          trip.emplace_back(i, i, 1.0);
        }
      Eigen::VectorXd dx = direction(g, trip);
      if (dx.size() == 0) return false;
      for (int i = 0; i < n_dof; ++i)
        if (fixed[i]) dx[i] = 0;
      // Newton decrement −g·dx ≈ dxᵀK dx below 1e-20 of the energy: relative error ~1e-10 in energy norm.
      const double decrement = -g.dot(dx);
      if (decrement <= 1e-20 * std::abs(E0)) return true;
      const double alpha = step_length(E0, g, dx);
      if (alpha <= 1e-12) return false;
      x += alpha * dx;
      // Converged: a full step, small against the solution in the u and the w components.
      double du = 0, dw = 0, umax = 0, wmax = 0;
      for (int i = 0; i < n_nodes; ++i) {
        du = std::max({du, std::abs(dx[4 * i]), std::abs(dx[4 * i + 1])});
        umax = std::max({umax, std::abs(x[4 * i]), std::abs(x[4 * i + 1])});
        dw = std::max({dw, std::abs(dx[4 * i + 2]), std::abs(dx[4 * i + 3])});
        wmax = std::max({wmax, std::abs(x[4 * i + 2]), std::abs(x[4 * i + 3])});
      }
      // (u ~ w² in a membrane: below 1e-12·w it is rounding, e.g. in the linear first load step of a
      // thick plate, where the bending stiffness makes the tangent ill-conditioned.)
      if (alpha == 1 && dw <= o.step_tolerance * wmax && du <= o.step_tolerance * umax + 1e-12 * wmax) return true;
    }
    return false;
  }
};

// Start of the membrane solves: a paraboloid with Hencky's amplitude (K ≈ 0.65) for the same
// total force spread over the whole film.
inline void hencky_start(const Model& m, double q_full, int n_nodes, Eigen::VectorXd& x) {
  const double w0 = 0.65 * std::cbrt(q_full * m.c * m.c);
  for (int i = 0; i < n_nodes; ++i) {
    const double r = m.nodes[i];
    x[4 * i + 2] = w0 * (1 - r * r);
    x[4 * i + 3] = -2 * w0 * r;
  }
}

// Relaxed membrane, slack or taut. A slack film has no stiffness at small load and its flat
// state is all wrinkled, so no load continuation: solve the taut film first (N0 ≥ 0, from
// Hencky's paraboloid, where the relaxation is rarely active), then lower N0 to its slack
// value in steps, each Newton solve started from the last (halving a step that fails).
inline bool solve_tension_field(Newton& newton, const AxisymmetricProblem& p, double q_full, AxisymmetricSolution& sol) {
  Model& m = newton.m;
  Eigen::VectorXd& x = newton.x;
  m.tf = true;
  m.gl = false;
  const double n0_target = m.n0;
  m.n0 = std::max(0.0, n0_target);
  hencky_start(m, q_full, newton.n_nodes, x);
  sol.load_steps = 1;
  bool ok = newton(q_full);
  double step = n0_target / 4;
  while (ok && m.n0 > n0_target) {
    const Eigen::VectorXd x_save = x;
    const double n0_save = m.n0;
    m.n0 = std::max(n0_target, m.n0 + step);
    ++sol.load_steps;
    if (newton(q_full)) {
      step *= 1.5;
    } else {
      x = x_save;
      m.n0 = n0_save;
      step *= 0.5;
      if (std::abs(step) < 1e-6 * std::abs(n0_target)) ok = false;
    }
  }
  if (ok && p.kinematics == Kinematics::green_lagrange) {
    m.gl = true;
    ok = newton(q_full);
    ++sol.load_steps;
  }
  return ok;
}

// The pure von Kármán membrane has no stiffness at w = 0: start from Hencky's paraboloid, then
// (Green–Lagrange) solve again with the full kinematics.
inline bool solve_pure_membrane(Newton& newton, const AxisymmetricProblem& p, double q_full, AxisymmetricSolution& sol) {
  Model& m = newton.m;
  m.gl = false;
  hencky_start(m, q_full, newton.n_nodes, newton.x);
  sol.load_steps = 1;
  bool ok = newton(q_full);
  if (ok && p.kinematics == Kinematics::green_lagrange) {
    m.gl = true;
    ok = newton(q_full);
    sol.load_steps = 2;
  }
  return ok;
}

// Load continuation from a load small enough for the linear response, doubling, with a
// power-law predictor w ∝ λ^e, u ∝ λ^(2e) fitted to the last two converged steps.
inline bool solve_load_continuation(Newton& newton, const AxisymmetricProblem& p, double q_full,
                                    AxisymmetricSolution& sol) {
  Model& m = newton.m;
  Eigen::VectorXd& x = newton.x;
  const int n_nodes = newton.n_nodes;
  const double a = p.radius_m, Eh = p.youngs_modulus_Pa * p.thickness_m, nu = p.poisson_ratio;
  m.gl = p.kinematics == Kinematics::green_lagrange;
  // First load factor: the linear estimate of the centre deflection (plate and/or tensioned
  // membrane, whichever is stiffer) at 1e-3 h.
  const double F = p.force_N, c_m = p.load_radius_m, h_m = p.thickness_m;
  double w_linear = std::numeric_limits<double>::infinity();
  if (p.bending)
    w_linear = F * a * a / (16 * M_PI * Eh * h_m * h_m / (12 * (1 - nu * nu)));
  if (m.n0 > 0)
    w_linear = std::min(w_linear, F / (2 * M_PI * p.pretension_N_per_m) * (std::log(a / c_m) + 0.5));
  double lambda = std::min(1.0, 1e-3 * h_m / w_linear);
  double exponent = 1.0, w_prev = 0, lambda_prev = 0;
  bool ok = newton(q_full * lambda);
  sol.load_steps = 1;
  double step = 2.0;
  while (ok && lambda < 1) {
    const double w_now = x[2];
    if (lambda_prev > 0 && w_prev > 0 && w_now > 0)
      exponent = std::clamp(std::log(w_now / w_prev) / std::log(lambda / lambda_prev), 0.3, 1.0);
    const double next = std::min(1.0, lambda * step);
    const double s = next / lambda;
    const Eigen::VectorXd x_save = x;
    for (int i = 0; i < n_nodes; ++i) {
      x[4 * i] *= std::pow(s, 2 * exponent);
      x[4 * i + 1] *= std::pow(s, 2 * exponent);
      x[4 * i + 2] *= std::pow(s, exponent);
      x[4 * i + 3] *= std::pow(s, exponent);
    }
    ++sol.load_steps;
    if (newton(q_full * next)) {
      lambda_prev = lambda;
      w_prev = w_now;
      lambda = next;
      step = std::min(4.0, step * 1.5);
    } else {
      x = x_save;
      step = std::sqrt(step);
      if (step < 1.0001) ok = false;
    }
  }
  return ok;
}

}  // namespace detail

/// Solves the axisymmetric problem. Throws std::invalid_argument on unusable input; a failed
/// Newton iteration is reported in `converged`/`message`, never as a wrong number.
inline AxisymmetricSolution solve_axisymmetric(const AxisymmetricProblem& p, const AxisymmetricOptions& o = {}) {
  if (!(p.radius_m > 0 && p.thickness_m > 0 && p.youngs_modulus_Pa > 0 && p.poisson_ratio > -1 &&
        p.poisson_ratio < 0.5 && p.force_N > 0 && p.load_radius_m > 0 && p.load_radius_m <= p.radius_m &&
        (p.pretension_N_per_m >= 0 || p.tension_field) && o.n_elements >= 8 &&
        !(p.tension_field && (p.bending || p.poisson_ratio < 0))))
    throw std::invalid_argument(
        "solve_axisymmetric: need a, h, E, F, c > 0, c <= a, -1 < nu < 0.5, N0 >= 0 (< 0 only with tension_field), "
        "n >= 8; tension_field is a membrane model (no bending, nu >= 0)");
  const double a = p.radius_m, Eh = p.youngs_modulus_Pa * p.thickness_m, nu = p.poisson_ratio;
  detail::Model m;
  m.A = 1.0 / (1 - nu * nu);
  m.nu = nu;
  m.D = p.thickness_m * p.thickness_m / (12 * (1 - nu * nu) * a * a);
  m.n0 = p.pretension_N_per_m / Eh;
  m.c = p.load_radius_m / a;
  m.bending = p.bending;
  const double q_full = p.force_N / (M_PI * p.load_radius_m * p.load_radius_m) * a / Eh;
  if (m.c < 1 - 1e-12) {
    const int n_in = std::max(4, static_cast<int>(std::lround(o.inner_fraction * o.n_elements)));
    detail::append_graded(m.nodes, 0.0, m.c, n_in);
    detail::append_graded(m.nodes, m.c, 1.0, o.n_elements - n_in);
  } else {
    m.c = 1.0;
    detail::append_graded(m.nodes, 0.0, 1.0, o.n_elements);
  }
  const int n_nodes = static_cast<int>(m.nodes.size()), n_dof = 4 * n_nodes;
  // Fixed dofs: centre u = 0, w' = 0; rim u = 0, w = 0 (+ w' = 0 with bending).
  std::vector<bool> fixed(n_dof, false);
  fixed[0] = fixed[3] = true;
  fixed[4 * (n_nodes - 1)] = fixed[4 * (n_nodes - 1) + 2] = true;
  if (p.bending) fixed[4 * (n_nodes - 1) + 3] = true;

  AxisymmetricSolution sol;
  sol.a_ = a;
  sol.Eh_ = Eh;
  sol.nu_ = nu;
  sol.n0_ = m.n0;
  sol.D_ = p.bending ? m.D : 0.0;
  sol.nodes_ = m.nodes;
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n_dof);
  detail::Newton newton{m, x, fixed, o, sol.newton_iterations, n_nodes, n_dof};

  const bool pure_membrane = !p.bending && m.n0 == 0;
  if (p.tension_field) {
    sol.converged = detail::solve_tension_field(newton, p, q_full, sol);
  } else if (pure_membrane) {
    sol.converged = detail::solve_pure_membrane(newton, p, q_full, sol);
  } else {
    sol.converged = detail::solve_load_continuation(newton, p, q_full, sol);
  }
  sol.gl_ = m.gl;
  sol.tf_ = m.tf;
  sol.x_ = x;
  if (!sol.converged) {
    sol.message = "Newton did not converge";
    return sol;
  }
  m.q = q_full;
  double stored = 0, work = 0;
  detail::energy(m, x, nullptr, nullptr, &stored, &work);
  const double E_scale = Eh * a * a;
  sol.strain_energy_J = stored * E_scale;
  sol.load_work_J = work * E_scale;
  // Rim reaction from the rim stress resultants (not from the discrete residual, which would
  // balance by construction): per unit length −N_r w' (the vertical row of F·S, exact for both
  // kinematics) plus the plate shear D (∇²w)' — the first integral 2πr[D(∇²w)' − N_r w'] = F(r).
  sol.rim_reaction_N = sol.vertical_force_N(a);
  return sol;
}

}  // namespace pvdf::fem::oracles
