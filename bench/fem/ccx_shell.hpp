// CalculiX S8R shells (8-node, bending kept) for an off-centre probe near the clamp: a structured
// "spoke" mesh that conforms to the probe footprint and is graded to a given radial size along the
// whole clamped rim, the deck (NLGEOM, dead vertical nodal loads on the footprint, rim clamped),
// and the electrode charge from the mid-surface displacements (docs/bench-fem.md, "CalculiX S8R
// references near the clamp (r14)"). The run and the .frd/.dat readers are ccx_peer.hpp's.
//
// The mesh. Spokes leave the footprint circle |x − p| = c at np equally spaced angles θ (about the
// probe centre p) and end on the rim at the point where the ray from p at θ meets it. Each spoke is
// a cubic Hermite curve that starts along the ray and arrives at the rim along the rim's normal, so
// the element edges across the rim are radial and the rings next to the rim are (nearly) circles.
// Along every spoke the nodes follow one size function of the arclength s:
//   h(s) = min(h_fp + γ s, h_rim + γ (S − s), (c + s)·2π/np)
// (geometric growth γ from the footprint and from the rim; beyond that the spokes' own spacing, so
// cells are about square away from both). Every spoke gets as many cells as the longest spoke
// needs, so no spoke is coarser than h. Inside the footprint: the O-grid of make_polar_mesh (a
// square core and a transfinite ring out to the circle). Midside nodes lie on the same curves
// (spoke arclength midpoints, circle), so the rim and the footprint are quadratic arcs.
//
// Why elements may be long along the rim: the clamp's bending layer varies across the rim over
// l_b = √(D/N) ≈ 0.2–0.4 mm (docs/fem.md §3.4), while along the rim the field varies on the scale
// of the distance to the probe; the spokes' tangential spacing is (distance to p)·2π/np, i.e. a
// fixed fraction of that scale everywhere. Far from the probe this gives rim cells of aspect ratio
// up to ~60 (h_rim = 0.15 mm, np = 64, 85 mm from the probe).
#pragma once

#include "ccx_peer.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/material.hpp"
#include "pvdf/core/piezo.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace pvdf::bench {

/// 8-node serendipity quad at (ξ, η) ∈ [−1, 1]²: corners 0–3 counter-clockwise from (−1, −1),
/// midsides 4 (0–1), 5 (1–2), 6 (2–3), 7 (3–0) — CalculiX's S8R order.
inline void serendipity8(double xi, double eta, double N[8], double dN[8][2]) {
  const double sx[4] = {-1, 1, 1, -1}, sy[4] = {-1, -1, 1, 1};
  for (int i = 0; i < 4; ++i) {
    const double a = 1 + sx[i] * xi, b = 1 + sy[i] * eta, g = sx[i] * xi + sy[i] * eta - 1;
    N[i] = 0.25 * a * b * g;
    dN[i][0] = 0.25 * sx[i] * b * (g + a);
    dN[i][1] = 0.25 * sy[i] * a * (g + b);
  }
  // Midsides on η = ∓1 (nodes 4, 6) and on ξ = ±1 (nodes 5, 7).
  for (int i : {4, 6}) {
    const double s = i == 4 ? -1 : 1;
    N[i] = 0.5 * (1 - xi * xi) * (1 + s * eta);
    dN[i][0] = -xi * (1 + s * eta);
    dN[i][1] = 0.5 * s * (1 - xi * xi);
  }
  for (int i : {5, 7}) {
    const double s = i == 5 ? 1 : -1;
    N[i] = 0.5 * (1 + s * xi) * (1 - eta * eta);
    dN[i][0] = 0.5 * s * (1 - eta * eta);
    dN[i][1] = -eta * (1 + s * xi);
  }
}

/// A mesh of S8R elements (node indices 0-based, in serendipity8's order).
struct ShellMesh {
  std::vector<std::array<double, 2>> nodes;  ///< m
  std::vector<std::array<int, 8>> elements;
  std::vector<bool> loaded;  ///< element lies in the probe footprint
  std::vector<int> rim_nodes;
  int centre_node = -1;  ///< the probe centre
  double rim_size_m = 0;      ///< largest radial size of the cells touching the rim
  double max_rim_aspect = 0;  ///< largest (along the rim) / (across the rim) of those cells
  double min_jacobian_ratio = 0;  ///< min over elements of min det J / max det J at the 3×3 Gauss points
};

