// The lookup runtime on its own (linked with pvdf::lookup only; check_lookup_links.cmake inspects
// this executable): the flat map round trip and its hostile-input rules. Oracle: the map built
// here by hand (a smooth analytic charge field), compared field by field and through the Locator.
#include "pvdf/core/error.hpp"
#include "pvdf/mapping/flat_map.hpp"
#include "pvdf/mapping/locator.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

using namespace pvdf::mapping;

namespace {

/// Charge of electrode k for a press at (x, y) with force F: a Gaussian bump around the
/// electrode's centre scaled by F^(2/3) (smooth, positive, distinct per electrode).
double field(const std::array<double, 2>& c, double x, double y, double F) {
  const double s = 6e-3, r2 = (x - c[0]) * (x - c[0]) + (y - c[1]) * (y - c[1]);
  return 10e-12 * std::cbrt(F * F) * (0.2 + std::exp(-r2 / (2 * s * s)));
}

ChargeMap hand_map(bool derivatives, bool calibration, bool charge_error = false) {
  ChargeMap m;
  for (int i = 0; i <= 20; ++i) m.x_m.push_back(-10e-3 + 1e-3 * i);
  for (int j = 0; j <= 16; ++j) m.y_m.push_back(-8e-3 + 1e-3 * j);
  m.forces_N = {0.5, 1.0, 2.0};
  m.electrode_names = {"A", "B", "C"};
  m.electrode_centers_m = {{{-4e-3, -3e-3}}, {{4e-3, -3e-3}}, {{0.0, 4e-3}}};
  m.noise_C = {0.05e-12, 0.06e-12, 0.05e-12};
  m.rim_margin_m = 1e-3;
  m.tolerance = 1e-3;
  m.model = "hand-made test field";
  m.allocate();
  for (std::size_t j = 0; j < m.ny(); ++j) {
    for (std::size_t i = 0; i < m.nx(); ++i) m.mask[j * m.nx() + i] = std::hypot(m.x_m[i], m.y_m[j]) < 9.5e-3 ? 1 : 0;
  }
  if (derivatives) {
    m.dcharge_dx_C_per_m.assign(m.charge_C.size(), 0.0);
    m.dcharge_dy_C_per_m.assign(m.charge_C.size(), 0.0);
  }
  for (std::size_t f = 0; f < m.nf(); ++f) {
    for (std::size_t j = 0; j < m.ny(); ++j) {
      for (std::size_t i = 0; i < m.nx(); ++i) {
        const std::size_t p = m.point(f, j, i);
        m.status[p] = std::uint8_t(m.mask[j * m.nx() + i] ? PointStatus::ok : PointStatus::outside);
        m.deflection_at_load_m[p] = 0;
        for (std::size_t k = 0; k < m.ne(); ++k) {
          const double x = m.x_m[i], y = m.y_m[j], F = m.forces_N[f], h = 1e-7;
          m.charge_C[m.charge_index(f, j, i, k)] = field(m.electrode_centers_m[k], x, y, F);
          if (derivatives) {
            const auto& c = m.electrode_centers_m[k];
            m.dcharge_dx_C_per_m[m.charge_index(f, j, i, k)] = (field(c, x + h, y, F) - field(c, x - h, y, F)) / (2 * h);
            m.dcharge_dy_C_per_m[m.charge_index(f, j, i, k)] = (field(c, x, y + h, F) - field(c, x, y - h, F)) / (2 * h);
          }
        }
      }
    }
  }
  if (calibration) m.calibration = Calibration{{1.02, 0.97, 1.0}, {1e-14, -2e-14, 0.0}, "bench.csv", "{}"};
  if (charge_error) {  // a per-node estimate that varies with node, level and electrode; NaN where not ok
    m.estimated_charge_error_C.resize(m.charge_C.size());
    for (std::size_t n = 0; n < m.charge_C.size(); ++n) {
      m.estimated_charge_error_C[n] = m.status[n / m.ne()] == std::uint8_t(PointStatus::ok) ? 1e-14 * double(1 + n % 7) : std::nan("");
    }
  }
  return m;
}

/// The InputError message of decoding `bytes`, or "" when it decodes.
std::string decode_error(const std::vector<unsigned char>& bytes) {
  try {
    decode_flat_map(bytes.data(), bytes.size(), "map.flat");
  } catch (const pvdf::InputError& e) {
    return e.what();
  }
  return "";
}

/// A little-endian u32 written at `offset`, and the checksum made right again.
void put_u32(std::vector<unsigned char>& b, std::size_t offset, std::uint32_t v, bool fix_crc) {
  for (int k = 0; k < 4; ++k) b[offset + std::size_t(k)] = static_cast<unsigned char>(v >> (8 * k));
  if (fix_crc) {
    const std::uint32_t crc = flat_map_crc32(b.data(), b.size() - 4);
    for (int k = 0; k < 4; ++k) b[b.size() - 4 + std::size_t(k)] = static_cast<unsigned char>(crc >> (8 * k));
  }
}

void require_one_line_naming_source(const std::string& message, const std::string& what) {
  INFO(message);
  REQUIRE(message.rfind("map.flat: ", 0) == 0);
  REQUIRE(message.find('\n') == std::string::npos);
  REQUIRE(message.find(what) != std::string::npos);
}

}  // namespace

