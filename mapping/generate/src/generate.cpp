// Charge-map generation (docs/map-generation.md): the grid and its mirror symmetry, the
// row blocks that threads and MPI ranks share, the force-scaling check, checkpoints.
//
// Why rows: every row block starts its warm-start chain from the flat film, so the result of
// a block does not depend on which rank or thread ran it, nor on what ran before — the map is
// the same (bitwise, for a deterministic solver) for any number of ranks and threads and for
// an interrupted-and-resumed run. Within a row each solve warm-starts from its neighbour.
//
// This file holds Generator::run and its steps; generator.hpp says where the rest lives.
#include "generator.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/resources.hpp"
#include "pvdf/mapping/locator.hpp"
#include "pvdf/version.hpp"

#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace pvdf::mapping {
namespace detail {

ChargeMap Generator::run(MapReport& report) {
  const auto t_start = std::chrono::steady_clock::now();
  validate_options();
  setup_mpi();
  sym_ = detect_symmetry(scene_, o_.use_symmetry);
  build_grid();
  layout_ = Layout{o_.forces_N.size(), scene_.electrodes.size()};
  init_map();
  scaling_ = o_.use_force_scaling && layout_.nf > 1;
  // The time left as of any moment, for the caller's heartbeat, from the setup on; withdrawn
  // however run() ends. During the setup it is the setup's checks still to run plus every
  // position at the checks' cost so far (NaN before the first check); then the positions' alone.
  struct Withdraw {
    const std::function<void(std::function<double()>)>& f;
    ~Withdraw() {
      if (f) f({});
    }
  } withdraw{o_.time_left_now};
  if (o_.time_left_now) {
    o_.time_left_now([this] {
      std::lock_guard<std::mutex> lock(mutex_);
      return time_left_now_s(eta_clock_s());
    });
  }
  const double setup_wall0_s = eta_clock_s(), setup_cpu0_s = pvdf::thread_cpu_s();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    plan_time_left();  // every position, as if none were known (the checkpoint is read after the setup)
  }
  setup_sweeps([this, setup_wall0_s, setup_cpu0_s](std::size_t done, std::size_t planned) {
    if (done == 0) return;
    std::lock_guard<std::mutex> lock(mutex_);
    const double wall_s = eta_clock_s() - setup_wall0_s;
    report_setup_prior(pvdf::thread_cpu_s() - setup_cpu0_s, wall_s, double(done),
                       wall_s / double(done) * double(planned - std::min(done, planned)));
  });
  const double setup_wall_s = eta_clock_s() - setup_wall0_s, setup_cpu_s = pvdf::thread_cpu_s() - setup_cpu0_s;
  hash_ = run_hash();
  resume();
  last_checkpoint_ = std::chrono::steady_clock::now();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    setup_left_s_ = 0;
    time_left_id_.clear();  // planned again below without the positions the checkpoint holds
    count_progress_total();
    report_setup_prior(setup_cpu_s, setup_wall_s, double(o_.n_setup_checks), 0.0);
  }
  // The positions to do, known now: the caller's progress shows them (and the ETA above) before
  // the first row ends, which near the clamp can take a minute.
  if (o_.progress) o_.progress(std::min(progress_total_, progress_done_ * std::size_t(size_)), progress_total_);

  bool stopped_anywhere = run_scaling_checks(report);      // phase A
  if (!stopped_anywhere) {
    // phase B: every other position, or level by level where the interpolant needs them
    stopped_anywhere = adaptive_ ? run_adaptive_levels() : run_other_positions();
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    maybe_checkpoint(true);
  }
  const std::array<std::size_t, 2> counters = gather_on_rank0();
  fill_mirrors();

  // Report.
  const fem::SweepSetup& setup = sweeps_[0]->setup();
  map_.model = fem::model_name(setup.model);
  report = MapReport{};
  if (adaptive_) finish_adaptive(report);
  summarize_estimates(report);
  for (const auto& sw : sweeps_) {
    if (!sw) continue;
    const fem::SweepTiming t = sw->timing();
    report.rim_solves += std::size_t(t.rim_solves);
    report.rim_s += t.rim_s;
    report.clamp_layer_solves += std::size_t(t.clamp_layer_solves);
    report.clamp_layer_s += t.clamp_layer_s;
    report.estimate_s += t.estimate_s;
    report.probe_mesh_s += t.probe_mesh_s;
    report.probe_mesh_dofs = std::max(report.probe_mesh_dofs, t.probe_mesh_dofs);
  }
  report.solve_cpu_s = solve_cpu_s_;
  if (use_mpi_ && size_ > 1) {  // all ranks' CPU time, for the per-solve figure over all ranks' solves
    double t[2] = {report.solve_cpu_s, report.estimate_s};
    MPI_Allreduce(MPI_IN_PLACE, t, 2, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    report.solve_cpu_s = t[0];
    report.estimate_s = t[1];
  }
  report.probe_size_m = setup.probe_size_m;
  report.direct_solves = direct_solves_;
  report.direct_s = direct_s_;
  report.ranks = size_;
  report.threads = threads_;
  report.model = map_.model;
  report.model_reason = setup.model_reason;
  report.estimated_relative_error = map_.estimated_relative_error;
  report.estimated_deflection_relative_error = map_.estimated_deflection_relative_error;
  report.n_dofs = setup.n_dofs;
  report.rim_n_dofs = setup.rim_n_dofs;
  report.clamp_layer_condition = setup.clamp_layer_condition;
  report.setup_s = setup.setup_s;
  report.mirror_x = sym_.about_x;
  report.mirror_y = sym_.about_y;
  report.symmetry_reason = sym_.reason;
  report.checkpoint_hash = hash_;
  report.stopped_early = stopped_anywhere;
  report.first_failure = first_failure_;
  report.n_solved = counters[0];
  report.n_resumed = n_resumed_points_;
  count_points(report);
  if (rank_ == 0 && !stopped_anywhere) report.lookup_total_relative_error = lookup_error_summary(map_);
  report.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  report.per_position_s = counters[1] > 0 ? report.wall_s * size_ / double(counters[1]) : 0.0;
  report.placement_s = placement_s_;
  report.placement = adaptive_ ? "adaptive" : "uniform";
  report.provenance = provenance_;
  report.node_model = node_model_;
  return std::move(map_);
}

