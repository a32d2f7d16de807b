// ccx_clamp_reference — stored CalculiX references for presses near the clamp (issue 29, item 4):
// the seed-001 film (examples/scenes/seed001.json: 45 mm, 25 µm, orthotropic drawn PVDF, three
// 2 mm electrodes), a 1 N probe within 8 mm of the clamp, solved by CalculiX (S8R shells, bending
// kept, NLGEOM; ccx_shell.hpp) on spoke meshes that conform to the footprint and are graded to a
// given radial size along the whole rim, at two or more levels per press. Writes per level the
// electrode charges (pvdfkit's definition, docs/charge-model.md §1), the deflection under the probe,
// the rim reaction, the mesh, and ccx's run time, as JSON (tests/fem/data/ccx_clamp_reference.json;
// test_fem_ccx_clamp compares `pvdfkit solve` with it).
//
// Usage: ccx_clamp_reference [--press X_M,Y_M]... [--level SPOKES:RIM_M]... [--out FILE] [--work DIR]
//                            [--append] [--reuse] [--mesh-only]
//   --append: keep the presses already in FILE that this run does not redo.
//   --mesh-only: print the meshes' sizes and quality, run nothing.
//   --reuse: where DIR holds a finished run of the identical deck, read its results instead of rerunning.
// Run it with OMP_NUM_THREADS=1 under nice: ccx is started with one thread, one run at a time.
#include "ccx_shell.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/scene.hpp"

#include <nlohmann/json.hpp>

#include <sys/resource.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

