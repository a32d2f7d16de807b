// Atlas files in HDF5 (C API), docs/atlas.md §2: self-describing (every dataset carries its unit in
// its name, the root its provenance), written to a temporary name and renamed, read back with the
// dataset at fault named.
#include "pvdf/mapping/atlas.hpp"

#include "pvdf/core/error.hpp"

#include <hdf5.h>

#include <cstdio>
#include <filesystem>
#include <sstream>

namespace pvdf::mapping {

namespace {

constexpr const char* format_name = "pvdfkit-charge-density-atlas";
constexpr int format_version = 2;  // 2 (r15): keep_out_m; version 1 files are read as keep_out_m = 0

class Handle {
 public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

struct Writer {
  hid_t file;
  std::string path;
  void fail(const std::string& what) const {
    throw pvdf::InputError(path + ": cannot write " + what + " (HDF5 error); check free space and permissions");
  }
  void string_attribute(hid_t obj, const std::string& name, const std::string& value) const {
    Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(type.get(), std::max<std::size_t>(1, value.size()));
    H5Tset_cset(type.get(), H5T_CSET_UTF8);
    Handle space(H5Screate(H5S_SCALAR), H5Sclose);
    Handle attr(H5Acreate2(obj, name.c_str(), type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    const std::string padded = value.empty() ? std::string(1, '\0') : value;
    if (!attr.valid() || H5Awrite(attr.get(), type.get(), padded.data()) < 0) fail("attribute " + name);
  }
  void number_attribute(hid_t obj, const std::string& name, double value) const {
    Handle space(H5Screate(H5S_SCALAR), H5Sclose);
    Handle attr(H5Acreate2(obj, name.c_str(), H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    if (!attr.valid() || H5Awrite(attr.get(), H5T_NATIVE_DOUBLE, &value) < 0) fail("attribute " + name);
  }
  template <class T>
  void dataset(const std::string& name, const std::vector<T>& data, const std::vector<hsize_t>& dims, hid_t file_type,
               hid_t memory_type, const std::string& unit_note = "") const {
    hsize_t n = 1;
    for (hsize_t d : dims) n *= d;
    if (n != data.size()) fail(name + " (shape does not match its data: internal error)");
    Handle space(H5Screate_simple(int(dims.size()), dims.data(), nullptr), H5Sclose);
    Handle set(H5Dcreate2(file, name.c_str(), file_type, space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
    if (!set.valid() || (n > 0 && H5Dwrite(set.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data.data()) < 0)) fail(name);
    if (!unit_note.empty()) string_attribute(set.get(), "description", unit_note);
  }
  void doubles(const std::string& name, const std::vector<double>& d, const std::vector<hsize_t>& dims, const std::string& note) const {
    dataset(name, d, dims, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, note);
  }
  void bytes(const std::string& name, const std::vector<std::uint8_t>& d, const std::vector<hsize_t>& dims, const std::string& note) const {
    dataset(name, d, dims, H5T_STD_U8LE, H5T_NATIVE_UINT8, note);
  }
};

struct Reader {
  hid_t file;
  std::string path;
  [[noreturn]] void fail(const std::string& what) const {
    throw pvdf::InputError(path + ": " + what + "; write the atlas again with `pvdfkit atlas`");
  }
  std::string string_attribute(hid_t obj, const std::string& name) const {
    if (H5Aexists(obj, name.c_str()) <= 0) fail("attribute " + name + " is missing (not a pvdfkit atlas?)");
    Handle attr(H5Aopen(obj, name.c_str(), H5P_DEFAULT), H5Aclose);
    Handle type(H5Aget_type(attr.get()), H5Tclose);
    if (H5Tget_class(type.get()) != H5T_STRING) fail("attribute " + name + " is not a string");
    const std::size_t size = H5Tget_size(type.get());
    std::string value(size, '\0');
    if (H5Tis_variable_str(type.get()) > 0) fail("attribute " + name + " is a variable-length string");
    if (H5Aread(attr.get(), type.get(), value.data()) < 0) fail("attribute " + name + " cannot be read");
    while (!value.empty() && value.back() == '\0') value.pop_back();
    return value;
  }
  double number_attribute(hid_t obj, const std::string& name) const {
    if (H5Aexists(obj, name.c_str()) <= 0) fail("attribute " + name + " is missing");
    Handle attr(H5Aopen(obj, name.c_str(), H5P_DEFAULT), H5Aclose);
    double v = 0;
    if (H5Aread(attr.get(), H5T_NATIVE_DOUBLE, &v) < 0) fail("attribute " + name + " cannot be read as a number");
    return v;
  }
  template <class T>
  std::vector<T> dataset(const std::string& name, std::size_t expected, hid_t memory_type) const {
    if (H5Lexists(file, name.c_str(), H5P_DEFAULT) <= 0) fail("dataset " + name + " is missing");
    Handle set(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
    Handle space(H5Dget_space(set.get()), H5Sclose);
    const hssize_t n = H5Sget_simple_extent_npoints(space.get());
    if (n < 0 || std::size_t(n) != expected) {
      fail("dataset " + name + " holds " + std::to_string(n) + " values, expected " + std::to_string(expected));
    }
    std::vector<T> out(expected);
    if (expected > 0 && H5Dread(set.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0) fail("dataset " + name + " cannot be read");
    return out;
  }
  std::vector<double> doubles(const std::string& name, std::size_t n) const { return dataset<double>(name, n, H5T_NATIVE_DOUBLE); }
  std::vector<std::uint8_t> bytes(const std::string& name, std::size_t n) const { return dataset<std::uint8_t>(name, n, H5T_NATIVE_UINT8); }
  std::size_t length(const std::string& name) const {
    if (H5Lexists(file, name.c_str(), H5P_DEFAULT) <= 0) fail("dataset " + name + " is missing");
    Handle set(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose);
    Handle space(H5Dget_space(set.get()), H5Sclose);
    return std::size_t(H5Sget_simple_extent_npoints(space.get()));
  }
};

}  // namespace

void write_atlas(const std::string& path, const ChargeAtlas& a) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const std::string temporary = path + ".tmp-atlas";
  {
    Handle file(H5Fcreate(temporary.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose);
    if (!file.valid()) throw pvdf::InputError(path + ": cannot create " + temporary + "; check the folder is writable");
    const Writer w{file.get(), path};
    const hid_t root = file.get();
    w.string_attribute(root, "format", format_name);
    w.number_attribute(root, "format_version", format_version);
    w.string_attribute(root, "pvdfkit_version", a.pvdfkit_version);
    w.string_attribute(root, "scene_json", a.scene_json);
    w.string_attribute(root, "model", a.model);
    w.string_attribute(root, "model_reason", a.model_reason);
    w.string_attribute(root, "error_estimator", a.error_estimator);
    w.string_attribute(root, "integration_error_rule", a.integration_error_rule);
    w.string_attribute(root, "description", a.description);
    w.number_attribute(root, "tolerance", a.tolerance);
    w.number_attribute(root, "rim_margin_m", a.rim_margin_m);
    w.number_attribute(root, "spacing_m", a.spacing_m);
    w.number_attribute(root, "fe_size_m", a.fe_size_m);
    w.number_attribute(root, "keep_out_m", a.keep_out_m);
    w.number_attribute(root, "n_dofs", double(a.n_dofs));
    if (!a.checkpoint_key.empty()) w.string_attribute(root, "checkpoint_key", a.checkpoint_key);
    {
      Handle g(H5Gcreate2(root, "provenance", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
      if (!g.valid()) w.fail("group /provenance");
      w.string_attribute(g.get(), "film", a.film_json);
      w.string_attribute(g.get(), "material", a.material_json);
      w.string_attribute(g.get(), "probe", a.probe_json);
      w.number_attribute(g.get(), "thickness_m", a.thickness_m);
    }
    {
      Handle g(H5Gcreate2(root, "cells", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose);
      if (!g.valid()) w.fail("group /cells");
      w.number_attribute(g.get(), "x0_m", a.grid.x0_m);
      w.number_attribute(g.get(), "y0_m", a.grid.y0_m);
      w.number_attribute(g.get(), "cell_m", a.grid.cell_m);
      w.number_attribute(g.get(), "nx", double(a.grid.nx));
      w.number_attribute(g.get(), "ny", double(a.grid.ny));
    }
    const hsize_t nx = a.nx(), ny = a.ny(), nf = a.nf(), nr = a.nr(), cx = a.grid.nx, cy = a.grid.ny;
    w.doubles("x_m", a.x_m, {nx}, "probe grid x (m)");
    w.doubles("y_m", a.y_m, {ny}, "probe grid y (m)");
    w.bytes("mask", a.mask, {ny, nx}, "[ny][nx] 1 = probe position served");
    w.doubles("forces_N", a.forces_N, {nf}, "force levels (N), ascending");
    w.doubles("cells/geometry", a.geometry, {cy, cx, 6},
              "[ncy][ncx][6] over cell and film: int dA (m2), int dx, int dy (m3), int dx2, int dx dy, int dy2 (m4); dx = x - xc");
    w.bytes("status", a.status, {nf, ny, nx}, "[nf][ny][nx] 0 ok, 1 not_converged, 2 outside, 3 not_computed");
    w.doubles("moments_C", a.moments, {nf, ny, nx, cy, cx, 3},
              "[nf][ny][nx][ncy][ncx][3]: int q dA (C), int q dx dA (C m), int q dy dA (C m); q = d31 N11/h + d32 N22/h");
    w.doubles("deflection_at_load_m", a.deflection_at_load_m, {nf, ny, nx}, "w at the probe centre (m)");
    w.doubles("estimated_relative_error", a.estimated_relative_error, {nf, ny, nx},
              "per press: max_k charge error / max_k |charge| of the reference electrodes");
    std::string names;
    for (const auto& n : a.reference_names) names += (names.empty() ? "" : ",") + n;
    w.string_attribute(root, "reference_electrodes", names);
    w.doubles("reference_charge_C", a.reference_charge_C, {nf, ny, nx, nr}, "charges of the reference electrodes (C)");
    w.doubles("reference_charge_error_C", a.reference_charge_error_C, {nf, ny, nx, nr},
              "estimated |error| of the reference charges (C)");
  }
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) {
    std::filesystem::remove(temporary, ec);
    throw pvdf::InputError(path + ": cannot rename the finished atlas into place; check the folder is writable");
  }
}

ChargeAtlas read_atlas(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  if (!std::filesystem::is_regular_file(path)) throw pvdf::InputError(path + ": no such atlas file; make it with `pvdfkit atlas SCENE -o " + path + "`");
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.valid()) throw pvdf::InputError(path + ": not an HDF5 file; give an atlas written by `pvdfkit atlas`");
  const Reader r{file.get(), path};
  const hid_t root = file.get();
  ChargeAtlas a;
  if (r.string_attribute(root, "format") != format_name) r.fail("attribute format is not " + std::string(format_name) + " (a map, not an atlas?)");
  const double version = r.number_attribute(root, "format_version");
  if (version != format_version && version != 1) r.fail("format_version is not 1 or " + std::to_string(format_version));
  a.pvdfkit_version = r.string_attribute(root, "pvdfkit_version");
  a.scene_json = r.string_attribute(root, "scene_json");
  a.model = r.string_attribute(root, "model");
  a.model_reason = r.string_attribute(root, "model_reason");
  a.error_estimator = r.string_attribute(root, "error_estimator");
  a.integration_error_rule = r.string_attribute(root, "integration_error_rule");
  a.description = r.string_attribute(root, "description");
  a.tolerance = r.number_attribute(root, "tolerance");
  a.rim_margin_m = r.number_attribute(root, "rim_margin_m");
  a.spacing_m = r.number_attribute(root, "spacing_m");
  a.fe_size_m = r.number_attribute(root, "fe_size_m");
  a.keep_out_m = version == 1 ? 0.0 : r.number_attribute(root, "keep_out_m");  // version 1: the whole film served
  if (!(a.keep_out_m >= 0)) r.fail("keep_out_m is not >= 0");
  a.n_dofs = std::size_t(r.number_attribute(root, "n_dofs"));
  if (H5Aexists(root, "checkpoint_key") > 0) a.checkpoint_key = r.string_attribute(root, "checkpoint_key");
  {
    if (H5Lexists(root, "provenance", H5P_DEFAULT) <= 0) r.fail("group /provenance is missing");
    Handle g(H5Gopen2(root, "provenance", H5P_DEFAULT), H5Gclose);
    a.film_json = r.string_attribute(g.get(), "film");
    a.material_json = r.string_attribute(g.get(), "material");
    a.probe_json = r.string_attribute(g.get(), "probe");
    a.thickness_m = r.number_attribute(g.get(), "thickness_m");
  }
  {
    if (H5Lexists(root, "cells", H5P_DEFAULT) <= 0) r.fail("group /cells is missing");
    Handle g(H5Gopen2(root, "cells", H5P_DEFAULT), H5Gclose);
    a.grid.x0_m = r.number_attribute(g.get(), "x0_m");
    a.grid.y0_m = r.number_attribute(g.get(), "y0_m");
    a.grid.cell_m = r.number_attribute(g.get(), "cell_m");
    const double cnx = r.number_attribute(g.get(), "nx"), cny = r.number_attribute(g.get(), "ny");
    if (!(a.grid.cell_m > 0) || !(cnx >= 1 && cny >= 1 && cnx * cny <= 4e6)) r.fail("/cells: cell_m, nx or ny out of range");
    a.grid.nx = std::size_t(cnx);
    a.grid.ny = std::size_t(cny);
  }
  a.x_m = r.doubles("x_m", r.length("x_m"));
  a.y_m = r.doubles("y_m", r.length("y_m"));
  a.forces_N = r.doubles("forces_N", r.length("forces_N"));
  const std::string names = r.string_attribute(root, "reference_electrodes");
  std::stringstream ss(names);
  for (std::string n; std::getline(ss, n, ',');) a.reference_names.push_back(n);
  const std::size_t np = a.nf() * a.ny() * a.nx(), nc = a.n_cells();
  if (double(np) * double(nc) * 3 > 2e9) r.fail("dataset moments_C is too large to hold");
  a.mask = r.bytes("mask", a.nx() * a.ny());
  a.geometry = r.doubles("cells/geometry", nc * 6);
  a.status = r.bytes("status", np);
  a.moments = r.doubles("moments_C", np * nc * 3);
  a.deflection_at_load_m = r.doubles("deflection_at_load_m", np);
  a.estimated_relative_error = r.doubles("estimated_relative_error", np);
  a.reference_charge_C = r.doubles("reference_charge_C", np * a.nr());
  a.reference_charge_error_C = r.doubles("reference_charge_error_C", np * a.nr());
  return a;
}

}  // namespace pvdf::mapping
