// The flat lookup map (docs/lookup.md §8): encoding, decoding with hostile-input checks, CRC-32.
// Every number is written byte by byte in little-endian order, so the bytes are the same on any
// host and the reader never depends on the host's alignment or byte order.
#include "pvdf/mapping/flat_map.hpp"

#include "pvdf/core/assert.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/mapping/interpolant.hpp"  // max_electrodes

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <utility>

namespace pvdf::mapping {

namespace {

const std::string reexport = "; export it again with `pvdfkit export-map MAP.h5 -o FILE`";

[[noreturn]] void bad(const std::string& source, const std::string& what) { throw InputError(source + ": " + what); }

class Writer {
 public:
  void u32(std::uint32_t v) {
    for (int b = 0; b < 4; ++b) bytes_.push_back(static_cast<unsigned char>(v >> (8 * b)));
  }
  void u64(std::uint64_t v) {
    for (int b = 0; b < 8; ++b) bytes_.push_back(static_cast<unsigned char>(v >> (8 * b)));
  }
  void f64(double v) {
    std::uint64_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    u64(bits);
  }
  void f64s(const std::vector<double>& v) {
    for (const double x : v) f64(x);
  }
  void bytes(const unsigned char* p, std::size_t n) { bytes_.insert(bytes_.end(), p, p + n); }
  std::vector<unsigned char>& data() { return bytes_; }