// The map's provenance and its arrays: every value NaN, positions outside the mask `outside`.
void Generator::init_map() {
  const std::size_t nf = layout_.nf, ne = layout_.ne, n = grid_.nx * grid_.ny;
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
  interpolated_.assign(n, 0);
  interp_err_G_.assign(adaptive_ ? nf * n * ne : 0, 0.0);
  known_.assign(n, 0);
  this_run_.assign(n, 0);
}

// The time left before any row is done: each position's solves at the setup checks' CPU seconds
// each (mesh included), at the setup's CPU per wall second on every thread (docs/design.md §6),
// plus `setup_left_s` of the setup still to run; stated to the caller. Nothing without a check.
void Generator::report_setup_prior(double cpu_s, double wall_s, double n_checks, double setup_left_s) {
  if (!(o_.n_setup_checks > 0 && n_checks > 0 && cpu_s > 0 && wall_s > 0)) return;
  time_left_.set_prior(std::size_t(fem::SweepModel::cheap), cpu_s / n_checks, n_checks, cpu_s / wall_s);
  const double now_s = eta_clock_s();
  setup_left_s_ = setup_left_s;
  setup_left_at_s_ = now_s;
  report_common_cost();
  if (o_.time_left) o_.time_left(time_left_now_s(now_s));
}

// Solver setup (one sweep per thread; the first here, so bad input fails before the threads).
void Generator::setup_sweeps(const std::function<void(std::size_t, std::size_t)>& on_check) {
  sweep_options_.solver = fem::options_from_scene(scene_);
  if (!o_.model.empty()) sweep_options_.solver.model = fem::parse_model(o_.model, "MapOptions::model");
  sweep_options_.solver.tolerance = tolerance_;
  sweep_options_.rim_margin_m = margin_;
  sweep_options_.forces_N = o_.forces_N;
  sweep_options_.n_setup_checks = o_.n_setup_checks;
  // The choices are enums: checked where they were parsed (parse_rim_model, ...).
  if (o_.rim_model == RimModel::never) sweep_options_.rim_model = fem::SweepOptions::RimModel::never;
  else if (o_.rim_model == RimModel::always) sweep_options_.rim_model = fem::SweepOptions::RimModel::always;
  sweep_options_.mesh = o_.mesh;
  if (o_.probe_refinement == ProbeRefinement::none) sweep_options_.probe_size_m = -1;
  sweeps_.resize(std::size_t(threads_));
  fem::SweepOptions first = sweep_options_;  // the other threads' sweeps run no checks
  first.on_setup_check = on_check;
  sweeps_[0] = std::make_unique<fem::ProbeSweep>(scene_, first);
}

// Canonical positions still to compute count for the progress total (phase B decided later).
std::size_t Generator::planned_positions() {
  validate_options();
  sym_ = detect_symmetry(scene_, o_.use_symmetry);
  build_grid();
  known_.assign(grid_.nx * grid_.ny, 0);
  progress_total_ = 0;
  count_progress_total();
  return progress_total_;
}