/// Spoke mesh of the disk |x| < a around the footprint |x − p| = c (see the file comment).
/// np: spokes (a multiple of 8); h_rim_m: radial cell size at the rim; growth: γ.
inline ShellMesh make_spoke_mesh(double a, double c, std::array<double, 2> p, int np, double h_rim_m,
                                 double growth = 0.3) {
  if (np % 8 != 0) throw std::invalid_argument("make_spoke_mesh: np must be a multiple of 8");
  if (std::hypot(p[0], p[1]) + 2 * c > a) throw std::invalid_argument("make_spoke_mesh: footprint too close to the rim");
  ShellMesh m;
  const int nf = 2 * np;  // fine (corner + midside) nodes around each ring
  auto add = [&](double x, double y) {
    m.nodes.push_back({x, y});
    return static_cast<int>(m.nodes.size()) - 1;
  };
  // Core square of half-width c/2 about p: n × n elements on a (2n + 1)² fine grid (element centres unused).
  const int n = np / 4;
  const double s = 0.5 * c;
  std::vector<int> grid((2 * n + 1) * (2 * n + 1), -1);
  auto g = [&](int i, int j) -> int& { return grid[j * (2 * n + 1) + i]; };
  for (int j = 0; j <= 2 * n; ++j)
    for (int i = 0; i <= 2 * n; ++i)
      if (i % 2 == 0 || j % 2 == 0) g(i, j) = add(p[0] - s + s * i / n, p[1] - s + s * j / n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int I = 2 * i, J = 2 * j;
      m.elements.push_back({g(I, J), g(I + 2, J), g(I + 2, J + 2), g(I, J + 2), g(I + 1, J), g(I + 2, J + 1),
                            g(I + 1, J + 2), g(I, J + 1)});
    }
  m.centre_node = g(n, n);
  // Fine perimeter of the square, counter-clockwise from the corner (−s, −s): 2 np nodes.
  std::vector<int> ring;
  for (int i = 0; i < 2 * n; ++i) ring.push_back(g(i, 0));
  for (int j = 0; j < 2 * n; ++j) ring.push_back(g(2 * n, j));
  for (int i = 2 * n; i > 0; --i) ring.push_back(g(i, 2 * n));
  for (int j = 2 * n; j > 0; --j) ring.push_back(g(0, j));
  std::vector<std::array<double, 2>> dir(nf), square(nf);
  for (int k = 0; k < nf; ++k) {
    const double th = -0.75 * pi + 2 * pi * k / nf;
    dir[k] = {std::cos(th), std::sin(th)};
    square[k] = m.nodes[ring[k]];
  }
  // One ring of elements between fine ring `in` and a new fine ring given by point(k, half),
  // half = 1 for the middle (only even k) and 2 for the outer fine ring.
  auto add_ring = [&](const std::vector<int>& in, bool loaded, auto point) {
    std::vector<int> mid(nf, -1), out(nf);
    for (int k = 0; k < nf; k += 2) {
      const auto x = point(k, 1);
      mid[k] = add(x[0], x[1]);
    }
    for (int k = 0; k < nf; ++k) {
      const auto x = point(k, 2);
      out[k] = add(x[0], x[1]);
    }
    for (int e = 0; e < np; ++e) {
      const int k = 2 * e, k1 = k + 1, k2 = (k + 2) % nf;
      m.elements.push_back({in[k], out[k], out[k2], in[k2], mid[k], out[k1], mid[k2], in[k1]});
      m.loaded.push_back(loaded);
    }
    return out;
  };
  m.loaded.assign(m.elements.size(), true);
  // Transfinite ring(s) from the square to the footprint circle (inside the footprint).
  const int m1 = std::max(1, n / 4);
  for (int l = 0; l < m1; ++l)
    ring = add_ring(ring, true, [&](int k, int half) {
      const double t = (l + 0.5 * half) / m1;
      return std::array<double, 2>{(1 - t) * square[k][0] + t * (p[0] + c * dir[k][0]),
                                   (1 - t) * square[k][1] + t * (p[1] + c * dir[k][1])};
    });
  // Spokes: Hermite curve from P = p + c e(θ) (tangent along e(θ)) to the rim point Q (tangent = Q/a).
  struct Spoke {
    std::array<double, 2> P, Q, T0, T1;
    std::vector<double> t_of_s_table, s_table;  // arclength table
    double length = 0;
    std::array<double, 2> at(double t) const {
      const double h00 = 2 * t * t * t - 3 * t * t + 1, h10 = t * t * t - 2 * t * t + t, h01 = -2 * t * t * t + 3 * t * t,
                   h11 = t * t * t - t * t;
      return {h00 * P[0] + h10 * T0[0] + h01 * Q[0] + h11 * T1[0], h00 * P[1] + h10 * T0[1] + h01 * Q[1] + h11 * T1[1]};
    }
    std::array<double, 2> at_arclength(double s) const {
      const auto it = std::lower_bound(s_table.begin(), s_table.end(), s);
      std::size_t i = static_cast<std::size_t>(std::clamp<std::ptrdiff_t>(it - s_table.begin(), 1, s_table.size() - 1));
      const double f = (s - s_table[i - 1]) / (s_table[i] - s_table[i - 1]);
      return at(t_of_s_table[i - 1] + f * (t_of_s_table[i] - t_of_s_table[i - 1]));
    }
  };
  std::vector<Spoke> spokes(nf);
  const double two_pi_np = 2 * pi / np;
  // A cell that starts at the rim with h = h0 and grows by γ per length spans h0 (e^γ − 1)/γ: so
  // h0 = h_rim γ/(e^γ − 1) makes the rim cells h_rim across.
  const double h0 = h_rim_m * growth / std::expm1(growth);
  auto h_of = [&](double s_, double S) {
    return std::min({c * two_pi_np + growth * s_, h0 + growth * (S - s_), (c + s_) * two_pi_np});
  };
  const int table = 4000;
  int n_cells = 1;
  for (int k = 0; k < nf; ++k) {
    Spoke& sp = spokes[k];
    sp.P = {p[0] + c * dir[k][0], p[1] + c * dir[k][1]};
    // Ray p + t e hits |x| = a at t = −p·e + √((p·e)² − |p|² + a²).
    const double pe = p[0] * dir[k][0] + p[1] * dir[k][1];
    const double t_hit = -pe + std::sqrt(pe * pe - (p[0] * p[0] + p[1] * p[1]) + a * a);
    sp.Q = {p[0] + t_hit * dir[k][0], p[1] + t_hit * dir[k][1]};
    const double L = std::hypot(sp.Q[0] - sp.P[0], sp.Q[1] - sp.P[1]);
    sp.T0 = {L * dir[k][0], L * dir[k][1]};
    sp.T1 = {L * sp.Q[0] / a, L * sp.Q[1] / a};
    sp.s_table.push_back(0);
    sp.t_of_s_table.push_back(0);
    auto prev = sp.at(0);
    for (int i = 1; i <= table; ++i) {
      const double t = static_cast<double>(i) / table;
      const auto x = sp.at(t);
      sp.s_table.push_back(sp.s_table.back() + std::hypot(x[0] - prev[0], x[1] - prev[1]));
      sp.t_of_s_table.push_back(t);
      prev = x;
    }
    sp.length = sp.s_table.back();
    double cells = 0;
    for (int i = 0; i < table; ++i) {
      const double s_mid = 0.5 * (sp.s_table[i] + sp.s_table[i + 1]);
      cells += (sp.s_table[i + 1] - sp.s_table[i]) / h_of(s_mid, sp.length);
    }
    n_cells = std::max(n_cells, static_cast<int>(std::ceil(cells)));
  }
  // Per spoke: arclengths of the n_cells + 1 element nodes, equidistributing ∫ ds / h.
  std::vector<std::vector<double>> s_nodes(nf);
  for (int k = 0; k < nf; ++k) {
    const Spoke& sp = spokes[k];
    std::vector<double> cum{0};
    for (int i = 0; i < table; ++i) {
      const double s_mid = 0.5 * (sp.s_table[i] + sp.s_table[i + 1]);
      cum.push_back(cum.back() + (sp.s_table[i + 1] - sp.s_table[i]) / h_of(s_mid, sp.length));
    }
    for (int l = 0; l <= n_cells; ++l) {
      const double target = cum.back() * l / n_cells;
      const auto it = std::lower_bound(cum.begin(), cum.end(), target);
      const std::size_t i = static_cast<std::size_t>(std::clamp<std::ptrdiff_t>(it - cum.begin(), 1, table));
      const double f = (target - cum[i - 1]) / (cum[i] - cum[i - 1]);
      s_nodes[k].push_back(sp.s_table[i - 1] + f * (sp.s_table[i] - sp.s_table[i - 1]));
    }
    s_nodes[k].back() = sp.length;
  }
  for (int l = 0; l < n_cells; ++l)
    ring = add_ring(ring, false, [&](int k, int half) {
      const double s_ = half == 2 ? s_nodes[k][l + 1] : 0.5 * (s_nodes[k][l] + s_nodes[k][l + 1]);
      if (half == 2 && l + 1 == n_cells) return spokes[k].Q;  // exactly on the rim
      return spokes[k].at_arclength(s_);
    });
  m.rim_nodes = ring;
  // Rim cells: radial size and aspect ratio (corner nodes of the outermost ring).
  const std::size_t first_rim = m.elements.size() - np;
  for (std::size_t e = first_rim; e < m.elements.size(); ++e) {
    const auto& el = m.elements[e];
    const auto& A = m.nodes[el[0]];  // inner corner
    const auto& B = m.nodes[el[1]];  // rim corner
    const auto& C = m.nodes[el[2]];  // rim corner
    const double across = a - std::hypot(A[0], A[1]);
    const double along = std::hypot(C[0] - B[0], C[1] - B[1]);
    m.rim_size_m = std::max(m.rim_size_m, across);
    m.max_rim_aspect = std::max(m.max_rim_aspect, along / across);
  }
  // Element quality: the Jacobian must stay positive inside every element.
  m.min_jacobian_ratio = 1e300;
  const double gp[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)};
  for (const auto& el : m.elements) {
    double jmin = 1e300, jmax = -1e300;
    for (double xi : gp)
      for (double eta : gp) {
        double N[8], dN[8][2];
        serendipity8(xi, eta, N, dN);
        Eigen::Matrix2d J = Eigen::Matrix2d::Zero();
        for (int i = 0; i < 8; ++i)
          for (int d = 0; d < 2; ++d) {
            J(d, 0) += m.nodes[el[i]][d] * dN[i][0];
            J(d, 1) += m.nodes[el[i]][d] * dN[i][1];
          }
        jmin = std::min(jmin, J.determinant());
        jmax = std::max(jmax, J.determinant());
      }
    m.min_jacobian_ratio = std::min(m.min_jacobian_ratio, jmin / jmax);
  }
  return m;
}

