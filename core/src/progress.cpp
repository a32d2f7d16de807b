// Progress on stderr: a terminal bar, or plain lines with rate and ETA for logs and pipes.
#include "pvdf/core/progress.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include <unistd.h>

namespace pvdf {

std::string format_duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  const long s = static_cast<long>(std::lround(seconds));
  char buf[32];
  if (s >= 3600) {
    std::snprintf(buf, sizeof buf, "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
  } else {
    std::snprintf(buf, sizeof buf, "%ld:%02ld", s / 60, s % 60);
  }
  return buf;
}

double Progress::line_interval_s() {
  const char* text = std::getenv("PVDF_PROGRESS_INTERVAL_S");
  if (text == nullptr) return 10.0;
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  return end != text && *end == '\0' && v >= 0.01 && v <= 3600 ? v : 10.0;
}

Progress::Progress(std::string label, std::size_t total, bool force)
    : label_(std::move(label)), total_(total), terminal_(force || ::isatty(STDERR_FILENO) == 1),
      interval_s_(line_interval_s()), start_(std::chrono::steady_clock::now()), last_draw_(start_) {
  if (!terminal_) heartbeat_ = std::thread([this] { heartbeat(); });
}

// Without finish() the work did not end well (an exception unwinds): no "done" line.
Progress::~Progress() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (terminal_ && !finished_) std::fputc('\n', stderr);
    finished_ = true;
  }
  stop_.notify_all();
  if (heartbeat_.joinable()) heartbeat_.join();
}

double Progress::elapsed_s() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

// A line whenever one interval passed without one: the log shows the job is alive.
void Progress::heartbeat() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!finished_) {
    const auto due = last_draw_ + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                      std::chrono::duration<double>(interval_s_));
    if (stop_.wait_until(lock, due, [this] { return finished_; })) break;
    if (std::chrono::steady_clock::now() < due) continue;  // a line was printed meanwhile
    if (refresh_) {  // the caller's ETA as of now, computed without our lock (it takes its own)
      const std::function<void()> refresh = refresh_;
      lock.unlock();
      refresh();
      lock.lock();
      if (finished_) break;
      if (std::chrono::steady_clock::now() < due) continue;
    }
    last_draw_ = std::chrono::steady_clock::now();
    print_line(false);
  }
}

void Progress::update(std::size_t done) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto now = std::chrono::steady_clock::now();
  if (done_ == 0 && done > 0) {
    first_item_ = now;
    done_at_first_ = done;
  }
  done_ = done;
  if (finished_) return;
  const double since = std::chrono::duration<double>(now - last_draw_).count();
  if (terminal_) {
    if (since < 0.2 && done_ < total_) return;
    last_draw_ = now;
    draw_bar(false);
  } else if (since >= interval_s_ && done_ < total_) {
    last_draw_ = now;
    print_line(false);
  }
}

double Progress::eta_s() const {
  if (eta_hint_s_ >= 0) {
    const double since = std::chrono::duration<double>(std::chrono::steady_clock::now() - eta_hint_at_).count();
    return std::max(0.0, eta_hint_s_ - since);
  }
  if (done_ <= done_at_first_ || total_ < done_) return NAN;
  const double since_first = std::chrono::duration<double>(std::chrono::steady_clock::now() - first_item_).count();
  const double rate = since_first > 0 ? static_cast<double>(done_ - done_at_first_) / since_first : 0.0;
  return rate > 0 ? static_cast<double>(total_ - done_) / rate : NAN;
}

void Progress::set_total(std::size_t total) {
  std::lock_guard<std::mutex> lock(mutex_);
  total_ = total;
}

void Progress::set_eta_s(double seconds_left) {
  std::lock_guard<std::mutex> lock(mutex_);
  eta_hint_s_ = std::isfinite(seconds_left) && seconds_left >= 0 ? seconds_left : -1;
  eta_hint_at_ = std::chrono::steady_clock::now();
}

void Progress::set_refresh(std::function<void()> refresh) {
  std::lock_guard<std::mutex> lock(mutex_);
  refresh_ = std::move(refresh);
}

void Progress::finish() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (finished_) return;
    finished_ = true;
    if (terminal_) {
      draw_bar(true);
    } else if (printed_) {
      print_line(true);
    }
  }
  stop_.notify_all();
}

void Progress::draw_bar(bool final_line) {
  const double elapsed = elapsed_s();
  const double rate = elapsed > 0 ? done_ / elapsed : 0.0;
  const double eta = eta_s();
  const int width = 30;
  const int filled = total_ ? static_cast<int>(width * static_cast<double>(done_) / total_) : width;
  std::ostringstream os;
  os << '\r' << label_ << " [";
  for (int i = 0; i < width; ++i) os << (i < filled ? '#' : '.');
  os << "] " << done_ << '/' << total_ << "  ";
  os.precision(3);
  os << rate << "/s  ";
  if (final_line) {
    os << "done in " << format_duration(elapsed) << '\n';
  } else {
    os << "ETA " << format_duration(eta) << "   ";
  }
  std::fputs(os.str().c_str(), stderr);
  std::fflush(stderr);
}

// One self-contained line (no carriage return), so a log read later shows each report.
void Progress::print_line(bool final_line) {
  const double elapsed = elapsed_s();
  const double rate = elapsed > 0 ? done_ / elapsed : 0.0;
  const double eta = eta_s();
  std::ostringstream os;
  os.precision(3);
  if (total_ == 0 && !final_line) {
    // The setup's own estimate of the whole job's time left, once it has one (set_eta_s).
    os << label_ << ": starting, elapsed " << format_duration(elapsed);
    if (eta_hint_s_ >= 0) os << ", ETA " << format_duration(eta);
    os << '\n';
    std::fputs(os.str().c_str(), stderr);
    std::fflush(stderr);
    printed_ = true;
    return;
  }
  os << label_ << ": " << done_ << '/' << total_;
  if (final_line) {
    os << " done in " << format_duration(elapsed) << " (" << rate << "/s)\n";
  } else {
    const double percent = total_ ? 100.0 * static_cast<double>(done_) / static_cast<double>(total_) : 100.0;
    os << " (" << static_cast<int>(percent) << " %), " << rate << "/s, elapsed " << format_duration(elapsed) << ", ETA "
       << format_duration(eta) << '\n';
  }
  std::fputs(os.str().c_str(), stderr);
  std::fflush(stderr);
  printed_ = true;
}

}  // namespace pvdf