 private:
  std::vector<unsigned char> bytes_;
};

class Reader {
 public:
  explicit Reader(const unsigned char* data) : data_(data) {}
  std::uint32_t u32() {
    std::uint32_t v = 0;
    for (int b = 0; b < 4; ++b) v |= std::uint32_t(data_[pos_ + std::size_t(b)]) << (8 * b);
    pos_ += 4;
    return v;
  }
  std::uint64_t u64() {
    std::uint64_t v = 0;
    for (int b = 0; b < 8; ++b) v |= std::uint64_t(data_[pos_ + std::size_t(b)]) << (8 * b);
    pos_ += 8;
    return v;
  }
  double f64() {
    const std::uint64_t bits = u64();
    double v = 0;
    std::memcpy(&v, &bits, sizeof v);
    return v;
  }
  void f64s(std::vector<double>& v, std::size_t n) {
    v.resize(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = f64();
  }
  void u8s(std::vector<std::uint8_t>& v, std::size_t n) {
    v.assign(data_ + pos_, data_ + pos_ + n);
    pos_ += n;
  }
  const unsigned char* here() const { return data_ + pos_; }
  void skip(std::size_t n) { pos_ += n; }

 private:
  const unsigned char* data_;
  std::size_t pos_ = 0;
};

/// Sizes read from a header, and the total they imply.
struct Layout {
  std::uint64_t nx = 0, ny = 0, nf = 0, ne = 0;
  bool derivatives = false, calibration = false, charge_error = false, total_error = false;
  std::uint64_t points() const { return nf * ny * nx; }
  std::uint64_t body_without_padding() const {
    std::uint64_t doubles = nx + ny + nf + ne + 2 * ne + points() * ne;
    if (calibration) doubles += 2 * ne;
    if (derivatives) doubles += 2 * points() * ne;
    if (charge_error) doubles += points() * ne;
    return flat_map_header_bytes + 8 * doubles + points() + ny * nx + ne * flat_map_name_bytes;
  }
  /// Total bytes: body, zero padding to a multiple of 4, then the CRC-32.
  std::uint64_t total() const { return (body_without_padding() + 3) / 4 * 4 + 4; }
};

std::string text(std::uint64_t v) { return std::to_string(v); }

/// Checks the header's fields and returns the layout they describe (size not yet compared).
Layout read_header(Reader& r, std::size_t size, const std::string& source) {
  if (size < flat_map_header_bytes) {
    bad(source, "truncated: " + text(size) + " bytes, fewer than the " + text(flat_map_header_bytes) + "-byte header" + reexport);
  }
  if (std::memcmp(r.here(), flat_map_magic, sizeof flat_map_magic) != 0) {
    bad(source, "is not a pvdfkit flat map (the first 8 bytes are not PVDFFLAT); give a file written by `pvdfkit export-map`");
  }
  r.skip(sizeof flat_map_magic);
  const std::uint32_t version = r.u32();
  if (version < flat_map_oldest_version || version > flat_map_version) {
    bad(source, "flat map version " + text(version) + " is not supported (this pvdfkit reads versions " + text(flat_map_oldest_version) +
                    ".." + text(flat_map_version) + ")" + reexport);
  }
  const std::uint32_t header_bytes = r.u32();
  if (header_bytes != flat_map_header_bytes) bad(source, "header size " + text(header_bytes) + " must be " + text(flat_map_header_bytes) + reexport);
  Layout l;
  l.nx = r.u32();
  l.ny = r.u32();
  l.nf = r.u32();
  l.ne = r.u32();
  const std::uint32_t contents = r.u32();
  const std::uint32_t name_bytes = r.u32();
  if (l.nx < 2 || l.nx > flat_map_max_axis) bad(source, "nx = " + text(l.nx) + " must lie in 2.." + text(flat_map_max_axis) + reexport);
  if (l.ny < 2 || l.ny > flat_map_max_axis) bad(source, "ny = " + text(l.ny) + " must lie in 2.." + text(flat_map_max_axis) + reexport);
  if (l.nf < 1 || l.nf > flat_map_max_levels) bad(source, "nf = " + text(l.nf) + " must lie in 1.." + text(flat_map_max_levels) + reexport);
  if (l.ne < 1 || l.ne > max_electrodes) bad(source, "ne = " + text(l.ne) + " must lie in 1.." + text(max_electrodes) + reexport);
  const std::uint32_t known = flat_map_has_derivatives | flat_map_has_calibration | (version >= 2 ? flat_map_has_charge_error : 0u) |
                              (version >= 3 ? flat_map_charge_error_is_total : 0u);
  if ((contents & ~known) != 0) {
    bad(source, "content bits " + text(contents) + " hold unknown bits (known in version " + text(version) + ": 1 derivatives, 2 calibration" +
                    (version >= 2 ? ", 4 charge errors" : "") + (version >= 3 ? ", 8 total errors" : "") + ")" + reexport);
  }
  if ((contents & flat_map_charge_error_is_total) && !(contents & flat_map_has_charge_error)) {
    bad(source, "content bit 8 (total errors) is set without bit 4 (charge errors)" + reexport);
  }
  if (name_bytes != flat_map_name_bytes) bad(source, "name field size " + text(name_bytes) + " must be " + text(flat_map_name_bytes) + reexport);
  l.derivatives = (contents & flat_map_has_derivatives) != 0;
  l.calibration = (contents & flat_map_has_calibration) != 0;
  l.charge_error = (contents & flat_map_has_charge_error) != 0;
  l.total_error = (contents & flat_map_charge_error_is_total) != 0;
  const std::uint64_t file_bytes = r.u64();
  const std::uint64_t need = l.total();
  if (need > flat_map_max_bytes) {
    bad(source, "sizes nx " + text(l.nx) + ", ny " + text(l.ny) + ", nf " + text(l.nf) + ", ne " + text(l.ne) + " need " + text(need) +
                    " bytes, more than the " + text(flat_map_max_bytes) + "-byte limit; export a coarser map");
  }
  if (file_bytes != need) bad(source, "header says " + text(file_bytes) + " bytes but its sizes need " + text(need) + reexport);
  if (size < need) bad(source, "truncated: " + text(size) + " bytes but the header's sizes need " + text(need) + reexport);
  if (size > need) bad(source, "oversized: " + text(size) + " bytes but the header's sizes need " + text(need) + " (trailing bytes)" + reexport);
  return l;
}

}  // namespace

std::uint32_t flat_map_crc32(const unsigned char* data, std::size_t size) {
  std::uint32_t crc = 0xffffffffu;
  for (std::size_t i = 0; i < size; ++i) {
    crc ^= data[i];
    for (int b = 0; b < 8; ++b) crc = (crc >> 1) ^ (0xedb88320u & (0u - (crc & 1u)));
  }
  return ~crc;
}

std::vector<unsigned char> encode_flat_map(const ChargeMap& map, const std::string& source) {
  validate(map, source);
  for (const auto& name : map.electrode_names) {
    if (name.size() >= flat_map_name_bytes) {
      bad(source, "electrode name '" + escape_control_bytes(name) + "' has " + text(name.size()) + " bytes; the flat map holds at most " +
                      text(flat_map_name_bytes - 1) + " (rename the electrode in the scene and regenerate the map)");
    }
  }
  Layout l;
  l.nx = map.nx();
  l.ny = map.ny();
  l.nf = map.nf();
  l.ne = map.ne();
  l.derivatives = !map.dcharge_dx_C_per_m.empty();
  l.calibration = map.calibration.has_value();
  l.charge_error = !map.estimated_charge_error_C.empty();
  l.total_error = l.charge_error && map.charge_error_is_total();
  if (l.nx > flat_map_max_axis || l.ny > flat_map_max_axis || l.nf > flat_map_max_levels || l.ne > max_electrodes ||
      l.total() > flat_map_max_bytes) {
    bad(source, "the map (" + text(l.nx) + " x " + text(l.ny) + " points, " + text(l.nf) + " levels, " + text(l.ne) +
                    " electrodes) exceeds the flat map's limits; regenerate it with a coarser grid");
  }
  Writer w;
  w.bytes(reinterpret_cast<const unsigned char*>(flat_map_magic), sizeof flat_map_magic);
  w.u32(l.total_error ? 3u : 2u);
  w.u32(flat_map_header_bytes);
  w.u32(std::uint32_t(l.nx));
  w.u32(std::uint32_t(l.ny));
  w.u32(std::uint32_t(l.nf));
  w.u32(std::uint32_t(l.ne));
  w.u32((l.derivatives ? flat_map_has_derivatives : 0u) | (l.calibration ? flat_map_has_calibration : 0u) |
        (l.charge_error ? flat_map_has_charge_error : 0u) | (l.total_error ? flat_map_charge_error_is_total : 0u));
  w.u32(flat_map_name_bytes);
  w.u64(l.total());
  w.f64(map.rim_margin_m);
  w.f64(map.tolerance);
  w.f64(map.estimated_relative_error);
  if (l.total_error) w.f64(map.estimated_total_relative_error);
  else w.u64(0);  // reserved
  w.f64s(map.x_m);
  w.f64s(map.y_m);
  w.f64s(map.forces_N);
  w.f64s(map.noise_C);
  for (const auto& c : map.electrode_centers_m) {
    w.f64(c[0]);
    w.f64(c[1]);
  }
  if (l.calibration) {
    w.f64s(map.calibration->gain);
    w.f64s(map.calibration->offset_C);
  }
  w.f64s(map.charge_C);
  if (l.derivatives) {
    w.f64s(map.dcharge_dx_C_per_m);
    w.f64s(map.dcharge_dy_C_per_m);
  }
  if (l.charge_error) w.f64s(map.estimated_charge_error_C);
  w.bytes(map.status.data(), map.status.size());
  w.bytes(map.mask.data(), map.mask.size());
  for (const auto& name : map.electrode_names) {
    unsigned char field[flat_map_name_bytes] = {};
    std::memcpy(field, name.data(), name.size());
    w.bytes(field, sizeof field);
  }
  while (w.data().size() % 4 != 0) w.data().push_back(0);
  w.u32(flat_map_crc32(w.data().data(), w.data().size()));
  PVDF_ASSERT(w.data().size() == l.total(), "the flat map written must have the size its header announces");
  return std::move(w.data());
}

ChargeMap decode_flat_map(const unsigned char* data, std::size_t size, const std::string& source) {
  Reader r(data);
  const Layout l = read_header(r, size, source);
  std::uint32_t stored_crc = 0;
  for (int b = 0; b < 4; ++b) stored_crc |= std::uint32_t(data[size - 4 + std::size_t(b)]) << (8 * b);
  const std::uint32_t crc = flat_map_crc32(data, size - 4);
  if (crc != stored_crc) bad(source, "checksum mismatch (CRC-32 " + text(crc) + ", stored " + text(stored_crc) + "): the file is damaged" + reexport);

  ChargeMap m;
  m.rim_margin_m = r.f64();
  m.tolerance = r.f64();
  m.estimated_relative_error = r.f64();
  if (l.total_error) m.estimated_total_relative_error = r.f64();
  else if (r.u64() != 0) bad(source, "the reserved header field is not zero" + reexport);
  const std::size_t n_values = std::size_t(l.points() * l.ne);
  r.f64s(m.x_m, std::size_t(l.nx));
  r.f64s(m.y_m, std::size_t(l.ny));
  r.f64s(m.forces_N, std::size_t(l.nf));
  r.f64s(m.noise_C, std::size_t(l.ne));
  m.electrode_centers_m.resize(std::size_t(l.ne));
  for (auto& c : m.electrode_centers_m) {
    c[0] = r.f64();
    c[1] = r.f64();
  }
  if (l.calibration) {
    Calibration c;
    r.f64s(c.gain, std::size_t(l.ne));
    r.f64s(c.offset_C, std::size_t(l.ne));
    c.source = source;
    m.calibration = std::move(c);
  }
  r.f64s(m.charge_C, n_values);
  if (l.derivatives) {
    r.f64s(m.dcharge_dx_C_per_m, n_values);
    r.f64s(m.dcharge_dy_C_per_m, n_values);
  }
  if (l.charge_error) r.f64s(m.estimated_charge_error_C, n_values);
  r.u8s(m.status, std::size_t(l.points()));
  r.u8s(m.mask, std::size_t(l.nx * l.ny));
  for (std::uint64_t k = 0; k < l.ne; ++k) {
    const char* field = reinterpret_cast<const char*>(r.here());
    const void* end = std::memchr(field, 0, flat_map_name_bytes);
    if (end == nullptr) bad(source, "electrode name " + text(k) + " is not NUL-terminated within " + text(flat_map_name_bytes) + " bytes" + reexport);
    const std::string name(field, std::size_t(static_cast<const char*>(end) - field));
    for (const char c : name) {
      if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
        bad(source, "electrode name " + text(k) + " '" + escape_control_bytes(name) + "' holds a control byte" + reexport);
      }
    }
    m.electrode_names.push_back(name);
    r.skip(flat_map_name_bytes);
  }
  PVDF_ASSERT(std::uint64_t(r.here() - data) == l.body_without_padding(),
              "the fields read must end where the header's sizes say the body ends");
  m.deflection_at_load_m.assign(std::size_t(l.points()), 0.0);
  m.model = "flat export";
  m.description = "read from the flat map " + source;
  validate(m, source);
  return m;
}

ChargeMap read_flat_map(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in) bad(path, "cannot open the flat map file; check the path and permissions");
  const std::streamoff size = in.tellg();
  if (size < 0) bad(path, "cannot read the flat map file's size; give a regular file");
  if (std::uint64_t(size) > flat_map_max_bytes) {
    bad(path, "oversized: " + text(std::uint64_t(size)) + " bytes, more than the " + text(flat_map_max_bytes) +
                  "-byte limit of a flat map; give a file written by `pvdfkit export-map`");
  }
  std::vector<unsigned char> bytes(static_cast<std::size_t>(size));
  in.seekg(0);
  if (!bytes.empty() && !in.read(reinterpret_cast<char*>(bytes.data()), size)) bad(path, "cannot read the flat map file (I/O error)");
  return decode_flat_map(bytes.data(), bytes.size(), path);
}

}  // namespace pvdf::mapping
