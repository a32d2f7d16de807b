// The pvdfkit command end to end: moduli contract, --help everywhere, exit codes and one-line
// errors for malformed scene files.
#include "cli_runner.hpp"

#include "pvdf/core/constants.hpp"
#include "pvdf/core/material.hpp"
#include "pvdf/core/scene.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <vector>

#include <unistd.h>

using pvdf::test::line_count;
using pvdf::test::run_pvdfkit;

namespace {

using pvdf::pi;

std::string write_temp(const std::string& name, const std::string& text) {
  const auto p = std::filesystem::temp_directory_path() / name;
  std::ofstream(p) << text;
  return p.string();
}

// Independent compliance rotation: Ex(β) = 1/S'1111 with S' from rotating the 2-D compliance
// tensor by direction cosines (the classical closed form 1/Ex = m⁴/E1 + (1/G12 − 2ν12/E1)m²n² + n⁴/E2,
// and likewise for the others), evaluated here from the compliance matrix entries directly.
struct Ref {
  double Ex, Ey, Gxy, nuxy, nuyx;
};
Ref reference(double beta) {
  const double E1 = 2.2e9, E2 = 1.8e9, G12 = 0.58e9, nu12 = 0.35;
  const double S11 = 1 / E1, S22 = 1 / E2, S12 = -nu12 / E1, S66 = 1 / G12;
  const double m = std::cos(beta), n = std::sin(beta);
  const double m2 = m * m, n2 = n * n;
  const double Sb11 = S11 * m2 * m2 + (2 * S12 + S66) * m2 * n2 + S22 * n2 * n2;
  const double Sb22 = S11 * n2 * n2 + (2 * S12 + S66) * m2 * n2 + S22 * m2 * m2;
  const double Sb12 = (S11 + S22 - S66) * m2 * n2 + S12 * (m2 * m2 + n2 * n2);
  const double Sb66 = 2 * (2 * S11 + 2 * S22 - 4 * S12 - S66) * m2 * n2 + S66 * (m2 * m2 + n2 * n2);
  return {1 / Sb11, 1 / Sb22, 1 / Sb66, -Sb12 / Sb11, -Sb12 / Sb22};
}

}  // namespace

TEST_CASE("pvdfkit moduli --json agrees with an independent compliance rotation to 1e-12", "[cli][moduli]") {
  const auto r = run_pvdfkit("moduli --json --angles-deg 0:7.5:180");
  REQUIRE(r.exit_code == 0);
  const auto j = nlohmann::json::parse(r.out);
  REQUIRE(j.is_array());
  REQUIRE(j.size() == 25);
  for (const auto& row : j) {
    const double beta = row.at("angle_deg").get<double>() * pi / 180;
    const Ref ref = reference(beta);
    INFO("angle " << row.at("angle_deg"));
    CHECK(std::abs(row.at("Ex_Pa").get<double>() / ref.Ex - 1) < 1e-12);
    CHECK(std::abs(row.at("Ey_Pa").get<double>() / ref.Ey - 1) < 1e-12);
    CHECK(std::abs(row.at("Gxy_Pa").get<double>() / ref.Gxy - 1) < 1e-12);
    CHECK(std::abs(row.at("nuxy").get<double>() / ref.nuxy - 1) < 1e-12);
    CHECK(std::abs(row.at("nuyx").get<double>() / ref.nuyx - 1) < 1e-12);
  }
}

TEST_CASE("pvdfkit moduli table, CSV and plot", "[cli][moduli]") {
  const auto table = run_pvdfkit("moduli");
  CHECK(table.exit_code == 0);
  CHECK_THAT(table.out, Catch::Contains("Ex_GPa"));
  const auto csv = run_pvdfkit("moduli --csv --angles-deg 0:45:90");
  CHECK(csv.exit_code == 0);
  CHECK(line_count(csv.out) == 4);
  CHECK_THAT(csv.out, Catch::StartsWith("angle_deg,Ex_Pa,Ey_Pa,Gxy_Pa,nuxy,nuyx"));
  const auto png = (std::filesystem::temp_directory_path() / "pvdf_test_moduli.png").string();
  std::filesystem::remove(png);
  const auto plot = run_pvdfkit("moduli --plot " + png);
  CHECK(plot.exit_code == 0);
  REQUIRE(std::filesystem::exists(png));
  std::ifstream in(png, std::ios::binary);
  char sig[8] = {};
  in.read(sig, 8);
  CHECK(std::string(sig + 1, 3) == "PNG");
  CHECK(std::filesystem::file_size(png) > 10000);
}

