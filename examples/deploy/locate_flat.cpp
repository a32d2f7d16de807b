// Example: a deployed program that locates the presses of a recorded charge stream with the
// installed lookup runtime (find_package(pvdfkit) -> pvdf::lookup) and a flat map.
//
// What it shows: the three steps of a deployment — load the flat map once (written by
// `pvdfkit export-map MAP.h5 -o MAP.flat`; a firmware image would embed the C-header variant and
// call decode_flat_map on its array), build the Locator once, then locate every sample of the
// stream with a tracker (what `pvdfkit locate --stream` does).
//
// Run:     locate_flat MAP.flat < stream.csv > located.csv
//          (CSV in: t_s,charge_<name>_C,... as `pvdfkit locate --stream` reads;
//           CSV out: the same columns as `pvdfkit locate --stream` writes)
// Expect:  the same rows as `pvdfkit locate MAP.h5 --stream < stream.csv`; exit 2 with one
//          `error: ...` line on a bad map or stream.
#include "pvdf/core/error.hpp"
#include "pvdf/mapping/flat_map.hpp"
#include "pvdf/mapping/locator.hpp"
#include "pvdf/mapping/stream.hpp"

#include <cstdio>
#include <iostream>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s MAP.flat < stream.csv > located.csv\n", argv[0]);
    return 2;
  }
  try {
    // 1. The flat map: checked (size, checksum, every value) as it is read. Version 2 carries the
    //    map's per-node charge error estimates (version-1 files are read too, without them).
    const pvdf::mapping::ChargeMap map = pvdf::mapping::read_flat_map(argv[1]);

    // 2. The Locator, built once (interpolant and coarse search table); the map's charge noise,
    //    the force range half the lowest to twice the highest level, and — a stream — linearised
    //    σ's (no valley σ's, which would halve the rate), as `pvdfkit locate --stream`. Its noise
    //    model holds the map's own error — the per-node estimates and the interpolation error
    //    between nodes and force levels, estimated here from the map's charges (docs/lookup.md
    //    §1.10) — so the answers, σ's and probabilities are those of `locate` on the HDF5 map.
    pvdf::mapping::LocatorOptions locator_options;
    locator_options.valley_sigma_cells = 0;
    const pvdf::mapping::Locator locator(map, locator_options);

    // 3. Every row of the stream, tracked from the previous row's solutions.
    pvdf::mapping::StreamOptions options;
    options.source = "<stdin>";
    const pvdf::mapping::StreamSummary s = pvdf::mapping::locate_stream(locator, std::cin, std::cout, std::cerr, options);
    std::fprintf(stderr, "%zu rows, %zu located, %zu flagged, %zu skipped\n", s.rows, s.located, s.flagged, s.skipped);
    return 0;
  } catch (const pvdf::InputError& e) {
    std::fprintf(stderr, "error: %s\n", pvdf::escape_control_bytes(e.what()).c_str());
    return 2;
  }
}
