// `pvdfkit export-map MAP.h5 -o FILE`: the map as a flat lookup map for deployed programs and
// firmware (docs/lookup.md §8) — a binary file, or a C header holding the same bytes.
#include "command.hpp"

#include "pvdf/core/error.hpp"
#include "pvdf/mapping/flat_map.hpp"
#include "pvdf/mapping/flat_map_file.hpp"
#include "pvdf/mapping/map.hpp"
#include "pvdf/mapping/map_io.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

namespace {

struct ExportMapOptions {
  std::string map_path;
  std::string output;
  std::string format = "auto";
  std::string symbol;
};

int run_export_map(const ExportMapOptions& o) {
  const std::string extension = std::filesystem::path(o.output).extension().string();
  const bool header = o.format == "c-header" || (o.format == "auto" && (extension == ".h" || extension == ".hpp"));
  if (!o.symbol.empty() && !header) throw pvdf::InputError("--symbol " + pvdf::escape_control_bytes(o.symbol) + ": applies to a C header only; add --format c-header or write FILE.h");
  if (!o.symbol.empty() && pvdf::mapping::c_identifier(o.symbol) != o.symbol) {
    throw pvdf::InputError("--symbol " + pvdf::escape_control_bytes(o.symbol) + ": must be a C identifier (letters, digits, '_', not starting with a digit), e.g. " +
                           pvdf::mapping::c_identifier(o.symbol));
  }
  const pvdf::mapping::ChargeMap map = pvdf::mapping::read_map(o.map_path);
  const std::vector<unsigned char> flat = pvdf::mapping::encode_flat_map(map, o.map_path);
  const std::size_t bytes = flat.size();
  // The version written: the oldest that holds the map (2; 3 when its errors are totals).
  const unsigned version = unsigned(flat[8]) | unsigned(flat[9]) << 8 | unsigned(flat[10]) << 16 | unsigned(flat[11]) << 24;
  // What the deployed Locator adds to the charge noise (docs/lookup.md §1.10): the per-node
  // estimates travel in the file; the interpolation error is estimated again from the charges.
  const char* errors = map.estimated_charge_error_C.empty()                 ? "no per-node charge errors"
                       : !map.charge_error_is_total()                    ? "per-node charge errors"
                                                                          : "per-node total charge errors (between nodes and levels included)";
  if (header) {
    const std::string symbol = o.symbol.empty() ? pvdf::mapping::c_identifier(std::filesystem::path(o.output).stem().string()) : o.symbol;
    pvdf::mapping::write_flat_map_c_header(o.output, map, symbol, o.map_path);
    std::printf("wrote %s (C header, array %s of %zu bytes: %zu x %zu points, %zu force levels, %zu electrodes, %s; version %u)\n",
                o.output.c_str(), symbol.c_str(), bytes, map.nx(), map.ny(), map.nf(), map.ne(), errors,
                version);
  } else {
    pvdf::mapping::write_flat_map(o.output, map, o.map_path);
    std::printf("wrote %s (flat map, %zu bytes: %zu x %zu points, %zu force levels, %zu electrodes, %s; version %u)\n",
                o.output.c_str(), bytes, map.nx(), map.ny(), map.nf(), map.ne(), errors, version);
  }
  return pvdf::exit_code::success;
}

}  // namespace

PVDF_COMMAND(63, [](CLI::App& root) {
  auto* sub = root.add_subcommand("export-map",
                                  "Write a map as a flat lookup map for deployed programs and firmware: binary, or a C header (docs/lookup.md)");
  auto o = std::make_shared<ExportMapOptions>();
  sub->add_option("MAP", o->map_path, "Charge map (HDF5 from `pvdfkit map` or `pvdfkit calibrate`)")->required();
  sub->add_option("-o,--output", o->output, "File to write: FILE.h = C header, any other name = binary")
      ->required()
      ->check(pvdf::app::output_file());
  sub->add_option("--format", o->format, "auto (by the -o extension: .h/.hpp = C header), binary or c-header (default auto)")
      ->check(CLI::IsMember({"auto", "binary", "c-header"}));
  sub->add_option("--symbol", o->symbol, "Name of the C array, C header only (default the output file's stem)");
  return pvdf::app::Subcommand{sub, [o] { return run_export_map(*o); }};
});
