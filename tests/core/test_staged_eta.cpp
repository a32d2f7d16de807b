// pvdf::StagedEta against hand-computed times left of two stages (a setup, then items at the
// stage's own rate), and the resident-memory probes.
#include "pvdf/core/resources.hpp"
#include "pvdf/core/staged_eta.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstdint>
#include <vector>

TEST_CASE("staged ETA: setup and rate measured per stage, stages to come predicted from them", "[core][progress]") {
  pvdf::StagedEta eta({20, 30});
  CHECK(std::isnan(eta.seconds_left(0)));
  eta.start_stage(0, 0.0);
  eta.items_done(0, 2, 20, 12.0);  // 10 s setup, then 2 items at 1/s
  CHECK(std::isnan(eta.seconds_left(12.0)));  // one report: no rate yet
  eta.items_done(0, 10, 20, 20.0);           // 8 more items in 8 s: 1/s, setup 12 − 2/1 = 10 s
  // Stage 0: 10 items left at 1/s; stage 1: setup 10 s + 30 items at 1/s.
  CHECK(eta.seconds_left(20.0) == Approx(10.0 + 40.0));
  // Counted down between reports, never below the next stage's share.
  CHECK(eta.seconds_left(24.0) == Approx(6.0 + 40.0));
  eta.items_done(0, 20, 20, 30.0);
  eta.start_stage(1, 30.0);
  // In stage 1's setup, 5 s in: 5 s of the measured setup left + 30 items at the pooled 1/s.
  CHECK(eta.seconds_left(35.0) == Approx(5.0 + 30.0));
  CHECK(eta.seconds_left(45.0) == Approx(0.0 + 30.0));  // a setup longer than measured: not negative
  // Stage 1 runs at its own rate, 2/s: its items left at that rate, not at the pooled one.
  eta.items_done(1, 4, 30, 47.0);
  eta.items_done(1, 10, 30, 50.0);
  CHECK(eta.seconds_left(50.0) == Approx(20.0 / 2.0));
  // A total revised by the stage (e.g. a mirror-symmetric grid) replaces the planned count.
  eta.items_done(1, 12, 16, 51.0);
  CHECK(eta.seconds_left(51.0) == Approx(4.0 / (8.0 / 4.0)));
}

TEST_CASE("resident memory: the peak covers a 64 MiB buffer touched now, and the current size sees it",
          "[core][resources]") {
  const std::uint64_t before = pvdf::current_resident_bytes();
  REQUIRE(before > 0);
  std::vector<unsigned char> buffer(64u << 20);
  for (std::size_t i = 0; i < buffer.size(); i += 4096) buffer[i] = static_cast<unsigned char>(i);
  const std::uint64_t now = pvdf::current_resident_bytes();
  CHECK(now >= before + (60u << 20));
  CHECK(pvdf::peak_resident_bytes() >= now - (1u << 20));
  CHECK(buffer[4096] == static_cast<unsigned char>(4096));
}
