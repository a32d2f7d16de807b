// pvdf::Progress when stderr is not a terminal (a CI log, a pipe): plain lines at the set
// cadence with rate and ETA, a heartbeat while no item completes, a final line only after a
// report, nothing for short work, no "done" when the work was abandoned.
#include "pvdf/core/progress.hpp"

#include <catch2/catch.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <unistd.h>

namespace {

/// Runs `work` with stderr sent to a file (not a terminal) and PVDF_PROGRESS_INTERVAL_S set;
/// returns what was written there, as lines.
template <class Work>
std::vector<std::string> stderr_lines_of(const char* interval_s, Work work) {
  const auto path = std::filesystem::temp_directory_path() / ("pvdf_test_progress_" + std::to_string(::getpid()));
  std::fflush(stderr);
  const int saved = ::dup(STDERR_FILENO);
  const int file = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  REQUIRE(file >= 0);
  ::dup2(file, STDERR_FILENO);
  ::close(file);
  ::setenv("PVDF_PROGRESS_INTERVAL_S", interval_s, 1);
  work();
  ::unsetenv("PVDF_PROGRESS_INTERVAL_S");
  std::fflush(stderr);
  ::dup2(saved, STDERR_FILENO);
  ::close(saved);
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  std::filesystem::remove(path);
  return lines;
}

void sleep_s(double s) { std::this_thread::sleep_for(std::chrono::duration<double>(s)); }

}  // namespace

TEST_CASE("progress off a terminal: lines with rate and ETA at the set cadence, then a final line", "[core][progress]") {
  const auto lines = stderr_lines_of("0.05", [] {
    pvdf::Progress p("job", 8);
    REQUIRE_FALSE(p.on_terminal());
    for (std::size_t i = 1; i <= 8; ++i) {
      sleep_s(0.03);
      p.update(i);
    }
    p.finish();
  });
  INFO([&] { std::string all; for (const auto& l : lines) all += l + "\n"; return all; }());
  REQUIRE(lines.size() >= 3);
  // Elapsed and done-in times allow a few seconds: a loaded machine (CI beside other jobs) stretches the sleeps.
  const std::regex report(R"(job: [0-9]/8 \([0-9]+ %\), [0-9.e+]+/s, elapsed 0:0[0-9], ETA (0:0[0-9]|\?))");
  for (std::size_t i = 0; i + 1 < lines.size(); ++i) CHECK(std::regex_match(lines[i], report));
  CHECK(std::regex_match(lines.back(), std::regex(R"(job: 8/8 done in 0:0[0-9] \([0-9.e+]+/s\))")));
  // Each line stands alone in a log: no carriage returns or escape sequences.
  for (const auto& l : lines) CHECK(l.find_first_of("\r\x1b") == std::string::npos);
}

TEST_CASE("progress off a terminal: a heartbeat while no item completes, 'starting' before the total is known",
          "[core][progress]") {
  const auto lines = stderr_lines_of("0.05", [] {
    pvdf::Progress p("maps", 0);
    sleep_s(0.18);  // a setup phase: no update at all
    p.set_total(4);
    p.update(1);
    sleep_s(0.18);  // one long item
    p.update(4);
    p.finish();
  });
  std::size_t starting = 0, reports = 0;
  for (const auto& l : lines) {
    starting += l.rfind("maps: starting, elapsed 0:00", 0) == 0 ? 1 : 0;
    reports += l.rfind("maps: 1/4 (25 %)", 0) == 0 ? 1 : 0;
  }
  CHECK(starting >= 2);
  CHECK(reports >= 2);
  REQUIRE_FALSE(lines.empty());
  CHECK(lines.back().rfind("maps: 4/4 done in", 0) == 0);
}

TEST_CASE("progress off a terminal: silent for short work and for work abandoned before its first report",
          "[core][progress]") {
  const auto short_work = stderr_lines_of("10", [] {
    pvdf::Progress p("quick", 3);
    for (std::size_t i = 1; i <= 3; ++i) p.update(i);
    p.finish();
  });
  CHECK(short_work.empty());
  const auto abandoned = stderr_lines_of("0.05", [] {
    pvdf::Progress p("failing", 10);
    p.update(2);
    sleep_s(0.5);  // ten heartbeats: at least one runs even on a loaded machine
    // destroyed without finish(): an exception left the work
  });
  REQUIRE_FALSE(abandoned.empty());
  for (const auto& l : abandoned) CHECK(l.find("done") == std::string::npos);
}

TEST_CASE("progress off a terminal shows the ETA the caller set, counted down, until it is withdrawn",
          "[core][progress]") {
  const auto lines = stderr_lines_of("0.01", [] {
    pvdf::Progress p("maps", 10);
    p.set_eta_s(600.0);
    sleep_s(0.03);
    p.update(1);
    sleep_s(0.03);
    p.update(2);
    p.set_eta_s(NAN);  // back to items left over the rate: well under ten minutes here
    sleep_s(0.03);
    p.update(3);
    sleep_s(0.03);
    p.update(4);
    p.finish();
  });
  // Lines while the caller's ETA holds (1 done) show it; lines after it was withdrawn (3 done) the rate's.
  int with_hint = 0, with_rate = 0;
  for (const auto& line : lines) {
    if (line.rfind("maps: 1/10", 0) == 0) {
      CHECK((line.find("ETA 10:00") != std::string::npos || line.find("ETA 9:5") != std::string::npos));
      ++with_hint;
    }
    if (line.rfind("maps: 3/10", 0) == 0) {
      CHECK(line.find("ETA 0:0") != std::string::npos);
      ++with_rate;
    }
  }
  CHECK(with_hint > 0);
  CHECK(with_rate > 0);
}
