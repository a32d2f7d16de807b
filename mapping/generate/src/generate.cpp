// Charge-map generation (docs/map-generation.md): the grid and its mirror symmetry, the
// row blocks that threads and MPI ranks share, the force-scaling check, checkpoints.
//
// Why rows: every row block starts its warm-start chain from the flat film, so the result of
// a block does not depend on which rank or thread ran it, nor on what ran before — the map is
// the same (bitwise, for a deterministic solver) for any number of ranks and threads and for
// an interrupted-and-resumed run. Within a row each solve warm-starts from its neighbour.
#include "pvdf/mapping/generate.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/core/membrane_scaling.hpp"
#include "pvdf/fem/probe_sweep.hpp"
#include "pvdf/version.hpp"

#include <mpi.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <mutex>
#include <numeric>
#include <sstream>
#include <thread>

namespace pvdf::mapping {
namespace {

constexpr double nan = std::numeric_limits<double>::quiet_NaN();

std::string num(double v) {
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}

// ---------------------------------------------------------------------------------------------
// Mirror symmetry of the scene.

struct Symmetry {
  bool about_x = false;                  // y -> -y
  bool about_y = false;                  // x -> -x
  std::vector<std::size_t> perm_about_x; // electrode k <-> perm[k] under y -> -y
  std::vector<std::size_t> perm_about_y; // under x -> -x
  std::string reason;
};

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

Symmetry detect_symmetry(const pvdf::Scene& scene, bool wanted) {
  Symmetry s;
  if (!wanted) {
    s.reason = "symmetry not used (--no-symmetry)";
    return s;
  }
  const std::string why_x = check_mirror(scene, true, s.perm_about_x);
  const std::string why_y = check_mirror(scene, false, s.perm_about_y);
  s.about_x = why_x.empty();
  s.about_y = why_y.empty();
  s.reason = std::string("mirror about the x axis (y -> -y): ") + (s.about_x ? "yes" : "no, " + why_x) +
             "; mirror about the y axis (x -> -x): " + (s.about_y ? "yes" : "no, " + why_y);
  return s;
}

// ---------------------------------------------------------------------------------------------
// Grid: nodes at integer multiples of the spacing, I = i0 + i, J = j0 + j.

struct Grid {
  long i0 = 0, j0 = 0;
  std::size_t nx = 0, ny = 0;
  double spacing = 0;
};

std::array<double, 4> outline_box(const FilmOutline& o) {
  switch (o.shape) {
    case FilmOutline::Shape::circle: return {-o.radius_m, o.radius_m, -o.radius_m, o.radius_m};
    case FilmOutline::Shape::rectangle: return {-o.size_m[0] / 2, o.size_m[0] / 2, -o.size_m[1] / 2, o.size_m[1] / 2};
    case FilmOutline::Shape::ellipse:
      return {-o.semi_axes_m[0], o.semi_axes_m[0], -o.semi_axes_m[1], o.semi_axes_m[1]};
    case FilmOutline::Shape::polygon: {
      std::array<double, 4> b{1e300, -1e300, 1e300, -1e300};
      for (const auto& v : o.vertices_m) {
        b[0] = std::min(b[0], v[0]);
        b[1] = std::max(b[1], v[0]);
        b[2] = std::min(b[2], v[1]);
        b[3] = std::max(b[3], v[1]);
      }
      return b;
    }
  }
  return {0, 0, 0, 0};
}

// Row blocks of tasks: the unit of work, of checkpointing and of distribution.
struct Task {
  std::size_t i = 0, j = 0;
  bool all_levels = true;  // false: solve the largest level only, scale the others
  double scaling_error = 0;  // worst force-scaling check error at the corners of its lattice cell
};
using Block = std::vector<Task>;

// Data of one solved position (all levels): the record format of checkpoints and MPI gathers.
// [point index j*nx+i, then per level: status, provenance, deflection, model, deflection error,
//  charges..., charge errors...]
struct Layout {
  std::size_t nf = 0, ne = 0;
  std::size_t per_level() const { return 5 + 2 * ne; }
  std::size_t size() const { return 1 + nf * per_level(); }
  // Fields of a level's block, at level(rec, f) + field (charges: + charges + k; errors: + errors() + k).
  enum Field : std::size_t { status = 0, provenance = 1, deflection = 2, model = 3, deflection_error = 4, charges = 5 };
  std::size_t errors() const { return charges + ne; }
  static constexpr std::size_t point_index = 0;  // rec[point_index] = j*nx + i
  double* level(double* rec, std::size_t f) const { return rec + 1 + f * per_level(); }
  const double* level(const double* rec, std::size_t f) const { return rec + 1 + f * per_level(); }
};

std::uint64_t fnv1a(const std::string& text) {
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return h;
}

std::string hex(std::uint64_t v) {
  char buf[20];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

// ---------------------------------------------------------------------------------------------
// Checkpoint files: a text header, then `records` × `record_doubles` float64 (native order).

constexpr const char* checkpoint_magic = "pvdfkit-map-checkpoint 2";

void write_checkpoint(const std::string& path, const std::string& hash, const Layout& layout,
                      const std::vector<double>& records) {
  write_file_atomically(path, [&](std::ostream& out) {
    out << checkpoint_magic << "\nhash " << hash << "\nrecord_doubles " << layout.size() << "\nrecords "
        << records.size() / layout.size() << "\n";
    out.write(reinterpret_cast<const char*>(records.data()), std::streamsize(records.size() * sizeof(double)));
  });
}

std::vector<double> read_checkpoint(const std::string& path, const std::string& hash, const Layout& layout) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the checkpoint; check permissions or delete it");
  std::string magic, key, file_hash;
  std::size_t record_doubles = 0, n_records = 0;
  std::getline(in, magic);
  if (magic != checkpoint_magic) {
    throw InputError(path + ": not a pvdfkit map checkpoint (first line '" + magic.substr(0, 40) +
                     "'); delete it or choose another --checkpoint");
  }
  in >> key >> file_hash;
  if (key != "hash") throw InputError(path + ": damaged checkpoint header; delete it");
  if (file_hash != hash) {
    throw InputError(path + ": checkpoint hash " + file_hash + " was written for a different scene or map options (this run: " +
                     hash + "); delete it, pass --no-resume, or choose another --checkpoint");
  }
  in >> key >> record_doubles;
  if (key != "record_doubles" || record_doubles != layout.size()) {
    throw InputError(path + ": checkpoint record size " + std::to_string(record_doubles) + " does not match " +
                     std::to_string(layout.size()) + "; delete it");
  }
  in >> key >> n_records;
  if (key != "records") throw InputError(path + ": damaged checkpoint header; delete it");
  in.get();  // the newline
  std::vector<double> data(n_records * layout.size());
  in.read(reinterpret_cast<char*>(data.data()), std::streamsize(data.size() * sizeof(double)));
  if (!in || std::size_t(in.gcount()) != data.size() * sizeof(double)) {
    throw InputError(path + ": checkpoint truncated (" + std::to_string(n_records) +
                     " records announced); delete it and start again");
  }
  return data;
}

std::string rank_checkpoint_path(const std::string& base, int rank, int size) {
  return size == 1 ? base : base + ".rank" + std::to_string(rank);
}

// The base file and every `<base>.rank<digits>` beside it.
std::vector<std::string> existing_checkpoints(const std::string& base) {
  namespace fs = std::filesystem;
  std::vector<std::string> out;
  std::error_code ec;
  if (fs::exists(base, ec)) out.push_back(base);
  const fs::path p(base);
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  const std::string prefix = p.filename().string() + ".rank";
  if (!fs::is_directory(dir, ec)) return out;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string tail = name.substr(prefix.size());
    if (std::all_of(tail.begin(), tail.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      out.push_back((dir / name).string());
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

// ---------------------------------------------------------------------------------------------

class Generator {
 public:
  Generator(const pvdf::Scene& scene, const MapOptions& options) : scene_(scene), o_(options) {}
  ChargeMap run(MapReport& report);

 private:
  // setup
  void validate_options();
  void build_grid();
  void setup_mpi();
  bool masked(long I, long J) const;
  bool in_grid(long I, long J, std::size_t& i, std::size_t& j) const;
  // representative (canonical) position of (i, j) under the scene symmetry
  struct Rep {
    std::size_t i, j;
    bool flip_i, flip_j;
  };
  Rep rep(std::size_t i, std::size_t j) const;
  bool canonical(std::size_t i, std::size_t j) const {
    const Rep r = rep(i, j);
    return r.i == i && r.j == j;
  }
  bool is_lattice(std::size_t i, std::size_t j) const {
    const long k = o_.scaling_check_stride;
    const long I = grid_.i0 + long(i), J = grid_.j0 + long(j);
    return ((I % k) + k) % k == 0 && ((J % k) + k) % k == 0;
  }
  // work
  void run_blocks(const std::vector<Block>& blocks);
  void solve_block(fem::ProbeSweep& sweep, const Block& block, std::vector<double>& records, bool& abandoned);
  void commit(const std::vector<double>& records, std::size_t n_positions);
  void maybe_checkpoint(bool force);
  std::vector<double> known_records(bool only_this_run) const;
  void store_record(const double* rec, bool resumed);
  std::vector<Block> split_for_rank(const std::vector<Block>& all) const;
  double check_error(std::size_t i, std::size_t j) const;
  void fill_mirrors();

  const pvdf::Scene& scene_;
  MapOptions o_;
  double tolerance_ = 0.01;
  double margin_ = 0;
  fem::SweepOptions sweep_options_;
  Grid grid_;
  Symmetry sym_;
  Layout layout_;
  ChargeMap map_;
  std::vector<std::uint8_t> provenance_;
  std::vector<std::uint8_t> node_model_;  // [nf][ny][nx] fem::SweepModel codes
  std::vector<double> deflection_error_;  // [nf][ny][nx] estimated |error| of the deflection (m)
  std::vector<std::uint8_t> known_;      // [ny][nx] 1 = canonical position has its record
  std::vector<std::uint8_t> this_run_;   // [ny][nx] 1 = computed in this run by this process
  std::string hash_;
  int rank_ = 0, size_ = 1, threads_ = 1;
  bool use_mpi_ = false;
  std::vector<std::unique_ptr<fem::ProbeSweep>> sweeps_;

  std::mutex mutex_;                     // guards map_, known_, checkpoint and progress
  std::atomic<bool> stop_{false};
  std::atomic<std::size_t> positions_solved_{0};  // FEM-solved positions (stop hook)
  std::size_t fem_points_solved_ = 0;    // FEM-solved points (position × level), committed
  std::size_t n_resumed_points_ = 0;
  std::size_t progress_done_ = 0, progress_total_ = 0;
  std::chrono::steady_clock::time_point last_checkpoint_;
  std::string first_failure_;
};

void Generator::validate_options() {
  if (!(o_.spacing_m > 0) || !std::isfinite(o_.spacing_m)) {
    throw InputError("--spacing-m " + num(o_.spacing_m) + ": the grid spacing must be > 0 (m), e.g. 0.001");
  }
  if (o_.forces_N.empty()) throw InputError("--forces-N: give at least one force level (N), e.g. 1");
  for (double f : o_.forces_N) {
    if (!(f > 0) || !std::isfinite(f)) throw InputError("--forces-N " + num(f) + ": every force level must be > 0 (N)");
  }
  std::sort(o_.forces_N.begin(), o_.forces_N.end());
  o_.forces_N.erase(std::unique(o_.forces_N.begin(), o_.forces_N.end()), o_.forces_N.end());
  tolerance_ = o_.tolerance > 0 ? o_.tolerance : scene_.model.tolerance;
  if (!(tolerance_ > 0 && tolerance_ < 1)) throw InputError("--tolerance " + num(tolerance_) + " must be in (0, 1), e.g. 0.01");
  if (!(o_.rim_margin_m >= 0) || !std::isfinite(o_.rim_margin_m)) {
    throw InputError("--rim-margin-m " + num(o_.rim_margin_m) + " must be >= 0 (m); 0 = twice the probe radius");
  }
  margin_ = o_.rim_margin_m > 0 ? o_.rim_margin_m : 2 * scene_.probe.radius_m;
  if (o_.scaling_check_stride < 1) {
    throw InputError("scaling check stride " + std::to_string(o_.scaling_check_stride) + " must be >= 1");
  }
  if (o_.threads < 0) throw InputError("--threads " + std::to_string(o_.threads) + " must be >= 0 (0 = all cores)");
  if (o_.region_m) {
    const auto& r = *o_.region_m;
    for (double v : r) {
      if (!std::isfinite(v)) throw InputError("--region: values must be finite (m): XMIN,XMAX,YMIN,YMAX");
    }
    if (!(r[1] > r[0]) || !(r[3] > r[2])) {
      throw InputError("--region " + num(r[0]) + "," + num(r[1]) + "," + num(r[2]) + "," + num(r[3]) +
                       ": need XMIN < XMAX and YMIN < YMAX (m)");
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
  const auto box = o_.region_m ? *o_.region_m : outline_box(scene_.membrane.outline);
  grid_.spacing = s;
  grid_.i0 = long(std::ceil(box[0] / s - 1e-9));
  grid_.j0 = long(std::ceil(box[2] / s - 1e-9));
  const long i1 = long(std::floor(box[1] / s + 1e-9));
  const long j1 = long(std::floor(box[3] / s + 1e-9));
  if (i1 < grid_.i0 || j1 < grid_.j0) {
    throw InputError("--region/--spacing-m: no grid node (multiples of " + num(s) + " m) lies in the region; widen it");
  }
  grid_.nx = std::size_t(i1 - grid_.i0 + 1);
  grid_.ny = std::size_t(j1 - grid_.j0 + 1);
  if (grid_.nx < 2 || grid_.ny < 2) {
    throw InputError("--region/--spacing-m: the grid has " + std::to_string(grid_.nx) + " x " + std::to_string(grid_.ny) +
                     " nodes (multiples of " + num(s) + " m); a map needs at least 2 along x and y: widen the region or reduce the spacing");
  }
  if (grid_.nx * grid_.ny > 50'000'000) {
    throw InputError("--spacing-m " + num(s) + ": " + std::to_string(grid_.nx * grid_.ny) +
                     " grid nodes is too many; use a larger spacing or a --region");
  }
  map_.x_m.resize(grid_.nx);
  map_.y_m.resize(grid_.ny);
  for (std::size_t i = 0; i < grid_.nx; ++i) map_.x_m[i] = double(grid_.i0 + long(i)) * s;
  for (std::size_t j = 0; j < grid_.ny; ++j) map_.y_m[j] = double(grid_.j0 + long(j)) * s;
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
    throw InputError("--region/--rim-margin-m: no grid position lies inside the film at least " + num(margin_) +
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
  const long I = grid_.i0 + long(i), J = grid_.j0 + long(j);
  const bool fi = sym_.about_y && I < 0, fj = sym_.about_x && J < 0;
  const bool options[4][2] = {{fi, fj}, {fi, false}, {false, fj}, {false, false}};
  for (const auto& opt : options) {
    std::size_t ri = 0, rj = 0;
    if (in_grid(opt[0] ? -I : I, opt[1] ? -J : J, ri, rj)) return {ri, rj, opt[0], opt[1]};
  }
  return {i, j, false, false};
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

// Contiguous ranges of blocks, balanced by the number of solves, independent of threads.
std::vector<Block> Generator::split_for_rank(const std::vector<Block>& all) const {
  if (size_ == 1) return all;
  std::vector<double> cost(all.size());
  double total = 0;
  for (std::size_t b = 0; b < all.size(); ++b) {
    double c = 0;
    for (const auto& t : all[b]) c += t.all_levels ? double(layout_.nf) : 1.0;
    cost[b] = c;
    total += c;
  }
  std::vector<Block> mine;
  double before = 0;
  for (std::size_t b = 0; b < all.size(); ++b) {
    const double mid = before + cost[b] / 2;
    before += cost[b];
    const int owner = std::min(size_ - 1, int(mid / total * size_));
    if (owner == rank_) mine.push_back(all[b]);
  }
  return mine;
}

// One row block with one sweep: warm starts chain along the row, per force level.
void Generator::solve_block(fem::ProbeSweep& sweep, const Block& block, std::vector<double>& records, bool& abandoned) {
  const std::size_t nf = layout_.nf, ne = layout_.ne, top = nf - 1;
  std::vector<fem::SweepState> state(nf);  // state of the previous position at each level
  std::vector<char> have(nf, 0);           // 1 = state[f] is from the immediately previous position
  records.clear();
  abandoned = false;
  for (const auto& task : block) {
    if (o_.cancel && o_.cancel->load()) stop_ = true;
    if (stop_) {
      abandoned = true;
      return;
    }
    const double x = map_.x_m[task.i], y = map_.y_m[task.j];
    std::vector<double> rec(layout_.size(), nan);
    rec[Layout::point_index] = double(task.j * grid_.nx + task.i);
    auto put = [&](std::size_t f, const fem::ProbeSolution* s, std::uint8_t prov) {
      double* r = layout_.level(rec.data(), f);
      const bool ok = s && fem::usable(s->status) && s->charge_C.size() == ne;
      r[Layout::status] = double(ok ? PointStatus::ok : PointStatus::not_converged);
      r[Layout::provenance] = prov;
      r[Layout::deflection] = ok ? s->deflection_at_load_m : nan;
      r[Layout::model] = ok ? double(s->model_used) : 0.0;
      r[Layout::deflection_error] = ok ? s->deflection_error_m : nan;
      if (ok && s->status == fem::Status::tolerance_not_met) r[Layout::provenance] = prov | provenance::tolerance_not_met;
      const bool has_err = ok && s->charge_error_C.size() == ne;
      for (std::size_t k = 0; k < ne; ++k) {
        r[Layout::charges + k] = ok ? s->charge_C[k] : nan;
        r[layout_.errors() + k] = has_err ? s->charge_error_C[k] : nan;
      }
      if (!ok && s) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (first_failure_.empty()) {
          first_failure_ = "(" + num(x) + ", " + num(y) + ") m, " + num(s->force_N) + " N: " + fem::status_name(s->status) +
                           (s->message.empty() ? "" : ": " + s->message);
        }
      }
    };
    auto solve = [&](std::size_t f, const fem::SweepState* warm, fem::SweepState* out) {
      try {
        return sweep.solve(x, y, o_.forces_N[f], warm, out);
      } catch (const NumericalError& e) {
        fem::ProbeSolution s;
        s.status = fem::Status::no_convergence;
        s.force_N = o_.forces_N[f];
        s.message = e.what();
        return s;
      }
    };
    std::vector<fem::SweepState> next(nf);
    std::vector<char> next_have(nf, 0);
    const fem::ProbeSolution top_solution = solve(top, have[top] ? &state[top] : nullptr, &next[top]);
    const bool top_ok = fem::usable(top_solution.status);
    next_have[top] = top_ok;
    put(top, &top_solution, provenance::solved);
    const bool scale = !task.all_levels && top_ok;
    for (std::size_t f = top; f-- > 0;) {
      if (scale) {
        const double ratio = o_.forces_N[f] / o_.forces_N[top];
        fem::ProbeSolution s = top_solution;
        s.force_N = o_.forces_N[f];
        s.deflection_at_load_m *= pvdf::membrane_deflection_factor(ratio);
        s.deflection_error_m = s.deflection_error_m * pvdf::membrane_deflection_factor(ratio) + task.scaling_error * std::abs(s.deflection_at_load_m);
        for (auto& q : s.charge_C) q *= pvdf::membrane_charge_factor(ratio);
        // The top level's estimate scaled alike, plus the worst scaling-check error of its cell.
        double q_max = 0;
        for (double q : s.charge_C) q_max = std::max(q_max, std::abs(q));
        for (auto& e : s.charge_error_C) e = e * pvdf::membrane_charge_factor(ratio) + task.scaling_error * q_max;
        put(f, &s, provenance::scaled);
        continue;
      }
      const fem::SweepState* warm = have[f] ? &state[f] : (top_ok ? &next[top] : nullptr);
      const fem::ProbeSolution s = solve(f, warm, &next[f]);
      next_have[f] = fem::usable(s.status);
      put(f, &s, provenance::solved);
    }
    // Keep each level's chain: a level not solved here restarts from the top level next time.
    for (std::size_t f = 0; f < nf; ++f) {
      if (next_have[f]) state[f] = std::move(next[f]);
      have[f] = next_have[f];
    }
    records.insert(records.end(), rec.begin(), rec.end());
    const std::size_t solved = positions_solved_.fetch_add(1) + 1;
    if (o_.stop_after_positions > 0 && solved >= o_.stop_after_positions) {
      stop_ = true;
      abandoned = true;  // as if killed: this block is not committed
      return;
    }
  }
}

void Generator::store_record(const double* rec, bool resumed) {
  const std::size_t p = std::size_t(rec[Layout::point_index]);
  const std::size_t ne = layout_.ne;
  for (std::size_t f = 0; f < layout_.nf; ++f) {
    const double* r = layout_.level(rec, f);
    const std::size_t pt = f * grid_.nx * grid_.ny + p;
    map_.status[pt] = std::uint8_t(r[Layout::status]);
    provenance_[pt] = std::uint8_t(r[Layout::provenance]);
    map_.deflection_at_load_m[pt] = r[Layout::deflection];
    node_model_[pt] = std::uint8_t(r[Layout::model]);
    deflection_error_[pt] = r[Layout::deflection_error];
    for (std::size_t k = 0; k < ne; ++k) {
      map_.charge_C[pt * ne + k] = r[Layout::charges + k];
      map_.estimated_charge_error_C[pt * ne + k] = r[layout_.errors() + k];
    }
    if (resumed) ++n_resumed_points_;
  }
  known_[p] = 1;
}

void Generator::commit(const std::vector<double>& records, std::size_t n_positions) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (std::size_t r = 0; r < records.size(); r += layout_.size()) {
    const double* rec = records.data() + r;
    store_record(rec, false);
    this_run_[std::size_t(rec[Layout::point_index])] = 1;
    for (std::size_t f = 0; f < layout_.nf; ++f) {
      if ((std::uint8_t(layout_.level(rec, f)[Layout::provenance]) & (provenance::scaled | provenance::mirrored)) == 0) ++fem_points_solved_;
    }
  }
  progress_done_ += n_positions;
  // Under MPI the total is global; this rank's count × ranks estimates the global count.
  if (o_.progress) o_.progress(std::min(progress_total_, progress_done_ * std::size_t(size_)), progress_total_);
}

std::vector<double> Generator::known_records(bool only_this_run) const {
  std::vector<double> out;
  const std::size_t ne = layout_.ne, n = grid_.nx * grid_.ny;
  for (std::size_t p = 0; p < n; ++p) {
    if (!known_[p] || (only_this_run && !this_run_[p])) continue;
    out.push_back(double(p));
    for (std::size_t f = 0; f < layout_.nf; ++f) {
      const std::size_t pt = f * n + p;
      out.push_back(map_.status[pt]);
      out.push_back(provenance_[pt]);
      out.push_back(map_.deflection_at_load_m[pt]);
      out.push_back(node_model_[pt]);
      out.push_back(deflection_error_[pt]);
      for (std::size_t k = 0; k < ne; ++k) out.push_back(map_.charge_C[pt * ne + k]);
      for (std::size_t k = 0; k < ne; ++k) out.push_back(map_.estimated_charge_error_C[pt * ne + k]);
    }
  }
  return out;
}

// Caller holds mutex_ (or runs single-threaded).
void Generator::maybe_checkpoint(bool force) {
  if (o_.checkpoint_path.empty()) return;
  const auto now = std::chrono::steady_clock::now();
  if (!force && std::chrono::duration<double>(now - last_checkpoint_).count() < o_.checkpoint_interval_s) return;
  write_checkpoint(rank_checkpoint_path(o_.checkpoint_path, rank_, size_), hash_, layout_, known_records(false));
  last_checkpoint_ = now;
}

void Generator::run_blocks(const std::vector<Block>& blocks) {
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto worker = [&](int t) {
    try {
      if (!sweeps_[std::size_t(t)]) {
        // Same mesh as the first sweep (its final sizes: the setup halves them when a check
        // fails), whose setup check already measured the error.
        fem::SweepOptions options = sweep_options_;
        options.n_setup_checks = 0;
        options.region_size_m = sweeps_[0]->setup().region_size_m;
        options.electrode_size_m = sweeps_[0]->setup().electrode_size_m;
        sweeps_[std::size_t(t)] = std::make_unique<fem::ProbeSweep>(scene_, options);
      }
      std::vector<double> records;
      while (!stop_) {
        const std::size_t b = next.fetch_add(1);
        if (b >= blocks.size()) break;
        bool abandoned = false;
        solve_block(*sweeps_[std::size_t(t)], blocks[b], records, abandoned);
        if (abandoned) break;
        commit(records, blocks[b].size());
        std::lock_guard<std::mutex> lock(mutex_);
        maybe_checkpoint(false);
      }
    } catch (...) {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
      stop_ = true;
    }
  };
  const int n = std::max(1, std::min<int>(threads_, int(blocks.size())));
  std::vector<std::thread> pool;
  for (int t = 1; t < n; ++t) pool.emplace_back(worker, t);
  worker(0);
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
}

// Worst relative error of Q ∝ F^(2/3), w ∝ F^(1/3) from the top level at a solved position;
// +inf when a level failed there.
double Generator::check_error(std::size_t i, std::size_t j) const {
  const std::size_t n = grid_.nx * grid_.ny, p = j * grid_.nx + i, ne = layout_.ne, top = layout_.nf - 1;
  const std::size_t pt_top = top * n + p;
  if (map_.status[pt_top] != std::uint8_t(PointStatus::ok)) return std::numeric_limits<double>::infinity();
  double worst = 0;
  for (std::size_t f = 0; f < top; ++f) {
    const std::size_t pt = f * n + p;
    if (map_.status[pt] != std::uint8_t(PointStatus::ok)) return std::numeric_limits<double>::infinity();
    const double ratio = o_.forces_N[f] / o_.forces_N[top];
    double qmax = 0, qerr = 0;
    for (std::size_t k = 0; k < ne; ++k) {
      const double solved = map_.charge_C[pt * ne + k];
      const double predicted = map_.charge_C[pt_top * ne + k] * pvdf::membrane_charge_factor(ratio);
      qmax = std::max(qmax, std::abs(solved));
      qerr = std::max(qerr, std::abs(predicted - solved));
    }
    const double w = map_.deflection_at_load_m[pt];
    const double w_pred = map_.deflection_at_load_m[pt_top] * pvdf::membrane_deflection_factor(ratio);
    worst = std::max(worst, qmax > 0 ? qerr / qmax : (qerr > 0 ? 1.0 : 0.0));
    worst = std::max(worst, w != 0 ? std::abs(w_pred - w) / std::abs(w) : 0.0);
  }
  return worst;
}

void Generator::fill_mirrors() {
  const std::size_t n = grid_.nx * grid_.ny, ne = layout_.ne;
  for (std::size_t j = 0; j < grid_.ny; ++j) {
    for (std::size_t i = 0; i < grid_.nx; ++i) {
      if (!map_.mask[j * grid_.nx + i]) continue;
      const Rep r = rep(i, j);
      if (r.i == i && r.j == j) continue;
      for (std::size_t f = 0; f < layout_.nf; ++f) {
        const std::size_t dst = f * n + j * grid_.nx + i, src = f * n + r.j * grid_.nx + r.i;
        map_.status[dst] = map_.status[src];
        map_.deflection_at_load_m[dst] = map_.deflection_at_load_m[src];
        node_model_[dst] = node_model_[src];
        deflection_error_[dst] = deflection_error_[src];
        provenance_[dst] = std::uint8_t(provenance_[src] | provenance::mirrored);
        if (map_.status[src] == std::uint8_t(PointStatus::not_computed)) provenance_[dst] = provenance_[src];
        for (std::size_t k = 0; k < ne; ++k) {
          std::size_t m = k;  // Q_k(p) = Q_{px(py(k))}(rep)
          if (r.flip_i) m = sym_.perm_about_y[m];
          if (r.flip_j) m = sym_.perm_about_x[m];
          map_.charge_C[dst * ne + k] = map_.charge_C[src * ne + m];
          map_.estimated_charge_error_C[dst * ne + k] = map_.estimated_charge_error_C[src * ne + m];
        }
      }
    }
  }
}

ChargeMap Generator::run(MapReport& report) {
  const auto t_start = std::chrono::steady_clock::now();
  validate_options();
  setup_mpi();
  sym_ = detect_symmetry(scene_, o_.use_symmetry);
  build_grid();
  const std::size_t nf = o_.forces_N.size(), ne = scene_.electrodes.size(), n = grid_.nx * grid_.ny;
  layout_ = Layout{nf, ne};

  // Provenance of the map.
  map_.scene_json = scene_.original.is_null() ? scene_to_json(scene_).dump() : scene_.original.dump();
  map_.pvdfkit_version = pvdf::version_string;
  map_.tolerance = tolerance_;
  map_.rim_margin_m = margin_;
  map_.description = o_.description.empty() ? "pvdfkit map (FEM probe sweep)" : o_.description;
  map_.forces_N = o_.forces_N;
  for (const auto& e : scene_.electrodes) {
    map_.electrode_names.push_back(e.name);
    map_.electrode_centers_m.push_back(e.centroid_m());
  }
  map_.noise_C = o_.noise_C.empty() ? std::vector<double>(ne, 0.05e-12) : o_.noise_C;
  map_.allocate();
  std::fill(map_.charge_C.begin(), map_.charge_C.end(), nan);
  std::fill(map_.deflection_at_load_m.begin(), map_.deflection_at_load_m.end(), nan);
  map_.estimated_charge_error_C.assign(map_.charge_C.size(), nan);
  node_model_.assign(nf * n, 0);
  deflection_error_.assign(nf * n, nan);
  for (std::size_t f = 0; f < nf; ++f) {
    for (std::size_t p = 0; p < n; ++p) {
      if (!map_.mask[p]) map_.status[f * n + p] = std::uint8_t(PointStatus::outside);
    }
  }
  provenance_.assign(nf * n, provenance::solved);
  known_.assign(n, 0);
  this_run_.assign(n, 0);

  // Solver setup (one sweep per thread; the first here, so bad input fails before the threads).
  sweep_options_.solver = fem::options_from_scene(scene_);
  if (!o_.model.empty()) sweep_options_.solver.model = fem::parse_model(o_.model, "--model");
  sweep_options_.solver.tolerance = tolerance_;
  sweep_options_.rim_margin_m = margin_;
  sweep_options_.forces_N = o_.forces_N;
  sweep_options_.n_setup_checks = o_.n_setup_checks;
  if (o_.rim_model == "never") sweep_options_.rim_model = fem::SweepOptions::RimModel::never;
  else if (o_.rim_model == "always") sweep_options_.rim_model = fem::SweepOptions::RimModel::always;
  else if (o_.rim_model != "by-estimate") {
    throw InputError("--rim-model " + o_.rim_model + ": use by-estimate, never or always");
  }
  sweep_options_.mesh = o_.mesh;
  sweeps_.resize(std::size_t(threads_));
  sweeps_[0] = std::make_unique<fem::ProbeSweep>(scene_, sweep_options_);

  // What ties a checkpoint to this run: everything that changes a point's value.
  {
    std::ostringstream key;
    key.precision(17);
    key << map_.scene_json << "|grid " << grid_.i0 << ' ' << grid_.j0 << ' ' << grid_.nx << ' ' << grid_.ny << ' '
        << grid_.spacing << "|forces";
    for (double f : o_.forces_N) key << ' ' << f;
    key << "|model " << fem::model_name(sweep_options_.solver.model) << "|tol " << tolerance_ << "|margin " << margin_
        << "|scaling " << o_.use_force_scaling << ' ' << o_.scaling_check_stride << "|sym " << sym_.about_x << sym_.about_y
        << "|rim " << int(sweep_options_.rim_model) << ' ' << sweep_options_.rim_size_m << ' ' << sweep_options_.rim_grading;
    if (o_.mesh) {  // another starting mesh changes every value
      key << "|mesh " << o_.mesh->n_cells();
      for (const auto& v : o_.mesh->vertices) key << ' ' << v[0] << ' ' << v[1];
    }
    hash_ = hex(fnv1a(key.str()));
  }

  // Resume.
  if (!o_.checkpoint_path.empty() && o_.resume) {
    for (const auto& file : existing_checkpoints(o_.checkpoint_path)) {
      const std::vector<double> data = read_checkpoint(file, hash_, layout_);
      for (std::size_t r = 0; r < data.size(); r += layout_.size()) {
        const double* rec = data.data() + r;
        const double pd = rec[Layout::point_index];
        const bool index_ok = pd >= 0 && pd < double(n) && pd == std::floor(pd);
        bool values_ok = index_ok && map_.mask[std::size_t(pd)] != 0;
        for (std::size_t f = 0; values_ok && f < nf; ++f) {
          const double st = layout_.level(rec, f)[Layout::status];
          values_ok = st == double(PointStatus::ok) || st == double(PointStatus::not_converged);
        }
        if (!values_ok) throw InputError(file + ": checkpoint record " + std::to_string(r / layout_.size()) + " is invalid; delete the checkpoint");
        if (known_[std::size_t(pd)]) continue;  // duplicates across rank files hold the same values
        store_record(rec, true);
      }
    }
  }
  last_checkpoint_ = std::chrono::steady_clock::now();

  // Canonical positions still to compute count for the progress total (phase B decided later).
  for (std::size_t p = 0; p < n; ++p) {
    if (map_.mask[p] && !known_[p] && canonical(p % grid_.nx, p / grid_.nx)) ++progress_total_;
  }

  const bool scaling = o_.use_force_scaling && nf > 1;
  auto rows_of = [&](auto&& want, bool all_levels) {
    std::vector<Block> blocks;
    for (std::size_t j = 0; j < grid_.ny; ++j) {
      Block b;
      bool complete = true;
      for (std::size_t i = 0; i < grid_.nx; ++i) {
        if (!map_.mask[j * grid_.nx + i] || !canonical(i, j) || !want(i, j)) continue;
        b.push_back(Task{i, j, all_levels});
        if (!known_[j * grid_.nx + i]) complete = false;
      }
      if (!b.empty() && !complete) blocks.push_back(std::move(b));
    }
    return blocks;
  };

  // Phase A: the force-scaling check positions (every level solved).
  std::vector<std::uint8_t> verdict(n, 0);  // 1 pass, 2 fail (canonical lattice positions)
  std::vector<double> check_err(n, 0.0);    // their scaling-check errors
  bool stopped_anywhere = false;
  if (scaling) {
    const auto blocks = split_for_rank(rows_of([&](std::size_t i, std::size_t j) { return is_lattice(i, j); }, true));
    run_blocks(blocks);
    for (std::size_t p = 0; p < n; ++p) {
      const std::size_t i = p % grid_.nx, j = p / grid_.nx;
      if (map_.mask[p] && known_[p] && is_lattice(i, j) && canonical(i, j)) {
        const double e = check_error(i, j);
        verdict[p] = e <= 0.5 * tolerance_ ? 1 : 2;
        check_err[p] = std::isfinite(e) ? e : 1.0;
        if (std::isfinite(e)) report.max_scaling_check_error = std::max(report.max_scaling_check_error, e);
      }
    }
    if (use_mpi_) {
      MPI_Allreduce(MPI_IN_PLACE, verdict.data(), int(n), MPI_UNSIGNED_CHAR, MPI_MAX, MPI_COMM_WORLD);
      MPI_Allreduce(MPI_IN_PLACE, check_err.data(), int(n), MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
      MPI_Allreduce(MPI_IN_PLACE, &report.max_scaling_check_error, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    }
  }
  int stopped = stop_ ? 1 : 0;
  if (use_mpi_) MPI_Allreduce(MPI_IN_PLACE, &stopped, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  stopped_anywhere = stopped != 0;

  // Phase B: every other position; scaled only where all lattice corners of its cell passed.
  if (!stopped_anywhere) {
    const long k = o_.scaling_check_stride;
    auto decide = [&](std::size_t i, std::size_t j, double& worst) {
      worst = 0;
      if (!scaling) return true;  // all levels
      const long I = grid_.i0 + long(i), J = grid_.j0 + long(j);
      const long Ia = I - (((I % k) + k) % k), Ja = J - (((J % k) + k) % k);
      const long Is[2] = {Ia, Ia == I ? Ia : Ia + k}, Js[2] = {Ja, Ja == J ? Ja : Ja + k};
      int counted = 0;
      for (long a : Is) {
        for (long b : Js) {
          std::size_t ci = 0, cj = 0;
          if (!in_grid(a, b, ci, cj)) continue;
          const Rep r = rep(ci, cj);
          const std::uint8_t v = verdict[r.j * grid_.nx + r.i];
          if (v != 1) return true;  // failed or unknown: solve every level
          worst = std::max(worst, check_err[r.j * grid_.nx + r.i]);
          ++counted;
        }
      }
      return counted == 0;
    };
    std::vector<Block> all;
    for (std::size_t j = 0; j < grid_.ny; ++j) {
      Block b;
      bool complete = true;
      for (std::size_t i = 0; i < grid_.nx; ++i) {
        const std::size_t p = j * grid_.nx + i;
        if (!map_.mask[p] || !canonical(i, j) || (scaling && is_lattice(i, j))) continue;
        double worst = 0;
        const bool all_levels = decide(i, j, worst);
        b.push_back(Task{i, j, all_levels, worst});
        if (!known_[p]) complete = false;
      }
      if (!b.empty() && !complete) all.push_back(std::move(b));
    }
    run_blocks(split_for_rank(all));
    int stopped_b = stop_ ? 1 : 0;
    if (use_mpi_) MPI_Allreduce(MPI_IN_PLACE, &stopped_b, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    stopped_anywhere = stopped_b != 0;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    maybe_checkpoint(true);
  }

  // Gather on rank 0.
  std::size_t counters[2] = {fem_points_solved_, positions_solved_.load()};
  if (use_mpi_ && size_ > 1) {
    const std::vector<double> mine = known_records(true);
    int count = int(mine.size());
    std::vector<int> counts(std::size_t(size_), 0), displs(std::size_t(size_), 0);
    MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
    std::vector<double> all;
    if (rank_ == 0) {
      long total = 0;
      for (int r = 0; r < size_; ++r) {
        displs[std::size_t(r)] = int(total);
        total += counts[std::size_t(r)];
      }
      all.resize(std::size_t(total));
    }
    MPI_Gatherv(mine.data(), count, MPI_DOUBLE, all.data(), counts.data(), displs.data(), MPI_DOUBLE, 0, MPI_COMM_WORLD);
    if (rank_ == 0) {
      for (std::size_t r = 0; r < all.size(); r += layout_.size()) {
        if (!this_run_[std::size_t(all[r])]) store_record(all.data() + r, false);
      }
    }
    unsigned long long c[2] = {counters[0], counters[1]};
    MPI_Allreduce(MPI_IN_PLACE, c, 2, MPI_UNSIGNED_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
    counters[0] = std::size_t(c[0]);
    counters[1] = std::size_t(c[1]);
  }
  fill_mirrors();

  // Report.
  const fem::SweepSetup& setup = sweeps_[0]->setup();
  map_.model = fem::model_name(setup.model);
  report = MapReport{};
  // The map's overall estimates: the largest per-node ones (ok points).
  {
    double charge = 0, deflection = 0;
    for (std::size_t pt = 0; pt < nf * n; ++pt) {
      if (map_.status[pt] != std::uint8_t(PointStatus::ok)) continue;
      double e = 0, q = 0;
      for (std::size_t k = 0; k < ne; ++k) {
        e = std::max(e, map_.estimated_charge_error_C[pt * ne + k]);
        q = std::max(q, std::abs(map_.charge_C[pt * ne + k]));
      }
      if (q > 0) charge = std::max(charge, e / q);
      const double w = std::abs(map_.deflection_at_load_m[pt]);
      if (w > 0) deflection = std::max(deflection, deflection_error_[pt] / w);
      if (node_model_[pt] == std::uint8_t(fem::SweepModel::rim)) ++report.n_rim_model;
      if (provenance_[pt] & provenance::tolerance_not_met) ++report.n_tolerance_not_met;
    }
    map_.estimated_relative_error = charge;
    map_.estimated_deflection_relative_error = deflection;
  }
  for (const auto& sw : sweeps_) {
    if (!sw) continue;
    const fem::SweepTiming t = sw->timing();
    report.rim_solves += std::size_t(t.rim_solves);
    report.rim_s += t.rim_s;
    report.estimate_s += t.estimate_s;
  }
  report.ranks = size_;
  report.threads = threads_;
  report.model = map_.model;
  report.model_reason = setup.model_reason;
  report.estimated_relative_error = map_.estimated_relative_error;
  report.estimated_deflection_relative_error = map_.estimated_deflection_relative_error;
  report.n_dofs = setup.n_dofs;
  report.rim_n_dofs = setup.rim_n_dofs;
  report.setup_s = setup.setup_s;
  report.mirror_x = sym_.about_x;
  report.mirror_y = sym_.about_y;
  report.symmetry_reason = sym_.reason;
  report.checkpoint_hash = hash_;
  report.stopped_early = stopped_anywhere;
  report.first_failure = first_failure_;
  report.n_solved = counters[0];
  report.n_resumed = n_resumed_points_;
  for (std::size_t p = 0; p < n; ++p) {
    if (!map_.mask[p]) continue;
    ++report.n_positions;
    if (scaling && is_lattice(p % grid_.nx, p / grid_.nx) && canonical(p % grid_.nx, p / grid_.nx) && verdict[p]) {
      ++report.n_scaling_checks;
      if (verdict[p] == 2) ++report.n_scaling_checks_failed;
    }
    for (std::size_t f = 0; f < nf; ++f) {
      const std::size_t pt = f * n + p;
      ++report.n_points;
      const auto st = PointStatus(map_.status[pt]);
      if (st == PointStatus::not_computed) {
        ++report.n_not_computed;
        continue;
      }
      if (st == PointStatus::not_converged) ++report.n_failed;
      if (provenance_[pt] & provenance::mirrored) ++report.n_mirrored;
      if (provenance_[pt] & provenance::scaled) ++report.n_scaled;
    }
  }
  // max check error: recompute on this rank's full knowledge (rank 0 has everything)
  report.max_scaling_check_error = 0;
  if (scaling) {
    for (std::size_t p = 0; p < n; ++p) {
      const std::size_t i = p % grid_.nx, j = p / grid_.nx;
      if (verdict[p] && known_[p]) {
        const double e = check_error(i, j);
        if (std::isfinite(e)) report.max_scaling_check_error = std::max(report.max_scaling_check_error, e);
      }
    }
  }
  report.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  report.per_position_s = counters[1] > 0 ? report.wall_s * size_ / double(counters[1]) : 0.0;
  report.provenance = provenance_;
  report.node_model = node_model_;
  return std::move(map_);
}

}  // namespace

ChargeMap generate_map(const pvdf::Scene& scene, const MapOptions& options, MapReport* report) {
  MapReport local;
  Generator g(scene, options);
  ChargeMap map = g.run(local);
  if (report) *report = std::move(local);
  return map;
}

// ---------------------------------------------------------------------------------------------

bool MpiSession::launched_by_mpirun() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMI_RANK", "PMIX_RANK", "MPI_LOCALNRANKS"}) {
    if (std::getenv(v)) return true;
  }
  return false;
}

MpiSession::MpiSession() {
  int initialized = 0;
  MPI_Initialized(&initialized);
  if (!initialized) {
    int provided = 0;
    if (MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS) {
      throw InputError("MPI_Init failed; run under mpirun or without MPI (--no-mpi)");
    }
    owns_ = true;
  }
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
}

MpiSession::~MpiSession() {
  int finalized = 0;
  MPI_Finalized(&finalized);
  if (owns_ && !finalized) MPI_Finalize();
}

void remove_checkpoint_files(const std::string& checkpoint_path) {
  if (checkpoint_path.empty()) return;
  for (const auto& f : existing_checkpoints(checkpoint_path)) std::remove(f.c_str());
}

}  // namespace pvdf::mapping