TEST_CASE("flat map: round trip keeps every field the lookup uses, bit for bit", "[flat_map]") {
  for (const bool derivatives : {false, true}) {
    for (const bool calibration : {false, true}) {
     for (const bool errors : {false, true}) {
      const ChargeMap m = hand_map(derivatives, calibration, errors);
      const auto bytes = encode_flat_map(m, "test");
      // Size from the documented layout: 80-byte header, doubles, status, mask, names, padding, CRC.
      const std::size_t points = m.nf() * m.ny() * m.nx(), values = points * m.ne();
      std::size_t doubles = m.nx() + m.ny() + m.nf() + 3 * m.ne() + values * (derivatives ? 3 : 1) + (calibration ? 2 * m.ne() : 0) +
                            (errors ? values : 0);
      const std::size_t body = 80 + 8 * doubles + points + m.nx() * m.ny() + 32 * m.ne();
      REQUIRE(bytes.size() == (body + 3) / 4 * 4 + 4);
      REQUIRE(std::memcmp(bytes.data(), "PVDFFLAT", 8) == 0);
      REQUIRE(bytes[8] == 2);                    // version 2
      REQUIRE(((bytes[32] & 4) != 0) == errors);  // content bit 2: the per-node charge errors
      const ChargeMap r = decode_flat_map(bytes.data(), bytes.size(), "map.flat");
      REQUIRE(r.x_m == m.x_m);
      REQUIRE(r.y_m == m.y_m);
      REQUIRE(r.forces_N == m.forces_N);
      REQUIRE(r.mask == m.mask);
      REQUIRE(r.status == m.status);
      REQUIRE(r.charge_C == m.charge_C);
      REQUIRE(r.dcharge_dx_C_per_m == m.dcharge_dx_C_per_m);
      REQUIRE(r.dcharge_dy_C_per_m == m.dcharge_dy_C_per_m);
      REQUIRE(r.electrode_names == m.electrode_names);
      REQUIRE(r.electrode_centers_m == m.electrode_centers_m);
      REQUIRE(r.noise_C == m.noise_C);
      REQUIRE(r.rim_margin_m == m.rim_margin_m);
      REQUIRE(r.tolerance == m.tolerance);
      REQUIRE(std::isnan(r.estimated_relative_error));
      REQUIRE(r.calibration.has_value() == calibration);
      REQUIRE(r.estimated_charge_error_C.size() == m.estimated_charge_error_C.size());
      if (!m.estimated_charge_error_C.empty())  // memcmp takes no null pointer, even for 0 bytes
        REQUIRE(std::memcmp(r.estimated_charge_error_C.data(), m.estimated_charge_error_C.data(),
                            m.estimated_charge_error_C.size() * sizeof(double)) == 0);  // bits, NaN included
      if (calibration) {
        REQUIRE(r.calibration->gain == m.calibration->gain);
        REQUIRE(r.calibration->offset_C == m.calibration->offset_C);
      }
      // The Locator built from either answers identically (it reads nothing else).
      const Locator a(m), b(r);
      for (const auto& press : std::vector<std::array<double, 3>>{{1.3e-3, -0.7e-3, 0.8}, {-3.1e-3, 2.2e-3, 1.6}, {5.5e-3, 1.1e-3, 0.6}}) {
        double q[3];
        for (std::size_t k = 0; k < 3; ++k) q[k] = field(m.electrode_centers_m[k], press[0], press[1], press[2]);
        const Location la = a.locate(q), lb = b.locate(q);
        REQUIRE(la.x_m == lb.x_m);
        REQUIRE(la.y_m == lb.y_m);
        REQUIRE(la.force_N == lb.force_N);
        REQUIRE(la.flags == lb.flags);
        REQUIRE(la.n_solutions == lb.n_solutions);
        REQUIRE(la.sigma_x_m == lb.sigma_x_m);
        REQUIRE(la.sigma_y_m == lb.sigma_y_m);
        REQUIRE(la.sigma_F_N == lb.sigma_F_N);
        REQUIRE(la.probability == lb.probability);
        if (!calibration && la.n_solutions == 1) {  // the oracle: the field the map was sampled from
          REQUIRE(std::abs(la.x_m - press[0]) < 0.1e-3);
          REQUIRE(std::abs(la.y_m - press[1]) < 0.1e-3);
        }
      }
     }
    }
  }
}

