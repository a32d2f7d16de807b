// Charge maps in HDF5 (C API): atomic writing, and a reader that names the dataset or attribute
// at fault. Layout: docs/mapping.md §1. The checks of the values (validate) are in map.cpp of the
// lookup runtime.
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/map_attributes.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/mapping/map_io.hpp"
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

namespace {

std::string num(double v) {
  std::ostringstream os;
  os.precision(10);
  os << v;
  return os.str();
}

const std::string regenerate = "; regenerate the map with `pvdfkit map` or repair the file";

}  // namespace

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
