// End-to-end: `pvdfkit rays`, `pvdfkit compare`, `pvdfkit isocharge` on a synthetic map — the
// JSON/CSV contracts, exit codes (0, 2 bad input naming the column or line, 3 nothing to report).
#include "../app/cli_runner.hpp"
#include "fixture.hpp"

#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/map_io.hpp"
#include "pvdf/mapping/synthetic.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>

using pvdf::test::run_pvdfkit;
using namespace pvdf::mapping;

namespace {

std::string dir() {
  const auto d = std::filesystem::temp_directory_path() / "pvdf_test_analysis_cli";
  std::filesystem::create_directories(d);
  return d.string();
}

const std::string& map_path() {
  static const std::string path = [] {
    const std::string p = dir() + "/map.h5";
    write_map(p, build_synthetic_map(SyntheticModel{}, 1e-3, 3e-3, {1.0}, 0.05e-12));
    return p;
  }();
  return path;
}

std::string write_text(const std::string& name, const std::string& text) {
  const std::string p = dir() + "/" + name;
  std::ofstream(p) << text;
  return p;
}

}  // namespace

TEST_CASE("compare: JSON contract, 10 % for 1.1 x the map at grid nodes, outside flagged", "[mapping][cli][analysis]") {
  const SyntheticModel model;
  std::ostringstream csv;
  csv.precision(17);
  csv << "x_m,y_m,force_N,charge_A_C,charge_B_C,charge_C_C\n";
  for (const auto& p : std::vector<pvdf_test::Press>{{0.004, -0.002, 1.0}, {-0.010, 0.006, 1.0}, {0.044, 0.0, 1.0}}) {
    const auto q = pvdf_test::charges(model, p);
    csv << p.x_m << ',' << p.y_m << ',' << p.force_N << ',' << 1.1 * q[0] << ',' << 1.1 * q[1] << ',' << 1.1 * q[2] << '\n';
  }
  const std::string measured = write_text("measured.csv", csv.str());
  const std::string report = dir() + "/report.csv", png = dir() + "/compare.png";
  std::filesystem::remove(report);
  const auto r = run_pvdfkit("compare " + map_path() + " " + measured + " --json -o " + report + " --plot " + png);
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const auto j = nlohmann::json::parse(r.out);
  CHECK(j["n_presses"] == 3);
  CHECK(j["n_outside_map"] == 1);
  CHECK(j["mean_abs_difference_pct"].get<double>() == Approx(10.0).epsilon(1e-9));
  CHECK(j["electrodes"][1]["name"] == "B");
  CHECK(j["presses"][0]["difference_B_pct"].get<double>() == Approx(10.0).epsilon(1e-9));
  CHECK(j["presses"][2]["in_map"] == false);
  CHECK(j["presses"][2]["difference_A_pct"].is_null());
  CHECK(std::filesystem::exists(report));
  CHECK(std::filesystem::exists(png));
  std::ifstream in(report);
  std::string header;
  std::getline(in, header);
  CHECK(header.rfind("line,x_m,y_m,force_N,in_map,force_extrapolated,charge_A_measured_C,charge_A_map_C,difference_A_pct", 0) == 0);
}

TEST_CASE("compare: bad files exit 2 naming the column or the line; nothing comparable exits 3", "[mapping][cli][analysis]") {
  const std::string missing = write_text("missing.csv", "x_m,y_m,force_N,charge_A_C,charge_C_C\n0,0,1,1e-12,1e-12\n");
  auto r = run_pvdfkit("compare " + map_path() + " " + missing);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("missing column 'charge_B_C'") != std::string::npos);
  const std::string bad = write_text("bad.csv", "x_m,y_m,force_N,charge_A_C,charge_B_C,charge_C_C\n0,0,1,1e-12,x,1e-12\n");
  r = run_pvdfkit("compare " + map_path() + " " + bad);
  CHECK(r.exit_code == 2);
  CHECK(r.err.find("bad.csv:2:") != std::string::npos);
  const std::string outside = write_text("outside.csv", "x_m,y_m,force_N,charge_A_C,charge_B_C,charge_C_C\n0.05,0,1,1e-12,1e-12,1e-12\n");
  r = run_pvdfkit("compare " + map_path() + " " + outside);
  CHECK(r.exit_code == 3);
  r = run_pvdfkit("compare " + map_path());
  CHECK(r.exit_code == 2);
}