namespace {

/// The help texts of every command and subcommand ("restore identify" included), by name: run
/// once per test process (each run of pvdfkit costs about a second on a loaded machine).
const std::vector<std::pair<std::string, std::string>>& all_help_texts() {
  static std::vector<std::pair<std::string, std::string>> out;
  if (!out.empty()) return out;
  std::vector<std::string> pending = {""};
  while (!pending.empty()) {
    const std::string name = pending.back();
    pending.pop_back();
    const auto r = run_pvdfkit(name + (name.empty() ? "" : " ") + "--help");
    REQUIRE(r.exit_code == 0);
    if (!name.empty()) out.emplace_back(name, r.out);
    const auto pos = r.out.find("Subcommands:");
    if (pos == std::string::npos) continue;
    std::istringstream lines(r.out.substr(pos));
    std::string line;
    std::getline(lines, line);
    while (std::getline(lines, line)) {
      std::istringstream words(line);
      std::string sub;
      if (words >> sub) pending.push_back(name.empty() ? sub : name + " " + sub);
    }
  }
  return out;
}

}  // namespace

TEST_CASE("every subcommand answers --help with exit 0", "[cli]") {
  const auto& texts = all_help_texts();  // exit 0 is required inside, for the top level too
#ifdef PVDF_TEST_WITH_FEM
  CHECK(texts.size() >= 18);
#else
  CHECK(texts.size() >= 15);  // without the solver: no solve, map, fit
#endif
  for (const auto& [name, help] : texts) {
    INFO(name);
    CHECK_THAT(help, Catch::Contains("Usage"));
  }
}

