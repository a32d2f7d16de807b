// Map files: exact round trip, readable by h5dump, and every malformed file refused with a
// message naming the dataset or attribute.
#include "pvdf/core/error.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/map_io.hpp"
#include "pvdf/mapping/synthetic.hpp"

#include <catch2/catch.hpp>
#include <hdf5.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>

using namespace pvdf::mapping;

namespace {

std::string temp_path(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / "pvdf_test_mapping";
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

ChargeMap small_map() {
  ChargeMap m = build_synthetic_map(SyntheticModel{}, 6e-3, 3e-3, {0.5, 1.0, 2.0}, 0.1e-12);
  // Mark a few points as failed/uncomputed so the status enum round-trips.
  m.status[m.point(1, 7, 7)] = std::uint8_t(PointStatus::not_converged);
  m.charge_C[m.charge_index(1, 7, 7, 0)] = std::nan("");
  m.status[m.point(2, 7, 8)] = std::uint8_t(PointStatus::not_computed);
  return m;
}

/// Writes a valid map, then lets `damage` edit the file with the HDF5 C API.
std::string damaged_map(const std::string& name, const std::function<void(hid_t)>& damage) {
  const std::string path = temp_path(name);
  write_map(path, small_map());
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  REQUIRE(file >= 0);
  damage(file);
  H5Fclose(file);
  return path;
}

void replace_doubles(hid_t file, const char* name, const std::vector<hsize_t>& dims, const std::vector<double>& values,
                     const char* units) {
  H5Ldelete(file, name, H5P_DEFAULT);
  const hid_t space = H5Screate_simple(int(dims.size()), dims.data(), nullptr);
  const hid_t ds = H5Dcreate2(file, name, H5T_IEEE_F64LE, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  H5Dwrite(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data());
  if (units != nullptr) {
    const hid_t type = H5Tcopy(H5T_C_S1);
    H5Tset_size(type, std::string(units).size());
    const hid_t scalar = H5Screate(H5S_SCALAR);
    const hid_t attr = H5Acreate2(ds, "units", type, scalar, H5P_DEFAULT, H5P_DEFAULT);
    H5Awrite(attr, type, units);
    H5Aclose(attr);
    H5Sclose(scalar);
    H5Tclose(type);
  }
  H5Dclose(ds);
  H5Sclose(space);
}

}  // namespace

TEST_CASE("a map survives a write/read round trip exactly", "[mapping][io]") {
  ChargeMap m = small_map();
  m.estimated_relative_error = 0.0071;
  m.estimated_deflection_relative_error = 0.031;
  m.calibration = Calibration{{1.1, 0.9, 1.05}, {1e-12, -2e-12, 0.0}, "measured.csv", R"({"n": 3})"};
  m.dcharge_dx_C_per_m.assign(m.charge_C.size(), 1e-9);
  m.dcharge_dy_C_per_m.assign(m.charge_C.size(), -2e-9);
  const std::string path = temp_path("roundtrip.h5");
  write_map(path, m);
  const ChargeMap r = read_map(path);
  CHECK(r.scene_json == m.scene_json);
  CHECK(r.model == m.model);
  CHECK(r.tolerance == m.tolerance);
  CHECK(r.estimated_relative_error == m.estimated_relative_error);
  CHECK(r.estimated_deflection_relative_error == m.estimated_deflection_relative_error);
  CHECK(r.rim_margin_m == m.rim_margin_m);
  CHECK(r.x_m == m.x_m);
  CHECK(r.y_m == m.y_m);
  CHECK(r.mask == m.mask);
  CHECK(r.forces_N == m.forces_N);
  CHECK(r.electrode_names == m.electrode_names);
  CHECK(r.electrode_centers_m == m.electrode_centers_m);
  CHECK(r.noise_C == m.noise_C);
  CHECK(r.status == m.status);
  CHECK(r.deflection_at_load_m == m.deflection_at_load_m);
  REQUIRE(r.charge_C.size() == m.charge_C.size());
  for (std::size_t i = 0; i < m.charge_C.size(); ++i) {
    if (std::isnan(m.charge_C[i])) {
      CHECK(std::isnan(r.charge_C[i]));
    } else {
      CHECK(r.charge_C[i] == m.charge_C[i]);
    }
  }
  CHECK(r.dcharge_dx_C_per_m == m.dcharge_dx_C_per_m);
  CHECK(r.dcharge_dy_C_per_m == m.dcharge_dy_C_per_m);
  REQUIRE(r.calibration.has_value());
  CHECK(r.calibration->gain == m.calibration->gain);
  CHECK(r.calibration->offset_C == m.calibration->offset_C);
  CHECK(r.calibration->report_json == m.calibration->report_json);
  CHECK_FALSE(r.pvdfkit_version.empty());
}

TEST_CASE("a map file without the error estimates (written before they existed) loads, estimates unknown",
          "[mapping][io]") {
  ChargeMap m = small_map();
  m.estimated_relative_error = 0.0071;
  m.estimated_deflection_relative_error = 0.031;
  const std::string path = temp_path("before_error_estimates.h5");
  write_map(path, m);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  REQUIRE(file >= 0);
  for (const char* name : {"estimated_relative_error", "estimated_deflection_relative_error"}) {
    INFO(name);
    REQUIRE(H5Aexists(file, name) > 0);  // written next to /:tolerance ...
    REQUIRE(H5Adelete(file, name) >= 0);  // ... and removed: the file as an older pvdfkit wrote it
  }
  H5Fclose(file);
  const ChargeMap r = read_map(path);
  CHECK(std::isnan(r.estimated_relative_error));
  CHECK(std::isnan(r.estimated_deflection_relative_error));
  CHECK(r.deflection_at_load_m == m.deflection_at_load_m);
  // Unknown is written as no attribute (and read back as unknown), never as a number.
  write_map(path, r);
  const ChargeMap again = read_map(path);
  CHECK(std::isnan(again.estimated_deflection_relative_error));
}

TEST_CASE("format 2: the per-node charge error estimates round-trip; format-1 files still load", "[mapping][io]") {
  ChargeMap m = small_map();
  m.estimated_charge_error_C.resize(m.charge_C.size());
  for (std::size_t i = 0; i < m.charge_C.size(); ++i) m.estimated_charge_error_C[i] = 1e-15 * double(i % 97);
  m.estimated_charge_error_C[m.charge_index(1, 7, 7, 0)] = std::nan("");  // at the not_converged point: allowed
  const std::string path = temp_path("format2.h5");
  write_map(path, m);
  const ChargeMap r = read_map(path);
  REQUIRE(r.estimated_charge_error_C.size() == m.estimated_charge_error_C.size());
  for (std::size_t i = 0; i < m.charge_C.size(); ++i) {
    if (std::isnan(m.estimated_charge_error_C[i])) CHECK(std::isnan(r.estimated_charge_error_C[i]));
    else CHECK(r.estimated_charge_error_C[i] == m.estimated_charge_error_C[i]);
  }

  // The same file as format 1 wrote it: version attribute 1, no per-node estimates.
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  auto set_version = [&](int version) {
    const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    REQUIRE(file >= 0);
    const hid_t attr = H5Aopen(file, "format_version", H5P_DEFAULT);
    REQUIRE(attr >= 0);
    REQUIRE(H5Awrite(attr, H5T_NATIVE_INT, &version) >= 0);
    H5Aclose(attr);
    if (H5Lexists(file, "/estimated_charge_error_C", H5P_DEFAULT) > 0) H5Ldelete(file, "/estimated_charge_error_C", H5P_DEFAULT);
    H5Fclose(file);
  };
  set_version(1);
  const ChargeMap v1 = read_map(path);
  CHECK(v1.estimated_charge_error_C.empty());
  CHECK(v1.deflection_at_load_m == m.deflection_at_load_m);
  CHECK(v1.status == m.status);
  set_version(3);
  CHECK_THROWS_WITH(read_map(path), Catch::Contains("format_version = 3"));

  // A negative estimate at an ok point is refused, naming the dataset.
  ChargeMap bad = m;
  bad.estimated_charge_error_C[bad.charge_index(0, 7, 7, 1)] = -1e-15;
  CHECK_THROWS_WITH(write_map(temp_path("format2_bad.h5"), bad), Catch::Contains("/estimated_charge_error_C"));
}

TEST_CASE("map files are plain HDF5 that h5dump can read", "[mapping][io]") {
  const std::string path = temp_path("dump.h5");
  write_map(path, small_map());
  if (std::system("command -v h5dump > /dev/null 2>&1") != 0) {
    // scripts/install-deps installs hdf5-tools: a missing h5dump is a broken install, not a skip.
    FAIL("h5dump not found on PATH: install hdf5-tools (scripts/install-deps) for the external-reader check");
  }
  const std::string out = temp_path("dump.txt");
  REQUIRE(std::system(("h5dump -H " + path + " > " + out).c_str()) == 0);
  std::FILE* f = std::fopen(out.c_str(), "r");
  REQUIRE(f != nullptr);
  std::string text;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;) text.append(buf, n);
  std::fclose(f);
  for (const char* name : {"charge_C", "deflection_at_load_m", "status", "forces_N", "x_m", "mask", "names", "units",
                           "scene_json", "pvdfkit_version"}) {
    INFO(name);
    CHECK(text.find(name) != std::string::npos);
  }
}

TEST_CASE("malformed map files are refused naming the dataset or attribute", "[mapping][io]") {
  auto expect = [](const std::string& path, const std::string& fragment) {
    INFO("expecting an error mentioning " << fragment);
    CHECK_THROWS_WITH(read_map(path), Catch::Contains(fragment));
    CHECK_THROWS_AS(read_map(path), pvdf::InputError);
  };
  expect(damaged_map("no_charge.h5", [](hid_t f) { H5Ldelete(f, "/charge_C", H5P_DEFAULT); }), "/charge_C is missing");
  expect(damaged_map("wrong_shape.h5", [](hid_t f) { replace_doubles(f, "/forces_N", {2}, {1.0, 2.0}, "N"); }),
         "dataset /charge_C has shape [3,17,17,3] but [nf][ny][nx][ne] = [2,17,17,3]");  // 3 levels stored, 2 forces
  expect(damaged_map("wrong_units.h5", [](hid_t f) { replace_doubles(f, "/forces_N", {3}, {0.5, 1.0, 2.0}, "kN"); }),
         "/forces_N has units 'kN'");
  expect(damaged_map("no_units.h5", [](hid_t f) { replace_doubles(f, "/forces_N", {3}, {0.5, 1.0, 2.0}, nullptr); }),
         "/forces_N:units is missing");
  expect(damaged_map("descending.h5", [](hid_t f) { replace_doubles(f, "/forces_N", {3}, {0.5, 2.0, 1.0}, "N"); }),
         "/forces_N[2]");
  expect(damaged_map("no_format.h5", [](hid_t f) { H5Adelete(f, "format"); }), "format is missing");
  // Not HDF5 at all.
  const std::string text = temp_path("not_a_map.h5");
  std::FILE* t = std::fopen(text.c_str(), "w");
  std::fputs("x_m,y_m\n1,2\n", t);
  std::fclose(t);
  expect(text, "not an HDF5 file");
  expect(temp_path("does_not_exist.h5"), "not an HDF5 file");
}

TEST_CASE("validation names the offending value", "[mapping][io]") {
  ChargeMap m = small_map();
  m.status[m.point(0, 0, 0)] = 0;  // ok where the mask says outside
  CHECK_THROWS_WITH(validate(m, "m.h5"), Catch::Contains("/status[0][0][0] = 0 (ok)"));
  m = small_map();
  m.status[5] = 7;
  CHECK_THROWS_WITH(validate(m, "m.h5"), Catch::Contains("not one of 0 ok, 1 not_converged, 2 outside, 3 not_computed"));
  m = small_map();
  m.charge_C[m.charge_index(0, 7, 7, 1)] = std::nan("");
  CHECK_THROWS_WITH(validate(m, "m.h5"), Catch::Contains("/charge_C[0][7][7][1] is not finite"));
  m = small_map();
  m.x_m[3] += 1e-4;
  CHECK_THROWS_WITH(validate(m, "m.h5"), Catch::Contains("equally spaced"));
  m = small_map();
  m.electrode_names[1] = "A";
  CHECK_THROWS_WITH(validate(m, "m.h5"), Catch::Contains("appears twice"));
  m = small_map();
  m.noise_C[0] = 0;
  CHECK_THROWS_WITH(validate(m, "m.h5"), Catch::Contains("/electrodes/noise_C[0]"));
  m = small_map();
  m.estimated_deflection_relative_error = -0.03;
  CHECK_THROWS_WITH(validate(m, "m.h5"), Catch::Contains("attribute estimated_deflection_relative_error = -0.03"));
  m = small_map();
  m.calibration = Calibration{{1.0, 0.0, 1.0}, {0, 0, 0}, "", ""};
  CHECK_THROWS_WITH(validate(m, "m.h5"), Catch::Contains("/calibration/gain[1]"));
  // A failed write leaves no file behind (atomic writer).
  const std::string path = temp_path("never_written.h5");
  std::remove(path.c_str());
  CHECK_THROWS_AS(write_map(path, m), pvdf::InputError);
  CHECK_FALSE(std::filesystem::exists(path));
}
