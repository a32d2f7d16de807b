// End-to-end: `pvdfkit design --optimize` on the synthetic stand-in — bad flags refused with exit 2
// before any work (count range, negative gap, missing atlas, no map source), the same --seed gives
// identical scenes and tables, another seed another search, and the output folder's files.
#include "../app/cli_runner.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

using pvdf::test::run_pvdfkit;

namespace {

std::string dir() {
  const auto d = std::filesystem::temp_directory_path() / "pvdf_test_optimize_cli";
  std::filesystem::create_directories(d);
  return d.string();
}

std::string film_scene() {
  const std::string path = dir() + "/film.json";
  std::ofstream(path) << R"({
    "membrane": {"shape": "circle", "radius_m": 0.012, "thickness_m": 25e-6},
    "material": {"E1_Pa": 2.2e9, "E2_Pa": 1.8e9, "G12_Pa": 0.58e9, "nu12": 0.35,
                 "draw_angle_deg": 0.0, "d31_C_per_N": 6.5e-12, "d32_C_per_N": 0.65e-12},
    "electrodes": [{"name": "A", "center_m": [0.0, 0.004], "size_m": [0.002, 0.002]},
                   {"name": "B", "center_m": [-0.0035, -0.002], "size_m": [0.002, 0.002]},
                   {"name": "C", "center_m": [0.0035, -0.002], "size_m": [0.002, 0.002]}],
    "probe": {"radius_m": 0.00075}})";
  return path;
}

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// optimize.txt with the seconds column (the 10th token of a row: "3 38.6 % 94.5 % 0.0850 mm 60 0 0.13 ...") taken out.
std::string table_without_seconds(const std::string& path) {
  std::istringstream in(slurp(path));
  std::string line, out;
  while (std::getline(in, line)) {
    std::istringstream tokens(line);
    std::string t;
    for (int k = 0; tokens >> t; ++k) {
      if (k != 9) out += t + " ";
    }
    out += "\n";
  }
  return out;
}

/// optimize.json without what legitimately changes between runs (timings, paths of the folder).
nlohmann::json comparable(const std::string& path) {
  nlohmann::json j = nlohmann::json::parse(slurp(path));
  j.erase("seconds");
  j.erase("files");
  for (auto& c : j["counts"]) c.erase("seconds");
  return j;
}

}  // namespace

TEST_CASE("design --optimize refuses bad flags with exit 2 and one line naming the input", "[design][optimize][cli]") {
  const std::string scene = film_scene();
  const struct {
    std::string flags, expected;
  } cases[] = {
      {"--synthetic --electrodes-min 5 --electrodes-max 4", "--electrodes-max 4"},
      {"--synthetic --electrodes-min 2", "--electrodes-min 2"},
      {"--synthetic --min-gap-m -0.001", "--min-gap-m -0.001"},
      {"--synthetic --clamp-margin-m -1", "--clamp-margin-m -1"},
      {"--synthetic --size-min-m 0.003 --size-max-m 0.002", "--size-max-m 0.002"},
      {"--synthetic --budget 0", "--budget 0"},
      {"--atlas " + dir() + "/missing.atlas.h5", "missing.atlas.h5"},
      {"", "--atlas"},
  };
  for (const auto& c : cases) {
    const auto r = run_pvdfkit("design --optimize " + scene + " " + c.flags + " --quiet -o " + dir() + "/refused");
    INFO(c.flags << " -> " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(r.err.rfind("error: ", 0) == 0);
    CHECK(r.err.find(c.expected) != std::string::npos);
    CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  }
  CHECK_FALSE(std::filesystem::exists(dir() + "/refused"));
}

TEST_CASE("design --optimize: the same seed gives the same layouts; files written", "[design][optimize][cli]") {
  const std::string scene = film_scene();
  const std::string flags = " --synthetic --spacing-m 0.0015 --electrodes-min 3 --electrodes-max 4 --budget 60 --quiet";
  const std::string a = dir() + "/seed_a", b = dir() + "/seed_b", c = dir() + "/seed_c";
  std::filesystem::remove_all(a);
  std::filesystem::remove_all(b);
  std::filesystem::remove_all(c);
  const auto ra = run_pvdfkit("design --optimize " + scene + flags + " --seed 5 -o " + a);
  INFO(ra.err);
  REQUIRE(ra.exit_code == 0);
  const auto rb = run_pvdfkit("design --optimize " + scene + flags + " --seed 5 --json -o " + b);
  REQUIRE(rb.exit_code == 0);
  const auto rc = run_pvdfkit("design --optimize " + scene + flags + " --seed 6 -o " + c);
  REQUIRE(rc.exit_code == 0);

  for (const char* f : {"/best-3.json", "/best-4.json"}) CHECK(slurp(a + f) == slurp(b + f));
  CHECK(table_without_seconds(a + "/optimize.txt") == table_without_seconds(b + "/optimize.txt"));
  CHECK(comparable(a + "/optimize.json") == comparable(b + "/optimize.json"));
  CHECK(slurp(a + "/best-3.json") != slurp(c + "/best-3.json"));  // another seed, another search path

  // --json prints what optimize.json holds; the table and the figures are in the folder.
  const auto j = nlohmann::json::parse(rb.out);
  CHECK(j == nlohmann::json::parse(slurp(b + "/optimize.json")));
  REQUIRE(j["counts"].size() == 2);
  for (const auto& count : j["counts"]) {
    CHECK(count["found"] == true);
    CHECK(count["evaluations"] == 60);
    CHECK(count["layout"].size() == count["n_electrodes"].get<std::size_t>());
    CHECK(count["usable_fraction"].get<double>() >= 0);
  }
  CHECK(std::filesystem::file_size(a + "/optimize_pareto.png") > 10000);
  CHECK(std::filesystem::file_size(a + "/optimize_pareto.svg") > 1000);
  CHECK(std::filesystem::file_size(a + "/design_position.png") > 10000);
  // The winners are scenes the other commands read: `design` ranks best-4.json as written.
  const auto again = run_pvdfkit("design " + a + "/best-4.json --synthetic --spacing-m 0.0015 --json --no-plots");
  REQUIRE(again.exit_code == 0);
  const auto ranked = nlohmann::json::parse(again.out);
  CHECK(ranked["layouts"][0]["usable_fraction"].get<double>() ==
        Approx(j["counts"][1]["usable_fraction"].get<double>()).margin(1e-12));
}
