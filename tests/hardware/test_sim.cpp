// Simulated front end: against the charge-amplifier model it implements — ideal output within
// half an ADC step, noise RMS, first-order decay with the amplifier time constant — and exact
// counts of the transport faults it injects, as seen through the real decoder.
#include "pvdf/hardware/sim_source.hpp"
#include "pvdf/hardware/source.hpp"

#include "pvdf/core/error.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include "../test_worst.hpp"

using namespace pvdf::hardware;

namespace {

std::vector<SampleBlock> run(SimSource& source) {
  std::vector<SampleBlock> all;
  for (int guard = 0; guard < 100000 && source.next(all, std::chrono::milliseconds(10)); ++guard) {
  }
  return all;
}

}  // namespace

TEST_CASE("sim: noiseless output equals the ideal amplifier voltage within half an ADC step", "[hardware][sim]") {
  SimScene scene = default_sim_scene();
  scene.noise_V = 0;
  scene.duration_s = 0.5;
  SimSource source(scene, false);
  const auto blocks = run(source);
  const auto& info = source.info();
  REQUIRE(blocks.size() == 50);  // 0.5 s × 10 kHz / 100 samples
  const double lsb = info.volts_per_count();
  CHECK(lsb == Approx(2.5 / 2048));
  double worst = 0, peak = 0;
  for (const auto& b : blocks) {
    for (int i = 0; i < b.frame.n_samples; ++i) {
      const double t = b.time_s(i, info.sample_rate_Hz);
      for (int c = 0; c < 3; ++c) {
        const double v = b.frame.counts[static_cast<std::size_t>(i * 3 + c)] * lsb;
        worst = pvdf::testing::worst_of(worst, std::abs(v - scene.ideal_output_V(c, t)));
        peak = pvdf::testing::worst_of(peak, v);
      }
    }
  }
  CHECK(worst <= 0.5 * lsb + 1e-12);
  // 1 N × 20 pC/N × 50 mV/pC = 1 V on the channel under the probe.
  CHECK(peak == Approx(1.0).margin(lsb));
  CHECK_FALSE(source.counters().decoder.any_fault());
  CHECK(source.end_reason() == EndReason::end_of_data);
}

TEST_CASE("sim: the noise has the requested RMS", "[hardware][sim]") {
  SimScene scene;
  scene.presses.clear();
  scene.noise_V = 0.01;  // 8 LSB: quantization adds lsb²/12, negligible
  scene.duration_s = 1.0;
  SimSource source(scene, false);
  const auto blocks = run(source);
  double sum2 = 0;
  std::size_t n = 0;
  for (const auto& b : blocks)
    for (const auto c : b.frame.counts) {
      const double v = c * source.info().volts_per_count();
      sum2 += v * v;
      ++n;
    }
  REQUIRE(n == 30000);
  const double expected = std::sqrt(0.01 * 0.01 + std::pow(source.info().volts_per_count(), 2) / 12);
  CHECK(std::sqrt(sum2 / n) == Approx(expected).epsilon(0.02));  // 30000 samples: ~0.4 % standard error
}

TEST_CASE("sim: with a finite time constant the held press decays as exp(-t/tau)", "[hardware][sim]") {
  SimScene scene;
  scene.noise_V = 0;
  scene.adc_bits = 16;
  scene.time_constant_s = 0.1;
  scene.duration_s = 0.4;
  SimPress press;
  press.start_s = 0.01;
  press.rise_s = 0.001;
  press.hold_s = 0.3;
  press.force_N = 1.0;
  scene.presses = {press};
  SimSource source(scene, false);
  const auto blocks = run(source);
  // Voltage at 0.05 s and 0.25 s after the end of the rise, both during the hold.
  auto at = [&](double t) {
    const auto index = static_cast<long>(std::llround(t * scene.sample_rate_Hz));
    const auto& b = blocks[static_cast<std::size_t>(index / scene.frame_samples)];
    return b.frame.counts[static_cast<std::size_t>((index % scene.frame_samples) * 3)] * source.info().volts_per_count();
  };
  const double t1 = 0.011 + 0.05, t2 = 0.011 + 0.25;
  CHECK(at(t2) / at(t1) == Approx(std::exp(-(t2 - t1) / 0.1)).epsilon(0.002));
  CHECK(at(t1) == Approx(std::exp(-0.05 / 0.1)).epsilon(0.02));  // ≈ 1 V step decayed for 50 ms
}