namespace {

double children_cpu_s() {
  rusage r{};
  getrusage(RUSAGE_CHILDREN, &r);
  return static_cast<double>(r.ru_utime.tv_sec + r.ru_stime.tv_sec) + 1e-6 * static_cast<double>(r.ru_utime.tv_usec + r.ru_stime.tv_usec);
}

/// "Version 2.20" from ccx's log, and the number of increments of the last step from its .sta file.
std::string ccx_version(const std::string& log) {
  std::ifstream in(log);
  std::string line;
  while (std::getline(in, line))
    if (const auto at = line.find("Version"); at != std::string::npos) return line.substr(at);
  return "unknown";
}

int last_step_increments(const std::string& sta) {
  std::ifstream in(sta);
  std::string line;
  int count = 0, step = -1;
  while (std::getline(in, line)) {
    std::istringstream is(line);
    int s = 0, inc = 0;
    if (!(is >> s >> inc)) continue;
    if (s != step) count = 0;
    step = s;
    ++count;
  }
  return count;
}

struct Level {
  int spokes;
  double rim_m;
};

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::array<double, 2>> presses;
  std::vector<Level> levels;
  std::string out = "ccx_clamp_reference.json", work = "/tmp/ccx_clamp_work";
  bool append = false, mesh_only = false, reuse = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--press" && i + 1 < argc) {
      double x = 0, y = 0;
      if (std::sscanf(argv[++i], "%lf,%lf", &x, &y) != 2) return 2;
      presses.push_back({x, y});
    } else if (a == "--level" && i + 1 < argc) {
      Level l{};
      if (std::sscanf(argv[++i], "%d:%lf", &l.spokes, &l.rim_m) != 2) return 2;
      levels.push_back(l);
    } else if (a == "--out" && i + 1 < argc) {
      out = argv[++i];
    } else if (a == "--work" && i + 1 < argc) {
      work = argv[++i];
    } else if (a == "--append") {
      append = true;
    } else if (a == "--reuse") {
      reuse = true;
    } else if (a == "--mesh-only") {
      mesh_only = true;
    } else {
      std::cerr << "usage: ccx_clamp_reference [--press X_M,Y_M]... [--level SPOKES:RIM_M]... [--out FILE] "
                   "[--work DIR] [--append] [--reuse] [--mesh-only]\n";
      return 2;
    }
  }
  if (presses.empty()) presses = {{0.0, -0.040}, {0.028, 0.028}, {-0.038, 0.008}};
  if (levels.empty()) levels = {{32, 6e-4}, {48, 3e-4}, {64, 1.5e-4}};
  const std::string scene_file = std::string(PVDF_SOURCE_DIR) + "/examples/scenes/seed001.json";
  const pvdf::Scene scene = pvdf::load_scene(scene_file);
  const double a = scene.membrane.outline.radius_m, c = scene.probe.radius_m, h = scene.membrane.thickness_m;
  const double force = 1.0;
  std::filesystem::create_directories(work);

  nlohmann::json j;
  if (append && std::filesystem::exists(out)) j = nlohmann::json::parse(std::ifstream(out));
  j["description"] =
      "CalculiX S8R (8-node shells, bending kept, NLGEOM) references for 1 N presses near the clamp of the seed-001 film "
      "(examples/scenes/seed001.json, orthotropic, draw along x), written by bench/fem/ccx_clamp_reference.cpp (mesh and "
      "deck: bench/fem/ccx_shell.hpp). Spoke meshes conform to the probe footprint and are graded to rim_size_m across "
      "the whole clamped rim; rim nodes clamped (DOFs 1-6: translations and rotations; 1-3 alone leave CalculiX's rim "
      "hinged); dead vertical consistent nodal forces of a uniform pressure on the footprint, "
      "scaled to sum to force_N; a thermal pretension in step 1, released in step 2 with the load. Charges as pvdfkit "
      "defines them (docs/charge-model.md): Q = integral over the electrode of (d31 N11 + d32 N22)/h, N the 2nd "
      "Piola-Kirchhoff membrane force from the mid-surface Green-Lagrange strain of CalculiX's nodal displacements "
      "(8-node interpolation), 40 x 40 midpoint samples per electrode. level_change = max over electrodes of "
      "|Q(finest) - Q(next)| / max |Q(finest)|: the reference's own discretization error is taken as that change.";
  j["made_by"] = "OMP_NUM_THREADS=1 nice -n 5 build/bench/fem/ccx_clamp_reference --press X,Y --level 32:6e-4 --level "
                 "48:3e-4 --level 64:1.5e-4 --out tests/fem/data/ccx_clamp_reference.json --append (one press per run; "
                 "levels = spokes:rim cell size in m)";
  j["scene"] = "examples/scenes/seed001.json";
  j["force_N"] = force;
  j["thickness_m"] = h;
  j["radius_m"] = a;
  j["probe_radius_m"] = c;
  j["material"] = {{"E1_Pa", scene.material.E1_Pa}, {"E2_Pa", scene.material.E2_Pa},
                   {"G12_Pa", scene.material.G12_Pa}, {"nu12", scene.material.nu12},
                   {"draw_angle_rad", scene.material.draw_angle_rad}, {"d31_C_per_N", scene.material.d31_C_per_N},
                   {"d32_C_per_N", scene.material.d32_C_per_N}};
  nlohmann::json electrodes = nlohmann::json::array();
  for (const auto& e : scene.electrodes)
    electrodes.push_back({{"name", e.name}, {"center_m", {e.center_m[0], e.center_m[1]}}, {"side_m", e.size_m[0]}});
  j["electrodes"] = electrodes;
  if (!j.contains("presses")) j["presses"] = nlohmann::json::array();

  for (const auto& p : presses) {
    nlohmann::json press{{"x_m", p[0]}, {"y_m", p[1]}, {"force_N", force},
                         {"distance_to_clamp_m", a - std::hypot(p[0], p[1])}, {"levels", nlohmann::json::array()}};
    for (const auto& lv : levels) {
      const auto mesh = pvdf::bench::make_spoke_mesh(a, c, p, lv.spokes, lv.rim_m);
      std::printf("press (%g, %g) mm, level %d spokes / rim %.3g mm: %zu S8R, %zu nodes, rim cells <= %.4g mm, aspect "
                  "<= %.1f, min det J ratio %.3f\n",
                  p[0] * 1e3, p[1] * 1e3, lv.spokes, lv.rim_m * 1e3, mesh.elements.size(), mesh.nodes.size(),
                  mesh.rim_size_m * 1e3, mesh.max_rim_aspect, mesh.min_jacobian_ratio);
      std::fflush(stdout);
      if (mesh.min_jacobian_ratio <= 0.05) {
        std::cerr << "error: a distorted element (det J ratio " << mesh.min_jacobian_ratio << ")\n";
        return 3;
      }
      if (mesh_only) continue;
      char job[128];
      std::snprintf(job, sizeof job, "clamp_%+.0f_%+.0f_n%d", p[0] * 1e3, p[1] * 1e3, lv.spokes);
      // --reuse: results of an earlier run of the same deck (its times kept in <job>.time).
      const std::string deck = work + "/" + job + ".inp", stamp = work + "/" + job + ".time";
      std::ostringstream deck_text;
      pvdf::bench::write_s8r_deck(deck + ".new", mesh, scene.material, h, force);
      deck_text << std::ifstream(deck + ".new").rdbuf();
      std::ostringstream old_text;
      if (std::filesystem::exists(deck)) old_text << std::ifstream(deck).rdbuf();
      pvdf::bench::CcxResult r;
      double cpu = 0;
      if (reuse && old_text.str() == deck_text.str() && std::filesystem::exists(stamp)) {
        double wall = 0;
        std::ifstream(stamp) >> wall >> cpu;
        r = pvdf::bench::read_ccx_results(work, job, mesh);
        r.wall_s = wall;
      } else {
        std::filesystem::rename(deck + ".new", deck);
        const double cpu0 = children_cpu_s();
        r = pvdf::bench::run_ccx(work, job, mesh);
        cpu = children_cpu_s() - cpu0;
        std::ofstream(stamp) << r.wall_s << " " << cpu << "\n";
      }
      std::filesystem::remove(deck + ".new");
      if (!r.ok) {
        std::cerr << "error: " << r.message << "\n";
        return 3;
      }
      j["ccx_version"] = ccx_version(work + "/" + job + ".log");
      nlohmann::json charges = nlohmann::json::array();
      for (const auto& e : scene.electrodes)
        charges.push_back(pvdf::bench::electrode_charge_C(mesh, r.displacement_m, scene.material, h, e.center_m,
                                                        e.size_m[0]));
      nlohmann::json level{{"spokes", lv.spokes},
                           {"rim_size_m", mesh.rim_size_m},
                           {"max_rim_aspect", mesh.max_rim_aspect},
                           {"min_jacobian_ratio", mesh.min_jacobian_ratio},
                           {"elements", mesh.elements.size()},
                           {"nodes", mesh.nodes.size()},
                           {"ccx_wall_s", r.wall_s},
                           {"ccx_cpu_s", cpu},
                           {"increments", last_step_increments(work + "/" + std::string(job) + ".sta")},
                           {"rim_reaction_N", r.rim_reaction_N},
                           {"deflection_at_load_m", std::abs(r.centre_deflection_m)},
                           {"charge_C", charges}};
      press["levels"].push_back(level);
      std::printf("  ccx %.0f s wall, %.0f s CPU, %d increments, rim reaction %.6f N, w %.6f mm, Q = %.5f %.5f %.5f pC\n",
                  r.wall_s, cpu, level["increments"].get<int>(), r.rim_reaction_N, std::abs(r.centre_deflection_m) * 1e3,
                  charges[0].get<double>() * 1e12, charges[1].get<double>() * 1e12, charges[2].get<double>() * 1e12);
      std::fflush(stdout);
    }
    if (mesh_only) continue;
    const auto& L = press["levels"];
    const auto& fine = L.back();
    press["charge_C"] = fine["charge_C"];
    press["deflection_at_load_m"] = fine["deflection_at_load_m"];
    if (L.size() >= 2) {
      const auto& prev = L[L.size() - 2];
      double scale = 0, change = 0;
      for (std::size_t k = 0; k < fine["charge_C"].size(); ++k) {
        scale = std::max(scale, std::abs(fine["charge_C"][k].get<double>()));
        change = std::max(change, std::abs(fine["charge_C"][k].get<double>() - prev["charge_C"][k].get<double>()));
      }
      press["level_change"] = change / scale;
    }
    auto& all = j["presses"];
    for (auto it = all.begin(); it != all.end(); ++it)
      if (std::abs((*it)["x_m"].get<double>() - p[0]) < 1e-9 && std::abs((*it)["y_m"].get<double>() - p[1]) < 1e-9) {
        all.erase(it);
        break;
      }
    all.push_back(press);
    std::ofstream(out) << j.dump(2) << "\n";  // after every press: a long run keeps what it has
  }
  return 0;
}
