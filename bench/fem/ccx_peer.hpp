// CalculiX (ccx 2.20) as the peer FEM tool for the seed-001 film: a conforming polar quad mesh,
// an M3D4 membrane deck (thermal pretension pre-step released in the load step, NLGEOM, dead
// vertical nodal loads on the probe disk), the run, and the parsing of its results.
// Why: with CalculiX 2.20 S8R shells converge from the flat film unaided but slowly; M3D4 membranes need a
// small pretension to start; a *DLOAD on membranes in the first step is silently dropped (so an empty step
// comes first and the rim reaction is checked against the applied force).
#pragma once

#include "pvdf/core/constants.hpp"
#include "pvdf/core/material.hpp"

#include <Eigen/Dense>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace pvdf::bench {

/// A quad mesh of the disk r < a conforming to the probe circle r = c (nodes on it).
struct PolarMesh {
  std::vector<std::array<double, 2>> nodes;  ///< m
  std::vector<std::array<int, 4>> quads;     ///< 0-based, counter-clockwise
  std::vector<bool> loaded;                  ///< quad lies in the probe disk
  std::vector<int> rim_nodes;
  int centre_node = -1;
};

/// Central square (half-width c/2, n×n quads), a transfinite ring out to the circle r = c, then
/// log-spaced rings to r = a (aspect ratio ≈ 1). `n` = quads per quarter circle.
inline PolarMesh make_polar_mesh(double a, double c, int n) {
  PolarMesh m;
  const double s = 0.5 * c;
  auto grid = [&](int i, int j) { return j * (n + 1) + i; };
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.nodes.push_back({-s + 2 * s * i / n, -s + 2 * s * j / n});
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) m.quads.push_back({grid(i, j), grid(i + 1, j), grid(i + 1, j + 1), grid(i, j + 1)});
  if (n % 2 == 0) m.centre_node = grid(n / 2, n / 2);
  // Perimeter of the square, counter-clockwise from the corner (−s, −s).
  std::vector<int> layer;
  for (int i = 0; i < n; ++i) layer.push_back(grid(i, 0));
  for (int j = 0; j < n; ++j) layer.push_back(grid(n, j));
  for (int i = n; i > 0; --i) layer.push_back(grid(i, n));
  for (int j = n; j > 0; --j) layer.push_back(grid(0, j));
  const int np = 4 * n;
  std::vector<std::array<double, 2>> square_pts, circle_dirs;
  for (int k = 0; k < np; ++k) {
    square_pts.push_back(m.nodes[layer[k]]);
    const double th = -0.75 * pi + 2 * pi * k / np;
    circle_dirs.push_back({std::cos(th), std::sin(th)});
  }
  auto add_ring = [&](const std::vector<int>& inner, bool loaded, auto point_of_k) {
    std::vector<int> outer(np);
    for (int k = 0; k < np; ++k) {
      outer[k] = static_cast<int>(m.nodes.size());
      m.nodes.push_back(point_of_k(k));
    }
    for (int k = 0; k < np; ++k) {
      const int k1 = (k + 1) % np;
      m.quads.push_back({inner[k], outer[k], outer[k1], inner[k1]});
      m.loaded.push_back(loaded);
    }
    return outer;
  };
  m.loaded.assign(m.quads.size(), true);
  const int m1 = std::max(1, n / 4);
  for (int l = 1; l <= m1; ++l) {
    const double t = static_cast<double>(l) / m1;
    layer = add_ring(layer, true, [&](int k) {
      return std::array<double, 2>{(1 - t) * square_pts[k][0] + t * c * circle_dirs[k][0],
                                   (1 - t) * square_pts[k][1] + t * c * circle_dirs[k][1]};
    });
  }
  const int m2 = std::max(2, static_cast<int>(std::lround(np * std::log(a / c) / (2 * pi))));
  for (int l = 1; l <= m2; ++l) {
    const double r = c * std::pow(a / c, static_cast<double>(l) / m2);
    layer = add_ring(layer, false, [&](int k) {
      return std::array<double, 2>{r * circle_dirs[k][0], r * circle_dirs[k][1]};
    });
  }
  m.rim_nodes = layer;
  return m;
}

/// Bilinear quad: shape functions and their derivatives at (ξ, η) ∈ [−1, 1]².
inline void bilinear(double xi, double eta, double N[4], double dN[4][2]) {
  const double sx[4] = {-1, 1, 1, -1}, sy[4] = {-1, -1, 1, 1};
  for (int i = 0; i < 4; ++i) {
    N[i] = 0.25 * (1 + sx[i] * xi) * (1 + sy[i] * eta);
    dN[i][0] = 0.25 * sx[i] * (1 + sy[i] * eta);
    dN[i][1] = 0.25 * sy[i] * (1 + sx[i] * xi);
  }
}

