// Element quality measured from vertex coordinates alone (no Gmsh), so the same numbers can be
// checked on any FilmMesh, including ones the fem refines.
#include "pvdf/mesh/mesher.hpp"

#include <algorithm>
#include <cmath>

namespace pvdf::mesh {

double scaled_jacobian(const std::array<std::array<double, 2>, 4>& p) {
  // At corner c the bilinear map's Jacobian is spanned by the two edges leaving c; normalizing
  // by their lengths gives sin(corner angle), 1 for a rectangle.
  double worst = 1.0;
  for (int c = 0; c < 4; ++c) {
    const auto& o = p[c];
    const auto& next = p[(c + 1) % 4];
    const auto& prev = p[(c + 3) % 4];
    const double ax = next[0] - o[0], ay = next[1] - o[1];
    const double bx = prev[0] - o[0], by = prev[1] - o[1];
    const double la = std::hypot(ax, ay), lb = std::hypot(bx, by);
    if (!(la > 0 && lb > 0)) return 0.0;
    worst = std::min(worst, (ax * by - ay * bx) / (la * lb));
  }
  return worst;
}

void measure_quality(const FilmMesh& mesh, MeshReport& report) {
  report.n_cells = mesh.quads.size();
  report.n_vertices = mesh.vertices.size();
  double h_min = 1e300, h_max = 0, sj_min = 1.0, ar_max = 1.0;
  for (const auto& q : mesh.quads) {
    std::array<std::array<double, 2>, 4> p{mesh.vertices[q[0]], mesh.vertices[q[1]], mesh.vertices[q[2]],
                                           mesh.vertices[q[3]]};
    double e_min = 1e300, e_max = 0;
    for (int c = 0; c < 4; ++c) {
      const double e = std::hypot(p[(c + 1) % 4][0] - p[c][0], p[(c + 1) % 4][1] - p[c][1]);
      e_min = std::min(e_min, e);
      e_max = std::max(e_max, e);
    }
    h_min = std::min(h_min, e_min);
    h_max = std::max(h_max, e_max);
    sj_min = std::min(sj_min, scaled_jacobian(p));
    ar_max = std::max(ar_max, e_min > 0 ? e_max / e_min : 1e300);
  }
  if (mesh.quads.empty()) {
    h_min = 0;
    sj_min = 0;
  }
  report.size_min_m = h_min;
  report.size_max_m = h_max;
  report.min_scaled_jacobian = sj_min;
  report.max_aspect_ratio = ar_max;
}

double material_area_m2(const FilmMesh& mesh, std::uint8_t material_id) {
  // Shoelace per quad, summed with Kahan compensation (many small terms).
  double sum = 0, carry = 0;
  for (std::size_t i = 0; i < mesh.quads.size(); ++i) {
    if (mesh.material_ids[i] != material_id) continue;
    const auto& q = mesh.quads[i];
    double a = 0;
    for (int c = 0; c < 4; ++c) {
      const auto& p = mesh.vertices[q[c]];
      const auto& r = mesh.vertices[q[(c + 1) % 4]];
      a += p[0] * r[1] - r[0] * p[1];
    }
    const double y = 0.5 * a - carry;
    const double t = sum + y;
    carry = (t - sum) - y;
    sum = t;
  }
  return sum;
}

double rim_length_m(const FilmMesh& mesh) {
  double length = 0;
  for (const auto& e : mesh.rim_edges) {
    const auto& a = mesh.vertices[e[0]];
    const auto& b = mesh.vertices[e[1]];
    length += std::hypot(b[0] - a[0], b[1] - a[1]);
  }
  return length;
}

}  // namespace pvdf::mesh
