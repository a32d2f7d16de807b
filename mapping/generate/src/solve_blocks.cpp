// Map generation, the work: row blocks split over the ranks and solved on the threads (one
// ProbeSweep each, warm starts along a row), the levels scaled from the largest force where the
// check allows it, the force-scaling check itself, and the copies to mirror-image positions.
#include "generator.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/membrane_scaling.hpp"
#include "pvdf/core/resources.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <limits>
#include <thread>
#include <utility>
#include <vector>

#include <malloc.h>

namespace pvdf::mapping::detail {
namespace {

// The order the row blocks are handed to the threads: the first and the last, then the middle of
// each gap, breadth first (0, n−1, n/2, n/4, 3n/4, …), so that the rows done early sample the whole
// film, the dear ones near the clamp included, and the time left learns their cost (docs/design.md
// §6). Each block is solved on its own (warm starts along its row only), so the map does not depend
// on the order, as it does not on the threads.
std::vector<std::size_t> spread_order(std::size_t n) {
  std::vector<std::size_t> order;
  if (n == 0) return order;
  std::vector<char> taken(n, 0);
  auto take = [&](std::size_t k) {
    if (!taken[k]) order.push_back(k);
    taken[k] = 1;
  };
  take(0);
  take(n - 1);
  std::vector<std::pair<std::size_t, std::size_t>> gaps{{0, n - 1}}, next;
  while (!gaps.empty()) {
    next.clear();
    for (const auto& [a, b] : gaps) {
      if (b - a < 2) continue;
      const std::size_t m = a + (b - a) / 2;
      take(m);
      next.push_back({a, m});
      next.push_back({m, b});
    }
    gaps.swap(next);
  }
  return order;
}

// PVDF_ETA_TRACE set: one stderr line per row committed and per run_blocks call, with what the
// time left was computed from, so that a run's ETA can be replayed offline (docs/design.md §6).
bool eta_trace() {
  static const bool on = std::getenv("PVDF_ETA_TRACE") != nullptr;
  return on;
}

}  // namespace

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
    // The time left's work of this position: sweep solves, and on top of them the rim-model and
    // clamp-layer solves the sweep ran (kept or not) and the direct solves tried.
    std::array<double, 4> work{};
    const fem::SweepTiming timing0 = sweep.timing();
    const double position_cpu0_s = thread_cpu_s();
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
      fem::ProbeSolution s;
      const double cpu0 = thread_cpu_s();
      try {
        s = sweep.solve(x, y, o_.forces_N[f], warm, out);
      } catch (const NumericalError& e) {
        s = fem::ProbeSolution{};
        s.status = fem::Status::no_convergence;
        s.force_N = o_.forces_N[f];
        s.message = e.what();
      }
      ++work[std::size_t(fem::SweepModel::cheap)];
      if (s.status == fem::Status::tolerance_not_met && o_.direct_solves == DirectSolves::by_estimate) {
        improve_by_direct_solve(x, y, s);
        ++work[std::size_t(direct_model)];  // tried, kept or not
      }
      const double cpu = thread_cpu_s() - cpu0;
      std::lock_guard<std::mutex> lock(mutex_);
      solve_cpu_s_ += cpu;
      return s;
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
    const fem::SweepTiming timing1 = sweep.timing();
    work[std::size_t(fem::SweepModel::rim)] += double(timing1.rim_solves - timing0.rim_solves);
    work[std::size_t(fem::SweepModel::clamp_layer)] += double(timing1.clamp_layer_solves - timing0.clamp_layer_solves);
    const std::size_t p = task.j * grid_.nx + task.i;
    if (p < time_left_work_.size()) {  // this thread's own position
      time_left_work_[p] = work;
      time_left_cpu_s_[p] = thread_cpu_s() - position_cpu0_s;
      // The time left learns this position's cost now, not at the row's end (a first row next to
      // the clamp runs a minute: its positions say what the clamp's work costs; ItemCostEta::item_done).
      std::lock_guard<std::mutex> lock(mutex_);
      if (p < time_left_id_.size() && time_left_id_[p] != std::size_t(-1)) {
        time_left_.item_done(time_left_id_[p], std::vector<double>(work.begin(), work.end()), time_left_cpu_s_[p], eta_clock_s());
        report_common_cost();
      }
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

double Generator::eta_clock_s() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - clock0_).count();
}

double Generator::time_left_now_s(double t_s) const {
  return time_left_.seconds_left(t_s) + std::max(0.0, setup_left_s_ - (t_s - setup_left_at_s_));
}

// The cost per position of the solves every layout of this film needs (sweep and clamp-layer
// solves), for the caller's prediction of other maps (MapOptions::common_seconds_per_position).
void Generator::report_common_cost() {
  if (!o_.common_seconds_per_position) return;
  const double cpu_s = time_left_.cpu_s_per_item({std::size_t(fem::SweepModel::cheap), std::size_t(fem::SweepModel::clamp_layer)});
  o_.common_seconds_per_position(cpu_s / time_left_.cpu_per_wall_s());
}

