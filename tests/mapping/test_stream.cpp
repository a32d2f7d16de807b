// The streaming lookup: documented columns, malformed rows reported by line number and
// skipped (or refused with strict), never a crash.
#include "pvdf/core/constants.hpp"
#include "fixture.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/mapping/stream.hpp"

#include <catch2/catch.hpp>

#include <array>
#include <cmath>
#include <random>
#include <sstream>

using namespace pvdf::mapping;

namespace {

const Locator& shared_locator() {
  static const Locator locator(build_synthetic_map(SyntheticModel{}, 1e-3, 3e-3, {0.5, 1.0, 2.0}, 0.05e-12));
  return locator;
}

std::string row(double t, const pvdf_test::Press& p) {
  const SyntheticModel model;
  const auto q = pvdf_test::charges(model, p);
  std::ostringstream os;
  os.precision(17);
  os << t << ',' << q[0] << ',' << q[1] << ',' << q[2];
  return os.str();
}

}  // namespace

std::vector<std::vector<std::string>> lines_of(const std::string& text) {
  std::vector<std::vector<std::string>> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(pvdf::split_csv_line(line));
  return out;
}

TEST_CASE("a stream of charges becomes a stream of positions", "[mapping][stream]") {
  const pvdf_test::Press a{0.002, 0.003, 1.0}, b{-0.004, -0.001, 0.7};
  std::istringstream in("# a comment line\nt_s,charge_A_C,charge_B_C,charge_C_C\n" + row(0.0001, a) + "\n\n" +
                        row(0.0002, b) + "\n0.0003,1e-16,-1e-16,2e-16\n");
  std::ostringstream out, warnings;
  const StreamSummary s = locate_stream(shared_locator(), in, out, warnings);
  CHECK(s.rows == 3);
  CHECK(s.located == 2);
  CHECK(s.skipped == 0);
  CHECK(warnings.str().empty());
  const auto lines = lines_of(out.str());
  REQUIRE(lines.size() == 4);
  CHECK(lines[0] == pvdf::split_csv_line(stream_output_header()));
  CHECK(lines[1][0] == "0.0001");
  double x = 0, y = 0, f = 0;
  REQUIRE(pvdf::parse_finite(lines[1][1], x));
  REQUIRE(pvdf::parse_finite(lines[1][2], y));
  REQUIRE(pvdf::parse_finite(lines[1][3], f));
  // A press near the centre of the triangle can have an exact twin; accept either answer.
  const Location r = shared_locator().locate(pvdf_test::charges(SyntheticModel{}, a));
  CHECK(x == Approx(r.x_m).epsilon(1e-6));
  CHECK(y == Approx(r.y_m).epsilon(1e-6));
  // Every solution is in the row: p_best, n_solutions, then the alternatives' fixed columns
  // (filled for the n_solutions − 1 others, empty after), probabilities summing to 1.
  REQUIRE(lines[1].size() == 11 + 4 * 7);
  CHECK(lines[0][9] == "p_best");
  CHECK(lines[0][10] == "n_solutions");
  CHECK(lines[0][11] == "alt1_x_m");
  CHECK(lines[0][38] == "alt7_p");
  for (int i = 1; i <= 2; ++i) {
    double p_best = 0, n_solutions = 0;
    REQUIRE(pvdf::parse_finite(lines[std::size_t(i)][9], p_best));
    REQUIRE(pvdf::parse_finite(lines[std::size_t(i)][10], n_solutions));
    double p_sum = p_best;
    for (int a = 1; a < 8; ++a) {
      const auto& p_text = lines[std::size_t(i)][std::size_t(11 + 4 * (a - 1) + 3)];
      CHECK(p_text.empty() == (a >= n_solutions));
      double p = 0;
      if (!p_text.empty() && pvdf::parse_finite(p_text, p)) {
        CHECK(p <= p_best);  // the main answer is the most probable one
        p_sum += p;
      }
    }
    CHECK(p_sum == Approx(1.0).margin(1e-3));
  }
  // The no-press row has empty numbers and the flag.
  REQUIRE(lines[3].size() == 11 + 4 * 7);
  CHECK(lines[3][1].empty());
  CHECK(lines[3][3].empty());
  CHECK(lines[3][8] == "no_press");
  CHECK(lines[3][10] == "0");
}

TEST_CASE("malformed rows are skipped with their line numbers, or refused with strict", "[mapping][stream]") {
  const pvdf_test::Press a{0.002, 0.003, 1.0};
  const std::string text = "charge_C_C,t_s,charge_A_C,charge_B_C,extra\n"   // any column order, extra ignored
                           "1e-11,0.1,2e-11\n"                                // line 2: too few fields
                           "abc,0.2,1e-11,1e-11,0\n"                          // line 3: not a number
                           "nan,0.3,1e-11,1e-11,0\n"                          // line 4: not finite
                           "1e-11,0.4,1e-11,inf,0\n"                          // line 5: not finite
                           "1e-11,,1e-11,1e-11,0\n";                          // line 6: empty time
  std::istringstream in(text);
  std::ostringstream out, warnings;
  const StreamSummary s = locate_stream(shared_locator(), in, out, warnings);
  CHECK(s.rows == 5);
  CHECK(s.skipped == 5);
  for (const char* where : {"<stdin>:2:", "<stdin>:3:", "<stdin>:4:", "<stdin>:5:", "<stdin>:6:"}) {
    INFO(where);
    CHECK(warnings.str().find(where) != std::string::npos);
  }
  CHECK(lines_of(out.str()).size() == 1);  // the header only

  StreamOptions strict;
  strict.strict = true;
  strict.source = "presses.csv";
  std::istringstream in2("t_s,charge_A_C,charge_B_C,charge_C_C\n" + row(0.1, a) + "\n0.2,1e-11,x,1e-11\n");
  std::ostringstream out2, warnings2;
  CHECK_THROWS_WITH(locate_stream(shared_locator(), in2, out2, warnings2, strict), Catch::Contains("presses.csv:3:"));
  CHECK(lines_of(out2.str()).size() == 2);  // the good row before it was written

  // A header without the map's electrodes is refused up front.
  std::istringstream in3("t_s,charge_A_C,charge_B_C\n0,1,2\n");
  CHECK_THROWS_WITH(locate_stream(shared_locator(), in3, out2, warnings2), Catch::Contains("charge_C_C"));
  std::istringstream empty("");
  CHECK_THROWS_AS(locate_stream(shared_locator(), empty, out2, warnings2), pvdf::InputError);
}

