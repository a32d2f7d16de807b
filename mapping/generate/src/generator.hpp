// Private to pvdf_mapping_fem: the pieces of a map generation shared by its sources — the
// scene's mirror symmetry, the grid, the row blocks of work, the record layout of checkpoints
// and MPI gathers, and the Generator that runs them (docs/map-generation.md).
//
//   symmetry_grid.cpp  mirror symmetry, the grid and its mask, option checks, MPI/thread setup
//   checkpoint.cpp     the run's hash, checkpoint files, records in and out of the map, resume
//   solve_blocks.cpp   row blocks on the threads and ranks, force scaling, mirror images
//   direct_solve.cpp   nodes the sweep leaves above the tolerance, solved on their own adaptive mesh
//   adaptive_placement.cpp  levels of solves placed by the interpolant's estimated error, the fill
//                      of the other nodes, every node's total error
//   generate.cpp       Generator::run step by step, the report, generate_map, MpiSession
#pragma once

#include "pvdf/core/item_cost_eta.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/fem/probe_sweep.hpp"
#include "pvdf/mapping/generate.hpp"

#include <array>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

namespace pvdf::mapping::detail {

inline constexpr double nan = std::numeric_limits<double>::quiet_NaN();

/// Node model code of a direct adaptive solve (after fem::SweepModel's cheap = 0 and rim = 1).
inline constexpr fem::SweepModel direct_model = static_cast<fem::SweepModel>(2);

inline std::string num(double v) {
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

/// Which mirrors leave the scene unchanged (film, material axes, electrodes), with the
/// electrode permutations; `wanted` false = none used.
Symmetry detect_symmetry(const pvdf::Scene& scene, bool wanted);

// ---------------------------------------------------------------------------------------------
// Grid: nodes at integer multiples of the spacing, I = i0 + i, J = j0 + j.

struct Grid {
  long i0 = 0, j0 = 0;
  std::size_t nx = 0, ny = 0;
  double spacing = 0;
};


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

// ---------------------------------------------------------------------------------------------
// Checkpoint files (checkpoint.cpp).

/// The 16 hex digits of `v`.
std::string hex(std::uint64_t v);
/// Writes `records` (whole records of `layout`) atomically under a header holding `hash`.
void write_checkpoint(const std::string& path, const std::string& hash, const Layout& layout,
                      const std::vector<double>& records);
/// Reads a checkpoint written for `hash` and `layout`; anything else throws pvdf::InputError.
std::vector<double> read_checkpoint(const std::string& path, const std::string& hash, const Layout& layout);
std::string rank_checkpoint_path(const std::string& base, int rank, int size);
/// The base file and every `<base>.rank<digits>` beside it.
std::vector<std::string> existing_checkpoints(const std::string& base);

// ---------------------------------------------------------------------------------------------

/// One map generation: run() reads as its steps (set up, resume, the force-scaling check
/// positions, every other position, gather, mirror, report).
class Generator {
 public:
  Generator(const pvdf::Scene& scene, const MapOptions& options) : scene_(scene), o_(options) {}
  ChargeMap run(MapReport& report);
  /// The positions run() would solve from scratch (planned_positions): options, symmetry, grid.
  std::size_t planned_positions();

 private:
  // steps of run() (generate.cpp)
  void init_map();
  /// The first sweep (its setup checks; `on_check(done, planned)` after each) — more are made per thread.
  void setup_sweeps(const std::function<void(std::size_t, std::size_t)>& on_check);
  std::string run_hash() const;
  void resume();  // with run_hash: checkpoint.cpp
  void count_progress_total();
  bool run_scaling_checks(MapReport& report);
  /// Phase B over the canonical positions not yet known (want: [ny][nx] 1 = solve; null = all).
  bool run_other_positions(const std::vector<std::uint8_t>* want = nullptr);
  std::array<std::size_t, 2> gather_on_rank0();
  void summarize_estimates(MapReport& report);
  void count_points(MapReport& report) const;
  // adaptive placement (adaptive_placement.cpp)
  bool run_adaptive_levels();
  void finish_adaptive(MapReport& report);
  int node_level(std::size_t i, std::size_t j) const;
  bool node_solved(std::size_t p) const;
  void share_records();
  // setup (symmetry_grid.cpp)
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
  // work (solve_blocks.cpp; records and checkpoints in checkpoint.cpp)
  void run_blocks(const std::vector<Block>& blocks);
  void solve_block(fem::ProbeSweep& sweep, const Block& block, std::vector<double>& records, bool& abandoned);
  /// `cpu_s`, `start_s`: the block's thread CPU seconds and its start on the time-left clock.
  void commit(const std::vector<double>& records, std::size_t n_positions, double cpu_s, double start_s);
  /// MapOptions::common_seconds_per_position from the time left's fit (the caller holds mutex_).
  void report_common_cost();
  double eta_clock_s() const;  ///< seconds on the time-left clock (steady, since construction)
  void plan_time_left();       ///< adds the counted positions not yet planned to time_left_
  /// MapOptions::time_left_now's answer at `t_s`: the positions' time left plus, during the setup,
  /// its checks still to run (setup_left_s_ counted down). The caller holds mutex_.
  double time_left_now_s(double t_s) const;
  /// The setup checks' prior for the time left (generate.cpp), stated to the caller (holds mutex_).
  void report_setup_prior(double cpu_s, double wall_s, double n_checks, double setup_left_s);
  void improve_by_direct_solve(double x_m, double y_m, fem::ProbeSolution& s);  // direct_solve.cpp
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
  // MapOptions::time_left: kinds of work = fem::SweepModel codes 0..3: the sweep solves of a
  // position (one per level solved) and, on top of them, the rim-model, direct and clamp-layer
  // solves it ran, kept or not; feature = the position's distance to the clamp; time_left_id_[p] =
  // its item id (npos: not planned); time_left_work_[p] = its work, written by the thread solving it.
  pvdf::ItemCostEta time_left_{4, 1.0, 1};
  std::vector<std::size_t> time_left_id_;
  std::vector<std::array<double, 4>> time_left_work_;
  std::vector<double> time_left_cpu_s_;  ///< [p]: the thread CPU seconds its solves took, same writer
  double setup_left_s_ = 0, setup_left_at_s_ = 0;  ///< the setup's checks left (wall s) as of setup_left_at_s_
  std::chrono::steady_clock::time_point clock0_ = std::chrono::steady_clock::now();
  std::chrono::steady_clock::time_point last_checkpoint_;
  std::string first_failure_;
  std::size_t direct_solves_ = 0;        // direct adaptive solves (this process), under mutex_
  double direct_s_ = 0;                  // their thread-seconds
  // One direct solve at a time in this process: near the clamp each holds GBs (2.6 GB at 128k DOFs,
  // docs/bench-fem.md "Memory"), and two at once on two threads were the README design's peak.
  std::mutex direct_solve_mutex_;

  // adaptive placement
  bool adaptive_ = false;
  int levels_ = 0;                        // refinement levels below the coarse level
  std::vector<std::uint8_t> interpolated_;  // [ny][nx] 1 = filled from a coarser level
  std::vector<double> interp_err_G_;      // [nf][ny][nx][ne] interpolation error of the governing cells (C/N^p)
  std::vector<std::size_t> level_positions_, level_solves_;
  double solve_cpu_s_ = 0;                // CPU-seconds of the FEM solves (this process), under mutex_
  double placement_s_ = 0;

  // force-scaling check (phase A), read when choosing scaled positions (phase B) and reporting
  bool scaling_ = false;
  std::vector<std::uint8_t> verdict_;  // [ny][nx] 1 pass, 2 fail (canonical lattice positions)
  std::vector<double> check_err_;      // [ny][nx] their scaling-check errors
};

}  // namespace pvdf::mapping::detail