TEST_CASE("sim: injected transport faults are counted exactly by the decoder", "[hardware][sim]") {
  SimScene scene = default_sim_scene();
  scene.duration_s = 1.0;  // 100 frames
  scene.faults.drop_every = 10;       // frames 9, 19, ..., 99: 10 gaps
  scene.faults.corrupt_every = 7;     // 6, 13, ..., 97 (unless dropped first)
  scene.faults.duplicate_every = 25;  // 24, 49, 74, 99
  scene.faults.garbage_every = 33;    // 32, 65, 98: 37 bytes each
  SimSource source(scene, false);
  const auto blocks = run(source);
  int dropped = 0, corrupted = 0, duplicated = 0, garbage = 0, lost = 0;
  for (int k = 0; k < 100; ++k) {
    const bool drop = k % 10 == 9, corrupt = k % 7 == 6, dup = k % 25 == 24, junk = k % 33 == 32;
    if (junk) ++garbage;
    if (drop) {
      ++dropped;
      ++lost;
      continue;
    }
    if (corrupt) {
      ++corrupted;
      ++lost;
      if (dup) ++corrupted;  // the copy is corrupted too
      continue;
    }
    if (dup) ++duplicated;
  }
  const auto c = source.counters().decoder;
  CHECK(blocks.size() == static_cast<std::size_t>(100 - lost));
  // Frame 99 (the last) is dropped: a loss at the very end leaves no later number to show the gap.
  CHECK(c.frames_missing == static_cast<std::uint64_t>(lost - 1));
  CHECK(c.crc_errors == static_cast<std::uint64_t>(corrupted));
  CHECK(c.duplicates == static_cast<std::uint64_t>(duplicated));
  CHECK(c.bytes_skipped >= 37u * garbage);
  CHECK(dropped == 10);
}

TEST_CASE("sim: scenes are read strictly", "[hardware][sim]") {
  const auto parse = [](const char* text) { return parse_sim_scene(nlohmann::json::parse(text), "scene.json"); };
  const SimScene s = parse(R"({"channels": 2, "sample_rate_Hz": 2000, "presses": [{"start_s": 0.2, "force_N": 2, "weights": [1, 0.5]}]})");
  CHECK(s.channels == 2);
  CHECK(s.presses.at(0).weights == std::vector<double>{1, 0.5});
  CHECK_THROWS_WITH(parse(R"({"chanels": 2})"), Catch::Contains("chanels"));
  CHECK_THROWS_WITH(parse(R"({"channels": 40})"), Catch::Contains("channels"));
  CHECK_THROWS_WITH(parse(R"({"channels": 2, "presses": [{"weights": [1]}]})"), Catch::Contains("weights"));
  CHECK_THROWS_AS(open_source("sim:/nonexistent/scene.json"), pvdf::InputError);
  CHECK_THROWS_WITH(open_source("bogus"), Catch::Contains("expected usb"));
}

TEST_CASE("block_mean_charges: the mean count in volts over the gain; clipped or overflowed blocks are saturated",
          "[hardware][charges]") {
  StreamInfo info;  // 12 bits over 2.5 V: 2.5 / 2048 V per count
  info.channel_mask = 0x3;
  SampleBlock b;
  b.frame.channel_mask = 0x3;
  b.frame.n_channels = 2;
  b.frame.n_samples = 4;
  b.frame.counts = {100, -40, 102, -42, 98, -38, 100, -40};  // channel means 100 and -40 counts
  const double gain_V_per_C = 2e9;                           // 2 mV/pC
  const BlockCharges q = block_mean_charges(b, info, gain_V_per_C);
  REQUIRE(q.charge_C.size() == 2);
  CHECK(q.charge_C[0] == Approx(100 * 2.5 / 2048 / gain_V_per_C).epsilon(1e-14));
  CHECK(q.charge_C[1] == Approx(-40 * 2.5 / 2048 / gain_V_per_C).epsilon(1e-14));
  CHECK_FALSE(q.saturated);
  // Twice the gain, half the charge (q = V / gain).
  CHECK(block_mean_charges(b, info, 2 * gain_V_per_C).charge_C[0] == Approx(q.charge_C[0] / 2).epsilon(1e-14));
  b.frame.counts[5] = 2047;  // one sample at the top code: clipped
  CHECK(block_mean_charges(b, info, gain_V_per_C).saturated);
  b.frame.counts[5] = -38;
  b.frame.overflow = true;
  CHECK(block_mean_charges(b, info, gain_V_per_C).saturated);
  // The default gain puts the peak charge at 80 % of full scale.
  const double g = gain_for_peak_charge_V_per_C(2.5, 1e-9);
  CHECK(1e-9 * g == Approx(0.8 * 2.5));
}
