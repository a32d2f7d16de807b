// Terminal progress bar with rate and ETA.
#include "pvdf/core/progress.hpp"

#include <cmath>
#include <cstdio>
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

Progress::Progress(std::string label, std::size_t total, bool force)
    : label_(std::move(label)), total_(total), active_(force || ::isatty(STDERR_FILENO) == 1),
      start_(std::chrono::steady_clock::now()), last_draw_(start_) {}

Progress::~Progress() {
  if (active_ && !finished_) std::fputc('\n', stderr);
}

void Progress::update(std::size_t done) {
  done_ = done;
  if (!active_) return;
  const auto now = std::chrono::steady_clock::now();
  if (std::chrono::duration<double>(now - last_draw_).count() < 0.2 && done_ < total_) return;
  last_draw_ = now;
  draw(false);
}

void Progress::finish() {
  if (!active_ || finished_) return;
  draw(true);
  finished_ = true;
}

void Progress::draw(bool final_line) {
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double rate = elapsed > 0 ? done_ / elapsed : 0.0;
  const double eta = rate > 0 ? (static_cast<double>(total_) - done_) / rate : NAN;
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

}  // namespace pvdf
