// Recording files: a stream written block by block replays bit-exactly; a file cut anywhere
// (a killed run) replays every complete frame and reports the torn one; bad files are clear
// errors; real-time replay takes the recorded time.
#include "pvdf/hardware/recording.hpp"
#include "pvdf/hardware/sim_source.hpp"

#include "pvdf/core/error.hpp"

#include <catch2/catch.hpp>

#include <fstream>
#include <iterator>

using namespace pvdf::hardware;

namespace {

std::string temp_path(const char* name) { return std::string(PVDF_BINARY_DIR) + "/tests/hardware/" + name; }

std::vector<SampleBlock> drain(Source& source) {
  std::vector<SampleBlock> all;
  for (int guard = 0; guard < 100000 && source.next(all, std::chrono::milliseconds(20)); ++guard) {
  }
  return all;
}

std::vector<SampleBlock> record_sim(const std::string& path, double duration_s) {
  SimScene scene = default_sim_scene();
  scene.duration_s = duration_s;
  SimSource sim(scene, false);
  Recorder recorder(path, sim.info());
  std::vector<SampleBlock> all, batch;
  while (true) {
    batch.clear();
    const bool more = sim.next(batch, std::chrono::milliseconds(10));
    recorder.write(batch);
    all.insert(all.end(), batch.begin(), batch.end());
    if (!more) break;
  }
  recorder.close();
  return all;
}

std::vector<char> slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace

TEST_CASE("recording: replay returns exactly what was recorded, with the stream info", "[hardware][recording]") {
  const std::string path = temp_path("roundtrip.pvdfrec");
  const auto recorded = record_sim(path, 0.3);
  REQUIRE(recorded.size() == 30);
  ReplaySource replay(path, false);
  CHECK(replay.info().sample_rate_Hz == 10000);
  CHECK(replay.info().channel_mask == 0x7);
  CHECK(replay.info().adc_bits == 12);
  const auto replayed = drain(replay);
  REQUIRE(replayed.size() == recorded.size());
  for (std::size_t i = 0; i < recorded.size(); ++i) {
    CHECK(replayed[i].frame.sequence == recorded[i].frame.sequence);
    CHECK(replayed[i].frame.timestamp_us == recorded[i].frame.timestamp_us);
    CHECK(replayed[i].frame.counts == recorded[i].frame.counts);
  }
  CHECK_FALSE(replay.counters().decoder.any_fault());
  CHECK(replay.end_reason() == EndReason::end_of_data);
}

TEST_CASE("recording: a file cut anywhere keeps every complete frame and reports the torn one", "[hardware][recording]") {
  const std::string path = temp_path("cut_source.pvdfrec");
  const auto recorded = record_sim(path, 0.05);  // 5 frames of 624 bytes
  const auto bytes = slurp(path);
  const std::size_t frame_bytes = protocol::frame_size(3, 100);
  const std::size_t header_bytes = bytes.size() - recorded.size() * frame_bytes;
  const std::string cut = temp_path("cut.pvdfrec");
  for (std::size_t length = header_bytes; length <= bytes.size(); length += 97) {
    {
      std::ofstream out(cut, std::ios::binary | std::ios::trunc);
      out.write(bytes.data(), static_cast<std::streamsize>(length));
    }
    ReplaySource replay(cut, false);
    const auto got = drain(replay);
    const std::size_t complete = (length - header_bytes) / frame_bytes;
    REQUIRE(got.size() == complete);
    for (std::size_t i = 0; i < complete; ++i) CHECK(got[i].frame.counts == recorded[i].frame.counts);
    CHECK(replay.counters().decoder.trailing_bytes == length - header_bytes - complete * frame_bytes);
  }
}

TEST_CASE("recording: files that are not recordings are refused clearly", "[hardware][recording]") {
  const std::string path = temp_path("not_a_recording.pvdfrec");
  {
    std::ofstream out(path);
    out << "t_s,ch0_V\n0,1\n";
  }
  CHECK_THROWS_WITH(ReplaySource(path, false), Catch::Contains("not a pvdfkit recording"));
  CHECK_THROWS_WITH(ReplaySource(temp_path("missing.pvdfrec"), false), Catch::Contains("cannot open"));
  CHECK_THROWS_WITH(Recorder("/nonexistent-dir/x.pvdfrec", StreamInfo{}), Catch::Contains("cannot create"));
}

TEST_CASE("recording: real-time replay takes the recorded duration", "[hardware][recording]") {
  const std::string path = temp_path("realtime.pvdfrec");
  record_sim(path, 0.2);
  ReplaySource replay(path, true);
  const auto start = std::chrono::steady_clock::now();
  const auto got = drain(replay);
  const double elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  CHECK(got.size() == 20);
  // The last frame starts 0.19 s after the first; as fast as possible takes milliseconds.
  CHECK(elapsed_s >= 0.185);
  CHECK(elapsed_s < 0.6);
}
