// Atomic output, range flags and line-numbered CSV reading.
#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;

TEST_CASE("an output that fails half-way leaves the old file untouched and no temporary", "[io]") {
  const fs::path dir = fs::temp_directory_path() / "pvdf_test_io";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string path = (dir / "out.txt").string();
  pvdf::write_file_atomically(path, [](std::ostream& o) { o << "first\n"; });
  CHECK_THROWS_AS(pvdf::write_file_atomically(path, [](std::ostream& o) {
                    o << "half";
                    throw std::runtime_error("interrupted");
                  }),
                  std::runtime_error);
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  CHECK(line == "first");
  std::size_t n_files = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    (void)e;
    ++n_files;
  }
  CHECK(n_files == 1);
  CHECK_THROWS_AS(pvdf::write_file_atomically((dir / "missing" / "x.txt").string(), [](std::ostream&) {}),
                  pvdf::InputError);
  fs::remove_all(dir);
}

TEST_CASE("ranges and number lists", "[io]") {
  const auto r = pvdf::parse_range("0:5:90", "--angles-deg");
  REQUIRE(r.size() == 19);
  CHECK(r.back() == Approx(90));
  CHECK(pvdf::parse_range("0:0.1:1", "x").size() == 11);  // inclusive despite round-off
  CHECK(pvdf::parse_range("90:-30:0", "x").size() == 4);
  CHECK_THROWS_AS(pvdf::parse_range("0:0:1", "x"), pvdf::InputError);
  CHECK_THROWS_AS(pvdf::parse_range("0:1", "x"), pvdf::InputError);
  CHECK_THROWS_AS(pvdf::parse_range("0:-1:5", "x"), pvdf::InputError);
  CHECK_THROWS_AS(pvdf::parse_range("0:1e-9:1", "x"), pvdf::InputError);
  CHECK_THROWS_AS(pvdf::parse_range("nan:1:5", "x"), pvdf::InputError);
  CHECK(pvdf::parse_number_list("1, 2.5,3e-12", "q", 3)[2] == 3e-12);
  CHECK_THROWS_AS(pvdf::parse_number_list("1,,2", "q"), pvdf::InputError);
  CHECK_THROWS_AS(pvdf::parse_number_list("1,2", "q", 3), pvdf::InputError);
}

TEST_CASE("CSV: bad rows are refused or skipped with their line numbers", "[io]") {
  const std::string text = "# comment\nx_m,m1_V\n0.0,1.0\n0.1,abc\n0.2\n\n0.3,nan\n0.4,2.0\n";
  {
    std::istringstream in(text);
    try {
      pvdf::read_csv(in, "scan.csv");
      FAIL("bad row accepted");
    } catch (const pvdf::InputError& e) {
      CHECK_THAT(std::string(e.what()), Catch::Contains("scan.csv:4") && Catch::Contains("m1_V"));
    }
  }
  std::istringstream in(text);
  std::vector<std::string> skipped;
  const auto t = pvdf::read_csv(in, "scan.csv", pvdf::BadRowPolicy::skip, &skipped);
  REQUIRE(t.rows.size() == 2);
  CHECK(t.line_numbers[1] == 8);
  REQUIRE(skipped.size() == 3);
  CHECK_THAT(skipped[1], Catch::Contains("scan.csv:5"));
  CHECK_THAT(skipped[2], Catch::Contains("scan.csv:7"));
  CHECK(t.column("m1_V") == 1);
  CHECK_THROWS_AS(t.column("m2_V"), pvdf::InputError);
}

TEST_CASE("CSV as users write it: BOM, quoted fields, CRLF, comments", "[io][csv]") {
  // Excel's "CSV UTF-8" (BOM), pandas QUOTE_ALL, Windows line ends, comment lines.
  const std::string text =
      "\xEF\xBB\xBF# exported by a spreadsheet\r\n"
      "\"x_m\",\"m1_V\",\"note, with comma\"\r\n"
      "# a comment between rows\r\n"
      "\"0.0\",\"1.5\",\"2\"\r\n"
      "\"0.1\", 2.5 ,\"3\"\r\n"
      "  # indented comment\r\n"
      "\r\n"
      "0.2,3.5,4\n";
  std::istringstream in(text);
  const auto t = pvdf::read_csv(in, "excel.csv");
  REQUIRE(t.columns.size() == 3);
  CHECK(t.columns[0] == "x_m");
  CHECK(t.columns[2] == "note, with comma");
  REQUIRE(t.rows.size() == 3);
  CHECK(t.rows[0][1] == 1.5);
  CHECK(t.rows[1][1] == 2.5);
  CHECK(t.rows[2][2] == 4.0);
  CHECK(t.line_numbers[0] == 4);
  CHECK(t.line_numbers[2] == 8);
  CHECK(t.column("m1_V") == 1);
  // A BOM before the header without a comment line.
  std::istringstream bom("\xEF\xBB\xBFx_m,m1_V\n0,1\n");
  CHECK(pvdf::read_csv(bom, "bom.csv").column("x_m") == 0);
  // Doubled quotes inside a quoted field; split_csv_line alone (used by the streaming reader).
  const auto f = pvdf::split_csv_line("\xEF\xBB\xBF\"t_s\",\"a \"\"b\"\"\" , 3\r");
  REQUIRE(f.size() == 3);
  CHECK(f[0] == "t_s");
  CHECK(f[1] == "a \"b\"");
  CHECK(f[2] == "3");
  // An unterminated quote is refused with its line number, never read as a number.
  std::istringstream bad("x_m,m1_V\n\"0.1,2\n");
  try {
    pvdf::read_csv(bad, "bad.csv");
    FAIL("unterminated quote accepted");
  } catch (const pvdf::InputError& e) {
    CHECK_THAT(std::string(e.what()), Catch::Contains("bad.csv:2") && Catch::Contains("quote"));
  }
}

TEST_CASE("CSV messages escape control bytes", "[io][csv][hostile]") {
  std::istringstream in(std::string("x_m,m1_V\n0.1,\x01\x1b[2J\x00z\n", 21));
  try {
    pvdf::read_csv(in, "ctl.csv");
    FAIL("garbage accepted");
  } catch (const pvdf::InputError& e) {
    const std::string m = e.what();
    CHECK_THAT(m, Catch::Contains("ctl.csv:2") && Catch::Contains("\\x1b") && Catch::Contains("\\x00"));
    for (const char c : m) CHECK_FALSE((static_cast<unsigned char>(c) < 0x20 || c == 0x7f));
  }
}