/// Jacobian of the 8-node map at (ξ, η) and the point itself.
inline Eigen::Matrix2d shell_jacobian(const ShellMesh& m, const std::array<int, 8>& el, double xi, double eta,
                                      double N[8], double dN[8][2], Eigen::Vector2d* x = nullptr) {
  serendipity8(xi, eta, N, dN);
  Eigen::Matrix2d J = Eigen::Matrix2d::Zero();
  Eigen::Vector2d X = Eigen::Vector2d::Zero();
  for (int i = 0; i < 8; ++i) {
    const auto& P = m.nodes[el[i]];
    X += N[i] * Eigen::Vector2d(P[0], P[1]);
    for (int d = 0; d < 2; ++d) {
      J(d, 0) += P[d] * dN[i][0];
      J(d, 1) += P[d] * dN[i][1];
    }
  }
  if (x) *x = X;
  return J;
}

/// The S8R deck: mid-surface shells, the rim clamped (DOFs 1–6 of the rim nodes: translations and
/// rotations; with 1–3 alone CalculiX 2.20 left the rim hinged — measured at (0, −40) mm on the
/// coarsest level: charges 3.1–3.6 % higher and w 1.2 % larger, about the plain membrane clamp), NLGEOM, a
/// small thermal pretension in step 1 that step 2 releases while the dead vertical probe load
/// (consistent nodal forces of a uniform pressure on the footprint elements, scaled to Σ = F) is
/// ramped; the final state does not depend on the path (elastic).
inline void write_s8r_deck(const std::string& path, const ShellMesh& m, const pvdf::Material& mat, double thickness_m,
                           double force_N) {
  std::ostringstream o;
  o.precision(12);  // ccx reads at most 20 characters per field: "-9.80171403296e-05" fits, 15 digits do not
  o << "*HEADING\npvdfkit bench/fem ccx_clamp_reference: clamped film, S8R, dead vertical probe load\n";
  o << "*NODE, NSET=NALL\n";
  for (std::size_t i = 0; i < m.nodes.size(); ++i) o << i + 1 << ", " << m.nodes[i][0] << ", " << m.nodes[i][1] << ", 0\n";
  o << "*ELEMENT, TYPE=S8R, ELSET=EFILM\n";
  for (std::size_t e = 0; e < m.elements.size(); ++e) {
    o << e + 1;
    for (int i = 0; i < 8; ++i) o << ", " << m.elements[e][i] + 1;
    o << "\n";
  }
  o << "*NSET, NSET=NRIM\n";
  for (std::size_t k = 0; k < m.rim_nodes.size(); ++k) o << m.rim_nodes[k] + 1 << (k % 10 == 9 ? ",\n" : ", ");
  o << "\n*NSET, NSET=NCENTER\n" << m.centre_node + 1 << "\n";
  // All nine 3-D constants; the out-of-plane ones barely matter in a thin shell (σ33 ≈ 0):
  // E3 = E2, ν13 = ν12, ν23 = ν21 (reciprocal), G13 = G12, G23 = E2 / (2 (1 + ν23)).
  const double nu23 = mat.nu21();
  o << "*MATERIAL, NAME=FILM\n*ELASTIC, TYPE=ENGINEERING CONSTANTS\n"
    << mat.E1_Pa << ", " << mat.E2_Pa << ", " << mat.E2_Pa << ", " << mat.nu12 << ", " << mat.nu12 << ", " << nu23 << ", "
    << mat.G12_Pa << ", " << mat.G12_Pa << ",\n"
    << mat.E2_Pa / (2 * (1 + nu23)) << ", 0.\n*EXPANSION\n1.e-5\n";
  const double th = mat.draw_angle_rad;
  o << "*ORIENTATION, NAME=DRAW\n" << std::cos(th) << ", " << std::sin(th) << ", 0., " << -std::sin(th) << ", "
    << std::cos(th) << ", 0.\n";
  o << "*SHELL SECTION, ELSET=EFILM, MATERIAL=FILM, ORIENTATION=DRAW\n" << thickness_m << "\n";
  o << "*BOUNDARY\nNRIM, 1, 6\n*INITIAL CONDITIONS, TYPE=TEMPERATURE\nNALL, 0.\n";
  // OUTPUT=2D (mid-surface displacements of the shell nodes) takes effect only in the first step.
  o << "*STEP, NLGEOM\n*STATIC\n1., 1.\n*TEMPERATURE\nNALL, -20.\n*NODE FILE, OUTPUT=2D\nU\n*END STEP\n";
  o << "*STEP, NLGEOM, INC=2000\n*STATIC\n0.05, 1., 1.e-7, 0.25\n*TEMPERATURE\nNALL, 0.\n";
  std::vector<double> fz(m.nodes.size(), 0.0);
  double area = 0;
  const double gp[3] = {-std::sqrt(0.6), 0.0, std::sqrt(0.6)}, gw[3] = {5.0 / 9, 8.0 / 9, 5.0 / 9};
  for (std::size_t e = 0; e < m.elements.size(); ++e) {
    if (!m.loaded[e]) continue;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        double N[8], dN[8][2];
        const double dA = shell_jacobian(m, m.elements[e], gp[a], gp[b], N, dN).determinant() * gw[a] * gw[b];
        area += dA;
        for (int i = 0; i < 8; ++i) fz[m.elements[e][i]] += N[i] * dA;
      }
  }
  o << "*CLOAD\n";
  for (std::size_t i = 0; i < fz.size(); ++i)
    if (fz[i] != 0) o << i + 1 << ", 3, " << force_N * fz[i] / area << "\n";
  o << "*NODE PRINT, NSET=NRIM, TOTALS=ONLY\nRF\n*NODE PRINT, NSET=NCENTER\nU\n*END STEP\n";
  std::ofstream f(path);
  if (!f) throw std::runtime_error("cannot write " + path);
  f << o.str();
}

