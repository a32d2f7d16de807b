// Mesh generation time for the seed-001 scene (target: well under 1 s at the default sizes)
// against uniform size factors, with the geometric error of the mesh: the rim length and film
// area deficit of the polygonal circle, and the area error of a 3 mm circular electrode (the
// seed's electrode C replaced by a circle, a second scene). Rectangular electrodes are exact
// (< 1e-14) at every size and are listed as a check. Median of `repeats` runs.
//
//   ./bench_mesh [repeats=5]
#include "pvdf/core/constants.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/mesh/mesher.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <vector>

namespace {

using pvdf::pi;

double total_area(const pvdf::mesh::FilmMesh& m) {
  double a = pvdf::mesh::material_area_m2(m, pvdf::mesh::film_material_id);
  for (std::size_t k = 0; k < m.electrode_names.size(); ++k) {
    a += pvdf::mesh::material_area_m2(m, pvdf::mesh::electrode_material_id(k));
  }
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  const int repeats = argc > 1 ? std::max(1, std::atoi(argv[1])) : 5;
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  const pvdf::Scene seed = pvdf::default_scene();
  pvdf::Scene circle = seed;
  circle.electrodes[2].shape = pvdf::Electrode::Shape::circle;
  circle.electrodes[2].radius_m = 0.0015;
  const double R = seed.membrane.outline.radius_m;

  std::printf("# pvdf::mesh on the seed-001 scene (Gmsh 4.8, OCC, Frontal-Delaunay + simple full-quad), median of %d runs\n",
              repeats);
  std::printf("%7s %8s %8s %8s %9s %9s %7s %11s %11s %11s %11s\n", "factor", "cells", "wall_s", "cpu_s", "edge_min", "edge_max",
              "min_SJ", "rim_len_err", "area_err", "rect_err", "circ_err");
  for (double factor : {2.0, 1.0, 0.7, 0.5, 0.35}) {
    pvdf::mesh::MeshParameters p;
    p.size_factor = factor;
    std::vector<double> times, cpu_times;
    pvdf::mesh::MeshReport report;
    pvdf::mesh::FilmMesh m;
    for (int r = 0; r < repeats; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      const std::clock_t c0 = std::clock();
      m = pvdf::mesh::build_film_mesh(seed, p, &report);
      cpu_times.push_back(static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
      times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
    std::sort(times.begin(), times.end());
    std::sort(cpu_times.begin(), cpu_times.end());
    const double rim_err = 1 - pvdf::mesh::rim_length_m(m) / (2 * pi * R);
    const double area_err = 1 - total_area(m) / (pi * R * R);
    double rect_err = 0;
    for (std::size_t k = 0; k < 3; ++k) {
      rect_err = std::max(rect_err, std::abs(pvdf::mesh::material_area_m2(m, pvdf::mesh::electrode_material_id(k)) /
                                                 seed.electrodes[k].area_m2() -
                                             1));
    }
    double circ_err = NAN;
    try {
      const auto mc = pvdf::mesh::build_film_mesh(circle, p);
      circ_err = 1 - pvdf::mesh::material_area_m2(mc, pvdf::mesh::electrode_material_id(2)) /
                         circle.electrodes[2].area_m2();
    } catch (const std::exception& e) {
      std::fprintf(stderr, "circle scene at factor %g: %s\n", factor, e.what());
    }
    std::printf("%7.2f %8zu %8.3f %8.3f %9.3g %9.3g %7.3f %11.3g %11.3g %11.3g %11.3g\n", factor, report.n_cells,
                times[times.size() / 2], cpu_times[cpu_times.size() / 2], report.size_min_m, report.size_max_m, report.min_scaled_jacobian, rim_err,
                area_err, rect_err, circ_err);
  }
  return 0;
}
