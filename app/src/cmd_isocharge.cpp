// `pvdfkit isocharge`: isocharge pictures of a charge map (seed 001 Figs 6 and 8) — one contour
// map per electrode, all electrodes on one figure, VTK image data for ParaView, and for a
// charge triple its three isocharge contours with their intersection.
#include "command.hpp"
#include "map_checks.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/map_io.hpp"
#include "pvdf/mapping/pictures.hpp"

#include <cmath>
#include <filesystem>
#include <cstdio>
#include <iostream>
#include <memory>

namespace {

struct IsochargeOptions {
  std::string map_path;
  std::string out_dir;
  double force_N = 0;
  double zoom_m = 0;
  std::string charges;
  std::string at;
};

int run_isocharge(const IsochargeOptions& o) {
  using namespace pvdf::mapping;
  const ChargeMap map = read_map(o.map_path);
  std::vector<double> q;
  if (!o.charges.empty()) q = pvdf::app::parse_charges(o.charges, map);  // count, and pC typed for C
  if (!o.charges.empty() && !o.at.empty()) throw pvdf::InputError("--charges-C and --at-m: give one charge triple, not both");
  LocatorOptions lo;
  lo.use_calibration = false;  // pictures of the map as computed
  lo.known_force_N = o.force_N;
  const Locator locator(map, lo);
  if (!o.at.empty()) {  // the triple the map itself predicts for a press there
    const auto xy = pvdf::parse_number_list(o.at, "--at-m", 2);
    q.assign(map.ne(), 0.0);
    if (!locator.predict(xy[0], xy[1], o.force_N > 0 ? o.force_N : 1.0, q.data())) {
      throw pvdf::InputError("--at-m " + o.at + ": not inside the map's usable cells; choose a position inside the map");
    }
  }
  // The triple is located before any picture is drawn: charges that place no press leave no
  // half-made folder of pictures behind (exit 3, nothing written).
  Location located;
  if (!q.empty()) {
    located = o.force_N > 0 ? locator.locate(q.data(), o.force_N) : locator.locate(q.data());
    if (!located.has_position()) {
      std::cerr << "error: the charges " << pvdf::quote_cell(o.charges) << " locate no press on this map ("
                << flags_text(located.flags) << "): no pictures written; check the charges (C, map electrode order)\n";
      return pvdf::exit_code::numerical;
    }
  }
  for (const char* name : {"/isocharge_all.png", "/charges.vtk", "/intersection.png"}) {
    // Before any picture is drawn (a folder still to be created holds nothing to protect).
    if (std::filesystem::is_directory(o.out_dir)) pvdf::app::check_output_file(o.out_dir + name, "--out-dir");
  }
  pvdf::make_directories(o.out_dir);
  const double force = picture_force_N(map, o.force_N);  // given, else the level nearest 1 N
  for (std::size_t k = 0; k < map.ne(); ++k) {
    const std::string path = o.out_dir + "/isocharge_" + map.electrode_names[k] + ".png";
    write_isocharge_png(locator, map, k, force, path, o.zoom_m);
    std::printf("wrote %s\n", path.c_str());
  }
  const std::string all = o.out_dir + "/isocharge_all.png";
  write_isocharge_overlay_png(locator, map, force, all, o.zoom_m);
  std::printf("wrote %s\n", all.c_str());
  const std::string vtk = o.out_dir + "/charges.vtk";
  write_charge_vtk(map, vtk);
  std::printf("wrote %s\n", vtk.c_str());
  if (!q.empty()) {
    const Location& r = located;
    const std::string path = o.out_dir + "/intersection.png";
    write_intersection_png(locator, map, q.data(), r, path);
    std::printf("wrote %s: contours meet at (%.3f, %.3f) mm, %.4g N, flags %s\n", path.c_str(), r.x_m * 1e3, r.y_m * 1e3,
                r.force_N, flags_text(r.flags).c_str());
  }
  return pvdf::exit_code::success;
}

}  // namespace

PVDF_COMMAND(62, [](CLI::App& root) {
  auto* sub = root.add_subcommand(
      "isocharge",
      "Isocharge pictures of a charge map: contour PNG per electrode and all together (seed 001 Figs 6, 8), VTK image "
      "data, and a charge triple's contours with their intersection");
  auto o = std::make_shared<IsochargeOptions>();
  sub->add_option("MAP", o->map_path, "Charge map (HDF5 from `pvdfkit map`, `synthetic-map` or `calibrate`)")->required();
  sub->add_option("--out-dir", o->out_dir, "Folder for isocharge_<name>.png, isocharge_all.png, charges.vtk")
      ->required()
      ->check(pvdf::app::output_folder());
  sub->add_option("--force-N", o->force_N, "Force of the press drawn (N) (default the force level nearest 1 N)")
      ->check(pvdf::app::number_in(0, 1e4, "N", true));
  sub->add_option("--zoom-m", o->zoom_m, "Draw only [-W, W] x [-W, W] around the film centre (m), e.g. 0.015 (default the whole map)")
      ->check(pvdf::app::number_in(0, 10, "m (0 = the whole map)"));
  sub->add_option("--charges-C", o->charges,
                  "A charge triple (C, map electrode order): also write intersection.png with its isocharge contours");
  sub->add_option("--at-m", o->at, "X,Y (m): use the charges the map predicts for a press there as the triple");
  return pvdf::app::Subcommand{sub, [o] { return run_isocharge(*o); }};
});
