// The scanner chain without hardware: the restore module's scanner simulator produces a scan,
// the simulated front end plays it through its 16-bit ADC, and `pvdfkit acquire --restore`
// restores (f_x, f_z) block by block. Oracles: the streamed forces equal the restore module's
// offline restoration of the very samples that were streamed (read back from --record), to
// round-off; and those samples equal the scan to half an ADC step. Built only with the restore
// module and the pvdfkit command.
#include "pvdf/hardware/recording.hpp"
#include "pvdf/restore/apply.hpp"
#include "pvdf/restore/filter.hpp"
#include "pvdf/restore/scan_io.hpp"
#include "pvdf/restore/scanner.hpp"

#include <catch2/catch.hpp>

#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <random>

namespace {
std::string temp_path(const char* name) { return std::string(PVDF_BINARY_DIR) + "/tests/hardware/" + name; }
}  // namespace

TEST_CASE("scanner scan played by the simulator and restored by --restore equals offline restoration", "[hardware][chain]") {
  auto scanner = pvdf::restore::default_scanner_scene();
  scanner.x_start_m = -0.01;
  scanner.x_end_m = 0.01;  // 4000 samples at 0.05 m/s and 10 kHz
  const auto scan = pvdf::restore::simulate_scan(scanner);
  const std::string scan_path = temp_path("restore_scan.csv"), filter_path = temp_path("restore_filter.json"),
                    scene_path = temp_path("restore_scene.json"), record_path = temp_path("restore.pvdfrec"),
                    csv_path = temp_path("restore_forces.csv");
  pvdf::restore::write_scan_csv(scan_path, scan);

  // Any FIR filter will do for this oracle; a small random one keeps the test fast.
  pvdf::restore::InverseFilter filter;
  filter.sample_spacing_m = scan.sample_spacing_m();
  filter.taps = 64;
  filter.delay_samples = 32;
  filter.design_fft_length = 128;
  filter.window = "none";
  std::mt19937 rng(3);
  std::normal_distribution<double> tap(0.0, 1.0);
  for (auto& row : filter.h)
    for (auto& h : row) {
      h.resize(filter.taps);
      for (auto& v : h) v = tap(rng);
    }
  pvdf::restore::save_filter(filter_path, filter);
  const auto loaded = pvdf::restore::load_filter(filter_path);

  double peak_V = 0;
  for (std::size_t i = 0; i < scan.size(); ++i) peak_V = std::max({peak_V, std::abs(scan.m1_V[i]), std::abs(scan.m2_V[i])});
  {
    std::ofstream scene(scene_path);
    scene << R"({"channels": 2, "noise_V": 0, "adc_bits": 16, "full_scale_V": )" << 1.25 * peak_V + 1e-3
          << R"(, "sample_rate_Hz": )" << scanner.sample_rate_Hz << R"(, "scan": ")" << scan_path << R"("})";
  }
  const std::string command = std::string(PVDFKIT_EXE) + " acquire --quiet --device sim:" + scene_path + " --restore " +
                              filter_path + " --record " + record_path + " --output " + csv_path;
  const int status = std::system(command.c_str());
  REQUIRE(WIFEXITED(status));
  REQUIRE(WEXITSTATUS(status) == 0);

  // The samples that went through the stream.
  pvdf::hardware::ReplaySource replay(record_path, false);
  std::vector<pvdf::hardware::SampleBlock> blocks;
  while (replay.next(blocks, std::chrono::milliseconds(10))) {
  }
  std::vector<double> m1, m2;
  const double lsb = replay.info().volts_per_count();
  for (const auto& b : blocks)
    for (int i = 0; i < b.frame.n_samples; ++i) {
      m1.push_back(b.frame.counts[static_cast<std::size_t>(2 * i)] * lsb);
      m2.push_back(b.frame.counts[static_cast<std::size_t>(2 * i + 1)] * lsb);
    }
  REQUIRE(m1.size() == scan.size());
  double worst_V = 0;
  for (std::size_t i = 0; i < m1.size(); ++i)
    worst_V = std::max({worst_V, std::abs(m1[i] - scan.m1_V[i]), std::abs(m2[i] - scan.m2_V[i])});
  CHECK(worst_V <= 0.5 * lsb * (1 + 1e-9));

  std::vector<double> fx, fz;
  pvdf::restore::restore_offline(loaded, m1, m2, fx, fz);
  std::ifstream in(csv_path);
  std::string line;
  REQUIRE(std::getline(in, line));
  CHECK(line == "t_s,fx_N,fz_N");
  std::size_t n = 0;
  double worst = 0, scale = 0;
  for (; std::getline(in, line) && n < fx.size(); ++n) {
    double t, a, b;
    REQUIRE(std::sscanf(line.c_str(), "%lf,%lf,%lf", &t, &a, &b) == 3);
    CHECK(t == Approx(n / scanner.sample_rate_Hz).margin(1e-9));
    worst = std::max({worst, std::abs(a - fx[n]), std::abs(b - fz[n])});
    scale = std::max({scale, std::abs(fx[n]), std::abs(fz[n])});
  }
  CHECK(n == fx.size());
  INFO("worst difference " << worst << " N of " << scale << " N");
  CHECK(worst <= 1e-8 * scale);  // the CSV carries 9 significant digits; FFT round-off is far smaller
}