void Generator::commit(const std::vector<double>& records, std::size_t n_positions, double cpu_s, double start_s) {
  std::lock_guard<std::mutex> lock(mutex_);
  // The time left: the solves of each kind each position of the block ran (solve_block).
  std::vector<std::size_t> items;
  std::vector<std::vector<double>> work;
  std::vector<double> item_cpu_s;  // each position's own CPU: the cost fit's rows (ItemCostEta)
  for (std::size_t r = 0; r < records.size(); r += layout_.size()) {
    const std::size_t p = std::size_t(records[r + Layout::point_index]);
    if (p >= time_left_id_.size() || time_left_id_[p] == std::size_t(-1) || p >= time_left_work_.size()) continue;
    items.push_back(time_left_id_[p]);
    work.emplace_back(time_left_work_[p].begin(), time_left_work_[p].end());
    item_cpu_s.push_back(time_left_cpu_s_[p]);
  }
  const double now_s = eta_clock_s();
  time_left_.block_done(items, work, cpu_s, start_s, now_s, item_cpu_s);
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
  report_common_cost();  // before time_left, whose report refreshes the caller's ETA
  const double left_s = time_left_.seconds_left(now_s);
  if (o_.time_left) o_.time_left(left_s);
  if (eta_trace()) {
    std::string line = "eta-trace row t=" + std::to_string(now_s) + " start=" + std::to_string(start_s) +
                       " cpu=" + std::to_string(cpu_s) + " left=" + std::to_string(left_s) + " items=";
    for (std::size_t n = 0; n < items.size(); ++n) {
      line += std::to_string(items[n]) + ":" + std::to_string(time_left_.feature(items[n])) + ":" +
              std::to_string(time_left_.units(items[n]));
      for (double w : work[n]) line += ":" + std::to_string(int(w));
      line += ":" + std::to_string(item_cpu_s[n]) + ";";
    }
    std::fprintf(stderr, "%s\n", line.c_str());
  }
}

void Generator::run_blocks(const std::vector<Block>& blocks) {
  const std::vector<std::size_t> order = spread_order(blocks.size());
  {
    // The time left learns which positions solve every force level and which the largest only, and
    // the rows in the order the threads take them.
    std::lock_guard<std::mutex> lock(mutex_);  // the heartbeat may ask for the time left meanwhile
    for (const auto& block : blocks) {
      for (const auto& t : block) {
        const std::size_t p = t.j * grid_.nx + t.i;
        if (p < time_left_id_.size() && time_left_id_[p] != std::size_t(-1)) {
          time_left_.set_units(time_left_id_[p], t.all_levels ? double(layout_.nf) : 1.0);
        }
      }
    }
    std::vector<std::vector<std::size_t>> queued;
    for (std::size_t b : order) {
      queued.emplace_back();
      for (const auto& t : blocks[b]) {
        const std::size_t p = t.j * grid_.nx + t.i;
        if (p < time_left_id_.size() && time_left_id_[p] != std::size_t(-1)) queued.back().push_back(time_left_id_[p]);
      }
    }
    time_left_.queue_blocks(queued);
  }
  if (eta_trace()) {
    const fem::SweepTiming t0 = sweeps_[0]->timing();
    std::string line = "eta-trace blocks t=" + std::to_string(eta_clock_s()) + " n=" + std::to_string(blocks.size()) +
                       " threads=" + std::to_string(threads_) + " setup_s=" + std::to_string(sweeps_[0]->setup().setup_s) +
                       " solve_cpu_s=" + std::to_string(solve_cpu_s_) + " newton=" + std::to_string(t0.newton_iterations) +
                       " plan=";
    for (std::size_t id = 0; id < time_left_.size(); ++id)
      line += std::to_string(time_left_.feature(id)) + ":" + std::to_string(time_left_.units(id)) + ";";
    std::fprintf(stderr, "%s\n", line.c_str());
  }
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
        const std::size_t k = next.fetch_add(1);
        if (k >= order.size()) break;
        const std::size_t b = order[k];
        bool abandoned = false;
        const double start_s = eta_clock_s(), cpu0_s = thread_cpu_s();
        {
          std::vector<std::size_t> ids;
          for (const auto& task : blocks[b]) {
            const std::size_t p = task.j * grid_.nx + task.i;
            if (p < time_left_id_.size() && time_left_id_[p] != std::size_t(-1)) ids.push_back(time_left_id_[p]);
          }
          std::lock_guard<std::mutex> lock(mutex_);
          time_left_.block_started(ids, start_s);
        }
        solve_block(*sweeps_[std::size_t(t)], blocks[b], records, abandoned);
        if (abandoned) break;
        commit(records, blocks[b].size(), thread_cpu_s() - cpu0_s, start_s);
        // A row's solves free what its probe meshes, rim engines and direct solves held, but glibc
        // keeps freed pages below its mmap threshold in each thread's arena; handing them back after
        // every row keeps the resident memory that of the live solvers (docs/bench-fem.md, "Memory").
        malloc_trim(0);
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

}  // namespace pvdf::mapping::detail
