// Seeded fuzz of the JSON readers (scene files and restore filter files): random truncations and
// mutations of valid files from a few hundred bytes up to 1 MB. Every input must either parse or
// be refused with pvdf::InputError — no crash, no other exception — within a time bound.
#include "pvdf/core/error.hpp"
#include "pvdf/core/json_reader.hpp"
#include "pvdf/core/scene.hpp"
#include "pvdf/restore/filter.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <iterator>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <unistd.h>

namespace fs = std::filesystem;

namespace {

constexpr std::size_t max_size = 1u << 20;

/// One random edit of `text`: truncation, byte changes, inserted JSON punctuation, a deleted or
/// repeated span, or a number swapped for an extreme token.
std::string mutate(const std::string& text, std::mt19937_64& rng) {
  std::string s = text;
  auto pos = [&](std::size_t n) { return n == 0 ? std::size_t{0} : std::uniform_int_distribution<std::size_t>(0, n - 1)(rng); };
  const int kind = std::uniform_int_distribution<int>(0, 6)(rng);
  switch (kind) {
    case 0: s.resize(pos(s.size() + 1)); break;
    case 1:
      for (int i = 0, n = 1 + static_cast<int>(pos(8)); i < n && !s.empty(); ++i) s[pos(s.size())] = static_cast<char>(pos(256));
      break;
    case 2: {
      static const std::string punct = "[]{}\",:\\-+.eE0";
      const std::size_t n = 1 + pos(std::size_t{1} << pos(12));
      std::string run;
      for (std::size_t i = 0; i < n; ++i) run += punct[pos(punct.size())];
      s.insert(pos(s.size() + 1), run);
      break;
    }
    case 3: {
      const std::size_t a = pos(s.size() + 1);
      s.erase(a, pos(s.size() - a + 1));
      break;
    }
    case 4: {
      const std::size_t a = pos(s.size() + 1);
      const std::string span = s.substr(a, pos(s.size() - a + 1));
      s.insert(pos(s.size() + 1), span);
      break;
    }
    case 5: {
      static const char* tokens[] = {"1e400", "-1e400", "NaN", "Infinity", "1e-400", "-0", "18446744073709551616",
                                     "1e308", "null", "true", "\"\"", "[]", "{}"};
      const std::size_t at = s.find_first_of("0123456789", pos(s.size() + 1));
      if (at != std::string::npos) s.replace(at, 1, tokens[pos(std::size(tokens))]);
      break;
    }
    default: s.insert(pos(s.size() + 1), std::string(1 + pos(20000), "[{"[pos(2)])); break;
  }
  if (s.size() > max_size) s.resize(max_size);
  return s;
}

std::string big_scene(std::size_t description_bytes) {
  nlohmann::json j = nlohmann::json::parse(pvdf::default_scene_json());
  j["description"] = std::string(description_bytes, 'd');
  return j.dump(1);
}

std::string filter_text(std::size_t taps) {
  pvdf::restore::InverseFilter f;
  f.sample_spacing_m = 1e-4;
  f.taps = taps;
  f.delay_samples = static_cast<long>(taps / 2);
  f.design_fft_length = 2 * taps;
  f.pvdfkit_version = "fuzz";
  for (auto& row : f.h)
    for (auto& h : row) h.assign(taps, 0.125);
  for (auto& row : f.transfer.g)
    for (auto& g : row) g.assign(taps, -0.5);
  f.transfer.forces = {{0.6, 0.9, 0.0}, {0.2, 1.0, 0.0}};
  const fs::path p = fs::temp_directory_path() / ("pvdf_fuzz_base_" + std::to_string(::getpid()) + ".json");
  pvdf::restore::save_filter(p.string(), f);
  std::ifstream in(p);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  REQUIRE_NOTHROW(pvdf::restore::load_filter(p.string()));
  fs::remove(p);
  return text;
}

/// Runs `read` on each mutant; returns the slowest call (s). Fails on anything but InputError.
template <typename Read>
double fuzz(const std::string& base, int n_cases, std::uint64_t seed, Read read) {
  std::mt19937_64 rng(seed);
  double slowest = 0;
  for (int i = 0; i < n_cases; ++i) {
    std::string text = mutate(base, rng);
    if (i % 3 == 0) text = mutate(text, rng);  // two edits
    INFO("seed " << seed << ", case " << i << ", " << text.size() << " bytes");
    const auto t0 = std::chrono::steady_clock::now();
    try {
      read(text);
    } catch (const pvdf::InputError&) {
      // refused cleanly
    } catch (const std::exception& e) {
      FAIL("not an InputError: " << e.what());
    }
    slowest = std::max(slowest, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return slowest;
}

}  // namespace

TEST_CASE("fuzzed scene files are parsed or refused, never crash, in bounded time", "[hostile][fuzz]") {
  auto read_scene = [](const std::string& text) {
    pvdf::parse_scene(pvdf::parse_json_text(text, "fuzz.json"), "fuzz.json");
  };
  const double small = fuzz(pvdf::default_scene_json(), 3000, 20261124, read_scene);
  const double large = fuzz(big_scene(max_size - 4096), 60, 7, read_scene);
  INFO("slowest: " << small << " s (seed-001 scene), " << large << " s (1 MB scene)");
  CHECK(small < 0.5);
  CHECK(large < 2.0);
}

TEST_CASE("fuzzed restore filter files are read or refused, never crash, in bounded time", "[hostile][fuzz]") {
  const fs::path p = fs::temp_directory_path() / ("pvdf_fuzz_filter_" + std::to_string(::getpid()) + ".json");
  auto read_filter = [&p](const std::string& text) {
    {
      std::ofstream out(p, std::ios::binary | std::ios::trunc);
      out << text;
    }
    pvdf::restore::load_filter(p.string());
  };
  const double small = fuzz(filter_text(64), 1500, 99, read_filter);
  const double large = fuzz(filter_text(12000), 40, 5, read_filter);  // ~1 MB of taps
  fs::remove(p);
  INFO("slowest: " << small << " s (64 taps), " << large << " s (12000 taps)");
  CHECK(small < 0.5);
  CHECK(large < 2.0);
}
