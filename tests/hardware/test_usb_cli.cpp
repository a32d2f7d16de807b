// `pvdfkit acquire` end to end against the front end emulated by umockdev (mock_front_end.hpp):
// the command, spawned from the test, inherits the testbed (LD_PRELOAD, UMOCKDEV_DIR) and drives
// the emulated device through libusb. A disconnect saves what arrived and exits 2 with the
// counters; no device and busy exit 2 with one line; Ctrl-C stops the device and exits 130.
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

namespace {
/// Runs a shell command (it inherits the testbed: LD_PRELOAD and UMOCKDEV_DIR) and returns its exit code.
int shell(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}
std::string read_text(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) return {};
  std::string text;
  char buffer[4096];
  std::size_t n;
  while ((n = std::fread(buffer, 1, sizeof buffer, f)) > 0) text.append(buffer, n);
  std::fclose(f);
  return text;
}
}  // namespace

TEST_CASE("pvdfkit acquire: a disconnect saves what arrived, prints the counters and exits 2", "[hardware][usb][cli]") {
  std::mt19937 rng(13);
  std::vector<std::uint8_t> stream;
  for (std::uint32_t s = 0; s < 20; ++s) encode_frame(make_frame(s, rng), stream);
  MockScript script;
  script.chunks = split(stream, rng, 4000);
  script.disconnect_after_chunks = true;
  MockFrontEnd device(script);
  const std::string record = temp_path("cli_disconnect.pvdfrec"), csv = temp_path("cli_disconnect.csv"),
                    err = temp_path("cli_disconnect.err");
  const int code = shell(std::string(PVDFKIT_EXE) + " acquire --device usb:1209:0001 --record " + record + " --output " +
                         csv + " 2> " + err);
  const std::string messages = read_text(err);
  INFO(messages);
  CHECK(code == 2);
  CHECK_THAT(messages, Catch::Contains("error: usb:1209:0001: device disconnected mid-stream"));
  CHECK_THAT(messages, Catch::Contains("frames 20, missing 0"));
  CHECK_THAT(messages, Catch::Contains("20 frames in"));
  const std::string rows = read_text(csv);
  CHECK(std::count(rows.begin(), rows.end(), '\n') == 1 + 20 * 100);
  ReplaySource replay(record, false);
  CHECK(drain(replay).size() == 20);
}

TEST_CASE("pvdfkit acquire: no device and busy exit 2 with one line", "[hardware][usb][cli]") {
  const std::string err = temp_path("cli_errors.err");
  {
    MockScript script;
    script.product_id = 0x0002;
    MockFrontEnd device(script);
    CHECK(shell(std::string(PVDFKIT_EXE) + " acquire --device usb:1209:0001 2> " + err) == 2);
    CHECK_THAT(read_text(err), Catch::StartsWith("error: usb:1209:0001: no device with VID:PID 1209:0001"));
  }
  {
    MockScript script;
    script.claim_busy = true;
    MockFrontEnd device(script);
    CHECK(shell(std::string(PVDFKIT_EXE) + " acquire --device usb 2> " + err) == 2);
    const std::string text = read_text(err);
    CHECK_THAT(text, Catch::StartsWith("error: usb:1209:0001: device busy"));
    CHECK(std::count(text.begin(), text.end(), '\n') == 1);
  }
}

TEST_CASE("pvdfkit acquire: Ctrl-C stops the device and writes out everything received", "[hardware][usb][cli]") {
  std::mt19937 rng(14);
  std::vector<std::uint8_t> stream;
  for (std::uint32_t s = 0; s < 30; ++s) encode_frame(make_frame(s, rng), stream);
  MockScript script;
  script.chunks = split(stream, rng, 3000);  // then the device keeps its transfers pending
  MockFrontEnd device(script);
  const std::string record = temp_path("cli_sigint.pvdfrec"), csv = temp_path("cli_sigint.csv"),
                    err = temp_path("cli_sigint.err");
  std::remove(record.c_str());  // the wait below watches this file grow: no stale copy from an earlier run
  const int code = shell(std::string(PVDFKIT_EXE) + " acquire --device usb --stall-timeout-s 20 --record " + record +
                         " --output " + csv + " 2> " + err +
                         // signal only once frames reach the recording (start-up alone can take seconds under load; before
                         // pvdfkit's handler is installed a background job ignores SIGINT)
                         " & pid=$!; for i in $(seq 600); do [ $(stat -c %s " + record + " 2>/dev/null || echo 0) -ge 4096 ] && break;"
                         " sleep 0.1; done; sleep 1; kill -INT $pid; wait $pid");
  const std::string messages = read_text(err);
  INFO(messages);
  CHECK(code == 130);
  CHECK_THAT(messages, Catch::Contains("stopped after 3000 samples per channel; frames 30, missing 0"));
  const std::string rows = read_text(csv);
  CHECK(std::count(rows.begin(), rows.end(), '\n') == 1 + 30 * 100);
  ReplaySource replay(record, false);
  CHECK(drain(replay).size() == 30);
  const auto controls = device.controls();
  REQUIRE_FALSE(controls.empty());
  CHECK(controls.back().request == protocol::request_stop);
}