/// Charge on a square electrode (axis-aligned, centre, side) as pvdfkit defines it
/// (docs/charge-model.md §1; the law is core/piezo.hpp's): Q = ∫ (d31 N11 + d32 N22) / h dA, with
/// N = h Q E the 2nd Piola–Kirchhoff membrane resultant in material axes and E = ½(FᵀF − I) the
/// mid-surface Green–Lagrange strain of (u_x, u_y, w) interpolated by the 8-node shape functions.
/// Midpoint rule on samples × samples points (the law is linear: the mean N times the area).
inline double electrode_charge_C(const ShellMesh& m, const std::vector<std::array<double, 3>>& u,
                                 const pvdf::Material& mat, double thickness_m, std::array<double, 2> centre,
                                 double side_m, int samples = 40) {
  std::vector<int> cand;
  for (std::size_t e = 0; e < m.elements.size(); ++e) {
    double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
    for (int i = 0; i < 8; ++i) {
      x0 = std::min(x0, m.nodes[m.elements[e][i]][0]);
      x1 = std::max(x1, m.nodes[m.elements[e][i]][0]);
      y0 = std::min(y0, m.nodes[m.elements[e][i]][1]);
      y1 = std::max(y1, m.nodes[m.elements[e][i]][1]);
    }
    // Curved edges bulge a little beyond the nodes' box: a margin of a tenth of the box.
    const double mx = 0.1 * (x1 - x0), my = 0.1 * (y1 - y0);
    if (x1 + mx >= centre[0] - side_m / 2 && x0 - mx <= centre[0] + side_m / 2 && y1 + my >= centre[1] - side_m / 2 &&
        y0 - my <= centre[1] + side_m / 2)
      cand.push_back(static_cast<int>(e));
  }
  const Eigen::Matrix3d Q = mat.stiffness();
  const double c = std::cos(mat.draw_angle_rad), s = std::sin(mat.draw_angle_rad);
  Eigen::Matrix2d R;
  R << c, s, -s, c;
  double sum11 = 0, sum22 = 0;  // Σ N11, Σ N22 over the samples
  int found = 0;
  for (int i = 0; i < samples; ++i)
    for (int j = 0; j < samples; ++j) {
      const Eigen::Vector2d target(centre[0] + side_m * ((i + 0.5) / samples - 0.5),
                                   centre[1] + side_m * ((j + 0.5) / samples - 0.5));
      for (int e : cand) {
        const auto& el = m.elements[e];
        double xi = 0, eta = 0, N[8], dN[8][2];
        Eigen::Matrix2d J;
        bool converged = false;
        for (int it = 0; it < 30; ++it) {
          Eigen::Vector2d x;
          J = shell_jacobian(m, el, xi, eta, N, dN, &x);
          const Eigen::Vector2d d = J.inverse() * (target - x);
          xi += d[0];
          eta += d[1];
          if (std::abs(xi) > 3 || std::abs(eta) > 3) break;
          if (d.norm() < 1e-12) {
            converged = true;
            break;
          }
        }
        if (!converged || std::abs(xi) > 1 + 1e-9 || std::abs(eta) > 1 + 1e-9) continue;
        J = shell_jacobian(m, el, xi, eta, N, dN);
        const Eigen::Matrix2d Jinv = J.inverse();
        Eigen::Matrix<double, 3, 2> F = Eigen::Matrix<double, 3, 2>::Zero();
        F(0, 0) = 1;
        F(1, 1) = 1;
        for (int k = 0; k < 8; ++k) {
          const Eigen::RowVector2d dNdX = Eigen::RowVector2d(dN[k][0], dN[k][1]) * Jinv;
          for (int c3 = 0; c3 < 3; ++c3) F.row(c3) += u[el[k]][c3] * dNdX;
        }
        const Eigen::Matrix2d E = 0.5 * (F.transpose() * F - Eigen::Matrix2d::Identity());
        const Eigen::Matrix2d Em = R * E * R.transpose();  // material axes
        const Eigen::Vector3d Nm = thickness_m * Q * Eigen::Vector3d(Em(0, 0), Em(1, 1), 2 * Em(0, 1));
        sum11 += Nm[0];
        sum22 += Nm[1];
        ++found;
        break;
      }
    }
  if (found != samples * samples) throw std::runtime_error("electrode_charge_C: a sample point lies in no element");
  return pvdf::piezo_charge_C(side_m * side_m, sum11 / found, sum22 / found, thickness_m, mat.d31_C_per_N,
                              mat.d32_C_per_N);
}

}  // namespace pvdf::bench
