// Map generation, setup: the scene's mirror symmetry, the grid of positions and its mask, the
// options' checks, and the split over MPI ranks and threads.
#include "generator.hpp"

#include "pvdf/core/assert.hpp"
#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"

#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <thread>

namespace pvdf::mapping::detail {
namespace {

bool same_point_set(const std::vector<Point2>& a, const std::vector<Point2>& b, double tol) {
  if (a.size() != b.size()) return false;
  for (const auto& p : a) {
    bool found = false;
    for (const auto& q : b) {
      if (std::abs(p[0] - q[0]) <= tol && std::abs(p[1] - q[1]) <= tol) {
        found = true;
        break;
      }
    }
    if (!found) return false;
  }
  return true;
}

// Whether the scene is invariant under the mirror `flip` (about_x: y -> -y; else x -> -x);
// fills the electrode permutation. Returns an empty string when it is, else why not.
std::string check_mirror(const pvdf::Scene& scene, bool about_x, std::vector<std::size_t>& perm) {
  const auto mirror = [about_x](Point2 p) { return about_x ? Point2{p[0], -p[1]} : Point2{-p[0], p[1]}; };
  const double tol = 1e-9 * std::max(1e-3, scene.membrane.outline.characteristic_radius_m());
  const auto& outline = scene.membrane.outline;
  if (outline.shape == FilmOutline::Shape::polygon) {
    std::vector<Point2> m;
    for (const auto& v : outline.vertices_m) m.push_back(mirror(v));
    if (!same_point_set(m, outline.vertices_m, tol)) return "the film outline is not mirror-symmetric";
  }
  const auto& mat = scene.material;
  const double r = std::remainder(mat.draw_angle_rad, pi / 2);
  const bool axes_aligned = std::abs(r) < 1e-12;
  const bool fully_isotropic = mat.E1_Pa == mat.E2_Pa && mat.d31_C_per_N == mat.d32_C_per_N &&
                               std::abs(mat.G12_Pa - mat.E1_Pa / (2 * (1 + mat.nu12))) <= 1e-12 * mat.E1_Pa;
  if (!axes_aligned && !fully_isotropic) return "the draw direction is not along x or y";
  const std::size_t ne = scene.electrodes.size();
  perm.assign(ne, ne);
  for (std::size_t k = 0; k < ne; ++k) {
    std::vector<Point2> m;
    for (const auto& v : scene.electrodes[k].outline(64)) m.push_back(mirror(v));
    for (std::size_t l = 0; l < ne; ++l) {
      if (same_point_set(m, scene.electrodes[l].outline(64), tol)) {
        perm[k] = l;
        break;
      }
    }
    if (perm[k] == ne) return "electrode " + scene.electrodes[k].name + " has no mirror image";
  }
  for (std::size_t k = 0; k < ne; ++k) {
    if (perm[perm[k]] != k) return "the electrode mirror images are not a pairing";
  }
  return "";
}

}  // namespace

Symmetry detect_symmetry(const pvdf::Scene& scene, bool wanted) {
  Symmetry s;
  if (!wanted) {
    s.reason = "symmetry not used (MapOptions::use_symmetry off)";
    return s;
  }
  const std::string why_x = check_mirror(scene, true, s.perm_about_x);
  const std::string why_y = check_mirror(scene, false, s.perm_about_y);
  s.about_x = why_x.empty();
  s.about_y = why_y.empty();
  // A mirror used maps the electrodes onto themselves in pairs: its permutation is an involution.
  for (const auto& [used, perm] : {std::pair{s.about_x, &s.perm_about_x}, std::pair{s.about_y, &s.perm_about_y}}) {
    if (!used) continue;
    PVDF_ASSERT(perm->size() == scene.electrodes.size(), "a mirror permutation has one entry per electrode");
    for (std::size_t k = 0; k < perm->size(); ++k) {
      PVDF_ASSERT((*perm)[k] < perm->size() && (*perm)[(*perm)[k]] == k, "a mirror's electrode permutation must be an involution");
    }
  }
  s.reason = std::string("mirror about the x axis (y -> -y): ") + (s.about_x ? "yes" : "no, " + why_x) +
             "; mirror about the y axis (x -> -x): " + (s.about_y ? "yes" : "no, " + why_y);
  return s;
}

void Generator::validate_options() {
  if (!(o_.spacing_m > 0) || !std::isfinite(o_.spacing_m)) {
    throw InputError("map: grid spacing " + num(o_.spacing_m) + " m must be > 0, e.g. 0.001 (MapOptions::spacing_m)");
  }
  if (o_.forces_N.empty()) throw InputError("map: give at least one force level (N), e.g. 1 (MapOptions::forces_N)");
  for (double f : o_.forces_N) {
    if (!(f > 0) || !std::isfinite(f)) throw InputError("map: force level " + num(f) + " N must be > 0 (MapOptions::forces_N)");
  }
  std::sort(o_.forces_N.begin(), o_.forces_N.end());
  o_.forces_N.erase(std::unique(o_.forces_N.begin(), o_.forces_N.end()), o_.forces_N.end());
  tolerance_ = o_.tolerance > 0 ? o_.tolerance : scene_.model.tolerance;
  if (!(tolerance_ > 0 && tolerance_ < 1)) throw InputError("map: tolerance " + num(tolerance_) + " must be in (0, 1), e.g. 0.01 (MapOptions::tolerance, or the scene's model.tolerance)");
  if (!(o_.rim_margin_m >= 0) || !std::isfinite(o_.rim_margin_m)) {
    throw InputError("map: rim margin " + num(o_.rim_margin_m) + " m must be >= 0; 0 = twice the probe radius (MapOptions::rim_margin_m)");
  }
  margin_ = o_.rim_margin_m > 0 ? o_.rim_margin_m : 2 * scene_.probe.radius_m;
  adaptive_ = o_.placement == Placement::adaptive;
  if (adaptive_) {
    if (o_.adaptive_levels < 1 || o_.adaptive_levels > 5) {
      throw InputError("map: " + std::to_string(o_.adaptive_levels) +
                       " adaptive levels must lie in 1..5 (coarse spacing = 2^levels x the spacing; MapOptions::adaptive_levels)");
    }
    levels_ = o_.adaptive_levels;
    o_.scaling_check_stride = 1 << levels_;  // the force-scaling check positions are the coarse level
  }
  if (o_.scaling_check_stride < 1) {
    throw InputError("scaling check stride " + std::to_string(o_.scaling_check_stride) + " must be >= 1");
  }
  if (o_.threads < 0) throw InputError("map: " + std::to_string(o_.threads) + " threads must be >= 0 (0 = all cores; MapOptions::threads)");
  if (o_.region_m) {
    const auto& r = *o_.region_m;
    for (double v : r) {
      if (!std::isfinite(v)) throw InputError("map: region values must be finite (m): XMIN,XMAX,YMIN,YMAX (MapOptions::region_m)");
    }
    if (!(r[1] > r[0]) || !(r[3] > r[2])) {
      throw InputError("map: region " + num(r[0]) + "," + num(r[1]) + "," + num(r[2]) + "," + num(r[3]) +
                       ": need XMIN < XMAX and YMIN < YMAX (m; MapOptions::region_m)");
    }
  }
  if (scene_.electrodes.empty()) throw InputError(scene_.source + ": the scene has no electrodes; a map needs at least one");
  if (!o_.noise_C.empty() && o_.noise_C.size() != scene_.electrodes.size()) {
    throw InputError("noise_C: " + std::to_string(o_.noise_C.size()) + " values for " +
                     std::to_string(scene_.electrodes.size()) + " electrodes; give one per electrode");
  }
}

void Generator::build_grid() {
  const double s = o_.spacing_m;
  const auto box = o_.region_m ? *o_.region_m : scene_.membrane.outline.bounding_box_m();
  grid_.spacing = s;
  grid_.i0 = long(std::ceil(box[0] / s - 1e-9));
  grid_.j0 = long(std::ceil(box[2] / s - 1e-9));
  const long i1 = long(std::floor(box[1] / s + 1e-9));
  const long j1 = long(std::floor(box[3] / s + 1e-9));
  if (i1 < grid_.i0 || j1 < grid_.j0) {
    throw InputError("map: no grid node (multiples of the spacing " + num(s) + " m) lies in the region; widen the region");
  }
  grid_.nx = std::size_t(i1 - grid_.i0 + 1);
  grid_.ny = std::size_t(j1 - grid_.j0 + 1);
  if (grid_.nx < 2 || grid_.ny < 2) {
    throw InputError("map: the grid has " + std::to_string(grid_.nx) + " x " + std::to_string(grid_.ny) +
                     " nodes (multiples of " + num(s) + " m); a map needs at least 2 along x and y: widen the region or reduce the spacing");
  }
  if (grid_.nx * grid_.ny > 50'000'000) {
    throw InputError("map: grid spacing " + num(s) + " m gives " + std::to_string(grid_.nx * grid_.ny) +
                     " grid nodes, too many; use a larger spacing or a smaller region");
  }
  map_.x_m.resize(grid_.nx);
  map_.y_m.resize(grid_.ny);
  for (std::size_t i = 0; i < grid_.nx; ++i) map_.x_m[i] = double(grid_.i0 + long(i)) * s;
  for (std::size_t j = 0; j < grid_.ny; ++j) map_.y_m[j] = double(grid_.j0 + long(j)) * s;
  for (const auto* axis : {&map_.x_m, &map_.y_m}) {
    for (std::size_t i = 1; i < axis->size(); ++i) {
      PVDF_ASSERT((*axis)[i] > (*axis)[i - 1], "the grid's axes must be strictly ascending");
    }
  }
  map_.mask.assign(grid_.nx * grid_.ny, 0);
  std::size_t n_in = 0;
  for (std::size_t j = 0; j < grid_.ny; ++j) {
    for (std::size_t i = 0; i < grid_.nx; ++i) {
      if (masked(grid_.i0 + long(i), grid_.j0 + long(j))) {
        map_.mask[j * grid_.nx + i] = 1;
        ++n_in;
      }
    }
  }
  if (n_in == 0) {
    throw InputError("map: no grid position lies inside the film at least " + num(margin_) +
                     " m from the rim; reduce the margin or the spacing, or move the region");
  }
}

bool Generator::masked(long I, long J) const {
  return scene_.membrane.outline.contains({double(I) * grid_.spacing, double(J) * grid_.spacing}, margin_);
}

bool Generator::in_grid(long I, long J, std::size_t& i, std::size_t& j) const {
  const long ii = I - grid_.i0, jj = J - grid_.j0;
  if (ii < 0 || jj < 0 || ii >= long(grid_.nx) || jj >= long(grid_.ny)) return false;
  i = std::size_t(ii);
  j = std::size_t(jj);
  return map_.mask[j * grid_.nx + i] != 0;
}

// Prefer the image with I >= 0 (if mirror about y) and J >= 0 (if mirror about x) that lies in
// the mapped grid; fall back to partial flips and finally to the point itself.
Generator::Rep Generator::rep(std::size_t i, std::size_t j) const {
  const auto find = [this](std::size_t i, std::size_t j) -> Rep {
    const long I = grid_.i0 + long(i), J = grid_.j0 + long(j);
    const bool fi = sym_.about_y && I < 0, fj = sym_.about_x && J < 0;
    const bool options[4][2] = {{fi, fj}, {fi, false}, {false, fj}, {false, false}};
    for (const auto& opt : options) {
      std::size_t ri = 0, rj = 0;
      if (in_grid(opt[0] ? -I : I, opt[1] ? -J : J, ri, rj)) return {ri, rj, opt[0], opt[1]};
    }
    return {i, j, false, false};
  };
  const Rep r = find(i, j);
  // The representative is its own representative (else a point could be solved twice or never).
  PVDF_ASSERT([&] {
    const Rep again = find(r.i, r.j);
    return again.i == r.i && again.j == r.j;
  }(), "a grid point's representative must be its own representative");
  return r;
}

void Generator::setup_mpi() {
  int initialized = 0;
  if (o_.distributed) {
    MPI_Initialized(&initialized);
    if (!initialized) throw InputError("distributed map generation: MPI is not initialized (create an MpiSession first)");
    use_mpi_ = true;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  threads_ = o_.threads > 0 ? o_.threads : std::max(1, int(hw) / size_);
}

}  // namespace pvdf::mapping::detail