TEST_CASE("malformed scene files give exit 2 and one line naming the key", "[cli][errors]") {
  struct Case {
    std::string name, text, expect;
  };
  const std::vector<Case> cases = {
      {"bad_json.json", "{\"membrane\": {\"radius_m\": 0.045,, }}", "bad_json.json:1:"},
      {"unknown_key.json", "{\"membrane\": {\"thicknes_m\": 25e-6}}", "membrane.thicknes_m"},
      {"negative.json", "{\"membrane\": {\"thickness_m\": -2.5e-5}}", "membrane.thickness_m"},
      {"nan.json", "{\"membrane\": {\"thickness_m\": NaN}}", "thickness_m"},
      {"wrong_type.json", "{\"material\": {\"E1_Pa\": \"2.2 GPa\"}}", "material.E1_Pa"},
      {"top_array.json", "[]", "JSON object"},
  };
  for (const auto& c : cases) {
    const auto path = write_temp("pvdf_cli_" + c.name, c.text);
    const auto r = run_pvdfkit("moduli --scene " + path);
    INFO(c.name << ": " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(line_count(r.err) == 1);
    CHECK_THAT(r.err, Catch::StartsWith("error: ") && Catch::Contains(c.expect));
    CHECK(r.out.empty());
  }
  const auto missing = run_pvdfkit("moduli --scene /nonexistent/dir/scene.json");
  CHECK(missing.exit_code == 2);
  CHECK(line_count(missing.err) == 1);
  CHECK_THAT(missing.err, Catch::Contains("/nonexistent/dir/scene.json"));
}

TEST_CASE("bad flags give exit 2 with one error line", "[cli][errors]") {
  for (const std::string args : {"moduli --angles-deg 0:0:90", "moduli --angles-deg abc", "moduli --no-such-flag",
                                 "no-such-command", "moduli --json --csv", "moduli --plot /nonexistent/dir/x.png"}) {
    const auto r = run_pvdfkit(args);
    INFO(args << " -> " << r.err);
    CHECK(r.exit_code == 2);
    CHECK(line_count(r.err) == 1);
    CHECK_THAT(r.err, Catch::StartsWith("error: "));
  }
}

namespace {

/// A fresh folder for one test's files.
std::filesystem::path fresh_dir(const std::string& name) {
  const auto d = std::filesystem::temp_directory_path() / ("pvdf_cli_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

bool process_alive(long pid) { return std::system(("kill -0 " + std::to_string(pid) + " 2>/dev/null").c_str()) == 0; }

}  // namespace

TEST_CASE("locate names the electrode order in --help, text, JSON and the wrong-count error", "[cli][locate]") {
  const auto d = fresh_dir("order");
  const std::string map = (d / "map.h5").string();
  REQUIRE(run_pvdfkit("synthetic-map -o " + map + " --spacing-m 0.002").exit_code == 0);
  const auto help = run_pvdfkit("locate --help");
  CHECK_THAT(help.out, Catch::Contains("order follows the map's electrode names"));
  const std::string q = " --charges-C 2.4925e-12,1.87487e-11,1.87487e-11";
  const auto text = run_pvdfkit("locate " + map + q);
  CHECK(text.exit_code == 0);
  CHECK_THAT(text.out, Catch::StartsWith("electrodes: A,B,C"));
  const auto json = run_pvdfkit("locate " + map + q + " --json");
  REQUIRE(json.exit_code == 0);
  CHECK(nlohmann::json::parse(json.out)["electrodes"] == nlohmann::json({"A", "B", "C"}));
  const auto count = run_pvdfkit("locate " + map + " --charges-C 1e-11,2e-11");
  CHECK(count.exit_code == 2);
  CHECK(line_count(count.err) == 1);
  CHECK_THAT(count.err, Catch::Contains("order A,B,C"));
  // pC typed for C: refused with the conversion; a force beyond the map's levels: its range named.
  const auto pico = run_pvdfkit("locate " + map + " --charges-C 146.1,165.1,160.2");
  CHECK(pico.exit_code == 2);
  CHECK_THAT(pico.err, Catch::Contains("look like pC") && Catch::Contains("1.461e-10"));
  const auto beyond = run_pvdfkit("locate " + map + q + " --force-N 70");
  CHECK(beyond.exit_code == 3);
  CHECK(line_count(beyond.err) == 1);
  CHECK_THAT(beyond.err, Catch::Contains("the map covers 1 N"));
  std::filesystem::remove_all(d);
}

#ifdef PVDF_TEST_WITH_FEM  // `map` exists only in builds with the finite-element solver
TEST_CASE("a second map writing the same output refuses at once; a stale lock file does not block", "[cli][map][lock]") {
  const auto d = fresh_dir("lock");
  const std::string scene = write_temp("pvdf_cli_lock_scene.json", pvdf::default_scene_json());
  const std::string out = (d / "m.h5").string();
  // 1. A first map (minutes of work at 4 mm) in the background.
  const std::string pid_file = (d / "pid").string();
  std::system(("'" + std::string(PVDFKIT_EXE) + "' map " + scene + " -o " + out + " --spacing-m 0.004 --quiet " +
               "</dev/null >/dev/null 2>&1 & echo $! > " + pid_file).c_str());
  long pid = 0;
  std::ifstream(pid_file) >> pid;
  REQUIRE(pid > 0);
  for (int i = 0; i < 300 && !std::filesystem::exists(out + ".lock"); ++i) ::usleep(100000);
  REQUIRE(std::filesystem::exists(out + ".lock"));
  // 2. The second writer: exit 2 at once, naming the holder.
  const auto t0 = std::chrono::steady_clock::now();
  const auto second = run_pvdfkit("map " + scene + " -o " + out + " --spacing-m 0.004 --quiet");
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  CHECK(second.exit_code == 2);
  CHECK(line_count(second.err) == 1);
  CHECK_THAT(second.err, Catch::Contains("being written by another pvdfkit (process " + std::to_string(pid)));
  CHECK(wall_s < 5);
  // 3. Killed without cleanup, the first leaves its lock file; a new run takes it over.
  std::system(("kill -9 " + std::to_string(pid)).c_str());
  for (int i = 0; i < 100 && process_alive(pid); ++i) ::usleep(100000);
  const auto third = run_pvdfkit("map " + scene + " -o " + out + " --spacing-m 0.01 --region -0.01,0.01,-0.01,0.01 " +
                                 "--setup-checks 0 --rim-model never --direct-solves never --tolerance 0.3 --quiet --no-checkpoint");
  INFO(third.err);
  CHECK(third.exit_code == 0);
  CHECK(std::filesystem::exists(out));
  CHECK_FALSE(std::filesystem::exists(out + ".lock"));
  std::filesystem::remove_all(d);
}
#endif


// Issue 31 item 3: one style across --help. Positional arguments in capitals (SCENE, MAP), and a
// default always written "(default ...)" at the end of the text — never CLI11's "=value" beside
// the type, "; default x" or "default: x" — so that a user finds it in the same place everywhere.
TEST_CASE("help texts share one style: capital positionals, defaults as '(default ...)'", "[cli][help]") {
  // Flags not yet in the style (named so the list can only shrink; empty since map, solve and
  // export-map were brought into it).
  const std::vector<std::string> pending = {};
  for (const auto& [command, help] : all_help_texts()) {
    std::istringstream lines(help);
    std::string line, section, flag;
    while (std::getline(lines, line)) {
      if (!line.empty() && line[0] != ' ') {
        section = line;
        continue;
      }
      const auto first = line.find_first_not_of(' ');
      if (first == std::string::npos) continue;
      INFO(command << " --help: " << line);
      // The first column: up to two spaces (or the end of the line, the text then follows below).
      const std::size_t gap = line.find("  ", first);
      const std::string column = line.substr(first, gap == std::string::npos ? std::string::npos : gap - first);
      const bool starts_entry = first == 2;  // descriptions wrapped onto their own line start deeper
      if (section == "Positionals:" && starts_entry) {
        const std::string name = column.substr(0, column.find(' '));
        CHECK(name == [&] { std::string u = name; for (auto& c : u) c = char(std::toupper(c)); return u; }());
      }
      if (section != "Options:") continue;
      std::string text = line;
      if (starts_entry) {
        flag = column.substr(0, column.find(' '));
        if (flag.find(',') != std::string::npos) flag = flag.substr(flag.find(',') + 1);
        CHECK(column.find('=') == std::string::npos);
        text = gap == std::string::npos ? "" : line.substr(gap);
      }
      if (std::find(pending.begin(), pending.end(), command + " " + flag) != pending.end()) continue;
      for (std::size_t at = text.find("default"); at != std::string::npos; at = text.find("default", at + 1)) {
        const bool in_parentheses = at > 0 && text[at - 1] == '(';
        const bool is_flag_or_word = at > 0 && (std::isalnum(static_cast<unsigned char>(text[at - 1])) || text[at - 1] == '-');
        CHECK((in_parentheses || is_flag_or_word));
        const bool colon_then_space = text.compare(at, 8, "default:") != 0 || text.compare(at, 9, "default: ") == 0;
        CHECK(colon_then_space);
      }
      CHECK(text.find("Default") == std::string::npos);
    }
  }
}

TEST_CASE("restore identify --plot-dir draws its results once, not the scans simulate already drew", "[cli][restore]") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("pvdf_test_identify_plots_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string ex = std::string(PVDF_SOURCE_DIR) + "/examples/restore/";
  const std::string d = dir.string() + "/";
  REQUIRE(run_pvdfkit("restore simulate " + ex + "edge_a.json -o " + d + "a.csv").exit_code == 0);
  REQUIRE(run_pvdfkit("restore simulate " + ex + "edge_b.json -o " + d + "b.csv").exit_code == 0);
  const auto r = run_pvdfkit("restore identify --scan " + d + "a.csv --force-N 0.6,0.9 --edge-x-m -0.0125 --scan " + d +
                             "b.csv --force 0.2,1.0 --edge-x-m -0.0125 -o " + d + "f.json --plot-dir " + d + "plots");
  INFO(r.err);
  REQUIRE(r.exit_code == 0);  // --force-N and its old name --force both accepted
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir / "plots")) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  CHECK(names == std::vector<std::string>{"fig13_inverse_filters.png", "fig14_restored1.png", "fig14_restored2.png",
                                          "transfer_G.png"});
  fs::remove_all(dir);
}

#ifdef PVDF_TEST_WITH_FEM
// A 10 mm film with three small electrodes: its maps are quick, for the progress cases below.
std::string progress_scene(const std::string& name, const std::string& tolerance) {
  return write_temp(name, R"({
    "membrane": {"shape": "circle", "radius_m": 0.010, "thickness_m": 25e-6},
    "material": {"E1_Pa": 2.2e9, "E2_Pa": 1.8e9, "G12_Pa": 0.58e9, "nu12": 0.35,
                 "draw_angle_deg": 0.0, "d31_C_per_N": 6.5e-12, "d32_C_per_N": 0.65e-12},
    "electrodes": [{"name": "A", "center_m": [0.0, 0.004], "size_m": [0.0015, 0.0015]},
                   {"name": "B", "center_m": [-0.0035, -0.002], "size_m": [0.0015, 0.0015]},
                   {"name": "C", "center_m": [0.0035, -0.002], "size_m": [0.0015, 0.0015]}],
    "probe": {"radius_m": 0.001},
    "model": {"kinematics": "auto", "tolerance": )" + tolerance + R"(, "max_refinements": 0}})");
}