void Generator::count_progress_total() {
  for (std::size_t p = 0; p < grid_.nx * grid_.ny; ++p) {
    if (map_.mask[p] && !known_[p] && canonical(p % grid_.nx, p / grid_.nx)) ++progress_total_;
  }
  plan_time_left();
}

// Every canonical position still to compute, planned once for the time left with its distance
// to the clamp as the feature (bins of one grid spacing).
void Generator::plan_time_left() {
  const std::size_t n = grid_.nx * grid_.ny;
  if (time_left_id_.size() != n) {
    time_left_ = pvdf::ItemCostEta(4, grid_.spacing > 0 ? grid_.spacing : 1e-3, std::max(1, threads_));
    time_left_id_.assign(n, std::size_t(-1));
    time_left_work_.assign(n, {});
    time_left_cpu_s_.assign(n, 0.0);
  }
  if (map_.mask.size() != n || known_.size() != n) return;
  std::vector<double> features;
  std::vector<std::size_t> points;
  for (std::size_t p = 0; p < n; ++p) {
    if (!map_.mask[p] || known_[p] || time_left_id_[p] != std::size_t(-1) || !canonical(p % grid_.nx, p / grid_.nx)) continue;
    const double x = double(grid_.i0 + long(p % grid_.nx)) * grid_.spacing;
    const double y = double(grid_.j0 + long(p / grid_.nx)) * grid_.spacing;
    features.push_back(scene_.membrane.outline.inside_distance_m({x, y}));
    points.push_back(p);
  }
  const std::size_t first = time_left_.plan(features);
  for (std::size_t k = 0; k < points.size(); ++k) {
    time_left_id_[points[k]] = first + k;
    // The force levels it will solve: all at a scaling check (and without scaling), else the
    // largest only — corrected when its cell's verdict is known (run_blocks).
    const bool check = is_lattice(points[k] % grid_.nx, points[k] / grid_.nx);
    time_left_.set_units(first + k, !scaling_ || check ? double(layout_.nf) : 1.0);
  }
}