TEST_CASE("flat map: a version-1 file (no charge error section) is still read", "[flat_map]") {
  // Version 1 is version 2 without content bit 2: the same bytes with the version field 1.
  const ChargeMap m = hand_map(true, true);
  auto v1 = encode_flat_map(m, "test");
  put_u32(v1, 8, 1, true);
  const ChargeMap r = decode_flat_map(v1.data(), v1.size(), "map.flat");
  REQUIRE(r.charge_C == m.charge_C);
  REQUIRE(r.dcharge_dx_C_per_m == m.dcharge_dx_C_per_m);
  REQUIRE(r.estimated_charge_error_C.empty());
  // A version-1 header may not claim the charge error section.
  auto forged = encode_flat_map(hand_map(false, false, true), "test");
  put_u32(forged, 8, 1, true);
  require_one_line_naming_source(decode_error(forged), "unknown bits");
}

TEST_CASE("flat map: truncated, oversized, damaged or foreign bytes are refused with one line", "[flat_map][hostile]") {
  const auto good = encode_flat_map(hand_map(true, false), "test");
  for (std::size_t n = 0; n < good.size(); n += (n < 200 ? 1 : 97)) {
    const std::vector<unsigned char> cut(good.begin(), good.begin() + long(n));
    require_one_line_naming_source(decode_error(cut), n < 80 ? "fewer than the 80-byte header" : "truncated");
  }
  auto longer = good;
  longer.push_back(0);
  require_one_line_naming_source(decode_error(longer), "oversized");

  auto flipped = good;
  flipped[good.size() / 2] ^= 0x10;
  require_one_line_naming_source(decode_error(flipped), "checksum mismatch");

  auto foreign = good;
  foreign[0] = 'X';
  require_one_line_naming_source(decode_error(foreign), "not a pvdfkit flat map");

  auto v4 = good;
  put_u32(v4, 8, 4, true);
  require_one_line_naming_source(decode_error(v4), "version 4 is not supported");
  auto v0 = good;
  put_u32(v0, 8, 0, true);
  require_one_line_naming_source(decode_error(v0), "version 0 is not supported");
  auto bit = good;
  put_u32(bit, 32, 1u | 8u, true);
  require_one_line_naming_source(decode_error(bit), "unknown bits");

  auto huge = good;  // nx = 100000, ny = 100000: far beyond the byte limit, refused before any allocation
  put_u32(huge, 16, 100000, false);
  put_u32(huge, 20, 100000, false);
  require_one_line_naming_source(decode_error(huge), "limit");

  auto absurd = good;
  put_u32(absurd, 28, 1000, false);
  require_one_line_naming_source(decode_error(absurd), "ne = 1000 must lie in 1..8");

  auto lying = good;  // the header's total disagrees with its sizes
  put_u32(lying, 40, std::uint32_t(good.size() + 8), true);
  require_one_line_naming_source(decode_error(lying), "header says");

  // A consistent file (right checksum) whose values are wrong: validate() names the value.
  auto descending = good;
  const std::size_t forces_at = 80 + 8 * (21 + 17);
  std::swap_ranges(descending.begin() + long(forces_at), descending.begin() + long(forces_at + 8), descending.begin() + long(forces_at + 8));
  put_u32(descending, 8, 1, true);
  require_one_line_naming_source(decode_error(descending), "ascending");
}

TEST_CASE("flat map files: the reader refuses a missing file and an oversized one before reading it", "[flat_map][hostile]") {
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(PVDF_BINARY_DIR) / "tests" / "mapping" / "flat_map_files";
  fs::create_directories(dir);
  const ChargeMap m = hand_map(false, false);
  const auto bytes = encode_flat_map(m, "test");
  const fs::path ok = dir / "ok.flat";
  std::ofstream(ok, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  REQUIRE(read_flat_map(ok.string()).charge_C == m.charge_C);

  const fs::path big = dir / "big.flat";  // sparse: 1 GiB + 1 byte of zeros
  { std::ofstream(big, std::ios::binary).put('P'); }
  fs::resize_file(big, flat_map_max_bytes + 1);
  try {
    read_flat_map(big.string());
    FAIL("an oversized file was accepted");
  } catch (const pvdf::InputError& e) {
    REQUIRE(std::string(e.what()).find("oversized") != std::string::npos);
  }
  fs::remove(big);
  REQUIRE_THROWS_WITH(read_flat_map((dir / "missing.flat").string()), Catch::Contains("cannot open"));
}