// Issue 31 item 1: a map written to a log (stderr not a terminal) reports progress as plain
// lines with rate and ETA at the set cadence (10 s by default; 0.05 s here), and --quiet silences it.
TEST_CASE("map reports progress as plain lines when stderr is not a terminal; --quiet silences it", "[cli][map][progress]") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("pvdf_test_progress_map_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string scene = progress_scene("pvdf_test_progress_scene.json", "0.02");
  const std::string args = "map " + scene + " --spacing-m 0.002 --region -0.004,0.004,-0.002,0.002 --setup-checks 0 "
                           "--threads 1 --no-checkpoint";
  const std::string env = "env PVDF_PROGRESS_INTERVAL_S=0.05 '" + std::string(PVDFKIT_EXE) + "' ";
  const std::string log = (dir / "log.txt").string();
  REQUIRE(std::system((env + args + " -o " + (dir / "b.h5").string() + " >/dev/null 2>" + log).c_str()) == 0);
  std::ifstream in(log);
  std::size_t reports = 0, done = 0;
  std::string first_report;
  const std::regex report(R"(map: [0-9]+/[0-9]+ \([0-9]+ %\), [0-9.e+-]+/s, elapsed [0-9:]+, ETA [0-9:?]+)");
  for (std::string line; std::getline(in, line);) {
    INFO(line);
    CHECK(line.find('\r') == std::string::npos);
    const bool is_report = std::regex_match(line, report);
    if (is_report && first_report.empty()) first_report = line;
    reports += is_report ? 1 : 0;
    done += line.rfind("map: ", 0) == 0 && line.find(" done in ") != std::string::npos ? 1 : 0;
  }
  CHECK(reports >= 1);
  CHECK(done == 1);
  // The positions to do are shown from the setup's end, before the first row is done (a first row
  // next to the clamp can take a minute; until r21 the first line came after it).
  INFO("first report: " << first_report);
  CHECK(first_report.rfind("map: 0/9 (0 %)", 0) == 0);
  REQUIRE(std::system((env + args + " --quiet -o " + (dir / "c.h5").string() + " >/dev/null 2>" + log).c_str()) == 0);
  CHECK(std::filesystem::file_size(log) == 0);
  fs::remove_all(dir);
}

