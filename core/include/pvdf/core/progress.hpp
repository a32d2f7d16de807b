// Progress reporting for long work on stderr: a bar with rate and ETA on a terminal, plain
// lines at a modest cadence otherwise (CI logs, pipes, files).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <functional>
#include <mutex>
#include <string>
#include <thread>

namespace pvdf {

/// Reports `done` of `total` items on stderr. On a terminal: `label [#####.....] 42/100
/// 3.1/s  ETA 0:19`, redrawn at most five times a second. Otherwise (stderr a file or a pipe):
/// one line `label: 42/100 (42 %), 3.1/s, elapsed 0:13, ETA 0:19` every line_interval_s()
/// seconds — from a heartbeat thread, so also while no item completes (a setup phase, a long
/// item) — and `label: 100/100 done in 0:32 (3.1/s)` at the end when a line was printed before
/// (a job shorter than the interval stays silent). A total of 0 means "not known yet": the line
/// then says `starting` (with the caller's ETA once set_eta_s gave one). The rate shown counts from construction; the ETA divides the items left
/// by the rate since the first item was reported (a setup phase before it does not make every
/// item look slow). Callers honour `--quiet` by not making one. Thread-safe.
class Progress {
 public:
  /// `force`: draw the terminal bar even when stderr is not a terminal.
  Progress(std::string label, std::size_t total, bool force = false);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;
  /// Sets the number of items done so far.
  void update(std::size_t done);
  /// Changes the total (work whose size is learnt on the way, e.g. several maps in turn).
  void set_total(std::size_t total);
  /// An ETA computed by the caller, who knows the work's structure (e.g. several maps, each with a
  /// setup and its own rate), in place of the items-left-over-rate one: the seconds left as of now,
  /// counted down until the next call. NaN or negative returns to the rate-based ETA.
  void set_eta_s(double seconds_left);
  /// Called by the heartbeat (plain lines) before each of its lines, without the progress's lock
  /// held, so that it may call set_eta_s with an ETA computed as of now (e.g. rows in flight that
  /// outrun their prediction). Empty: none.
  void set_refresh(std::function<void()> refresh);
  /// Final line (see the class comment); idempotent. Stops the heartbeat.
  void finish();
  /// True when stderr is a terminal (or forced): the bar; false: plain lines.
  bool on_terminal() const { return terminal_; }

  /// Seconds between plain lines: 10, or the environment variable PVDF_PROGRESS_INTERVAL_S
  /// (a number in [0.01, 3600]; anything else is ignored).
  static double line_interval_s();

 private:
  void draw_bar(bool final_line);
  void print_line(bool final_line);
  void heartbeat();
  double elapsed_s() const;
  double eta_s() const;
  std::string label_;
  std::size_t total_;
  std::size_t done_ = 0;
  bool terminal_;
  bool finished_ = false;
  bool printed_ = false;  ///< a plain line was printed (non-terminal)
  double interval_s_;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
  std::chrono::steady_clock::time_point first_item_;  ///< when done first became > 0
  std::size_t done_at_first_ = 0;
  double eta_hint_s_ = -1;  ///< set_eta_s's value (< 0: none)
  std::chrono::steady_clock::time_point eta_hint_at_;
  std::mutex mutex_;  ///< guards the counts, the clocks and stderr writes
  std::function<void()> refresh_;  ///< set_refresh's (guarded by mutex_; called without it)
  std::condition_variable stop_;
  std::thread heartbeat_;  ///< non-terminal only
};

/// Formats seconds as h:mm:ss or m:ss ("?" when not finite or negative).
std::string format_duration(double seconds);

}  // namespace pvdf
