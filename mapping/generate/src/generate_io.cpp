// The map file's `/provenance` (solved / scaled / mirrored / tolerance not met per point) and
// `/model` (which model solved it) datasets, added beside the datasets that write_map writes;
// readers that do not know them ignore them.
#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/mapping/generate.hpp"
#include "pvdf/mapping/map_io.hpp"

#include <hdf5.h>

#include <string>

namespace pvdf::mapping {
namespace {

constexpr const char* provenance_path = "/provenance";
constexpr const char* model_path = "/model";

void put_string_attribute(hid_t obj, const char* name, const std::string& value) {
  const hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, value.size());
  H5Tset_strpad(type, H5T_STR_NULLPAD);
  H5Tset_cset(type, H5T_CSET_UTF8);
  const hid_t space = H5Screate(H5S_SCALAR);
  const hid_t attr = H5Acreate2(obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
  const herr_t status = attr < 0 ? -1 : H5Awrite(attr, type, value.data());
  if (attr >= 0) H5Aclose(attr);
  H5Sclose(space);
  H5Tclose(type);
  if (status < 0) throw InputError(std::string("cannot write attribute ") + name);
}

// One uint8 [nf][ny][nx] dataset with units and description attributes.
void put_bytes(hid_t file, const char* path, const ChargeMap& map, const std::vector<std::uint8_t>& values,
               const std::string& description) {
  const hsize_t dims[3] = {map.nf(), map.ny(), map.nx()};
  const hid_t space = H5Screate_simple(3, dims, nullptr);
  const hid_t plist = H5Pcreate(H5P_DATASET_CREATE);
  const hsize_t chunk[3] = {1, map.ny(), map.nx()};
  if (values.size() > 4096) {
    H5Pset_chunk(plist, 3, chunk);
    H5Pset_shuffle(plist);
    H5Pset_deflate(plist, 4);
  }
  const hid_t ds = H5Dcreate2(file, path, H5T_STD_U8LE, space, H5P_DEFAULT, plist, H5P_DEFAULT);
  herr_t status = ds < 0 ? -1 : H5Dwrite(ds, H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data());
  if (status >= 0) {
    try {
      put_string_attribute(ds, "units", "1");
      put_string_attribute(ds, "description", description);
    } catch (...) {
      status = -1;
    }
  }
  if (ds >= 0) H5Dclose(ds);
  H5Pclose(plist);
  H5Sclose(space);
  if (status < 0) throw InputError(std::string("cannot write ") + path);
}

}  // namespace

void write_generated_map(const std::string& path, const ChargeMap& map, const std::vector<std::uint8_t>& provenance,
                         const std::vector<std::uint8_t>& node_model) {
  const std::size_t n_points = map.nf() * map.ny() * map.nx();
  for (const auto* v : {&provenance, &node_model}) {
    if (!v->empty() && v->size() != n_points) {
      throw InputError(path + ": " + (v == &provenance ? "provenance" : "model") + " has " + std::to_string(v->size()) +
                       " values, the map " + std::to_string(n_points) + " points (nf*ny*nx)");
    }
  }
  write_path_atomically(path, [&](const std::string& tmp) {
    write_map(tmp, map);
    if (provenance.empty() && node_model.empty()) return;
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    const hid_t file = H5Fopen(tmp.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
    if (file < 0) throw InputError(tmp + ": cannot reopen the map to add " + provenance_path);
    try {
      if (!provenance.empty()) {
        put_bytes(file, provenance_path, map, provenance,
                  "per point [nf][ny][nx]: bit flags, 0 = solved by the FEM, 1 = scaled from the largest force "
                  "level (Q ~ F^(2/3), w ~ F^(1/3)), 2 = copied from the mirror-image position, 4 = tolerance_not_met "
                  "(estimated charge error above the tolerance), 8 = interpolated (adaptive placement: not solved, "
                  "filled from the coarser level's interpolant; its stored error is the total error there)");
      }
      if (!node_model.empty()) {
        put_bytes(file, model_path, map, node_model,
                  "per point [nf][ny][nx]: model that solved it, 0 = the root attribute model as the sweep chose it "
                  "(bending dropped when its estimate allowed), 1 = the same kinematics with bending on a mesh graded "
                  "toward the clamped rim, 2 = a direct adaptive solve at this press alone (its own goal-oriented mesh; "
                  "with the model auto as `pvdfkit solve`: bending and the clamp layer by estimate; else bending kept) where the "
                  "sweep's estimate exceeded the tolerance, 3 = the model of 0 with the clamp's "
                  "bending layer as a boundary condition (docs/fem.md 3.4) on the probe's own mesh");
      }
    } catch (...) {
      H5Fclose(file);
      throw;
    }
    if (H5Fclose(file) < 0) throw InputError(tmp + ": cannot write " + std::string(provenance_path));
  });
}

std::vector<std::uint8_t> read_provenance(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (file < 0) throw InputError(path + ": cannot open as HDF5; check the path");
  std::vector<std::uint8_t> out;
  std::string error;
  if (H5Lexists(file, provenance_path, H5P_DEFAULT) > 0) {
    const hid_t ds = H5Dopen2(file, provenance_path, H5P_DEFAULT);
    const hid_t space = ds < 0 ? -1 : H5Dget_space(ds);
    const hssize_t count = space < 0 ? -1 : H5Sget_simple_extent_npoints(space);
    if (count < 0) {
      error = path + ": dataset " + provenance_path + " is unreadable; regenerate the map";
    } else {
      out.resize(std::size_t(count));
      if (count > 0 && H5Dread(ds, H5T_NATIVE_UINT8, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0) {
        error = path + ": dataset " + provenance_path + " is unreadable; regenerate the map";
      }
    }
    if (space >= 0) H5Sclose(space);
    if (ds >= 0) H5Dclose(ds);
  }
  H5Fclose(file);
  if (!error.empty()) throw InputError(error);
  return out;
}

}  // namespace pvdf::mapping