// Issue 31: a setup of minutes (the check solves that size the sweep mesh) is not silent about its
// end: once its first check is solved, the line says the ETA of the whole map (the checks left
// plus every position at the checks' cost). Until r22 it said "starting, elapsed" alone.
TEST_CASE("map states an ETA during its setup, once the first setup check is solved", "[cli][map][progress]") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("pvdf_test_progress_setup_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string scene = progress_scene("pvdf_test_progress_setup_scene.json", "0.01");
  const std::string log = (dir / "log.txt").string();
  const std::string cmd = "env PVDF_PROGRESS_INTERVAL_S=0.01 '" + std::string(PVDFKIT_EXE) + "' map " + scene +
                          " --spacing-m 0.002 --region -0.004,0.004,-0.002,0.002 --setup-checks 3 --threads 1"
                          " --no-checkpoint -o " + (dir / "m.h5").string() + " >/dev/null 2>" + log;
  REQUIRE(std::system(cmd.c_str()) == 0);
  std::ifstream in(log);
  std::size_t starting = 0, starting_with_eta = 0;
  bool counted = false;
  const std::regex with_eta(R"(map: starting, elapsed [0-9:]+, ETA [0-9]+:[0-9]{2})");
  for (std::string line; std::getline(in, line);) {
    INFO(line);
    if (line.rfind("map: starting", 0) == 0) {
      CHECK_FALSE(counted);  // the setup comes first
      ++starting;
      starting_with_eta += std::regex_match(line, with_eta) ? 1 : 0;
      CHECK(line.find("ETA ?") == std::string::npos);  // no ETA at all rather than an unknown one
    }
    counted = counted || line.rfind("map: 0/", 0) == 0;
  }
  INFO("setup lines " << starting << ", with an ETA " << starting_with_eta);
  REQUIRE(starting >= 2);  // the setup outlasts the line interval (else the case says nothing)
  CHECK(starting_with_eta >= 1);
  fs::remove_all(dir);
}
#endif
