// Charge maps in HDF5 (C API): validation, atomic writing, and a reader that names the dataset
// or attribute at fault. Layout: docs/mapping.md §1.
#include "pvdf/mapping/map.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/version.hpp"

#include <hdf5.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <set>
#include <sstream>
#include <utility>

namespace pvdf::mapping {

std::string status_name(PointStatus status) {
  switch (status) {
    case PointStatus::ok: return "ok";
    case PointStatus::not_converged: return "not_converged";
    case PointStatus::outside: return "outside";
    case PointStatus::not_computed: return "not_computed";
  }
  return "unknown";
}

void ChargeMap::allocate() {
  const std::size_t n_points = nf() * ny() * nx();
  charge_C.assign(n_points * ne(), 0.0);
  deflection_at_load_m.assign(n_points, 0.0);
  status.assign(n_points, static_cast<std::uint8_t>(PointStatus::not_computed));
  if (mask.size() != nx() * ny()) mask.assign(nx() * ny(), 1);
  if (noise_C.size() != ne()) noise_C.assign(ne(), 1e-13);
  if (electrode_centers_m.size() != ne()) electrode_centers_m.assign(ne(), {0.0, 0.0});
}

namespace {

std::string num(double v) {
  std::ostringstream os;
  os.precision(10);
  os << v;
  return os.str();
}

[[noreturn]] void bad(const std::string& source, const std::string& what) { throw InputError(source + ": " + what); }

const std::string regenerate = "; regenerate the map with `pvdfkit map` or repair the file";

/// Root attributes that may be absent (files written before they existed, maps without an FEM
/// error estimate): absent in the file = NaN in ChargeMap = unknown. No new format version needed.
constexpr std::array<std::pair<const char*, double ChargeMap::*>, 2> optional_number_attributes{{
    {"estimated_relative_error", &ChargeMap::estimated_relative_error},
    {"estimated_deflection_relative_error", &ChargeMap::estimated_deflection_relative_error},
}};

void check_axis(const std::vector<double>& axis, const std::string& name, const std::string& source) {
  if (axis.size() < 2) bad(source, name + " has " + std::to_string(axis.size()) + " values; at least 2 are needed" + regenerate);
  for (std::size_t i = 0; i < axis.size(); ++i) {
    if (!std::isfinite(axis[i])) bad(source, name + "[" + std::to_string(i) + "] is not finite" + regenerate);
  }
  const double h = (axis.back() - axis.front()) / double(axis.size() - 1);
  if (!(h > 0)) bad(source, name + " must be ascending (first " + num(axis.front()) + ", last " + num(axis.back()) + ")" + regenerate);
  for (std::size_t i = 1; i < axis.size(); ++i) {
    const double d = axis[i] - axis[i - 1];
    if (std::abs(d - h) > 1e-6 * h) {
      bad(source, name + " must be equally spaced: step " + std::to_string(i) + " is " + num(d) + " m, mean " + num(h) +
                      " m" + regenerate);
    }
  }
}

}  // namespace

void validate(const ChargeMap& m, const std::string& source) {
  check_axis(m.x_m, "/grid/x_m", source);
  check_axis(m.y_m, "/grid/y_m", source);
  if (m.mask.size() != m.nx() * m.ny()) {
    bad(source, "/grid/mask has " + std::to_string(m.mask.size()) + " values but [ny][nx] = " +
                    std::to_string(m.ny() * m.nx()) + " are required" + regenerate);
  }
  for (std::size_t i = 0; i < m.mask.size(); ++i) {
    if (m.mask[i] > 1) bad(source, "/grid/mask[" + std::to_string(i) + "] = " + std::to_string(m.mask[i]) + " must be 0 or 1" + regenerate);
  }
  if (m.forces_N.empty()) bad(source, "/forces_N is empty; at least one force level is needed" + regenerate);
  for (std::size_t f = 0; f < m.nf(); ++f) {
    if (!std::isfinite(m.forces_N[f]) || !(m.forces_N[f] > 0)) {
      bad(source, "/forces_N[" + std::to_string(f) + "] = " + num(m.forces_N[f]) + " must be finite and > 0" + regenerate);
    }
    if (f > 0 && !(m.forces_N[f] > m.forces_N[f - 1])) {
      bad(source, "/forces_N[" + std::to_string(f) + "] = " + num(m.forces_N[f]) + " must be > /forces_N[" +
                      std::to_string(f - 1) + "] = " + num(m.forces_N[f - 1]) + " (ascending)" + regenerate);
    }
  }
  if (m.ne() < 1) bad(source, "/electrodes/names is empty; a map needs at least one electrode" + regenerate);
  std::set<std::string> names;
  for (const auto& n : m.electrode_names) {
    if (n.empty()) bad(source, "/electrodes/names holds an empty name" + regenerate);
    if (n.find_first_of(",\n\r\" ") != std::string::npos) bad(source, "/electrodes/names: '" + n + "' contains a comma, quote or space" + regenerate);
    if (!names.insert(n).second) bad(source, "/electrodes/names: '" + n + "' appears twice" + regenerate);
  }
  if (m.electrode_centers_m.size() != m.ne()) {
    bad(source, "/electrodes/center_m has " + std::to_string(m.electrode_centers_m.size()) + " rows but there are " +
                    std::to_string(m.ne()) + " electrodes" + regenerate);
  }
  for (std::size_t k = 0; k < m.ne(); ++k) {
    if (!std::isfinite(m.electrode_centers_m[k][0]) || !std::isfinite(m.electrode_centers_m[k][1])) {
      bad(source, "/electrodes/center_m[" + std::to_string(k) + "] is not finite" + regenerate);
    }
  }
  if (m.noise_C.size() != m.ne()) {
    bad(source, "/electrodes/noise_C has " + std::to_string(m.noise_C.size()) + " values but there are " +
                    std::to_string(m.ne()) + " electrodes" + regenerate);
  }
  for (std::size_t k = 0; k < m.ne(); ++k) {
    if (!std::isfinite(m.noise_C[k]) || !(m.noise_C[k] > 0)) {
      bad(source, "/electrodes/noise_C[" + std::to_string(k) + "] = " + num(m.noise_C[k]) + " must be finite and > 0" + regenerate);
    }
  }
  const std::size_t n_points = m.nf() * m.ny() * m.nx();
  auto shape = [&](std::size_t got, std::size_t want, const std::string& name, const std::string& dims) {
    if (got != want) {
      bad(source, name + " has " + std::to_string(got) + " values but " + dims + " = " + std::to_string(want) +
                      " are required" + regenerate);
    }
  };
  shape(m.status.size(), n_points, "/status", "[nf][ny][nx]");
  shape(m.deflection_at_load_m.size(), n_points, "/deflection_at_load_m", "[nf][ny][nx]");
  shape(m.charge_C.size(), n_points * m.ne(), "/charge_C", "[nf][ny][nx][ne]");
  const bool has_dx = !m.dcharge_dx_C_per_m.empty(), has_dy = !m.dcharge_dy_C_per_m.empty();
  if (has_dx != has_dy) bad(source, "/derivatives must hold both dcharge_dx_C_per_m and dcharge_dy_C_per_m or neither" + regenerate);
  if (has_dx) {
    shape(m.dcharge_dx_C_per_m.size(), n_points * m.ne(), "/derivatives/dcharge_dx_C_per_m", "[nf][ny][nx][ne]");
    shape(m.dcharge_dy_C_per_m.size(), n_points * m.ne(), "/derivatives/dcharge_dy_C_per_m", "[nf][ny][nx][ne]");
  }
  const bool has_err = !m.estimated_charge_error_C.empty();
  if (has_err) shape(m.estimated_charge_error_C.size(), n_points * m.ne(), "/estimated_charge_error_C", "[nf][ny][nx][ne]");
  std::size_t n_ok = 0;
  for (std::size_t f = 0; f < m.nf(); ++f) {
    for (std::size_t j = 0; j < m.ny(); ++j) {
      for (std::size_t i = 0; i < m.nx(); ++i) {
        const std::size_t p = m.point(f, j, i);
        const int s = m.status[p];
        const std::string at = "[" + std::to_string(f) + "][" + std::to_string(j) + "][" + std::to_string(i) + "]";
        if (s > 3) bad(source, "/status" + at + " = " + std::to_string(s) + " is not one of 0 ok, 1 not_converged, 2 outside, 3 not_computed" + regenerate);
        if (s == 0 && m.mask[j * m.nx() + i] == 0) {
          bad(source, "/status" + at + " = 0 (ok) at a point where /grid/mask = 0 (outside)" + regenerate);
        }
        if (s != 0) continue;
        ++n_ok;
        if (!std::isfinite(m.deflection_at_load_m[p])) bad(source, "/deflection_at_load_m" + at + " is not finite at an ok point" + regenerate);
        for (std::size_t k = 0; k < m.ne(); ++k) {
          if (!std::isfinite(m.charge_C[p * m.ne() + k])) {
            bad(source, "/charge_C" + at + "[" + std::to_string(k) + "] is not finite at an ok point" + regenerate);
          }
          if (has_dx && (!std::isfinite(m.dcharge_dx_C_per_m[p * m.ne() + k]) || !std::isfinite(m.dcharge_dy_C_per_m[p * m.ne() + k]))) {
            bad(source, "/derivatives" + at + "[" + std::to_string(k) + "] is not finite at an ok point" + regenerate);
          }
          if (has_err && !(std::isfinite(m.estimated_charge_error_C[p * m.ne() + k]) && m.estimated_charge_error_C[p * m.ne() + k] >= 0)) {
            bad(source, "/estimated_charge_error_C" + at + "[" + std::to_string(k) + "] = " +
                            num(m.estimated_charge_error_C[p * m.ne() + k]) + " must be finite and >= 0 at an ok point" + regenerate);
          }
        }
      }
    }
  }
  if (n_ok == 0) bad(source, "/status has no ok point; the map holds no usable charge" + regenerate);
  if (!std::isfinite(m.tolerance) || m.tolerance < 0) bad(source, "attribute tolerance = " + num(m.tolerance) + " must be finite and >= 0" + regenerate);
  if (!std::isfinite(m.rim_margin_m) || m.rim_margin_m < 0) bad(source, "attribute rim_margin_m = " + num(m.rim_margin_m) + " must be finite and >= 0" + regenerate);
  for (const auto& [name, member] : optional_number_attributes) {
    const double value = m.*member;
    if (!std::isnan(value) && !(std::isfinite(value) && value >= 0)) {
      bad(source, std::string("attribute ") + name + " = " + num(value) + " must be finite and >= 0 (or absent: unknown)" + regenerate);
    }
  }
  if (m.calibration) {
    const auto& c = *m.calibration;
    if (c.gain.size() != m.ne() || c.offset_C.size() != m.ne()) {
      bad(source, "/calibration/gain and /calibration/offset_C must hold " + std::to_string(m.ne()) + " values (one per electrode)" + regenerate);
    }
    for (std::size_t k = 0; k < m.ne(); ++k) {
      if (!std::isfinite(c.gain[k]) || !(std::abs(c.gain[k]) > 0)) {
        bad(source, "/calibration/gain[" + std::to_string(k) + "] = " + num(c.gain[k]) + " must be finite and non-zero; re-run pvdfkit calibrate");
      }
      if (!std::isfinite(c.offset_C[k])) bad(source, "/calibration/offset_C[" + std::to_string(k) + "] is not finite; re-run pvdfkit calibrate");
    }
  }
}

// ------------------------------------------------------------------------------------------
// HDF5 helpers
namespace {

/// Owns one HDF5 identifier and closes it with the right function.
class Handle {
 public:
  Handle() = default;
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  Handle(Handle&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
  ~Handle() {
    if (id_ >= 0 && close_ != nullptr) close_(id_);
  }
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }

 private:
  hid_t id_ = -1;
  herr_t (*close_)(hid_t) = nullptr;
};

void silence_hdf5() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

// --- writing
struct Writer {
  std::string path;  // the final path, for messages
  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(path + ": cannot write " + what + " (HDF5 error); check free space and permissions");
  }
  void check(herr_t status, const std::string& what) const {
    if (status < 0) fail(what);
  }
  void string_attribute(hid_t obj, const std::string& name, const std::string& value) const {
    Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(type.get(), std::max<std::size_t>(1, value.size()));
    H5Tset_strpad(type.get(), H5T_STR_NULLPAD);
    H5Tset_cset(type.get(), H5T_CSET_UTF8);
    Handle space(H5Screate(H5S_SCALAR), H5Sclose);
    Handle attr(H5Acreate2(obj, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    if (!attr.valid()) fail("attribute " + name);
    const std::string padded = value.empty() ? std::string(1, '\0') : value;
    check(H5Awrite(attr.get(), type.get(), padded.data()), "attribute " + name);
  }
  void number_attribute(hid_t obj, const std::string& name, double value) const {
    Handle space(H5Screate(H5S_SCALAR), H5Sclose);
    Handle attr(H5Acreate2(obj, name.c_str(), H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    if (!attr.valid()) fail("attribute " + name);
    check(H5Awrite(attr.get(), H5T_NATIVE_DOUBLE, &value), "attribute " + name);
  }
  void int_attribute(hid_t obj, const std::string& name, long value) const {
    Handle space(H5Screate(H5S_SCALAR), H5Sclose);
    Handle attr(H5Acreate2(obj, name.c_str(), H5T_STD_I64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    if (!attr.valid()) fail("attribute " + name);
    check(H5Awrite(attr.get(), H5T_NATIVE_LONG, &value), "attribute " + name);
  }
  Handle group(hid_t parent, const std::string& name) const {
    Handle g(H5Gcreate2(parent, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
    if (!g.valid()) fail("group " + name);
    return g;
  }
  template <class T>
  void dataset(hid_t parent, const std::string& name, const std::vector<hsize_t>& dims, const T* data, hid_t file_type,
               hid_t mem_type, const std::string& units, const std::string& description) const {
    Handle space(H5Screate_simple(int(dims.size()), dims.data(), nullptr), H5Sclose);
    Handle plist(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
    hsize_t total = 1;
    for (auto d : dims) total *= d;
    if (total > 4096) {  // chunk + compress big arrays; chunk = the whole trailing slab
      std::vector<hsize_t> chunk = dims;
      chunk[0] = 1;
      H5Pset_chunk(plist.get(), int(chunk.size()), chunk.data());
      H5Pset_shuffle(plist.get());
      H5Pset_deflate(plist.get(), 4);
    }
    Handle ds(H5Dcreate2(parent, name.c_str(), file_type, space.get(), H5P_DEFAULT, plist.get(), H5P_DEFAULT), H5Dclose);
    if (!ds.valid()) fail("dataset " + name);
    check(H5Dwrite(ds.get(), mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), "dataset " + name);
    string_attribute(ds.get(), "units", units);
    if (!description.empty()) string_attribute(ds.get(), "description", description);
  }
  void doubles(hid_t parent, const std::string& name, const std::vector<hsize_t>& dims, const std::vector<double>& v,
               const std::string& units, const std::string& description) const {
    dataset(parent, name, dims, v.data(), H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, units, description);
  }
  void bytes(hid_t parent, const std::string& name, const std::vector<hsize_t>& dims, const std::vector<std::uint8_t>& v,
             const std::string& units, const std::string& description) const {
    dataset(parent, name, dims, v.data(), H5T_STD_U8LE, H5T_NATIVE_UINT8, units, description);
  }
  void strings(hid_t parent, const std::string& name, const std::vector<std::string>& v, const std::string& description) const {
    std::size_t width = 1;
    for (const auto& s : v) width = std::max(width, s.size() + 1);
    std::vector<char> buffer(width * v.size(), '\0');
    for (std::size_t i = 0; i < v.size(); ++i) std::copy(v[i].begin(), v[i].end(), buffer.begin() + long(i * width));
    Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(type.get(), width);
    H5Tset_strpad(type.get(), H5T_STR_NULLTERM);
    const std::vector<hsize_t> dims{hsize_t(v.size())};
    dataset(parent, name, dims, buffer.data(), type.get(), type.get(), "1", description);
  }
};

// --- reading
struct Reader {
  std::string path;
  hid_t file = -1;

  [[noreturn]] void fail(const std::string& what) const { throw InputError(path + ": " + what); }

  bool exists(const std::string& name) const {
    // Check each path component so that a missing group does not raise an HDF5 error.
    std::size_t pos = 1;
    while (true) {
      const std::size_t next = name.find('/', pos);
      const std::string prefix = name.substr(0, next);
      if (H5Lexists(file, prefix.c_str(), H5P_DEFAULT) <= 0) return false;
      if (next == std::string::npos) return true;
      pos = next + 1;
    }
  }
  std::string read_string_attribute(hid_t obj, const std::string& name, const std::string& where) const {
    if (H5Aexists(obj, name.c_str()) <= 0) fail("attribute " + where + name + " is missing" + regenerate);
    Handle attr(H5Aopen(obj, name.c_str(), H5P_DEFAULT), H5Aclose);
    Handle type(H5Aget_type(attr.get()), H5Tclose);
    if (H5Tget_class(type.get()) != H5T_STRING) fail("attribute " + where + name + " must be a string" + regenerate);
    if (H5Tis_variable_str(type.get()) > 0) {
      Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
      H5Tset_size(mem.get(), H5T_VARIABLE);
      char* text = nullptr;
      if (H5Aread(attr.get(), mem.get(), &text) < 0) fail("cannot read attribute " + where + name);
      std::string out = text != nullptr ? text : "";
      H5free_memory(text);
      return out;
    }
    const std::size_t size = H5Tget_size(type.get());
    std::vector<char> buffer(size + 1, '\0');
    if (H5Aread(attr.get(), type.get(), buffer.data()) < 0) fail("cannot read attribute " + where + name);
    return std::string(buffer.data(), strnlen(buffer.data(), size));
  }
  double read_number_attribute(hid_t obj, const std::string& name, const std::string& where) const {
    if (H5Aexists(obj, name.c_str()) <= 0) fail("attribute " + where + name + " is missing" + regenerate);
    Handle attr(H5Aopen(obj, name.c_str(), H5P_DEFAULT), H5Aclose);
    Handle type(H5Aget_type(attr.get()), H5Tclose);
    const auto cls = H5Tget_class(type.get());
    Handle space(H5Aget_space(attr.get()), H5Sclose);
    if ((cls != H5T_FLOAT && cls != H5T_INTEGER) || H5Sget_simple_extent_npoints(space.get()) != 1) {
      fail("attribute " + where + name + " must be a single number" + regenerate);
    }
    double v = 0;
    if (H5Aread(attr.get(), H5T_NATIVE_DOUBLE, &v) < 0) fail("cannot read attribute " + where + name);
    return v;
  }
  /// Opens a dataset, checks its class, rank, shape and units.
  Handle open(const std::string& name, H5T_class_t cls, const std::vector<hsize_t>& want, const std::string& dims_text,
              const std::string& units) const {
    if (!exists(name)) fail("dataset " + name + " is missing" + regenerate);
    Handle ds(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
    if (!ds.valid()) fail("cannot open dataset " + name + regenerate);
    Handle type(H5Dget_type(ds.get()), H5Tclose);
    if (H5Tget_class(type.get()) != cls) {
      const char* cls_name = cls == H5T_FLOAT ? "floating point" : cls == H5T_INTEGER ? "integer" : "string";
      fail("dataset " + name + " must hold " + cls_name + " values" + regenerate);
    }
    Handle space(H5Dget_space(ds.get()), H5Sclose);
    const int rank = H5Sget_simple_extent_ndims(space.get());
    std::vector<hsize_t> dims(std::max(rank, 0));
    H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
    bool ok = rank == int(want.size());
    for (std::size_t i = 0; ok && i < want.size(); ++i) ok = want[i] == 0 || dims[i] == want[i];
    if (!ok) {
      std::string got = "[";
      for (std::size_t i = 0; i < dims.size(); ++i) got += (i ? "," : "") + std::to_string(dims[i]);
      got += "]";
      std::string need = "[";
      for (std::size_t i = 0; i < want.size(); ++i) need += (i ? "," : "") + (want[i] ? std::to_string(want[i]) : "n");
      need += "]";
      fail("dataset " + name + " has shape " + got + " but " + dims_text + " = " + need + " is required" + regenerate);
    }
    const std::string u = read_string_attribute(ds.get(), "units", name + ":");
    if (u != units) fail("dataset " + name + " has units '" + u + "' but '" + units + "' is required" + regenerate);
    return ds;
  }
  std::size_t length(const std::string& name) const {
    if (!exists(name)) fail("dataset " + name + " is missing" + regenerate);
    Handle ds(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
    Handle space(H5Dget_space(ds.get()), H5Sclose);
    if (H5Sget_simple_extent_ndims(space.get()) < 1) fail("dataset " + name + " must be an array" + regenerate);
    hsize_t dims[8] = {0};
    if (H5Sget_simple_extent_ndims(space.get()) > 8) fail("dataset " + name + " has too many dimensions" + regenerate);
    H5Sget_simple_extent_dims(space.get(), dims, nullptr);
    return std::size_t(dims[0]);
  }
  std::vector<double> doubles(const std::string& name, const std::vector<hsize_t>& dims, const std::string& dims_text,
                              const std::string& units) const {
    Handle ds = open(name, H5T_FLOAT, dims, dims_text, units);
    hsize_t total = 1;
    for (auto d : dims) total *= d;
    std::vector<double> v(total);
    if (total > 0 && H5Dread(ds.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0) {
      fail("cannot read dataset " + name + regenerate);
    }
    return v;
  }
  std::vector<std::uint8_t> bytes(const std::string& name, const std::vector<hsize_t>& dims, const std::string& dims_text,
                                  const std::string& units) const {
    Handle ds = open(name, H5T_INTEGER, dims, dims_text, units);
    hsize_t total = 1;
    for (auto d : dims) total *= d;
    // Read as int to catch values outside 0..255 written with a wider type.
    std::vector<int> wide(total);
    if (total > 0 && H5Dread(ds.get(), H5T_NATIVE_INT, H5S_ALL, H5S_ALL, H5P_DEFAULT, wide.data()) < 0) {
      fail("cannot read dataset " + name + regenerate);
    }
    std::vector<std::uint8_t> v(total);
    for (std::size_t i = 0; i < total; ++i) {
      if (wide[i] < 0 || wide[i] > 255) fail("dataset " + name + "[" + std::to_string(i) + "] = " + std::to_string(wide[i]) + " is out of range" + regenerate);
      v[i] = std::uint8_t(wide[i]);
    }
    return v;
  }
  std::vector<std::string> strings(const std::string& name, std::size_t n) const {
    Handle ds = open(name, H5T_STRING, {hsize_t(n)}, "[ne]", "1");
    Handle type(H5Dget_type(ds.get()), H5Tclose);
    std::vector<std::string> out(n);
    if (H5Tis_variable_str(type.get()) > 0) {
      Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
      H5Tset_size(mem.get(), H5T_VARIABLE);
      std::vector<char*> ptrs(n, nullptr);
      if (H5Dread(ds.get(), mem.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()) < 0) fail("cannot read dataset " + name);
      for (std::size_t i = 0; i < n; ++i) {
        out[i] = ptrs[i] != nullptr ? ptrs[i] : "";
        H5free_memory(ptrs[i]);
      }
      return out;
    }
    const std::size_t width = H5Tget_size(type.get());
    std::vector<char> buffer(width * n + 1, '\0');
    if (H5Dread(ds.get(), type.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer.data()) < 0) fail("cannot read dataset " + name);
    for (std::size_t i = 0; i < n; ++i) {
      const char* s = buffer.data() + i * width;
      out[i] = std::string(s, strnlen(s, width));
    }
    return out;
  }
};

}  // namespace

void write_map(const std::string& path, const ChargeMap& map) {
  validate(map, path + " (map to be written)");
  silence_hdf5();
  write_path_atomically(path, [&](const std::string& tmp) {
    Writer w{path};
    Handle file(H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
    if (!file.valid()) throw InputError(path + ": cannot create the HDF5 file; check the folder and its permissions");
    const hid_t root = file.get();
    w.string_attribute(root, "format", map_format_name);
    w.int_attribute(root, "format_version", map_format_version);
    w.string_attribute(root, "pvdfkit_version", map.pvdfkit_version.empty() ? pvdf::version_string : map.pvdfkit_version);
    w.string_attribute(root, "scene_json", map.scene_json);
    w.string_attribute(root, "model", map.model);
    w.number_attribute(root, "tolerance", map.tolerance);
    for (const auto& [name, member] : optional_number_attributes) {
      if (!std::isnan(map.*member)) w.number_attribute(root, name, map.*member);
    }
    w.number_attribute(root, "rim_margin_m", map.rim_margin_m);
    w.string_attribute(root, "description", map.description);
    w.string_attribute(root, "layout",
                       "charge_C[force][y][x][electrode]; deflection_at_load_m and status [force][y][x]; "
                       "grid/mask[y][x]; see docs/mapping.md");

    const hsize_t nx = map.nx(), ny = map.ny(), nf = map.nf(), ne = map.ne();
    {
      Handle grid = w.group(root, "grid");
      w.doubles(grid.get(), "x_m", {nx}, map.x_m, "m", "probe x positions (regular axis)");
      w.doubles(grid.get(), "y_m", {ny}, map.y_m, "m", "probe y positions (regular axis)");
      w.bytes(grid.get(), "mask", {ny, nx}, map.mask, "1", "1 = inside the film minus the rim margin, 0 = not mapped");
    }
    w.doubles(root, "forces_N", {nf}, map.forces_N, "N", "probe force levels (ascending)");
    {
      Handle el = w.group(root, "electrodes");
      w.strings(el.get(), "names", map.electrode_names, "electrode names, in the order of the last axis of charge_C");
      std::vector<double> centers;
      for (const auto& c : map.electrode_centers_m) centers.insert(centers.end(), {c[0], c[1]});
      w.doubles(el.get(), "center_m", {ne, 2}, centers, "m", "electrode centroid [x, y]");
      w.doubles(el.get(), "noise_C", {ne}, map.noise_C, "C", "default 1-sigma charge noise of each channel");
    }
    w.doubles(root, "charge_C", {nf, ny, nx, ne}, map.charge_C, "C", "electrode charge [force][y][x][electrode]");
    w.doubles(root, "deflection_at_load_m", {nf, ny, nx}, map.deflection_at_load_m, "m",
              "film deflection under the probe [force][y][x]");
    w.bytes(root, "status", {nf, ny, nx}, map.status, "1",
            "0 ok, 1 not_converged, 2 outside, 3 not_computed [force][y][x]");
    if (!map.dcharge_dx_C_per_m.empty()) {
      Handle d = w.group(root, "derivatives");
      w.doubles(d.get(), "dcharge_dx_C_per_m", {nf, ny, nx, ne}, map.dcharge_dx_C_per_m, "C/m", "dQ/dx of the probe position");
      w.doubles(d.get(), "dcharge_dy_C_per_m", {nf, ny, nx, ne}, map.dcharge_dy_C_per_m, "C/m", "dQ/dy of the probe position");
    }
    if (!map.estimated_charge_error_C.empty()) {
      w.doubles(root, "estimated_charge_error_C", {nf, ny, nx, ne}, map.estimated_charge_error_C, "C",
                "estimated absolute error of each charge (discretization + model) [force][y][x][electrode]");
    }
    if (map.calibration) {
      Handle c = w.group(root, "calibration");
      w.doubles(c.get(), "gain", {ne}, map.calibration->gain, "1", "q_measured = gain * q_map + offset");
      w.doubles(c.get(), "offset_C", {ne}, map.calibration->offset_C, "C", "q_measured = gain * q_map + offset");
      w.string_attribute(c.get(), "source", map.calibration->source);
      w.string_attribute(c.get(), "report_json", map.calibration->report_json);
    }
    if (H5Fflush(root, H5F_SCOPE_GLOBAL) < 0) w.fail("the file (flush)");
  });
}

ChargeMap read_map(const std::string& path) {
  silence_hdf5();
  if (H5Fis_hdf5(path.c_str()) <= 0) {
    throw InputError(path + ": not an HDF5 file (or missing); give a map written by `pvdfkit map` or `pvdfkit calibrate`");
  }
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.valid()) throw InputError(path + ": cannot open the HDF5 file; check it and its permissions");
  Reader r{path, file.get()};
  const hid_t root = file.get();
  const std::string format = r.read_string_attribute(root, "format", "/:");
  if (format != map_format_name) {
    r.fail("attribute /:format = '" + format + "' but '" + map_format_name + "' is required (is this a charge map?)");
  }
  const double version = r.read_number_attribute(root, "format_version", "/:");
  if (version != 1 && version != map_format_version) {
    r.fail("attribute /:format_version = " + num(version) + " is not supported (this pvdfkit reads versions 1 to " +
           std::to_string(map_format_version) + "); use a matching pvdfkit");
  }
  ChargeMap m;
  m.pvdfkit_version = r.read_string_attribute(root, "pvdfkit_version", "/:");
  m.scene_json = r.read_string_attribute(root, "scene_json", "/:");
  m.model = r.read_string_attribute(root, "model", "/:");
  m.tolerance = r.read_number_attribute(root, "tolerance", "/:");
  for (const auto& [name, member] : optional_number_attributes) {
    if (H5Aexists(root, name) > 0) m.*member = r.read_number_attribute(root, name, "/:");
  }
  m.rim_margin_m = r.read_number_attribute(root, "rim_margin_m", "/:");
  if (H5Aexists(root, "description") > 0) m.description = r.read_string_attribute(root, "description", "/:");

  const std::size_t nx = r.length("/grid/x_m"), ny = r.length("/grid/y_m"), nf = r.length("/forces_N");
  const std::size_t ne = r.length("/electrodes/names");
  const hsize_t hx = nx, hy = ny, hf = nf, he = ne;
  m.x_m = r.doubles("/grid/x_m", {hx}, "[nx]", "m");
  m.y_m = r.doubles("/grid/y_m", {hy}, "[ny]", "m");
  m.mask = r.bytes("/grid/mask", {hy, hx}, "[ny][nx]", "1");
  m.forces_N = r.doubles("/forces_N", {hf}, "[nf]", "N");
  m.electrode_names = r.strings("/electrodes/names", ne);
  const auto centers = r.doubles("/electrodes/center_m", {he, 2}, "[ne][2]", "m");
  for (std::size_t k = 0; k < ne; ++k) m.electrode_centers_m.push_back({centers[2 * k], centers[2 * k + 1]});
  m.noise_C = r.doubles("/electrodes/noise_C", {he}, "[ne]", "C");
  m.charge_C = r.doubles("/charge_C", {hf, hy, hx, he}, "[nf][ny][nx][ne]", "C");
  m.deflection_at_load_m = r.doubles("/deflection_at_load_m", {hf, hy, hx}, "[nf][ny][nx]", "m");
  m.status = r.bytes("/status", {hf, hy, hx}, "[nf][ny][nx]", "1");
  if (r.exists("/derivatives")) {
    m.dcharge_dx_C_per_m = r.doubles("/derivatives/dcharge_dx_C_per_m", {hf, hy, hx, he}, "[nf][ny][nx][ne]", "C/m");
    m.dcharge_dy_C_per_m = r.doubles("/derivatives/dcharge_dy_C_per_m", {hf, hy, hx, he}, "[nf][ny][nx][ne]", "C/m");
  }
  if (version >= 2 && r.exists("/estimated_charge_error_C")) {
    m.estimated_charge_error_C = r.doubles("/estimated_charge_error_C", {hf, hy, hx, he}, "[nf][ny][nx][ne]", "C");
  }
  if (r.exists("/calibration")) {
    Calibration c;
    c.gain = r.doubles("/calibration/gain", {he}, "[ne]", "1");
    c.offset_C = r.doubles("/calibration/offset_C", {he}, "[ne]", "C");
    Handle g(H5Gopen2(root, "/calibration", H5P_DEFAULT), H5Gclose);
    c.source = r.read_string_attribute(g.get(), "source", "/calibration:");
    c.report_json = r.read_string_attribute(g.get(), "report_json", "/calibration:");
    m.calibration = std::move(c);
  }
  validate(m, path);
  return m;
}

}  // namespace pvdf::mapping