// Phase A: the force-scaling check positions (every level solved), their verdicts shared by
// all ranks. Returns whether any rank stopped early.
bool Generator::run_scaling_checks(MapReport& report) {
  const std::size_t n = grid_.nx * grid_.ny;
  verdict_.assign(n, 0);
  check_err_.assign(n, 0.0);
  if (scaling_) {
    std::vector<Block> blocks;
    for (std::size_t j = 0; j < grid_.ny; ++j) {
      Block b;
      bool complete = true;
      for (std::size_t i = 0; i < grid_.nx; ++i) {
        if (!map_.mask[j * grid_.nx + i] || !canonical(i, j) || !is_lattice(i, j)) continue;
        b.push_back(Task{i, j, true});
        if (!known_[j * grid_.nx + i]) complete = false;
      }
      if (!b.empty() && !complete) blocks.push_back(std::move(b));
    }
    run_blocks(split_for_rank(blocks));
    for (std::size_t p = 0; p < n; ++p) {
      const std::size_t i = p % grid_.nx, j = p / grid_.nx;
      if (map_.mask[p] && known_[p] && is_lattice(i, j) && canonical(i, j)) {
        const double e = check_error(i, j);
        verdict_[p] = e <= 0.5 * tolerance_ ? 1 : 2;
        check_err_[p] = std::isfinite(e) ? e : 1.0;
        if (std::isfinite(e)) report.max_scaling_check_error = std::max(report.max_scaling_check_error, e);
      }
    }
    if (use_mpi_) {
      MPI_Allreduce(MPI_IN_PLACE, verdict_.data(), int(n), MPI_UNSIGNED_CHAR, MPI_MAX, MPI_COMM_WORLD);
      MPI_Allreduce(MPI_IN_PLACE, check_err_.data(), int(n), MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
      MPI_Allreduce(MPI_IN_PLACE, &report.max_scaling_check_error, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    }
  }
  int stopped = stop_ ? 1 : 0;
  if (use_mpi_) MPI_Allreduce(MPI_IN_PLACE, &stopped, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  return stopped != 0;
}

// Phase B: every other position; scaled only where all lattice corners of its cell passed.
// Returns whether any rank stopped early.
bool Generator::run_other_positions(const std::vector<std::uint8_t>* want) {
  const long k = o_.scaling_check_stride;
  auto decide = [&](std::size_t i, std::size_t j, double& worst) {
    worst = 0;
    if (!scaling_) return true;  // all levels
    const long I = grid_.i0 + long(i), J = grid_.j0 + long(j);
    const long Ia = I - (((I % k) + k) % k), Ja = J - (((J % k) + k) % k);
    const long Is[2] = {Ia, Ia == I ? Ia : Ia + k}, Js[2] = {Ja, Ja == J ? Ja : Ja + k};
    int counted = 0;
    for (long a : Is) {
      for (long b : Js) {
        std::size_t ci = 0, cj = 0;
        if (!in_grid(a, b, ci, cj)) continue;
        const Rep r = rep(ci, cj);
        const std::uint8_t v = verdict_[r.j * grid_.nx + r.i];
        if (v != 1) return true;  // failed or unknown: solve every level
        worst = std::max(worst, check_err_[r.j * grid_.nx + r.i]);
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
      if (!map_.mask[p] || !canonical(i, j) || (scaling_ && is_lattice(i, j))) continue;
      if (want && (!(*want)[p] || known_[p])) continue;
      double worst = 0;
      const bool all_levels = decide(i, j, worst);
      b.push_back(Task{i, j, all_levels, worst});
      if (!known_[p]) complete = false;
    }
    if (!b.empty() && !complete) all.push_back(std::move(b));
  }
  run_blocks(split_for_rank(all));
  int stopped = stop_ ? 1 : 0;
  if (use_mpi_) MPI_Allreduce(MPI_IN_PLACE, &stopped, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  return stopped != 0;
}

// Gathers every rank's records on rank 0; returns {FEM-solved points, FEM-solved positions}
// summed over the ranks.
std::array<std::size_t, 2> Generator::gather_on_rank0() {
  std::array<std::size_t, 2> counters = {fem_points_solved_, positions_solved_.load()};
  if (!use_mpi_ || size_ <= 1) return counters;
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
  return counters;
}

// The map's overall estimates: the largest per-node ones (ok points); rim-model and
// tolerance-not-met counts.
void Generator::summarize_estimates(MapReport& report) {
  const std::size_t ne = layout_.ne, n_pt = layout_.nf * grid_.nx * grid_.ny;
  double charge = 0, deflection = 0;
  for (std::size_t pt = 0; pt < n_pt; ++pt) {
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
    if (node_model_[pt] == std::uint8_t(fem::SweepModel::clamp_layer)) ++report.n_clamp_layer;
    if (node_model_[pt] == std::uint8_t(direct_model)) ++report.n_direct;
    if (provenance_[pt] & provenance::tolerance_not_met) ++report.n_tolerance_not_met;
  }
  if (adaptive_) {
    // The stored errors are totals; the node estimates' own largest share is kept separately.
    map_.estimated_total_relative_error = charge;
    report.estimated_total_relative_error = charge;
  } else {
    map_.estimated_relative_error = charge;
    report.estimated_total_relative_error = charge;
  }
  map_.estimated_deflection_relative_error = deflection;
}

// Positions, points and how each was obtained; the scaling checks and their worst error,
// recomputed on this rank's full knowledge (rank 0 has everything).
void Generator::count_points(MapReport& report) const {
  const std::size_t n = grid_.nx * grid_.ny, nf = layout_.nf;
  for (std::size_t p = 0; p < n; ++p) {
    if (!map_.mask[p]) continue;
    ++report.n_positions;
    if (scaling_ && is_lattice(p % grid_.nx, p / grid_.nx) && canonical(p % grid_.nx, p / grid_.nx) && verdict_[p]) {
      ++report.n_scaling_checks;
      if (verdict_[p] == 2) ++report.n_scaling_checks_failed;
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
  report.max_scaling_check_error = 0;
  if (scaling_) {
    for (std::size_t p = 0; p < n; ++p) {
      const std::size_t i = p % grid_.nx, j = p / grid_.nx;
      if (verdict_[p] && known_[p]) {
        const double e = check_error(i, j);
        if (std::isfinite(e)) report.max_scaling_check_error = std::max(report.max_scaling_check_error, e);
      }
    }
  }
}

}  // namespace detail

ChargeMap generate_map(const pvdf::Scene& scene, const MapOptions& options, MapReport* report) {
  MapReport local;
  detail::Generator g(scene, options);
  ChargeMap map = g.run(local);
  if (report) *report = std::move(local);
  return map;
}

std::size_t planned_positions(const pvdf::Scene& scene, const MapOptions& options) {
  return detail::Generator(scene, options).planned_positions();
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
      throw InputError("MPI_Init failed; run under mpirun or without MPI");
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

}  // namespace pvdf::mapping