/// What the peer run produced.
struct CcxResult {
  bool ok = false;
  std::string message;
  double wall_s = 0;
  double centre_deflection_m = 0;  ///< w at the centre node
  double rim_reaction_N = 0;       ///< |Σ RF_z| over the rim nodes
  std::vector<std::array<double, 3>> displacement_m;  ///< per node
  std::size_t n_dofs = 0;          ///< 3 × nodes of the 2-D mesh (ccx expands to 6 × nodes internally)
};

/// Material for the deck: orthotropic (draw along x) or isotropic.
struct CcxMaterial {
  bool isotropic = false;
  double E_Pa = 2e9, nu = 0.3;  ///< isotropic
  pvdf::Material ortho;         ///< orthotropic, seed 001 Table 1 with reciprocal ν21
};

/// Writes the CalculiX deck `<dir>/<job>.inp`.
inline void write_ccx_deck(const std::string& path, const PolarMesh& m, const CcxMaterial& mat, double thickness_m,
                           double force_N) {
  std::ostringstream o;
  o.precision(12);
  o << "*HEADING\npvdfkit bench_fem: clamped film, dead vertical probe load on a disk\n*NODE, NSET=NALL\n";
  for (std::size_t i = 0; i < m.nodes.size(); ++i) o << i + 1 << ", " << m.nodes[i][0] << ", " << m.nodes[i][1] << ", 0\n";
  o << "*ELEMENT, TYPE=M3D4, ELSET=EFILM\n";
  for (std::size_t e = 0; e < m.quads.size(); ++e)
    o << e + 1 << ", " << m.quads[e][0] + 1 << ", " << m.quads[e][1] + 1 << ", " << m.quads[e][2] + 1 << ", "
      << m.quads[e][3] + 1 << "\n";
  o << "*NSET, NSET=NRIM\n";
  for (std::size_t k = 0; k < m.rim_nodes.size(); ++k) o << m.rim_nodes[k] + 1 << (k % 10 == 9 ? ",\n" : ", ");
  o << "\n*NSET, NSET=NCENTER\n" << m.centre_node + 1 << "\n";
  o << "*MATERIAL, NAME=FILM\n";
  if (mat.isotropic) {
    o << "*ELASTIC\n" << mat.E_Pa << ", " << mat.nu << "\n";
  } else {
    // All nine 3-D constants (ccx needs them); the out-of-plane ones barely matter for a membrane
    // (σ33 ≈ 0): E3 = E2, ν13 = ν12, ν23 = ν21 (reciprocal), G13 = G12, G23 = E2 / (2 (1 + ν23)).
    const auto& M = mat.ortho;
    const double nu23 = M.nu21();
    o << "*ELASTIC, TYPE=ENGINEERING CONSTANTS\n"
      << M.E1_Pa << ", " << M.E2_Pa << ", " << M.E2_Pa << ", " << M.nu12 << ", " << M.nu12 << ", " << nu23 << ", "
      << M.G12_Pa << ", " << M.G12_Pa << ",\n"
      << M.E2_Pa / (2 * (1 + nu23)) << ", 0.\n";
  }
  o << "*EXPANSION\n1.e-5\n";
  const double th = mat.isotropic ? 0.0 : mat.ortho.draw_angle_rad;
  o << "*ORIENTATION, NAME=DRAW\n" << std::cos(th) << ", " << std::sin(th) << ", 0., " << -std::sin(th) << ", "
    << std::cos(th) << ", 0.\n";
  o << "*MEMBRANE SECTION, ELSET=EFILM, MATERIAL=FILM, ORIENTATION=DRAW\n" << thickness_m << "\n";
  o << "*BOUNDARY\nNRIM, 1, 3\n";
  o << "*INITIAL CONDITIONS, TYPE=TEMPERATURE\nNALL, 0.\n";
  // Step 1: a thermal pretension (≈14 N/m against ~200 N/m under load) so the flat membrane
  // has a tangent; it also keeps loads out of the first step, where ccx drops them. It is fully
  // released by the end of step 2 (elastic: the final state does not depend on the path).
  o << "*STEP, NLGEOM\n*STATIC\n1., 1.\n*TEMPERATURE\nNALL, -20.\n*END STEP\n";
  // Step 2: release the pretension while ramping the load (dead vertical nodal forces).
  o << "*STEP, NLGEOM, INC=2000\n*STATIC\n0.05, 1., 1.e-7, 0.25\n*TEMPERATURE\nNALL, 0.\n";
  // Consistent nodal forces of a uniform pressure on the loaded quads, scaled so Σ = F exactly
  // (the polygonal disk is a little smaller than π c²).
  std::vector<double> fz(m.nodes.size(), 0.0);
  double area = 0;
  const double g = 1 / std::sqrt(3.0);
  for (std::size_t e = 0; e < m.quads.size(); ++e) {
    if (!m.loaded[e]) continue;
    for (double xi : {-g, g})
      for (double eta : {-g, g}) {
        double N[4], dN[4][2];
        bilinear(xi, eta, N, dN);
        Eigen::Matrix2d J = Eigen::Matrix2d::Zero();
        for (int i = 0; i < 4; ++i)
          for (int d = 0; d < 2; ++d) {
            J(d, 0) += m.nodes[m.quads[e][i]][d] * dN[i][0];
            J(d, 1) += m.nodes[m.quads[e][i]][d] * dN[i][1];
          }
        const double dA = J.determinant();
        area += dA;
        for (int i = 0; i < 4; ++i) fz[m.quads[e][i]] += N[i] * dA;
      }
  }
  o << "*CLOAD\n";
  for (std::size_t i = 0; i < fz.size(); ++i)
    if (fz[i] != 0) o << i + 1 << ", 3, " << force_N * fz[i] / area << "\n";
  o << "*NODE FILE\nU\n*NODE PRINT, NSET=NRIM, TOTALS=ONLY\nRF\n*NODE PRINT, NSET=NCENTER\nU\n*END STEP\n";
  std::ofstream f(path);
  if (!f) throw std::runtime_error("cannot write " + path);
  f << o.str();
}

