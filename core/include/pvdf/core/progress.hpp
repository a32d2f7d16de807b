// Progress reporting for long work: a bar with rate and ETA on a terminal, quiet otherwise.
#pragma once

#include <chrono>
#include <cstddef>
#include <string>

namespace pvdf {

/// Prints `label [#####.....] 42/100  3.1/s  ETA 0:19` on stderr, at most a few times a
/// second, only when stderr is a terminal (or when forced). Thread-compatible: call `update`
/// from one thread.
class Progress {
 public:
  Progress(std::string label, std::size_t total, bool force = false);
  ~Progress();
  /// Sets the number of items done so far.
  void update(std::size_t done);
  /// Final line (always printed when active).
  void finish();
  bool active() const { return active_; }

 private:
  void draw(bool final_line);
  std::string label_;
  std::size_t total_;
  std::size_t done_ = 0;
  bool active_;
  bool finished_ = false;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point last_draw_;
};

/// Formats seconds as h:mm:ss or m:ss.
std::string format_duration(double seconds);

}  // namespace pvdf
