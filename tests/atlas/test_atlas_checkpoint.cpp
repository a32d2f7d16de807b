// `pvdfkit atlas` checkpoints (docs/atlas.md §7): stopped (test hook) and resumed with another
// thread count = uninterrupted, bit for bit; a checkpoint of other settings, or a damaged one,
// refused with exit 2 naming it. The 10 mm CI film at 3 mm spacing and 5 % tolerance (8 solved
// positions, seconds per run).
#include "../app/cli_runner.hpp"

#include "pvdf/mapping/atlas.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

using pvdf::test::run_pvdfkit;

namespace {

std::string dir() {
  const auto d = std::filesystem::temp_directory_path() / "pvdf_test_atlas_checkpoint";
  std::filesystem::create_directories(d);
  return d.string();
}

std::string atlas_args(const std::string& out, int threads) {
  return "atlas " + std::string(PVDF_SOURCE_DIR) + "/tests/mapping/small_film_10mm.json -o " + out +
         " --spacing-m 0.003 --tolerance 0.05 --setup-checks 0 --quiet --threads " + std::to_string(threads);
}

// Bit for bit, NaN where NaN.
bool same(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

}  // namespace

TEST_CASE("pvdfkit atlas: stopped and resumed equals uninterrupted; foreign or damaged checkpoints refused",
          "[atlas][cli][checkpoint]") {
  const std::string full = dir() + "/full.h5", out = dir() + "/resumed.h5", checkpoint = dir() + "/resumed.ckpt";
  for (const auto& p : {full, out, checkpoint}) std::filesystem::remove(p);

  auto r = run_pvdfkit(atlas_args(full, 1) + " --no-checkpoint --json");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const auto whole = nlohmann::json::parse(r.out);
  REQUIRE(whole["n_solved_positions"] == 8);
  CHECK(whole["n_resumed_positions"] == 0);

  // Stopped after 6 positions: the chain of row starts (3) and the first row done (3) are in the
  // checkpoint; the rest is lost.
  r = run_pvdfkit(atlas_args(out, 1) + " --checkpoint " + checkpoint + " --stop-after-positions 6");
  CHECK(r.exit_code == 3);
  CHECK(r.err.find(checkpoint) != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(out));
  REQUIRE(std::filesystem::exists(checkpoint));
  {
    const auto saved = pvdf::mapping::read_atlas(checkpoint);
    std::size_t computed = 0, waiting = 0;
    for (auto s : saved.status) {
      computed += s == std::uint8_t(pvdf::mapping::PointStatus::ok);
      waiting += s == std::uint8_t(pvdf::mapping::PointStatus::not_computed);
    }
    CHECK(computed > 0);  // completed rows kept
    CHECK(waiting > 0);   // the rest not
  }

  // Other settings (a tolerance of 2 %): exit 2 naming the checkpoint, before any solve.
  r = run_pvdfkit("atlas " + std::string(PVDF_SOURCE_DIR) + "/tests/mapping/small_film_10mm.json -o " + out +
                  " --spacing-m 0.003 --tolerance 0.02 --setup-checks 0 --quiet --checkpoint " + checkpoint);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find(checkpoint) != std::string::npos);
  CHECK(r.err.find("--no-resume") != std::string::npos);
  CHECK_FALSE(std::filesystem::exists(out));

  // Resumed with two threads: the same atlas as the uninterrupted one-thread run, bit for bit.
  r = run_pvdfkit(atlas_args(out, 2) + " --checkpoint " + checkpoint + " --json");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const auto resumed = nlohmann::json::parse(r.out);
  CHECK(resumed["n_resumed_positions"].get<int>() >= 1);
  CHECK(resumed["n_resumed_positions"].get<int>() < 8);
  CHECK_FALSE(std::filesystem::exists(checkpoint));  // removed once the atlas is written
  const auto a = pvdf::mapping::read_atlas(full), b = pvdf::mapping::read_atlas(out);
  CHECK(a.status == b.status);
  CHECK(same(a.moments, b.moments));
  CHECK(same(a.reference_charge_C, b.reference_charge_C));
  CHECK(same(a.reference_charge_error_C, b.reference_charge_error_C));
  CHECK(same(a.deflection_at_load_m, b.deflection_at_load_m));
  CHECK(same(a.estimated_relative_error, b.estimated_relative_error));
  CHECK(b.checkpoint_key.empty());

  // A damaged checkpoint (truncated): exit 2 naming it, not a crash; --no-resume starts afresh.
  std::filesystem::remove(out);
  {
    std::ofstream f(checkpoint, std::ios::binary);
    f << "\x89HDF\r\n\x1a\n truncated";
  }
  r = run_pvdfkit(atlas_args(out, 1) + " --checkpoint " + checkpoint);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find(checkpoint) != std::string::npos);
  r = run_pvdfkit(atlas_args(out, 1) + " --checkpoint " + checkpoint + " --no-resume --stop-after-positions 1");
  CHECK(r.exit_code == 3);  // started afresh (the damaged file is overwritten by the new checkpoint)
  std::filesystem::remove(checkpoint);
}