/// Last DISP block of a .frd file: node id (1-based) → displacement.
inline std::map<int, std::array<double, 3>> read_frd_displacements(const std::string& path) {
  std::ifstream f(path);
  std::map<int, std::array<double, 3>> out, current;
  std::string line;
  bool in_disp = false;
  while (std::getline(f, line)) {
    const auto first = line.find_first_not_of(' ');
    if (first == std::string::npos) continue;
    const std::string body = line.substr(first);
    if (body.rfind("-4  DISP", 0) == 0) {
      in_disp = true;
      current.clear();
      continue;
    }
    if (!in_disp) continue;
    if (body.rfind("-3", 0) == 0) {
      in_disp = false;
      out = current;
      continue;
    }
    if (line.rfind(" -1", 0) == 0 && line.size() >= 13 + 36) {
      const int id = std::stoi(line.substr(3, 10));
      current[id] = {std::stod(line.substr(13, 12)), std::stod(line.substr(25, 12)), std::stod(line.substr(37, 12))};
    }
  }
  return out;
}

/// Last "total force" line for set NRIM in a .dat file.
inline std::optional<std::array<double, 3>> read_dat_rim_total(const std::string& path) {
  std::ifstream f(path);
  std::string line;
  std::optional<std::array<double, 3>> out;
  bool next = false;
  while (std::getline(f, line)) {
    if (line.find("total force") != std::string::npos && line.find("NRIM") != std::string::npos) {
      next = true;
      continue;
    }
    if (next && line.find_first_not_of(" \t\r") != std::string::npos) {
      std::istringstream is(line);
      std::array<double, 3> v{};
      if (is >> v[0] >> v[1] >> v[2]) out = v;
      next = false;
    }
  }
  return out;
}

template <class Mesh>
CcxResult read_ccx_results(const std::string& dir, const std::string& job, const Mesh& m);

/// Runs ccx on `<dir>/<job>.inp` with one thread; wall time of the run only. Mesh: PolarMesh or
/// any mesh with `nodes` and `centre_node` (ccx_shell.hpp's ShellMesh).
template <class Mesh>
CcxResult run_ccx(const std::string& dir, const std::string& job, const Mesh& m) {
  CcxResult r;
  const std::string cmd = "cd '" + dir + "' && OMP_NUM_THREADS=1 CCX_NPROC_EQUATION_SOLVER=1 CCX_NPROC_RESULTS=1 ccx -i " +
                          job + " > " + job + ".log 2>&1";
  const auto t0 = std::chrono::steady_clock::now();
  const int status = std::system(cmd.c_str());
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (status != 0) {
    r.message = "ccx failed (see " + dir + "/" + job + ".log)";
    r.wall_s = wall_s;
    return r;
  }
  r = read_ccx_results(dir, job, m);
  r.wall_s = wall_s;
  return r;
}

/// The results of a finished ccx run of `<dir>/<job>` (.frd displacements, .dat rim reaction).
template <class Mesh>
CcxResult read_ccx_results(const std::string& dir, const std::string& job, const Mesh& m) {
  CcxResult r;
  r.n_dofs = 3 * m.nodes.size();
  const auto disp = read_frd_displacements(dir + "/" + job + ".frd");
  const auto rim = read_dat_rim_total(dir + "/" + job + ".dat");
  if (disp.size() != m.nodes.size() || !rim) {
    r.message = "ccx failed or produced no results (see " + dir + "/" + job + ".log)";
    return r;
  }
  r.displacement_m.resize(m.nodes.size());
  for (const auto& [id, u] : disp) r.displacement_m[id - 1] = u;
  r.centre_deflection_m = r.displacement_m[m.centre_node][2];
  r.rim_reaction_N = std::abs((*rim)[2]);
  r.ok = true;
  return r;
}

