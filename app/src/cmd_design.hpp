// The two halves of `pvdfkit design` share these: cmd_design.cpp ranks typed layouts (maps,
// analysis, ranking, figures), cmd_design_optimize.cpp searches layouts (--optimize, docs/design.md
// section 7). The command's options, one candidate layout, the progress of a phase of FEM maps, and
// the steps both call.
#pragma once

#include "pvdf/core/progress.hpp"
#include "pvdf/core/resources.hpp"
#include "pvdf/core/staged_eta.hpp"
#include "pvdf/mapping/design.hpp"
#include "pvdf/mapping/design_study.hpp"
#include "pvdf/mapping/map.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace pvdf::app::design {

struct DesignCommandOptions {
  std::vector<std::string> scenes;
  std::vector<std::string> maps;
  std::string vary;
  std::string noise = "5e-14";
  double target_mm = 0.5;
  double force_N = 1.0;
  std::string force_range = "0.25,4";
  bool force_known = false;
  double spacing_m = 0;  // 0: 1 mm synthetic, 3 mm FEM
  bool synthetic = false;
  int refine_best = 0;
  double refine_spacing_m = 0;  // 0: half the preview spacing
  double tolerance = 0;         // 0: the scene's
  int threads = 0;
  int adc_bits = 12;
  double full_scale_C = 0;
  double ambiguity_min_distance_m = 0;
  bool json = false;
  std::string out_dir = "design-out";
  bool no_plots = false;
  bool include_map_error = false;
  bool quiet = false;
  // --optimize (docs/design.md §7)
  bool optimize = false;
  std::string atlas_path;
  int electrodes_min = 3, electrodes_max = 6;
  double size_min_m = 0.001, size_max_m = 0.004;
  bool square = false, no_rotation = false;
  double min_gap_m = 0.0005, clamp_margin_m = 0.001;
  long long seed = 1;     // signed here, so that a negative value is refused, not wrapped
  long long budget = 300;
  int search_stride = 1;
  bool verify = false;
};

/// The process's resident memory after each block of map positions (design.json's `memory`).
struct MemorySample {
  std::string phase;
  std::size_t positions = 0;  ///< positions solved in the phase so far
  std::uint64_t resident_bytes = 0;
};

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

/// One candidate layout and what the analysis found (the library's: mapping/studies/design_study.hpp).
using Candidate = pvdf::mapping::DesignCandidate;

/// printf-formatted number ("%.3g").
std::string fmt(const char* f, double v);
/// m as mm ("0.0850 mm"), "unbounded" for +inf (never "inf" or "nan" as a result).
std::string mm(double m);
/// A fraction as a percentage ("38.6 %"), "unbounded" for +inf.
std::string pct(double f);

/// The positions each FEM map of `maps` will solve at `spacing` (progress totals; none synthetic).
std::vector<std::size_t> planned_positions(const std::vector<const Candidate*>& maps, const DesignCommandOptions& o,
                                           double spacing);
/// The candidate's charge map at `spacing`: synthetic, or an FEM map written to --out-dir/maps/
/// (`map_file`); `map_source` receives "synthetic" or "fem". Map number `map_index` of `progress`.
pvdf::mapping::ChargeMap make_map(const Candidate& c, const DesignCommandOptions& o, double spacing,
                                  std::string& map_file, std::string& map_source, MapsProgress& progress,
                                  std::size_t map_index);
/// The candidate's DesignSummary from its map.
void evaluate(Candidate& c, const pvdf::mapping::DesignOptions& d);
/// The analysis options from the command's flags, each checked against its rule.
pvdf::mapping::DesignOptions design_options(const DesignCommandOptions& o);
/// The figures' noise label: "σ = 0.05 pC, 12-bit ADC" (per electrode "0.05/0.1" when they differ).
std::string noise_label(const pvdf::mapping::DesignOptions& d, const DesignCommandOptions& o);
/// design_position.png and design_force.png of the (at most 8) first of `ranked`; paths appended to `written`.
void write_map_figures(const std::vector<const Candidate*>& ranked, const DesignCommandOptions& o,
                       const std::string& noise_text, std::vector<std::string>& written);

/// `pvdfkit design --optimize` (cmd_design_optimize.cpp): the exit code.
int run_optimize(const DesignCommandOptions& o);

}  // namespace pvdf::app::design
