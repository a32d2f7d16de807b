// The real libusb code path (UsbSource → libusb-1.0 Linux backend → usbdevfs ioctls) against a
// front end emulated by umockdev (mock_front_end.hpp): streaming across transfer boundaries
// with several transfers in flight, corrupted/duplicated/dropped frames, a disconnect in
// mid-stream with nothing lost before it, and the no-device / busy / permission-denied errors.
#include "mock_front_end.hpp"
#include "usb_test_helpers.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/hardware/recording.hpp"
#include "pvdf/hardware/usb_source.hpp"

#include <catch2/catch.hpp>

#include <sys/stat.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <map>
#include <random>
#include <set>

using namespace pvdf::hardware;
using pvdf_test::MockFrontEnd;
using pvdf_test::MockScript;

using pvdf_test::drain;
using pvdf_test::make_frame;
using pvdf_test::split;
using pvdf_test::temp_path;

TEST_CASE("the test runs inside umockdev", "[hardware][usb]") {
  const char* preload = std::getenv("LD_PRELOAD");
  REQUIRE(preload != nullptr);
  REQUIRE(std::string(preload).find("libumockdev-preload") != std::string::npos);
}

TEST_CASE("usb: frames split across transfers arrive intact with several transfers in flight", "[hardware][usb]") {
  std::mt19937 rng(11);
  std::vector<Frame> frames;
  std::vector<std::uint8_t> stream;
  for (std::uint32_t s = 0; s < 60; ++s) {
    frames.push_back(make_frame(s, rng));
    encode_frame(frames.back(), stream);
  }
  MockScript script;
  script.chunks = split(stream, rng, 2500);
  MockFrontEnd device(script);

  OpenOptions options;
  options.sample_rate_Hz = 5000;
  options.channel_mask = 0x7;
  options.gain_mV_per_pC = 50;
  options.transfers_in_flight = 6;
  UsbSource source(0x1209, 0x0001, options);
  CHECK(source.info().sample_rate_Hz == 5000);
  CHECK(source.info().channel_mask == 0x7);
  CHECK(source.info().volts_per_count() == Approx(2.5 / 2048).epsilon(1e-6));
  const auto blocks = drain(source, frames.size());

  REQUIRE(blocks.size() == frames.size());
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    CHECK(blocks[i].frame.sequence == frames[i].sequence);
    CHECK(blocks[i].frame.counts == frames[i].counts);
  }
  CHECK(source.end_reason() == EndReason::stopped);
  const auto c = source.counters();
  CHECK_FALSE(c.decoder.any_fault());
  CHECK(c.transfers >= script.chunks.size());
  CHECK(device.chunks_sent() == script.chunks.size());
  CHECK(device.peak_bulk_in_flight() >= 2);  // asynchronous: several transfers queued at once

  // The configuration went out as documented, before START; STOP at the end.
  std::vector<int> order;
  for (const auto& c2 : device.controls()) order.push_back(c2.request);
  const auto pos = [&](int r) { return std::find(order.begin(), order.end(), r) - order.begin(); };
  CHECK(pos(protocol::request_get_info) < pos(protocol::request_set_sample_rate));
  CHECK(pos(protocol::request_set_sample_rate) < pos(protocol::request_start));
  CHECK(pos(protocol::request_set_channel_mask) < pos(protocol::request_start));
  CHECK(pos(protocol::request_set_gain) < pos(protocol::request_start));
  CHECK(order.back() == protocol::request_stop);
  for (const auto& c2 : device.controls()) {
    if (c2.request == protocol::request_set_sample_rate) {
      REQUIRE(c2.data.size() == 4);
      CHECK((c2.data[0] | (c2.data[1] << 8)) == 5000);
    }
    if (c2.request == protocol::request_set_channel_mask) CHECK(c2.value == 0x7);
    if (c2.request == protocol::request_set_gain) {
      CHECK(c2.value == protocol::all_channels);
      REQUIRE(c2.data.size() == 4);
      CHECK(c2.data[0] == 50);
    }
  }
}