TEST_CASE("rays: table as JSON and CSV, Fig. 7 plot; bad options exit 2", "[mapping][cli][analysis]") {
  const std::string csv = dir() + "/rays.csv", png = dir() + "/rays.png";
  auto r = run_pvdfkit("rays " + map_path() + " --json --csv " + csv + " --plot " + png + " --plot-angles-deg 45,65,85");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  const auto j = nlohmann::json::parse(r.out);
  CHECK(j["rays"].size() == 3 * 36);
  CHECK(j["rays"][0]["beta_deg"] == 0.0);
  CHECK(j["rays"][1]["beta_deg"] == 10.0);
  CHECK(j["paper_decay_exponent_range"][0] == 0.58);
  CHECK(j["electrodes"][0]["n_fitted"] == 36);
  // The default model decays like d^-0.8 away from its 2 mm core: the median fit sees that.
  CHECK(j["electrodes"][0]["median_decay_exponent"].get<double>() == Approx(0.8).margin(0.05));
  CHECK(std::filesystem::exists(png));
  std::ifstream in(csv);
  std::string header;
  std::getline(in, header);
  CHECK(header == "electrode,beta_deg,fitted,C1_C,C2,decay_exponent,r_squared,n_used,n_nonpositive,max_relative_deviation");
  CHECK(run_pvdfkit("rays " + map_path() + " --d-min-m 0.02 --d-max-m 0.01").exit_code == 2);
  CHECK(run_pvdfkit("rays " + map_path() + " --plot " + png + " --electrode Z").exit_code == 2);
  // Rays entirely outside the map: nothing fitted, exit 3.
  CHECK(run_pvdfkit("rays " + map_path() + " --d-min-m 0.2 --d-max-m 0.3").exit_code == 3);
}

TEST_CASE("isocharge: PNGs per electrode and together, VTK, and the intersection of a triple", "[mapping][cli][analysis]") {
  const std::string out = dir() + "/iso";
  std::filesystem::remove_all(out);
  const auto q = pvdf_test::charges(SyntheticModel{}, {0.003, 0.002, 1.0});
  char triple[128];
  std::snprintf(triple, sizeof triple, "%.12g,%.12g,%.12g", q[0], q[1], q[2]);
  const auto r = run_pvdfkit("isocharge " + map_path() + " --out-dir " + out + " --zoom-m 0.015 --force-N 1 --charges-C " + triple);
  INFO(r.err);
  REQUIRE(r.exit_code == 0);
  for (const char* f : {"isocharge_A.png", "isocharge_B.png", "isocharge_C.png", "isocharge_all.png", "charges.vtk",
                        "intersection.png"}) {
    CHECK(std::filesystem::exists(out + "/" + f));
  }
  CHECK(r.out.find("contours meet at (3.000, 2.000) mm") != std::string::npos);
  CHECK(run_pvdfkit("isocharge " + map_path() + " --out-dir " + out + " --zoom-m -1").exit_code == 2);
  // --at-m: the map's own triple at a grid node; its contours meet there.
  const auto at = run_pvdfkit("isocharge " + map_path() + " --out-dir " + out + " --force-N 1 --at-m 0.004,-0.002");
  CHECK(at.exit_code == 0);
  CHECK(at.out.find("contours meet at (4.000, -2.000) mm") != std::string::npos);
  CHECK(run_pvdfkit("isocharge " + map_path() + " --out-dir " + out + " --at-m 0.2,0").exit_code == 2);
}
