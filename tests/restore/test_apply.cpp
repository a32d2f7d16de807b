// Filter application: offline = direct convolution, streaming = offline, latency, files and CSV errors.
#include "restore_test_util.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/restore/scan_io.hpp"

#include <catch2/catch.hpp>

#include <cstdio>
#include <fstream>
#include <random>

using namespace pvdf::restore;

namespace {
InverseFilter random_filter(std::size_t taps, long delay, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, 1);
  InverseFilter f;
  f.sample_spacing_m = 5e-6;
  f.taps = taps;
  f.delay_samples = delay;
  for (auto& row : f.h)
    for (auto& h : row) {
      h.resize(taps);
      for (auto& v : h) v = n(rng);
    }
  return f;
}

std::vector<double> random_signal(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> d(0, 1);
  std::vector<double> v(n);
  for (auto& x : v) x = d(rng);
  return v;
}

std::string temp_path(const std::string& name) { return std::string(PVDF_BINARY_DIR) + "/tests/restore/" + name; }
}  // namespace

TEST_CASE("Offline restoration is the linear convolution f[n] = sum h[t] m[n + D - t]", "[restore][apply]") {
  const auto f = random_filter(64, 21, 1);
  const auto m1 = random_signal(500, 2), m2 = random_signal(500, 3);
  std::vector<double> fx, fz;
  restore_offline(f, m1, m2, fx, fz);
  REQUIRE(fx.size() == 500);
  for (std::size_t n = 0; n < 500; n += 7) {
    double ex = 0, ez = 0;
    for (std::size_t t = 0; t < 64; ++t) {
      const long k = static_cast<long>(n) + 21 - static_cast<long>(t);
      if (k < 0 || k >= 500) continue;  // zero outside the record: no circular wrap-around
      ex += f.h[0][0][t] * m1[k] + f.h[0][1][t] * m2[k];
      ez += f.h[1][0][t] * m1[k] + f.h[1][1][t] * m2[k];
    }
    CHECK(fx[n] == Approx(ex).margin(1e-10));
    CHECK(fz[n] == Approx(ez).margin(1e-10));
  }
}

TEST_CASE("Streaming output equals offline output for any block size, with the documented latency", "[restore][apply]") {
  const auto f = random_filter(64, 30, 4);
  const std::size_t n = 1000;
  const auto m1 = random_signal(n, 5), m2 = random_signal(n, 6);
  std::vector<double> ox, oz;
  restore_offline(f, m1, m2, ox, oz);
  for (std::size_t block : {1u, 7u, 64u, 333u, 2000u}) {
    StreamingRestorer s(f, block);
    CHECK(s.latency_samples() == 30 + block - 1);
    std::vector<double> fx, fz;
    std::size_t pushed = 0;
    for (std::size_t chunk : {5u, 100u, 1u, 250u, 644u}) {
      s.push(m1.data() + pushed, m2.data() + pushed, chunk, fx, fz);
      pushed += chunk;
      // Every force older than the latency has been emitted, none beyond the input minus the delay.
      CHECK(fx.size() + s.latency_samples() >= pushed);
      CHECK(fx.size() + 30 <= std::max<std::size_t>(pushed, 30));
    }
    REQUIRE(pushed == n);
    s.flush(fx, fz);
    REQUIRE(fx.size() == n);
    for (std::size_t i = 0; i < n; ++i) {
      CHECK(fx[i] == Approx(ox[i]).margin(1e-9));
      CHECK(fz[i] == Approx(oz[i]).margin(1e-9));
    }
  }
}

TEST_CASE("Filter files round-trip exactly and malformed ones name the key", "[restore][apply]") {
  auto f = random_filter(128, 64, 7);
  f.beta = 1e-4;
  f.beta_abs = 3.5;
  f.beta_policy = "constant";
  f.regularization = "isotropic";
  f.peak_fraction = 0.83;
  f.conditioning = {1.5, 8.0, 900.0, 0.14};
  const std::string path = temp_path("filter_roundtrip.json");
  save_filter(path, f);
  const auto g = load_filter(path);
  CHECK(g.taps == f.taps);
  CHECK(g.delay_samples == f.delay_samples);
  CHECK(g.sample_spacing_m == f.sample_spacing_m);
  CHECK(g.beta == f.beta);
  CHECK(g.regularization == f.regularization);
  CHECK(g.peak_fraction == f.peak_fraction);
  CHECK(g.conditioning.median == f.conditioning.median);
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) CHECK(g.h[i][j] == f.h[i][j]);

  auto text = [&] {
    std::ifstream in(path);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  auto write_variant = [&](const std::string& from, const std::string& to) {
    std::string t = text;
    const auto p = t.find(from);
    REQUIRE(p != std::string::npos);
    t.replace(p, from.size(), to);
    const std::string bad = temp_path("filter_bad.json");
    std::ofstream(bad) << t;
    return bad;
  };
  CHECK_THROWS_WITH(load_filter(write_variant("\"h12\"", "\"h12x\"")), Catch::Contains("h12"));
  CHECK_THROWS_WITH(load_filter(write_variant("\"taps\": 128", "\"taps\": 100")), Catch::Contains("h11"));
  CHECK_THROWS_WITH(load_filter(write_variant("\"sample_spacing_m\"", "\"sample_spacing\"")), Catch::Contains("sample_spacing"));
  CHECK_THROWS_WITH(load_filter(write_variant("\"delay_samples\": 64", "\"delay_samples\": 500")), Catch::Contains("delay_samples"));
  CHECK_THROWS_AS(load_filter(temp_path("no_such_filter.json")), pvdf::InputError);
}

TEST_CASE("Scan CSV: malformed rows are reported by line number; t_s needs a speed", "[restore][apply]") {
  const std::string path = temp_path("scan_bad.csv");
  {
    std::ofstream out(path);
    out << "# a comment\nx_m,m1_V,m2_V\n";
    for (int i = 0; i < 30; ++i) {
      if (i == 5) out << "0.000025,abc,0.1\n";  // file line 8
      else out << i * 5e-6 << ",0.1,0.2\n";
    }
  }
  CHECK_THROWS_WITH(read_scan_csv(path), Catch::Contains(":8"));
  {
    std::ofstream out(path);
    out << "t_s,m1_V,m2_V\n";
    for (int i = 0; i < 30; ++i) out << i * 1e-4 << ",0.1,0.2\n";
  }
  CHECK_THROWS_WITH(read_scan_csv(path), Catch::Contains("speed"));
  const Scan s = read_scan_csv(path, 0.05);
  CHECK(s.sample_spacing_m() == Approx(5e-6));
  {
    std::ofstream out(path);
    out << "x_m,m1_V,m2_V\n";
    for (int i = 0; i < 30; ++i) out << (i < 20 ? i : i + 3) * 5e-6 << ",0.1,0.2\n";  // a gap at line 22
  }
  CHECK_THROWS_WITH(read_scan_csv(path), Catch::Contains(":22"));
}