TEST_CASE("usb: corrupted, duplicated and dropped frames are counted; a disconnect loses nothing received before it",
          "[hardware][usb]") {
  std::mt19937 rng(12);
  std::map<std::uint32_t, Frame> sent;
  std::vector<std::uint8_t> stream;
  const std::string garbage = "line noise";
  for (std::uint32_t s = 0; s < 40; ++s) {
    const Frame f = make_frame(s, rng);
    if (s == 25) continue;  // dropped by the device: a gap
    const std::size_t begin = stream.size();
    encode_frame(f, stream);
    if (s == 10) stream[begin + 100] ^= 0x40;  // corrupted in transit: CRC error
    else sent[s] = f;
    if (s == 20) encode_frame(f, stream);      // sent twice
    if (s == 30) stream.insert(stream.end(), garbage.begin(), garbage.end());
  }
  MockScript script;
  script.chunks = split(stream, rng, 1500);
  script.disconnect_after_chunks = true;
  MockFrontEnd device(script);

  const std::string record = temp_path("usb_disconnect.pvdfrec");
  std::remove(record.c_str());
  UsbSource source(0x1209, 0x0001, OpenOptions{});
  std::vector<SampleBlock> blocks;
  {
    Recorder recorder(record, source.info());
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    std::vector<SampleBlock> batch;
    while (std::chrono::steady_clock::now() < give_up) {
      batch.clear();
      const bool more = source.next(batch, std::chrono::milliseconds(50));
      recorder.write(batch);  // flushed per block, as acquire does
      blocks.insert(blocks.end(), batch.begin(), batch.end());
      if (!more) break;
    }
  }
  REQUIRE(device.disconnected());
  struct stat node {};
  CHECK(::stat(device.sysfs_path().c_str(), &node) != 0);  // gone from sysfs, as when unplugged
  CHECK(source.end_reason() == EndReason::disconnected);
  CHECK_THAT(source.end_message(), Catch::Contains("disconnected"));

  // Every good frame the device sent before it vanished was delivered, exactly once, intact.
  std::set<std::uint32_t> got;
  for (const auto& b : blocks) {
    REQUIRE(sent.count(b.frame.sequence) == 1);
    CHECK(b.frame.counts == sent[b.frame.sequence].counts);
    CHECK(got.insert(b.frame.sequence).second);
  }
  CHECK(got.size() == sent.size());
  const auto c = source.counters().decoder;
  CHECK(c.crc_errors == 1);
  CHECK(c.duplicates == 1);
  CHECK(c.frames_missing == 2);  // 10 (rejected) and 25 (never sent)
  CHECK(c.bytes_skipped >= garbage.size());
  CHECK(c.trailing_bytes == 0);

  // ... and the recording written on the way holds the same frames.
  ReplaySource replay(record, false);
  const auto replayed = drain(replay);
  REQUIRE(replayed.size() == blocks.size());
  for (std::size_t i = 0; i < blocks.size(); ++i) CHECK(replayed[i].frame.counts == blocks[i].frame.counts);
  const auto r = replay.counters().decoder;
  CHECK(r.frames_missing == 2);  // the recording keeps the gaps visible
  CHECK(r.crc_errors + r.duplicates + r.bytes_skipped + r.trailing_bytes == 0);
}

TEST_CASE("usb: a device that sends nothing ends as stalled, with its transfers cancelled", "[hardware][usb]") {
  MockFrontEnd device(MockScript{});
  OpenOptions options;
  options.stall_timeout_s = 0.3;
  UsbSource source(0x1209, 0x0001, options);
  const auto start = std::chrono::steady_clock::now();
  const auto blocks = drain(source);
  const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  CHECK(blocks.empty());
  CHECK(source.end_reason() == EndReason::stalled);
  CHECK_THAT(source.end_message(), Catch::Contains("no data"));
  CHECK(elapsed_s < 3.0);
}

TEST_CASE("usb: no device, busy and permission denied are one-line InputErrors", "[hardware][usb]") {
  SECTION("no device with this VID:PID") {
    MockScript script;
    script.product_id = 0x0002;
    MockFrontEnd device(script);
    CHECK_THROWS_WITH(open_source("usb:1209:0001"), Catch::Contains("no device with VID:PID 1209:0001"));
    CHECK_THROWS_AS(open_source("usb:1209:0001"), pvdf::InputError);
    // ... and the right id opens it.
    CHECK_NOTHROW(open_source("usb:1209:0002"));
  }
  SECTION("interface claimed by someone else") {
    MockScript script;
    script.claim_busy = true;
    MockFrontEnd device(script);
    CHECK_THROWS_WITH(open_source("usb"), Catch::Contains("device busy"));
  }
  SECTION("permission denied") {
    MockFrontEnd device(MockScript{});
    REQUIRE(::chmod(device.node_path().c_str(), 0) == 0);
    pvdf_test::WithoutFileCapabilities as_user;
    CHECK_THROWS_WITH(open_source("usb:1209:0001"), Catch::Contains("permission denied") && Catch::Contains("udev rule"));
  }
  SECTION("a setting the device refuses") {
    MockScript script;
    script.refuse_request = protocol::request_set_sample_rate;
    MockFrontEnd device(script);
    OpenOptions options;
    options.sample_rate_Hz = 2000;
    CHECK_THROWS_WITH(open_source("usb", options), Catch::Contains("refused SET_SAMPLE_RATE"));
  }
  SECTION("a rate above the device maximum is refused before anything is sent") {
    MockFrontEnd device(MockScript{});
    OpenOptions options;
    options.sample_rate_Hz = 20000;
    CHECK_THROWS_WITH(open_source("usb", options), Catch::Contains("OpenOptions::sample_rate_Hz") && Catch::Contains("10000"));
  }
  SECTION("malformed specifications") {
    CHECK_THROWS_WITH(open_source("usb:12:34"), Catch::Contains("usb:VID:PID"));
    CHECK_THROWS_WITH(open_source("usb:12g9:0001"), Catch::Contains("hexadecimal"));
    CHECK_THROWS_WITH(open_source("serial:/dev/ttyUSB0"), Catch::Contains("expected usb"));
  }
}
