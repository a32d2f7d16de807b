// ccx_anisotropy_reference — the stored CalculiX reference for an anisotropic (drawn) film: the
// seed-001 film (25 µm, 45 mm, orthotropic Table 1 material) with its draw direction at 30° to x,
// a 1 N probe at the centre, solved by CalculiX 2.20 (M3D4 membranes, NLGEOM, the deck of
// ccx_peer.hpp) on conforming polar meshes of increasing level. Writes the centre deflection and
// every electrode's mean 2nd Piola–Kirchhoff membrane force in material axes per level, as JSON
// (tests/fem/data/ccx_anisotropic_reference.json; test_fem_ccx_anisotropy compares pvdfkit with it).
//
// Usage: ccx_anisotropy_reference [--levels 16,24,32] [--out FILE] [--work DIR]
#include "pvdf/core/constants.hpp"
#include "ccx_peer.hpp"

#include "pvdf/core/scene.hpp"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  std::vector<int> levels{16, 24, 32};
  std::string out = "ccx_anisotropic_reference.json", work = "ccx_aniso_work";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--levels" && i + 1 < argc) {
      levels.clear();
      std::stringstream in(argv[++i]);
      std::string item;
      while (std::getline(in, item, ',')) levels.push_back(std::stoi(item));
    } else if (a == "--out" && i + 1 < argc) {
      out = argv[++i];
    } else if (a == "--work" && i + 1 < argc) {
      work = argv[++i];
    } else {
      std::cerr << "usage: ccx_anisotropy_reference [--levels 16,24,32] [--out FILE] [--work DIR]\n";
      return 2;
    }
  }
  pvdf::Scene scene = pvdf::default_scene();
  scene.material.draw_angle_rad = 30.0 * pvdf::pi / 180.0;
  const double a = scene.membrane.outline.radius_m, c = scene.probe.radius_m, h = scene.membrane.thickness_m;
  const double force = 1.0;
  std::filesystem::create_directories(work);
  nlohmann::json j;
  j["description"] = "CalculiX 2.20 M3D4 membrane (NLGEOM, dead vertical load on the probe disk) reference for an "
                     "orthotropic film drawn at 30 deg to x; written by bench/fem/ccx_anisotropy_reference.cpp";
  j["thickness_m"] = h;
  j["radius_m"] = a;
  j["probe_radius_m"] = c;
  j["force_N"] = force;
  j["draw_angle_rad"] = scene.material.draw_angle_rad;
  j["material"] = {{"E1_Pa", scene.material.E1_Pa}, {"E2_Pa", scene.material.E2_Pa},
                   {"G12_Pa", scene.material.G12_Pa}, {"nu12", scene.material.nu12}};
  nlohmann::json electrodes = nlohmann::json::array();
  for (const auto& e : scene.electrodes) {
    electrodes.push_back({{"name", e.name}, {"center_m", {e.center_m[0], e.center_m[1]}}, {"side_m", e.size_m[0]}});
  }
  j["electrodes"] = electrodes;
  j["levels"] = nlohmann::json::array();
  const Eigen::Matrix3d Q = scene.material.stiffness();
  for (int n : levels) {
    const auto mesh = pvdf::bench::make_polar_mesh(a, c, n);
    pvdf::bench::CcxMaterial mat;
    mat.isotropic = false;
    mat.ortho = scene.material;
    const std::string job = "aniso_n" + std::to_string(n);
    pvdf::bench::write_ccx_deck(work + "/" + job + ".inp", mesh, mat, h, force);
    const auto r = pvdf::bench::run_ccx(work, job, mesh);
    if (!r.ok) {
      std::cerr << "error: ccx level n=" << n << ": " << r.message << "\n";
      return 3;
    }
    nlohmann::json level{{"n", n}, {"dofs", r.n_dofs}, {"wall_s", r.wall_s}, {"rim_reaction_N", r.rim_reaction_N},
                         {"centre_deflection_m", std::abs(r.centre_deflection_m)}};
    nlohmann::json forces = nlohmann::json::array();
    for (const auto& e : scene.electrodes) {
      const auto f = pvdf::bench::electrode_mean_force(mesh, r.displacement_m, Q, h, scene.material.draw_angle_rad,
                                                       e.center_m, e.size_m[0], 48);
      forces.push_back({f[0], f[1], f[2]});
    }
    level["mean_membrane_force_material_N_per_m"] = forces;
    j["levels"].push_back(level);
    std::printf("n=%d: %zu DOFs, %.1f s, w0 %.6g mm, rim %.6f N\n", n, r.n_dofs, r.wall_s,
                std::abs(r.centre_deflection_m) * 1e3, r.rim_reaction_N);
    std::ofstream(out) << j.dump(2) << "\n";  // after every level: a long run keeps what it has
  }
  return 0;
}
