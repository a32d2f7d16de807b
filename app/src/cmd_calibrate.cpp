// `pvdfkit calibrate`: fuse a computed charge map with measured presses: per-electrode
// gain and offset by least squares, leave-one-out validation, before/after report, and a
// calibrated map that `pvdfkit locate` uses.
#include "command.hpp"
#include "map_checks.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/mapping/calibration.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/map_io.hpp"

#include <cstdio>
#include <iostream>
#include <memory>

namespace {

struct CalibrateOptions {
  std::string map_path;
  std::string measured_path;
  std::string output_path;
  std::string noise;
  bool json = false;
};

int run_calibrate(const CalibrateOptions& o) {
  using namespace pvdf::mapping;
  ChargeMap map = read_map(o.map_path);
  pvdf::check_csv_file(o.measured_path, "MEASURED");
  const auto presses = read_measurements(o.measured_path, map.electrode_names);
  pvdf::app::check_measured_plausible(presses, o.measured_path, map.electrode_names);
  LocatorOptions options;
  if (!o.noise.empty()) options.noise_C = pvdf::parse_number_list(o.noise, "--noise-C");
  const CalibrationReport report = fit_calibration(map, presses, options, o.measured_path);
  map.calibration = report.calibration;
  write_map(o.output_path, map);
  if (o.json) {
    auto j = report.to_json();
    j["output"] = o.output_path;
    j["presses_in_file"] = presses.size();
    std::cout << j.dump(2) << '\n';
    return pvdf::exit_code::success;
  }
  std::printf("calibration of %s from %zu presses in %s (%zu inside the map)\n", o.map_path.c_str(), presses.size(),
              o.measured_path.c_str(), report.n_presses);
  std::printf("%-10s %10s %12s %16s %16s %16s\n", "electrode", "gain", "offset_pC", "rms_before_pC", "rms_after_pC",
              "rms_LOO_pC");
  for (std::size_t k = 0; k < map.ne(); ++k) {
    std::printf("%-10s %10.4f %12.4f %16.4f %16.4f %16.4f\n", map.electrode_names[k].c_str(), report.calibration.gain[k],
                report.calibration.offset_C[k] * 1e12, report.before.rms_charge_C[k] * 1e12,
                report.after_in_sample.rms_charge_C[k] * 1e12, report.after_leave_one_out.rms_charge_C[k] * 1e12);
  }
  std::printf("position error, force known:  median %.4f mm (RMS %.4f mm) before, median %.4f mm (RMS %.4f mm) "
              "after (leave-one-out)\n",
              report.before.median_position_m * 1e3, report.before.rms_position_m * 1e3,
              report.after_leave_one_out.median_position_m * 1e3, report.after_leave_one_out.rms_position_m * 1e3);
  std::printf("force error, force unknown:  median %.3g %% before, median %.3g %% after (leave-one-out)\n",
              report.before.median_force_relative * 100, report.after_leave_one_out.median_force_relative * 100);
  std::printf("calibrated map written to %s\n", o.output_path.c_str());
  return pvdf::exit_code::success;
}

}  // namespace

PVDF_COMMAND(61, [](CLI::App& root) {
  auto* sub = root.add_subcommand("calibrate",
                                  "Fit per-electrode gain and offset of a charge map to measured presses "
                                  "(leave-one-out validated) and write the calibrated map (docs/lookup.md)");
  auto o = std::make_shared<CalibrateOptions>();
  sub->add_option("MAP", o->map_path, "Charge map (HDF5 from `pvdfkit map`, `synthetic-map` or `calibrate`)")->required();
  sub->add_option("MEASURED", o->measured_path,
                  "CSV of presses at known places: x_m,y_m,force_N,charge_<name>_C for every electrode")
      ->required();
  sub->add_option("-o,--output", o->output_path, "Calibrated map to write (the map plus a /calibration group)")
      ->required()
      ->check(pvdf::app::output_file());
  sub->add_option("--noise-C", o->noise, "1-sigma charge noise per electrode used when locating for the report (C) (default the map's)");
  sub->add_flag("--json", o->json, "Print the report as JSON");
  return pvdf::app::Subcommand{sub, [o] {
    try {
      return run_calibrate(*o);
    } catch (const pvdf::InputError& e) {
      std::string what = e.what();  // the locator's option is the flag --noise-C here
      if (what.rfind("locator noise_C", 0) == 0) what.replace(0, 15, "--noise-C");
      throw pvdf::InputError(what);
    }
  }};
});
