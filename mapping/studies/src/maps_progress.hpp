// The progress of one phase of a design study's FEM maps on stderr, with its ETA and the memory
// samples of design.json (private to design_fem_maps.cpp; moved from app/src/cmd_design.hpp).
#pragma once

#include "pvdf/core/progress.hpp"
#include "pvdf/core/resources.hpp"
#include "pvdf/core/staged_eta.hpp"
#include "pvdf/mapping/design_study.hpp"

#include <chrono>
#include <cstdio>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace pvdf::mapping {

/// One progress report over the FEM maps of a phase (the previews, or the refined winners), so
/// that its ETA is the phase's: the total is the positions of the maps done, of the map in
/// progress, and the planned positions of each map still to come (mapping::planned_positions:
/// layouts differ, e.g. a mirror-symmetric one solves half its grid). The ETA is pvdf::StagedEta's:
/// each map's setup (mesh, setup checks) and its rate per position are measured apart, the map in
/// progress is finished by its own estimate (MapOptions::time_left: each position's cost predicted
/// from its distance to the clamp) or else at its own rate, and the maps to come are predicted with
/// the measured mean setup and the cost per position of the solves every layout needs, as the maps
/// seen measured it (MapOptions::common_seconds_per_position: sweep and clamp-layer solves, not
/// their own rim-model and direct solves), docs/design.md §6. Before each heartbeat line the map in
/// progress is asked for its time left as of now (MapOptions::time_left_now: its rows in flight at
/// their time so far), so that a dear row is seen while it runs, not only once it ends.
class MapsProgress {
 public:
  /// The clock (and a heartbeat line every 10 s off a terminal) starts now, before the first setup.
  /// `planned`: the positions of each map of the phase, in the order they run. `memory`: where the
  /// resident memory after each block is appended (also when quiet), or null.
  MapsProgress(std::string label, std::vector<std::size_t> planned, bool quiet, std::string phase = {},
               std::vector<MemorySample>* memory = nullptr)
      : label_(std::move(label)), planned_(std::move(planned)), n_maps_(planned_.size()), quiet_(quiet),
        phase_(std::move(phase)), memory_(memory), eta_(planned_), t0_(std::chrono::steady_clock::now()) {
    // The total is known before the first setup: a line with the positions to do (and, once the
    // first map's setup states a prior, its ETA) instead of "starting".
    std::size_t total = 0;
    for (std::size_t n : planned_) total += n;
    if (!quiet_ && n_maps_ > 0) {
      bar_ = std::make_unique<pvdf::Progress>(label_, total);
      bar_->set_refresh([this] { refresh(); });
    }
  }
  ~MapsProgress() {
    if (bar_) bar_->set_refresh({});
  }
  /// Map number `index` (0-based) starts its setup now.
  void start_map(std::size_t index) {
    if (quiet_) return;
    std::lock_guard<std::mutex> lock(eta_mutex_);
    eta_.start_stage(index, now_s());
    if (bar_) bar_->set_eta_s(eta_.seconds_left(now_s()));
  }
  /// The callback of MapOptions::progress for map number `index` (0-based) of the phase.
  std::function<void(std::size_t, std::size_t)> for_map(std::size_t index) {
    if (quiet_ && memory_ == nullptr) return {};
    return [this, index](std::size_t done, std::size_t total) {
      if (index != current_) {  // the previous map ended: its positions are done
        done_before_ += current_total_;
        current_ = index;
      }
      current_total_ = total;
      std::size_t all = done_before_ + total;
      for (std::size_t k = index + 1; k < n_maps_; ++k) all += planned_[k];
      if (memory_ != nullptr) memory_->push_back({phase_, done_before_ + done, pvdf::current_resident_bytes()});
      if (!bar_) return;
      std::lock_guard<std::mutex> lock(eta_mutex_);
      const double t = now_s();
      eta_.items_done(index, done, total, t);
      bar_->set_total(all);
      bar_->set_eta_s(eta_.seconds_left(t));
      bar_->update(done_before_ + done);
    };
  }
  /// The callback of MapOptions::time_left for map number `index`: the map's own estimate of its
  /// time left (its positions' costs predicted by their distance to the clamp) replaces its rate's.
  std::function<void(double)> time_left_for_map(std::size_t index) {
    if (quiet_) return {};
    return [this, index](double seconds_left) {
      if (!bar_) return;
      std::lock_guard<std::mutex> lock(eta_mutex_);
      const double t = now_s();
      eta_.stage_seconds_left(index, seconds_left, t);
      bar_->set_eta_s(eta_.seconds_left(t));
    };
  }
  /// The callback of MapOptions::common_seconds_per_position for map number `index`: what a
  /// position of the maps still to come is expected to take.
  std::function<void(double)> common_cost_for_map(std::size_t index) {
    if (quiet_) return {};
    return [this, index](double seconds_per_position) {
      if (!bar_) return;
      std::lock_guard<std::mutex> lock(eta_mutex_);
      eta_.stage_item_seconds(index, seconds_per_position);
    };
  }
  /// The callback of MapOptions::time_left_now for map number `index`: the map's time left as of
  /// any moment, which the heartbeat asks for before each line (refresh), so that a row in flight
  /// longer than predicted counts between rows too.
  std::function<void(std::function<double()>)> time_left_now_for_map(std::size_t index) {
    if (quiet_) return {};
    return [this, index](std::function<double()> seconds_left_now) {
      std::lock_guard<std::mutex> lock(live_mutex_);
      live_ = std::move(seconds_left_now);
      live_index_ = index;
    };
  }
  void finish() {
    if (bar_) bar_->finish();
  }
  /// A line of its own on stderr (the terminal bar continues below it); nothing when quiet.
  void note(const std::string& text) {
    if (quiet_) return;
    if (bar_ && bar_->on_terminal()) std::fputc('\n', stderr);
    std::fputs((text + "\n").c_str(), stderr);
    std::fflush(stderr);
  }

 private:
  double now_s() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count(); }
  // The heartbeat's: the map's time left as of now. Lock order: live_mutex_, then the map's own
  // (inside live_), released before eta_mutex_ — the map's callbacks hold its lock, then eta_mutex_.
  void refresh() {
    std::lock_guard<std::mutex> live_lock(live_mutex_);
    if (!live_ || !bar_) return;
    const double seconds = live_();
    std::lock_guard<std::mutex> lock(eta_mutex_);
    const double t = now_s();
    eta_.stage_seconds_left(live_index_, seconds, t);
    bar_->set_eta_s(eta_.seconds_left(t));
  }
  std::string label_;
  std::vector<std::size_t> planned_;
  std::size_t n_maps_;
  bool quiet_;
  std::string phase_;
  std::vector<MemorySample>* memory_;
  pvdf::StagedEta eta_;
  std::mutex eta_mutex_;   ///< guards eta_ (the map's callbacks and the heartbeat's refresh)
  std::mutex live_mutex_;  ///< guards live_ and is held while it is called
  std::function<double()> live_;  ///< MapOptions::time_left_now's of the map in progress
  std::size_t live_index_ = 0;
  std::chrono::steady_clock::time_point t0_;
  std::size_t current_ = 0, current_total_ = 0, done_before_ = 0;
  std::unique_ptr<pvdf::Progress> bar_;
};

}  // namespace pvdf::mapping
