// `pvdfkit synthetic-map` (hidden): writes a charge map sampled from the analytic stand-in
// model (pvdf::mapping::SyntheticModel) — for tests and examples that must not wait for FEM.
#include "command.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/map_io.hpp"
#include "pvdf/mapping/synthetic.hpp"

#include <cstdio>
#include <memory>

namespace {

struct SyntheticMapOptions {
  std::string output;
  double spacing_m = 1e-3;
  double rim_margin_m = 3e-3;
  std::string forces = "1";
  double noise_C = 0.05e-12;
};

int run_synthetic_map(const SyntheticMapOptions& o) {
  const std::vector<double> forces = pvdf::app::parse_force_levels(o.forces, "--forces-N");
  pvdf::mapping::SyntheticModel model;
  pvdf::mapping::write_map(o.output, pvdf::mapping::build_synthetic_map(model, o.spacing_m, o.rim_margin_m, forces, o.noise_C));
  std::printf("wrote %s (analytic stand-in, not an FEM result)\n", o.output.c_str());
  return pvdf::exit_code::success;
}

}  // namespace

PVDF_COMMAND(990, [](CLI::App& root) {
  auto* sub = root.add_subcommand("synthetic-map", "Write a map of the analytic stand-in model (tests, examples)");
  sub->group("");  // hidden from `pvdfkit --help`
  auto o = std::make_shared<SyntheticMapOptions>();
  sub->add_option("-o,--output", o->output, "Charge map to write (HDF5)")->required()->check(pvdf::app::output_file());
  sub->add_option("--spacing-m", o->spacing_m, "Grid spacing (m) (default 0.001)")->check(pvdf::app::number_in(1e-4, 0.02, "m"));
  sub->add_option("--rim-margin-m", o->rim_margin_m, "No presses closer than this to the rim (m) (default 0.003)")->check(pvdf::app::number_in(0, 1, "m"));
  sub->add_option("--forces-N", o->forces, "Force levels F1,F2,... (N, in [1e-9, 1e4], distinct) (default 1)");
  sub->add_option("--noise-C", o->noise_C, "1-sigma charge noise per electrode (C) (default 5e-14)")->check(pvdf::app::number_in(0, 1e-6, "C", true));
  return pvdf::app::Subcommand{sub, [o] { return run_synthetic_map(*o); }};
});