/// Mean 2nd Piola–Kirchhoff membrane forces [N11, N22, N12] (N/m, material axes = global axes
/// rotated by `draw_angle_rad`) over a square electrode, from nodal displacements of a bilinear
/// quad mesh: Green–Lagrange strain of the mid-surface (u_x, u_y, w all in F), plane-stress Q.
/// Sampled on an s×s grid of points in the square; the quad containing each point is found by
/// inverting the bilinear map.
inline std::array<double, 3> electrode_mean_force(const PolarMesh& m, const std::vector<std::array<double, 3>>& u,
                                                  const Eigen::Matrix3d& Q_material, double thickness_m,
                                                  double draw_angle_rad, std::array<double, 2> centre,
                                                  double side_m, int samples = 24) {
  const double cth = std::cos(draw_angle_rad), sth = std::sin(draw_angle_rad);
  // Candidate quads: bounding box overlaps the square.
  std::vector<int> cand;
  for (std::size_t e = 0; e < m.quads.size(); ++e) {
    double x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;
    for (int i = 0; i < 4; ++i) {
      x0 = std::min(x0, m.nodes[m.quads[e][i]][0]);
      x1 = std::max(x1, m.nodes[m.quads[e][i]][0]);
      y0 = std::min(y0, m.nodes[m.quads[e][i]][1]);
      y1 = std::max(y1, m.nodes[m.quads[e][i]][1]);
    }
    if (x1 >= centre[0] - side_m / 2 && x0 <= centre[0] + side_m / 2 && y1 >= centre[1] - side_m / 2 &&
        y0 <= centre[1] + side_m / 2)
      cand.push_back(static_cast<int>(e));
  }
  std::array<double, 3> sum{0, 0, 0};
  int count = 0;
  for (int i = 0; i < samples; ++i)
    for (int j = 0; j < samples; ++j) {
      const double px = centre[0] + side_m * ((i + 0.5) / samples - 0.5);
      const double py = centre[1] + side_m * ((j + 0.5) / samples - 0.5);
      for (int e : cand) {
        double xi = 0, eta = 0, N[4], dN[4][2];
        Eigen::Matrix2d J;
        for (int it = 0; it < 20; ++it) {
          bilinear(xi, eta, N, dN);
          double x = 0, y = 0;
          J.setZero();
          for (int k = 0; k < 4; ++k) {
            const auto& X = m.nodes[m.quads[e][k]];
            x += N[k] * X[0];
            y += N[k] * X[1];
            J(0, 0) += X[0] * dN[k][0];
            J(0, 1) += X[0] * dN[k][1];
            J(1, 0) += X[1] * dN[k][0];
            J(1, 1) += X[1] * dN[k][1];
          }
          const Eigen::Vector2d d = J.inverse() * Eigen::Vector2d(px - x, py - y);
          xi += d[0];
          eta += d[1];
          if (d.norm() < 1e-13) break;
        }
        if (std::abs(xi) > 1 + 1e-9 || std::abs(eta) > 1 + 1e-9) continue;
        bilinear(xi, eta, N, dN);
        const Eigen::Matrix2d Jinv = J.inverse();
        Eigen::Matrix<double, 3, 2> grad = Eigen::Matrix<double, 3, 2>::Zero();  // ∂u_i/∂X_a
        for (int k = 0; k < 4; ++k) {
          const Eigen::RowVector2d dNdX = Eigen::RowVector2d(dN[k][0], dN[k][1]) * Jinv;
          for (int c3 = 0; c3 < 3; ++c3) grad.row(c3) += u[m.quads[e][k]][c3] * dNdX;
        }
        Eigen::Matrix<double, 3, 2> F = grad;
        F(0, 0) += 1;
        F(1, 1) += 1;
        const Eigen::Matrix2d E = 0.5 * (F.transpose() * F - Eigen::Matrix2d::Identity());
        // Strain to material axes (engineering shear), then N = h Q ε.
        Eigen::Matrix2d R;
        R << cth, sth, -sth, cth;
        const Eigen::Matrix2d Em = R * E * R.transpose();
        const Eigen::Vector3d eps(Em(0, 0), Em(1, 1), 2 * Em(0, 1));
        const Eigen::Vector3d Nm = thickness_m * Q_material * eps;
        for (int c3 = 0; c3 < 3; ++c3) sum[c3] += Nm[c3];
        ++count;
        break;
      }
    }
  for (auto& v : sum) v /= std::max(count, 1);
  return sum;
}

}  // namespace pvdf::bench