TEST_CASE("random garbage never crashes the stream", "[mapping][stream]") {
  std::mt19937 rng(12);
  std::uniform_int_distribution<int> byte(0, 127);
  std::string text = "t_s,charge_A_C,charge_B_C,charge_C_C\n";
  for (int i = 0; i < 2000; ++i) {
    char c = char(byte(rng));
    if (c == 0) c = ',';
    text += c;
    if (i % 37 == 0) text += "\n0.1,2e-11,3e-11,1e-11\n";
  }
  std::istringstream in(text);
  std::ostringstream out, warnings;
  StreamOptions o;
  o.max_warnings = 3;
  const StreamSummary s = locate_stream(shared_locator(), in, out, warnings, o);
  CHECK(s.rows == s.skipped + (lines_of(out.str()).size() - 1));
  CHECK(s.located > 0);
  CHECK(out.str().find("nan") == std::string::npos);
}

TEST_CASE("the tracker answers as the full search does on a noisy stream of presses", "[mapping][stream][tracker]") {
  // Presses of 20-60 ms at 10 kHz with raised-cosine force ramps to 0.6-1.8 N, half of them
  // moving at up to 50 mm/s, 0.05 pC noise on every sample, gaps of nothing between them.
  // Oracle: Locator::locate on every sample (the full search), independent of the tracker's
  // memory. Agreement: the most probable answer within a tenth of the full search's σ.
  const Locator& locator = shared_locator();
  const SyntheticModel model;
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> noise(0, 0.05e-12);
  std::vector<std::array<double, 3>> q;
  while (q.size() < 30000) {
    for (int i = 0; i < 100; ++i) q.push_back({noise(rng), noise(rng), noise(rng)});
    const int samples = 200 + int(400 * u(rng));
    const double peak = 0.6 + 1.2 * u(rng), x0 = 0.02 * u(rng) - 0.01, y0 = 0.02 * u(rng) - 0.01;
    const double speed = u(rng) < 0.5 ? 0.05 * u(rng) : 0.0, heading = 6.283 * u(rng);
    for (int i = 0; i < samples; ++i) {
      const double t = double(i) / samples, ramp = t < 0.2 ? 0.5 - 0.5 * std::cos(pvdf::pi * t / 0.2)
                                                 : t > 0.8 ? 0.5 - 0.5 * std::cos(pvdf::pi * (1 - t) / 0.2) : 1.0;
      const double time_s = i * 1e-4;
      const pvdf_test::Press p{x0 + speed * time_s * std::cos(heading), y0 + speed * time_s * std::sin(heading),
                               std::max(peak * ramp, 1e-6)};
      const auto c = pvdf_test::charges(model, p);
      q.push_back({c[0] + noise(rng), c[1] + noise(rng), c[2] + noise(rng)});
    }
  }
  Tracker tracker(locator);
  std::size_t both = 0, same = 0, presence = 0;
  for (const auto& c : q) {
    const Location a = locator.locate(c.data());
    const Location b = tracker.next(c.data());
    if (a.has_position() != b.has_position()) {
      ++presence;
      continue;
    }
    if (!a.has_position()) continue;
    ++both;
    same += std::abs(a.x_m - b.x_m) <= 0.1 * a.sigma_x_m + 1e-12 && std::abs(a.y_m - b.y_m) <= 0.1 * a.sigma_y_m + 1e-12 &&
            std::abs(a.force_N - b.force_N) <= 0.1 * a.sigma_F_N + 1e-12 && a.n_solutions == b.n_solutions;
  }
  const TrackerSummary& s = tracker.summary();
  WARN(both << " samples with a position in both, " << same << " the same, " << presence << " with/without a position "
            "(of " << q.size() << "); " << s.full_searches << " full searches, " << s.tracked << " tracked");
  CHECK(both > 20000);
  CHECK(double(same) >= 0.999 * double(both));
  // The agreement target, 99.9 % of all samples (before the fallback rule of
  // docs/lookup.md §1.7 the presence differed at 126 samples, 0.4 %).
  CHECK(double(presence + both - same) <= 0.001 * double(q.size()));
  CHECK(s.tracked > s.full_searches);  // most samples are tracked
  // After reset() the next sample is a full search.
  const auto before = s.full_searches;
  tracker.reset();
  tracker.next(q[150].data());
  CHECK(tracker.summary().full_searches == before + 1);
}
