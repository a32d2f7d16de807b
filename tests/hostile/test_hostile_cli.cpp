// Hostile input, end to end: each row runs `pvdfkit` on a bad scene, flag or file and asserts the
// project's promise — the documented exit code, exactly one `error:` line that names the input
// (no raw control bytes on stderr), no output file (or temporary) left behind, and a wall-time
// bound. Rows are data; the fixture files are written by hostile_fixtures.cpp.
#include "hostile_fixtures.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;

namespace {

struct Row {
  const char* id;
  /// Arguments after `pvdfkit`; run in the fixture folder. `$M` is a synthetic charge map. A row
  /// that contains `$X` is a whole shell command instead, `$X` standing for the pvdfkit call
  /// (it must send stderr to .err itself).
  const char* args;
  int exit_code;
  /// Text the single `error:` line must contain (the input it names); "" = no error line at all.
  const char* names;
  /// Paths (relative to the folder, comma-separated) that must not exist afterwards.
  const char* absent = "";
  double max_wall_s = 20;
};

// The checkpoint rows: make ck0 once (a map of small_film.json stopped after its first row), then
// resume the same map from a damaged copy.
#define CKPT_ARGS "small_film.json -o ck.h5 --spacing-m 0.002 --region -0.004,0.004,-0.002,0.002 --setup-checks 0 " \
                  "--threads 1 --quiet"
#define CKPT_MAKE "test -s ck0 || $X map " CKPT_ARGS " --checkpoint ck0 --stop-after-positions 4 2>/dev/null; "

// clang-format off
const std::vector<Row> rows = {
  // ---- scene files: syntax, nesting, garbage, duplicates (read by every command)
  {"solve-trunc40k", "solve trunc40k.json", 2, "trunc40k.json:"},
  {"solve-trunc-half", "solve trunc_half.json", 2, "trunc_half.json:"},
  {"solve-deep-array", "solve deep_array.json", 2, "deep_array.json:1:"},
  {"solve-deep-object", "solve deep_object.json", 2, "deep_object.json:1:"},
  {"solve-deep-valid", "solve deep_valid.json", 2, "deep_valid.json:1:"},
  {"solve-garbage", "solve garbage.json", 2, "garbage.json:1:1"},
  {"solve-empty", "solve empty.json", 2, "empty.json"},
  {"solve-nan", "solve nan.json", 2, "thickness_m"},
  {"solve-array", "solve array.json", 2, "array.json"},
  {"solve-huge-number", "solve huge_number.json", 2, "radius_m"},
  {"solve-dup-key", "solve dup_key.json", 2, "membrane.radius_m"},
  {"solve-dup-top", "solve dup_top.json", 2, "model"},
  {"solve-unknown-key", "solve unknown_key.json", 2, "membrane.thicknes_m"},
  {"solve-bad-utf8", "solve bad_utf8.json", 2, "bad_utf8.json"},
  {"solve-missing-file", "solve no_such_scene.json", 2, "no_such_scene.json"},
  {"solve-folder-as-scene", "solve .", 2, "."},
  // ---- scene geometry, refused by the scene reader for every command
  {"solve-e-outside", "solve e_outside.json", 2, "electrodes[0]"},
  {"solve-e-crossing", "solve e_crossing.json", 2, "electrodes[0]"},
  {"solve-e-overlap", "solve e_overlap.json", 2, "electrodes[1]"},
  {"solve-e-tiny", "solve e_tiny.json", 2, "electrodes[0].size_m"},
  {"solve-radius-huge", "solve radius_huge.json", 2, "membrane.radius_m"},
  {"solve-radius-tiny", "solve radius_tiny.json", 2, "membrane.radius_m"},
  {"solve-rect-huge", "solve rect_huge.json", 2, "membrane.size_m"},
  {"solve-probe-1e-20", "solve probe_1e-20.json", 2, "probe.radius_m"},
  {"solve-probe-1e-300", "solve probe_1e-300.json", 2, "probe.radius_m"},
  {"solve-probe-huge", "solve probe_huge.json", 2, "probe.radius_m"},
  {"solve-load-rim", "solve load_rim.json", 2, "loads[0]"},
  {"solve-load-outside", "solve load_outside.json", 2, "loads[0]"},
  {"solve-size-min-tiny", "solve size_min_tiny.json", 2, "mesh.size_min_m"},
  {"solve-tolerance-tiny", "solve tolerance_tiny.json", 2, "model.tolerance"},
  {"solve-thickness-neg", "solve thickness_neg.json", 2, "membrane.thickness_m"},
  {"map-e-outside", "map e_outside.json -o m1.h5 --quiet", 2, "electrodes[0]", "m1.h5,m1.h5.checkpoint"},
  {"map-e-overlap", "map e_overlap.json -o m2.h5 --quiet", 2, "electrodes[1]", "m2.h5"},
  {"map-probe-1e-20", "map probe_1e-20.json -o m3.h5 --quiet", 2, "probe.radius_m", "m3.h5"},
  {"map-trunc40k", "map trunc40k.json -o m4.h5 --quiet", 2, "trunc40k.json:", "m4.h5"},
  {"map-dup-key", "map dup_key.json -o m5.h5 --quiet", 2, "membrane.radius_m", "m5.h5"},
  {"map-radius-huge", "map radius_huge.json -o m6.h5 --quiet", 2, "membrane.radius_m", "m6.h5"},
  {"mesh-e-outside", "mesh e_outside.json -o k1.msh", 2, "electrodes[0]", "k1.msh,k1.png"},
  {"mesh-deep-array", "mesh deep_array.json -o k2.msh", 2, "deep_array.json:1:", "k2.msh,k2.png"},
  {"mesh-radius-huge", "mesh radius_huge.json -o k3.msh", 2, "membrane.radius_m", "k3.msh,k3.png"},
  {"mesh-probe-1e-300", "mesh probe_1e-300.json -o k4.msh", 2, "probe.radius_m", "k4.msh,k4.png"},
  {"mesh-short-edge", "mesh e_short_edge.json -o k6.msh", 2, "electrodes[0]", "k6.msh,k6.png"},
  {"mesh-size-min-tiny", "mesh size_min_tiny.json -o k5.msh", 2, "mesh.size_min_m", "k5.msh,k5.png"},
  {"design-e-outside", "design e_outside.json --synthetic --no-plots", 2, "electrodes[0]"},
  {"design-e-crossing", "design e_crossing.json --synthetic --no-plots", 2, "electrodes[0]"},
  {"design-e-overlap", "design e_overlap.json --synthetic --no-plots", 2, "electrodes[1]"},
  {"design-garbage", "design garbage.json --synthetic --no-plots", 2, "garbage.json:1:1"},
  {"moduli-garbage", "moduli --scene garbage.json", 2, "garbage.json:1:1"},
  {"moduli-trunc40k", "moduli --scene trunc40k.json", 2, "trunc40k.json:"},
  {"moduli-deep", "moduli --scene deep_array.json", 2, "deep_array.json:1:"},
  {"restore-filter-trunc", "restore apply filter_trunc.json scan.csv -o forces1.csv", 2, "filter_trunc.json:", "forces1.csv"},
  {"restore-filter-deep", "restore apply filter_deep.json scan.csv -o forces2.csv", 2, "filter_deep.json:1:", "forces2.csv"},
  // ---- solve flags: the scene's rules, checked where the flag is parsed
  {"solve-tolerance-0", "solve good.json --tolerance 0", 2, "--tolerance"},
  {"solve-tolerance-1e-12", "solve good.json --tolerance 1e-12", 2, "--tolerance"},
  {"solve-tolerance-0.9", "solve good.json --tolerance 0.9", 2, "--tolerance"},
  {"solve-tolerance-nan", "solve good.json --tolerance nan", 2, "--tolerance"},
  {"solve-max-ref-neg", "solve good.json --max-refinements -1", 2, "--max-refinements"},
  {"solve-max-ref-99", "solve good.json --max-refinements 99", 2, "--max-refinements"},
  {"solve-load-rim", "solve good.json --load 0,0.044,1", 2, "--load"},
  {"solve-load-near-rim", "solve good.json --load 0,0.0435,1", 2, "--load"},
  {"solve-load-outside", "solve good.json --load 0,0.06,1", 2, "--load"},
  {"solve-load-1e308", "solve good.json --load 1e308,0,1", 2, "--load"},
  {"solve-load-force-1e9", "solve good.json --load 0,0,1e9", 2, "--load"},
  {"solve-load-two", "solve good.json --load 0,0", 2, "--load"},
  {"solve-load-nan", "solve good.json --load nan,0,1", 2, "--load"},
  {"solve-model", "solve good.json --model magic", 2, "--model"},
  {"solve-sample-outside", "solve good.json --sample 0.1,0", 2, "--sample"},
  // ---- map flags and output
  {"map-nodir", "map good.json -o nodir/m.h5 --quiet", 2, "nodir", "nodir", 10},
  {"map-tolerance-0", "map good.json -o m.h5 --quiet --tolerance 0", 2, "--tolerance", "m.h5"},
  {"map-probe-refinement-bad", "map good.json -o m.h5 --quiet --probe-refinement coarse", 2, "--probe-refinement", "m.h5"},
  {"map-tolerance-1e-12", "map good.json -o m.h5 --quiet --tolerance 1e-12", 2, "--tolerance", "m.h5"},
  {"map-setup-checks-5", "map good.json -o m.h5 --quiet --setup-checks 5", 2, "--setup-checks", "m.h5"},
  {"map-setup-checks-neg", "map good.json -o m.h5 --quiet --setup-checks -1", 2, "--setup-checks", "m.h5"},
  {"map-spacing-0", "map good.json -o m.h5 --quiet --spacing-m 0", 2, "--spacing-m", "m.h5"},
  {"map-spacing-1e-9", "map good.json -o m.h5 --quiet --spacing-m 1e-9", 2, "--spacing-m", "m.h5"},
  {"map-spacing-neg", "map good.json -o m.h5 --quiet --spacing-m -0.001", 2, "--spacing-m", "m.h5"},
  {"map-forces-0", "map good.json -o m.h5 --quiet --forces-N 0", 2, "--forces-N", "m.h5"},
  {"map-forces-neg", "map good.json -o m.h5 --quiet --forces-N -1,1", 2, "--forces-N", "m.h5"},
  {"map-region-empty", "map good.json -o m.h5 --quiet --region 0.01,0,0,0.01", 2, "--region", "m.h5"},
  {"map-threads-neg", "map good.json -o m.h5 --quiet --threads -1", 2, "--threads", "m.h5"},
  {"map-stride-0", "map good.json -o m.h5 --quiet --scaling-check-stride 0", 2, "--scaling-check-stride", "m.h5"},
  {"map-rim-margin-neg", "map good.json -o m.h5 --quiet --rim-margin-m -1", 2, "--rim-margin-m", "m.h5"},
  {"map-noise-neg", "map good.json -o m.h5 --quiet --noise-C -1e-14,5e-14,5e-14", 2, "--noise-C", "m.h5"},
  // ---- solve --mesh FILE.msh: files Gmsh cannot read, meshes that do not fit the scene
  {"solve-msh-missing", "solve good.json --mesh no_such.msh", 2, "no_such.msh"},
  {"solve-msh-json", "solve good.json --mesh good.json", 2, "good.json"},
  {"solve-msh-folder", "solve good.json --mesh .", 2, "."},
  {"solve-msh-not-gmsh", "solve good.json --mesh not_gmsh.msh", 2, "not_gmsh.msh"},
  {"solve-msh-garbage", "solve good.json --mesh garbage.msh", 2, "garbage.msh"},
  {"solve-msh-huge-count", "solve good.json --mesh huge_count.msh", 2, "huge_count.msh"},
  {"solve-msh-triangles", "solve good.json --mesh triangles.msh", 2, "triangles.msh"},
  {"solve-msh-no-rim", "solve good.json --mesh no_rim.msh", 2, "rim"},
  {"solve-msh-bowtie", "solve good.json --mesh bowtie.msh", 2, "quadrilateral 0"},
  {"solve-msh-other-film", "solve good.json --mesh square.msh", 2, "square.msh"},
  {"solve-msh-other-scene", "$X mesh e_tiny_ok.json -o other.msh --no-preview >/dev/null 2>&1; $X solve good.json --mesh other.msh 2>.err", 2, "electrode groups"},
  // ---- mesh flags and outputs
  {"mesh-size-factor-1e-6", "mesh good.json -o k.msh --size-factor 1e-6", 2, "--size-factor", "k.msh,k.png"},
  {"mesh-size-factor-0", "mesh good.json -o k.msh --size-factor 0", 2, "--size-factor", "k.msh,k.png"},
  {"mesh-size-factor-neg", "mesh good.json -o k.msh --size-factor -1", 2, "--size-factor", "k.msh,k.png"},
  {"mesh-size-factor-nan", "mesh good.json -o k.msh --size-factor nan", 2, "--size-factor", "k.msh,k.png"},
  {"mesh-size-factor-1e6", "mesh good.json -o k.msh --size-factor 1e6", 2, "--size-factor", "k.msh,k.png"},
  {"mesh-preview-nodir", "mesh good.json -o film2.msh --preview nodir/p.png", 2, "nodir", "film2.msh,nodir"},
  {"mesh-output-nodir", "mesh good.json -o nodir/f.msh", 2, "nodir", "nodir"},
  // ---- design flags
  {"design-spacing-0", "design good.json --synthetic --no-plots --spacing-m 0", 2, "--spacing-m"},
  {"design-spacing-1e-9", "design good.json --synthetic --no-plots --spacing-m 1e-9", 2, "--spacing-m"},
  {"design-fem-spacing-1e-9", "design good.json --no-plots --spacing-m 1e-9", 2, "--spacing-m"},
  {"design-target-0", "design good.json --synthetic --no-plots --target-mm 0", 2, "--target-mm"},
  {"design-adc-bits-99", "design good.json --synthetic --no-plots --adc-bits 99", 2, "--adc-bits"},
  {"design-tolerance-1e-12", "design good.json --no-plots --tolerance 1e-12", 2, "--tolerance"},
  {"design-force-0", "design good.json --synthetic --no-plots --force-N 0", 2, "--force-N"},
  {"design-noise-neg", "design good.json --synthetic --no-plots --noise-C -1e-14", 2, "--noise-C"},
  {"design-refine-neg", "design good.json --synthetic --no-plots --refine-best -1", 2, "--refine-best"},
  {"design-out-dir-file", "design good.json --synthetic --out-dir good.json", 2, "good.json"},
  // ---- rays flags and outputs (map from synthetic-map)
  {"rays-step-1e-9", "rays $M --angle-step-deg 1e-9", 2, "--angle-step-deg"},
  {"rays-step-0", "rays $M --angle-step-deg 0", 2, "--angle-step-deg"},
  {"rays-step-neg", "rays $M --angle-step-deg -10", 2, "--angle-step-deg"},
  {"rays-step-400", "rays $M --angle-step-deg 400", 2, "--angle-step-deg"},
  {"rays-samples-2e9", "rays $M --n-samples 2000000000", 2, "--n-samples"},
  {"rays-samples-0", "rays $M --n-samples 0", 2, "--n-samples"},
  {"rays-d-min-0", "rays $M --d-min-m 0", 2, "--d-min-m"},
  {"rays-d-order", "rays $M --d-min-m 0.02 --d-max-m 0.01", 2, "--d-max-m"},
  {"rays-min-points-0", "rays $M --min-points 0", 2, "--min-points"},
  {"rays-force-0", "rays $M --force-N 0", 2, "--force-N"},
  {"rays-plot-nodir", "rays $M --plot nodir/p.png", 2, "nodir", "nodir"},
  {"rays-csv-nodir", "rays $M --csv nodir/r.csv", 2, "nodir", "nodir"},
  // ---- other map consumers
  {"isocharge-out-dir-file", "isocharge $M --out-dir good.json", 2, "good.json"},
  {"isocharge-zoom-neg", "isocharge $M --out-dir iso --zoom-m -1", 2, "--zoom-m", "iso"},
  {"compare-garbage", "compare $M garbage.csv", 2, "garbage.csv:2"},
  {"compare-empty", "compare $M empty.csv", 2, "empty.csv"},
  {"compare-noheader", "compare $M noheader.csv", 2, "noheader.csv"},
  {"calibrate-garbage", "calibrate $M garbage.csv -o cal.h5", 2, "garbage.csv:2", "cal.h5"},
  {"calibrate-nodir", "calibrate $M garbage.csv -o nodir/cal.h5", 2, "nodir", "nodir"},
  // ---- moduli flags, stdout faults
  {"moduli-range-step-0", "moduli --angles-deg 0:0:90", 2, "--angles-deg"},
  {"moduli-range-tiny-step", "moduli --angles-deg 0:1e-9:90", 2, "--angles-deg"},
  {"moduli-range-nan", "moduli --angles-deg nan:1:2", 2, "--angles-deg"},
  {"moduli-plot-nodir", "moduli --plot nodir/m.png", 2, "nodir", "nodir"},
  {"moduli-json-dev-full", "$X moduli --json >/dev/full 2>.err", 2, "stdout"},
  {"moduli-csv-dev-full", "$X moduli --csv >/dev/full 2>.err", 2, "stdout"},
  {"moduli-table-dev-full", "$X moduli >/dev/full 2>.err", 2, "stdout"},
  {"moduli-pipe-head", "$X moduli --csv --angles-deg 0:0.002:180 2>.err | head -2 >/dev/null; exit ${PIPESTATUS[0]}", 2, ""},
  {"synthetic-map-nodir", "synthetic-map -o nodir/x.h5", 2, "nodir", "nodir"},
  {"synthetic-map-spacing-0", "synthetic-map -o s.h5 --spacing-m 0", 2, "--spacing-m", "s.h5"},
  {"synthetic-map-forces-0", "synthetic-map -o s.h5 --forces-N 0", 2, "--forces-N", "s.h5"},
  // ---- lookup: flag ranges, values printed as given, stdout faults
  {"locate-force-0", "locate $M --charges-C 2.4925e-12,1.87487e-11,1.87487e-11 --force-N 0", 2, "--force-N"},
  {"locate-noise-neg", "locate $M --charges-C 2.4925e-12,1.87487e-11,1.87487e-11 --noise-C -1e-14", 2, "-1e-14"},
  {"locate-dev-full", "$X locate $M --charges-C 2.4925e-12,1.87487e-11,1.87487e-11 >/dev/full 2>.err", 2, "stdout"},
  {"locate-json-dev-full", "$X locate $M --charges-C 2.4925e-12,1.87487e-11,1.87487e-11 --json >/dev/full 2>.err", 2, "stdout"},
  {"locate-stream-dev-full", "$X locate $M --input stream.csv >/dev/full 2>.err", 2, "stdout"},
  {"locate-stream-head", "$X locate $M --input stream.csv 2>.err | head -2 >/dev/null; exit ${PIPESTATUS[0]}", 2, ""},
  {"isocharge-force-0", "isocharge $M --out-dir iso2 --force-N 0", 2, "--force-N", "iso2"},
  {"lookup-accuracy-presses-neg", "lookup-accuracy $M --presses -5", 2, "-5"},
  {"lookup-accuracy-presses-0", "lookup-accuracy $M --presses 0", 2, "--presses"},
  {"lookup-accuracy-radius-5", "lookup-accuracy $M --radius-m 5", 2, "--radius-m 5 m"},
  {"lookup-accuracy-radius-nan", "lookup-accuracy $M --radius-m nan", 2, "--radius-m"},
  {"lookup-accuracy-noise-neg", "lookup-accuracy $M --noise-C -1e-14", 2, "-1e-14"},
  {"lookup-accuracy-plot-nodir", "lookup-accuracy $M --presses 10 --plot nodir/p.png", 2, "nodir", "nodir", 10},
  {"map-noise-value", "map good.json -o m.h5 --quiet --noise-C -1e-14,5e-14,5e-14", 2, "-1e-14", "m.h5"},
  {"design-noise-value", "design good.json --synthetic --no-plots --noise-C -1e-14", 2, "-1e-14"},
  {"map-e-crossing", "map e_crossing.json -o m7.h5 --quiet", 2, "electrodes[0]", "m7.h5"},
  // ---- restore and acquire flags and files
  {"restore-filter-tap-1e308", "restore apply filter_huge_tap.json scan.csv -o forces3.csv", 2, "h11[0]", "forces3.csv"},
  {"restore-mu-threshold-neg", "restore apply filter_ok.json scan.csv -o forces4.csv --mu-threshold-N -1", 2, "--mu-threshold-N", "forces4.csv"},
  {"acquire-gain-0", "acquire --device sim: --quiet --gain-mV-per-pC 0", 2, "--gain-mV-per-pC"},
  {"acquire-gain-nan", "acquire --device sim: --quiet --gain-mV-per-pC nan", 2, "--gain-mV-per-pC: nan is not a finite number"},
  {"acquire-rate-sim", "acquire --device sim: --quiet --rate-Hz 5000", 2, "--rate-Hz"},
  {"acquire-bad-device", "acquire --device serial:/dev/ttyUSB0 --quiet", 2, "--device"},
  {"acquire-usb-spec", "acquire --device usb:12 --quiet", 2, "--device usb:12"},
  {"acquire-replay-empty", "acquire --device replay: --quiet", 2, "--device"},
  {"acquire-record-nodir", "acquire --device sim: --quiet --record nodir/r.pvdfrec", 2, "--record", "nodir"},
  // ---- outputs never destroy files (issue 30): devices, symbolic links, folders, inputs, the
  // checkpoint; refused before any work, the target untouched (checked again by the next case)
  {"compare-o-dev-full", "compare $M measured.csv -o /dev/full", 2, "/dev/full"},
  {"compare-o-symlink", "compare $M measured.csv -o link.out", 2, "symbolic link"},
  {"compare-o-input-csv", "compare $M measured.csv -o measured.csv", 2, "is the input"},
  {"compare-o-input-map", "compare $M measured.csv -o map.h5", 2, "is the input"},
  {"compare-o-folder", "compare $M measured.csv -o realdir", 2, "is a folder"},
  {"compare-plot-bmp", "compare $M measured.csv --plot p.bmp", 2, "figure format", "p.bmp"},
  {"compare-plot-report-same", "compare $M measured.csv --plot pr.png -o pr.png", 2, "pr.png", "pr.png"},
  {"fit-o-dev-full", "fit good.json fit_ok.csv -o /dev/full", 2, "/dev/full"},
  {"fit-o-input-scene", "fit good.json fit_ok.csv -o good.json", 2, "is the input"},
  {"fit-o-symlink", "fit good.json fit_ok.csv -o link_stdout.out", 2, "symbolic link"},
  {"fit-plot-txt", "fit good.json fit_ok.csv -o f.json --plot p.txt", 2, "figure format", "f.json,p.txt"},
  {"fit-params-empty", "fit good.json fit_ok.csv -o f.json --params ''", 2, "--params", "f.json"},
  {"fit-start-twice", "fit good.json fit_ok.csv -o f.json --start E_scale=1 --start E_scale=2", 2, "--start", "f.json"},
  {"fit-force-1e-300", "fit good.json fit_tiny_force.csv -o f.json", 2, "force_N", "f.json"},
  {"fit-sigma-denormal", "fit good.json fit_sigma_denormal.csv -o f.json", 2, "fit_sigma_denormal.csv:2: sigma_deflection_m", "f.json"},
  {"solve-json-verbose", "$X solve good.json --json --verbose --tolerance 0.3 2>/dev/null | python3 -c 'import json,sys; json.load(sys.stdin)' "
                         "2>.err", 0, "", "", 60},
  {"fit-dup-column", "fit good.json fit_dup.csv -o f.json", 2, "appears twice", "f.json"},
  {"map-o-dev-full", "map good.json -o /dev/full --quiet", 2, "/dev/full"},
  {"map-o-symlink", "map good.json -o link.out --quiet", 2, "symbolic link", "link.out.checkpoint"},
  {"map-o-scene", "map good.json -o good.json --quiet", 2, "is the input", "good.json.checkpoint"},
  {"map-o-folder", "map good.json -o realdir --quiet", 2, "is a folder"},
  {"map-o-is-checkpoint", "map good.json -o mc.h5 --checkpoint mc.h5 --quiet", 2, "--checkpoint", "mc.h5"},
  {"map-checkpoint-dev-full", "map good.json -o mc2.h5 --checkpoint /dev/full --quiet", 2, "/dev/full", "mc2.h5"},
  {"map-checkpoint-scene", "map good.json -o mc3.h5 --checkpoint good.json --quiet", 2, "is the input", "mc3.h5"},
  // A handshake, not a sleep: the holder signals when it has the lock and keeps it until the map
  // returned (a fixed 0.5 s let a loaded machine start the map before the lock was taken).
  {"map-locked", "rm -f ml.held ml.done; flock -x ml.h5.lock sh -c 'touch ml.held; n=0; while [ ! -e ml.done ] && [ $n -lt 600 ]; do sleep 0.05; n=$((n+1)); done' & "
                 "n=0; while [ ! -e ml.held ] && [ $n -lt 600 ]; do sleep 0.05; n=$((n+1)); done; "
                 "$X map good.json -o ml.h5 --quiet 2>.err; rc=$?; touch ml.done; wait; exit $rc",
   2, "being written by another pvdfkit", "ml.h5"},
  {"map-lock-symlink", "ln -sf target.txt ml2.h5.lock; $X map good.json -o ml2.h5 --quiet 2>.err", 2, "ml2.h5.lock",
   "ml2.h5"},
  {"map-forces-not-distinct", "map good.json -o m.h5 --quiet --forces-N 1,1.0000000000000002", 2, "not distinct", "m.h5"},
  {"map-forces-1e-300", "map good.json -o m.h5 --quiet --forces-N 1e-300", 2, "--forces-N", "m.h5"},
  {"map-forces-1e5", "map good.json -o m.h5 --quiet --forces-N 1e5", 2, "--forces-N", "m.h5"},
  {"map-region-1e10", "map good.json -o m.h5 --quiet --region -1e10,1e10,-1e10,1e10", 2, "beyond the film", "m.h5"},
  {"map-region-mm", "map good.json -o m.h5 --quiet --region -12,12,-12,12", 2, "look like mm", "m.h5"},
  {"map-spacing-mm", "map good.json -o m.h5 --quiet --spacing-m 2", 2, "metres", "m.h5"},
  {"map-linear-all-zero", "map good.json -o lin.h5 --spacing-m 0.01 --region -0.01,0.01,-0.01,0.01 --setup-checks 0 "
                          "--model linear --rim-model never --direct-solves never --tolerance 0.3 --quiet --no-checkpoint",
   3, "every charge of the map is zero", "lin.h5", 30},
  {"map-stop-after-neg", "map good.json -o m.h5 --quiet --stop-after-positions -1", 2, "--stop-after-positions", "m.h5"},
  {"map-spacing-twice", "map good.json -o m.h5 --quiet --spacing-m 0.004 --spacing-m 0.002", 2, "--spacing-m", "m.h5"},
  {"calibrate-o-input-map", "calibrate $M measured.csv -o map.h5", 2, "is the input"},
  {"calibrate-o-dev-full", "calibrate $M measured.csv -o /dev/full", 2, "/dev/full"},
  {"calibrate-dup-column", "calibrate $M measured_dup.csv -o cal2.h5", 2, "appears twice", "cal2.h5"},
  {"mesh-o-dev-full", "mesh good.json -o /dev/full", 2, "/dev/full"},
  {"mesh-o-scene", "mesh good.json -o good.json --no-preview", 2, "is the input"},
  {"mesh-preview-txt", "mesh good.json -o k7.msh --preview k7.txt", 2, "figure format", "k7.msh,k7.txt"},
  {"mesh-preview-is-output", "mesh good.json -o k8.msh --preview k8.msh", 2, "k8.msh", "k8.msh"},
  {"rays-csv-dev-full", "rays $M --csv /dev/full", 2, "/dev/full"},
  {"rays-csv-input-map", "rays $M --csv map.h5", 2, "is the input"},
  {"rays-plot-bmp", "rays $M --plot r.bmp", 2, "figure format", "r.bmp"},
  {"synthetic-map-dev-full", "synthetic-map -o /dev/full", 2, "/dev/full"},
  {"synthetic-map-symlink", "synthetic-map -o link.out", 2, "symbolic link"},
  {"synthetic-map-not-distinct", "synthetic-map -o s.h5 --forces-N 1,1.0000000000000002", 2, "not distinct", "s.h5"},
  {"export-map-dev-full", "export-map $M -o /dev/full", 2, "/dev/full"},
  {"export-map-symlink-stdout", "export-map $M -o link_stdout.out", 2, "symbolic link"},
  {"export-map-o-input", "export-map $M -o map.h5", 2, "is the input"},
  {"restore-apply-o-dev-full", "restore apply filter_ok.json scan.csv -o /dev/full", 2, "/dev/full"},
  {"restore-apply-o-input", "restore apply filter_ok.json scan.csv -o scan.csv", 2, "is the input"},
  {"restore-apply-o-symlink", "restore apply filter_ok.json scan.csv -o link.out", 2, "symbolic link"},
  {"moduli-plot-txt", "moduli --plot m.txt", 2, "figure format", "m.txt"},
  {"moduli-plot-dev-full", "moduli --plot /dev/full", 2, "/dev/full"},
  {"lookup-accuracy-plot-bmp", "lookup-accuracy $M --presses 10 --plot p.bmp", 2, "figure format", "p.bmp"},
  {"locate-plot-txt", "locate $M --charges-C 2.4925e-12,1.87487e-11,1.87487e-11 --plot p.txt", 2, "figure format", "p.txt"},
  {"locate-plot-input", "locate $M --charges-C 2.4925e-12,1.87487e-11,1.87487e-11 --plot map.h5", 2, "figure format"},
  {"locate-pictures-symlink", "locate $M --pictures link_dir", 2, "symbolic link"},
  {"isocharge-out-dir-symlink", "isocharge $M --out-dir link_dir", 2, "symbolic link"},
  {"solve-vtu-dev-full", "solve good.json --vtu /dev/full", 2, "/dev/full"},
  // ---- absurd scenes refused before work (docs/scene.md "Physical bounds")
  {"solve-E-1e-30", "solve E_tiny.json", 2, "material.E1_Pa"},
  {"solve-E2-milli", "solve E2_milli.json", 2, "material.E2_Pa"},
  {"solve-E-huge", "solve E_huge.json", 2, "material.E1_Pa"},
  {"solve-E-MPa", "solve iso_E_MPa.json", 2, "material.E_Pa"},
  {"solve-nu-auxetic", "solve nu_auxetic.json", 2, "material.nu"},
  {"solve-nu12-edge", "solve nu12_edge.json", 2, "material.nu12"},
  {"solve-pretension-1e9", "solve pretension_huge.json", 2, "membrane.pretension_N_per_m"},
  {"solve-pretension-1e5", "solve pretension_pos.json", 2, "membrane.pretension_N_per_m"},
  {"solve-force-1e-300", "solve force_tiny.json", 2, "loads[0].force_N"},
  {"solve-force-0", "solve force_zero.json", 2, "loads[0].force_N"},
  {"solve-force-neg", "solve force_neg.json", 2, "loads[0].force_N"},
  {"solve-load-flag-1e-300", "solve good.json --load 0,0,1e-300", 2, "--load"},
  {"map-pretension-1e9", "map pretension_huge.json -o m8.h5 --quiet", 2, "membrane.pretension_N_per_m", "m8.h5"},
  {"map-nu-auxetic", "map nu_auxetic.json -o m9.h5 --quiet", 2, "material.nu", "m9.h5"},
  {"fit-E-1e-30", "fit E_tiny.json fit_ok.csv -o f.json", 2, "material.E1_Pa", "f.json"},
  // A force must deflect the film beyond rounding (1e-12 of its size, docs/scene.md): on a 10 mm
  // thick stiff film 1 uN does not, in the scene, in solve --load and in map --forces-N.
  {"solve-force-below-rounding", "solve stiff_thick_1uN.json", 2, "loads[0].force_N"},
  {"solve-load-below-rounding", "solve stiff_thick.json --load 0,0,1e-6", 2, "lost to rounding"},
  {"map-forces-below-rounding", "map stiff_thick.json -o m10.h5 --quiet --forces-N 1e-6,1", 2, "lost to rounding",
   "m10.h5,m10.h5.checkpoint"},
  {"map-forces-duplicate-rounding", "map good.json -o m11.h5 --quiet --forces-N 2,1,2.0000000000000004", 2,
   "not distinct", "m11.h5,m11.h5.checkpoint"},
  {"solve-probe-as-film", "solve probe_as_film.json", 2, "probe.radius_m"},
  {"map-probe-as-film", "map probe_as_film.json -o m12.h5 --quiet", 2, "probe.radius_m", "m12.h5,m12.h5.checkpoint"},
  {"solve-poisson-not-pd", "solve poisson_pd_edge.json", 2, "material"},
  {"solve-pressure-huge", "solve pressure_huge.json", 2, "pressure_Pa"},
  // ---- CSV inputs: rows, duplicate columns, cells quoted to 80 characters, NUL bytes
  {"compare-too-many-rows", "compare $M measured_many.csv", 2, "100000"},
  {"compare-dup-column", "compare $M measured_dup.csv", 2, "appears twice"},
  {"compare-big-cell", "compare $M measured_bigcell.csv", 2, "50000 characters"},
  {"compare-nul", "compare $M measured_nul.csv", 2, "NUL"},
  {"fit-too-many-rows", "fit good.json measured_many.csv -o f.json", 2, "100000", "f.json"},
  {"locate-input-dup-column", "locate $M --input stream_dup.csv", 2, "appears twice"},
  {"locate-charges-huge-cell", "$X locate $M --charges-C $(head -c 20000 /dev/zero | tr '\\0' 7) 2>.err", 2, "20000 characters"},
  // ---- map checkpoints with integrity (issue 30 item 3): a damaged, truncated, edited or
  // implausible checkpoint is refused naming it and the way to start afresh, never resumed;
  // the header's record count allocates nothing. The first row makes the checkpoint (a run
  // stopped after one row of three positions); the others damage copies of it.
  {"map-checkpoint-flipped-bit", CKPT_MAKE "python3 ckpt_edit.py ck0 ck1 flip; $X map " CKPT_ARGS " --checkpoint ck1 2>.err",
   2, "ck1: checkpoint checksum", "ck.h5", 30},
  {"map-checkpoint-truncated", CKPT_MAKE "python3 ckpt_edit.py ck0 ck2 truncate; $X map " CKPT_ARGS " --checkpoint ck2 2>.err",
   2, "ck2: checkpoint truncated or damaged", "ck.h5", 30},
  {"map-checkpoint-one-coulomb", CKPT_MAKE "python3 ckpt_edit.py ck0 ck3 one-coulomb; $X map " CKPT_ARGS
   " --checkpoint ck3 2>.err", 2, "ck3: checkpoint checksum", "ck.h5", 30},
  {"map-checkpoint-1e10-records", CKPT_MAKE "python3 ckpt_edit.py ck0 ck4 huge-count; ulimit -v 3000000; $X map " CKPT_ARGS
   " --checkpoint ck4 2>.err", 2, "announces 10000000000 records", "ck.h5", 30},
  {"map-checkpoint-no-newline", CKPT_MAKE "python3 ckpt_edit.py ck0 ck5 no-newline; $X map " CKPT_ARGS " --checkpoint ck5 2>.err",
   2, "ck5: not a pvdfkit map checkpoint", "ck.h5", 30},
  {"map-checkpoint-format-2", CKPT_MAKE "python3 ckpt_edit.py ck0 ck6 format-2; $X map " CKPT_ARGS " --checkpoint ck6 2>.err",
   2, "ck6: a checkpoint of an older pvdfkit", "ck.h5", 30},
  {"map-checkpoint-nan-resummed", CKPT_MAKE "python3 ckpt_edit.py ck0 ck7 nan-with-checksum; $X map " CKPT_ARGS
   " --checkpoint ck7 2>.err", 2, "ck7: checkpoint record 0 is invalid", "ck.h5", 30},
  // ---- locate --stream limits (issue 30 item 5): a line beyond 64 KiB refuses the stream; NaN,
  // inf, a wrong field count, control bytes and long cells are malformed rows, refused by --strict
  // with the line named (without it skipped with a warning: "stream rows" case below)
  {"locate-stream-long-line", "$X locate $M --stream < stream_long_line.csv >/dev/null 2>.err", 2,
   "<stdin>:3: a line longer than 65536 bytes"},
  {"locate-stream-dup-column-stdin", "$X locate $M --stream < stream_dup.csv >/dev/null 2>.err", 2, "appears twice"},
  {"locate-stream-strict-nan", "locate $M --input stream_rows.csv --strict", 2, "stream_rows.csv:3: column charge_A_C = 'nan'"},
  {"locate-stream-strict-inf", "$X locate $M --stream --strict < stream_inf.csv >/dev/null 2>.err", 2,
   "<stdin>:2: column charge_B_C = '-inf'"},
  {"locate-stream-strict-fields", "$X locate $M --stream --strict < stream_fields.csv >/dev/null 2>.err", 2,
   "<stdin>:2: has 2 fields but the header has 4"},
  {"locate-stream-strict-nul", "$X locate $M --stream --strict < stream_nul.csv >/dev/null 2>.err", 2,
   "<stdin>:2: column charge_C_C = '1e-\\x0011'"},
  {"locate-stream-strict-big-cell", "$X locate $M --stream --strict < stream_big_cell.csv >/dev/null 2>.err", 2,
   "'<cell of 20000 characters>'"},
  // ---- unit and order mistakes get a hint (issue 31 item 2)
  {"locate-charges-pC", "locate $M --charges-C 146.1,165.1,160.2", 2, "look like pC"},
  {"locate-charges-count", "locate $M --charges-C 1e-11,2e-11", 2, "order A,B,C"},
  {"map-noise-count", "map good.json -o m.h5 --quiet --noise-C 5e-14,5e-14", 2, "order A,B,C", "m.h5"},
  {"locate-noise-count", "locate $M --charges-C 1e-11,2e-11,3e-11 --noise-C 1e-14,1e-14", 2, "order A,B,C"},
  // ---- found by the hostile sweep (tests/hostile/hostile_sweep.py): an empty value no longer
  // keeps the default, a known force and the acquisition flags are range-checked at parse time
  {"sweep-seed-empty", "lookup-accuracy $M --presses 10 --seed ''", 2, "--seed is given an empty value"},
  {"sweep-residual-stiffness-empty", "fit good.json fit_ok.csv -o f.json --residual-stiffness ''", 2,
   "--residual-stiffness is given an empty value", "f.json"},
  {"sweep-solve-model-empty", "solve good.json --model=", 2, "--model"},
  {"sweep-locate-force-1e308", "locate $M --charges-C 2.4925e-12,1.87487e-11,1.87487e-11 --force-N 1e308", 2,
   "--force-N: 1e+308 must lie in (0, 10000]"},
  {"sweep-locate-force-5e5", "locate $M --charges-C 2.4925e-12,1.87487e-11,1.87487e-11 --force-N 5e5", 2, "--force-N"},
  {"sweep-acquire-duration-nan", "acquire --device sim: --quiet --duration-s nan", 2, "--duration-s: nan"},
  {"sweep-acquire-duration-inf", "acquire --device sim: --quiet --duration-s inf", 2, "--duration-s"},
  {"sweep-acquire-stall-0", "acquire --device sim: --quiet --duration-s 0.01 --stall-timeout-s 0", 2, "--stall-timeout-s"},
  {"sweep-acquire-gain-1e308", "acquire --device sim: --quiet --duration-s 0.01 --gain-mV-per-pC 1e308", 2,
   "--gain-mV-per-pC"},
  {"sweep-acquire-transfers-0", "acquire --device sim: --quiet --duration-s 0.01 --transfers 0", 2, "--transfers"},
  {"sweep-acquire-output-symlink", "acquire --device sim: --quiet --duration-s 0.01 --output link.out", 2, "symbolic link"},
  {"sweep-acquire-record-symlink", "acquire --device sim: --quiet --duration-s 0.01 --record link.out", 2, "symbolic link"},
  {"sweep-mesh-o-long-name", "mesh good.json --no-preview -o nnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnnn.msh",
   2, "characters; give one of at most 200"},
  {"sweep-isocharge-long-name", "isocharge $M --out-dir dddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddddd",
   2, "characters; give one of at most 200"},
  {"sweep-locate-input-folder", "locate $M --input realdir", 2, "--input realdir is a folder"},
  {"sweep-locate-noise-1C", "locate $M --charges-C 2.4925e-12,1.87487e-11,1.87487e-11 --noise-C 1", 2, "is the unit pC"},
  {"sweep-rays-plot-angles-nan", "rays $M --plot-angles-deg nan", 2, "--plot-angles-deg"},
  {"sweep-rays-plot-angles-1e308", "rays $M --plot-angles-deg 1e308", 2, "must lie in [-360, 360] deg"},
  {"sweep-fit-params-empty-item", "fit good.json fit_ok.csv -o f.json --params E_scale,,", 2, "--params E_scale,,: has an empty item",
   "f.json"},
  {"sweep-fit-params-twice", "fit good.json fit_ok.csv -o f.json --params E_scale,E_scale", 2, "(--params)", "f.json"},
  {"sweep-fit-start-1e308", "fit good.json fit_ok.csv -o f.json --start E_scale=1e308", 2, "E_scale must lie in [1e-3, 1e3]",
   "f.json"},
  {"sweep-fit-start-negative", "fit good.json fit_ok.csv -o f.json --start E_scale=-1", 2, "--start", "f.json"},
  {"sweep-calibrate-noise-neg", "calibrate $M measured.csv -o cal3.h5 --noise-C -1", 2, "--noise-C", "cal3.h5"},
  {"sweep-compare-charges-pC", "compare $M measured_pC.csv", 2, "measured_pC.csv:2: charge_A_C = 2 exceeds 1e-6 C"},
  {"sweep-compare-force-mN", "compare $M measured_mN.csv", 2, "measured_mN.csv:2: force_N = 1e+06"},
  {"sweep-calibrate-charges-pC", "calibrate $M measured_pC.csv -o cal4.h5", 2, "look like pC", "cal4.h5"},
  {"sweep-isocharge-charges-pC", "isocharge $M --out-dir iso3 --charges-C 1,2,3", 2, "these look like pC", "iso3"},
  {"sweep-help-dev-full", "$X --help >/dev/full 2>.err", 2, "stdout"},
  {"sweep-solve-help-dev-full", "$X solve --help >/dev/full 2>.err", 2, "stdout"},
  {"sweep-solve-nu12-auxetic", "solve nu12_auxetic.json", 2, "material.nu12 = -0.99 is below -0.5"},
  {"sweep-map-nu12-auxetic", "map nu12_auxetic.json -o m13.h5 --quiet", 2, "material.nu12", "m13.h5,m13.h5.checkpoint"},
  // compare against a scene: a deflection the CSV does not give is printed "-", never "nan"
  {"sweep-compare-scene-no-nan", "$X compare small_film.json measured.csv --quiet 2>.err | grep -i -w nan >/dev/null; test $? -eq 1",
   0, "", "", 60},
  // ---- the command line itself
  {"unknown-command", "frobnicate", 2, "frobnicate"},
  {"unknown-command-ctl", "$X $'fro\\x1bbnicate' 2>.err", 2, "fro\\x1bbnicate"},
  {"no-command", "", 2, "command"},
  {"unknown-flag", "solve good.json --bogus", 2, "--bogus"},
  // named in the order typed (CLI11 lists them last first: "1 --threads"), with the command
  {"unknown-flag-order", "solve good.json --threads 1", 2, "'pvdfkit solve' does not take --threads 1"},
  // an option typed short of its name: the ones it begins are named
  {"flag-short-name", "map good.json -o m14.h5 --spacing 0.004", 2, "--spacing is short for --spacing-m", "m14.h5"},
  {"missing-scene-arg", "solve", 2, "'pvdfkit solve': SCENE is required"},
  // a command of commands without one: its commands named, and what was typed in their place
  {"restore-unknown-subcommand", "restore frob", 2,
   "'pvdfkit restore' needs a command first: one of simulate, identify, apply (frob is not one of them)"},
};
// clang-format on

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
  for (std::size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) {
    s.replace(at, from.size(), to);
  }
  return s;
}

std::string quote(const std::string& s) { return "'" + s + "'"; }

/// A fresh fixture folder named by `tag` (with a small synthetic map for the map-reading commands).
fs::path make_fixture_dir(const std::string& tag) {
  const fs::path d = fs::temp_directory_path() / ("pvdf_hostile_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  pvdf::test::write_hostile_fixtures(d);
  const std::string cmd = quote(PVDFKIT_EXE) + " synthetic-map -o " + quote((d / "map.h5").string()) +
                          " --spacing-m 0.002 >/dev/null 2>&1";
  REQUIRE(std::system(cmd.c_str()) == 0);
  return d;
}

/// The fixture folder of the table, written once.
const fs::path& fixture_dir() {
  static const fs::path dir = make_fixture_dir("table");
  return dir;
}

bool has_temporary(const fs::path& dir) {
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.path().filename().string().find(".tmp.") != std::string::npos) return true;
  }
  return false;
}

}  // namespace

TEST_CASE("hostile input: every row fails cleanly, fast, with one error line and no output", "[hostile][cli]") {
  const fs::path& dir = fixture_dir();
  CHECK(rows.size() >= 80);
  for (const Row& row : rows) {
    // Memory is capped as well as time: a row that tries to allocate without bound fails here
    // instead of taking the machine down.
    const std::string limit = "ulimit -v 6000000; ";
    const std::string call = "timeout -k 2 " + std::to_string(static_cast<int>(row.max_wall_s) + 5) + " " + quote(PVDFKIT_EXE);
    std::string args = replace_all(row.args, "$M", "map.h5");
    std::string script;
    if (args.find("$X") != std::string::npos) {
      script = limit + replace_all(args, "$X", call);
    } else {
      script = limit + call + " " + args + " </dev/null >.out 2>.err";
    }
    const std::string cmd = "cd " + quote(dir.string()) + " && bash -c " + quote(replace_all(script, "'", "'\\''"));
    fs::remove(dir / ".err");
    const auto t0 = std::chrono::steady_clock::now();
    const int status = std::system(cmd.c_str());
    const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    const std::string err = slurp(dir / ".err");

    INFO("row " << row.id << ": pvdfkit " << row.args);
    INFO("exit " << code << ", " << wall_s << " s, stderr: " << err);
    CHECK(code == row.exit_code);
    CHECK(wall_s < row.max_wall_s);
    std::size_t n_error_lines = 0;
    std::istringstream lines(err);
    for (std::string line; std::getline(lines, line);) {
      if (line.rfind("error:", 0) != 0) continue;
      ++n_error_lines;
      CHECK_THAT(line, Catch::Contains(row.names));
    }
    CHECK(n_error_lines == (std::string(row.names).empty() ? 0u : 1u));
    bool clean = true;
    for (const char c : err) clean = clean && !((static_cast<unsigned char>(c) < 0x20 && c != '\n') || c == 0x7f);
    CHECK(clean);
    std::stringstream absent(row.absent);
    for (std::string p; std::getline(absent, p, ',');) {
      INFO("output " << p);
      CHECK_FALSE(fs::exists(dir / p));
    }
    CHECK_FALSE(has_temporary(dir));
  }
  fs::remove_all(dir);
}

TEST_CASE("outputs never destroy files: /dev/full, a symbolic link and an input given as the output are refused, "
          "the target unchanged", "[hostile][cli][output]") {
  const fs::path dir = make_fixture_dir("outputs");
  struct Writer {
    const char* args;   ///< `{OUT}` is the output under test
    const char* input;  ///< an input of the same command, given as the output ("" = none)
  };
  const std::vector<Writer> writers = {
      {"compare map.h5 measured.csv -o {OUT}", "measured.csv"},
      {"compare map.h5 measured.csv --plot {OUT}", "map.h5"},
      {"fit good.json fit_ok.csv -o {OUT}", "good.json"},
      {"fit good.json fit_ok.csv -o f2.json --plot {OUT}", "fit_ok.csv"},
      {"map good.json -o {OUT} --quiet", "good.json"},
      {"map good.json -o mx.h5 --checkpoint {OUT} --quiet", "good.json"},
      {"calibrate map.h5 measured.csv -o {OUT}", "map.h5"},
      {"mesh good.json -o {OUT} --no-preview", "good.json"},
      {"mesh good.json -o k9.msh --preview {OUT}", "good.json"},
      {"rays map.h5 --csv {OUT}", "map.h5"},
      {"synthetic-map -o {OUT}", ""},
      {"export-map map.h5 -o {OUT}", "map.h5"},
      {"restore apply filter_ok.json scan.csv -o {OUT}", "scan.csv"},
      {"locate map.h5 --charges-C 2.4925e-12,1.87487e-11,1.87487e-11 --plot {OUT}", "map.h5"},
      {"lookup-accuracy map.h5 --presses 10 --plot {OUT}", "map.h5"},
      {"moduli --plot {OUT}", ""},
  };
  const std::string target_before = slurp(dir / "target.txt");
  for (const Writer& w : writers) {
    std::vector<std::string> outputs = {"/dev/full", "link.out"};
    if (std::string(w.input).size() > 0) outputs.push_back(w.input);
    for (const std::string& out : outputs) {
      const std::string input_before = out.rfind('/', 0) == 0 ? "" : slurp(dir / (out == "link.out" ? "target.txt" : out));
      const std::string args = replace_all(w.args, "{OUT}", out);
      const std::string cmd = "cd " + quote(dir.string()) + " && timeout 60 " + quote(PVDFKIT_EXE) + " " + args +
                              " </dev/null >.out 2>.err";
      const int status = std::system(cmd.c_str());
      const int code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      const std::string err = slurp(dir / ".err");
      INFO("pvdfkit " << args << "\nexit " << code << ", stderr: " << err);
      CHECK(code == 2);
      CHECK(err.rfind("error: ", 0) == 0);
      CHECK(std::count(err.begin(), err.end(), '\n') == 1);
      struct stat st {};
      REQUIRE(::stat("/dev/full", &st) == 0);
      CHECK(S_ISCHR(st.st_mode));  // still the device
      CHECK(fs::is_symlink(dir / "link.out"));
      CHECK(fs::read_symlink(dir / "link.out") == "target.txt");
      CHECK(slurp(dir / "target.txt") == target_before);
      if (out != "/dev/full" && out != "link.out") CHECK(slurp(dir / out) == input_before);
      CHECK_FALSE(has_temporary(dir));
    }
  }
  fs::remove_all(dir);
}

// Issue 30 item 5, the lenient side of the stream rows above: without --strict each malformed
// row is skipped with one warning that names its line and quotes at most a short cell (no raw
// control byte, no 20000-character echo), the good rows are located, and the summary counts both.
TEST_CASE("locate --stream skips malformed rows with short, clean warnings and locates the rest", "[hostile][cli][stream]") {
  const fs::path dir = make_fixture_dir("stream");
  const std::string cmd = "cd " + quote(dir.string()) + " && " + quote(PVDFKIT_EXE) +
                          " locate map.h5 --stream < stream_rows.csv >.out 2>.err";
  const int status = std::system(cmd.c_str());
  const std::string out = slurp(dir / ".out"), err = slurp(dir / ".err");
  INFO("stderr: " << err);
  REQUIRE(WIFEXITED(status));
  CHECK(WEXITSTATUS(status) == 0);
  std::vector<std::string> warnings;
  std::istringstream lines(err);
  for (std::string line; std::getline(lines, line);) {
    CHECK(line.size() <= 200);
    if (line.rfind("warning: ", 0) == 0) warnings.push_back(line);
  }
  REQUIRE(warnings.size() == 6);
  CHECK_THAT(warnings[0], Catch::Contains("<stdin>:3: column charge_A_C = 'nan' is not a finite number"));
  CHECK_THAT(warnings[1], Catch::Contains("<stdin>:4: column charge_B_C = 'inf'"));
  CHECK_THAT(warnings[2], Catch::Contains("<stdin>:5: has 2 fields but the header has 4"));
  CHECK_THAT(warnings[3], Catch::Contains("<stdin>:6: column charge_C_C = '1e-\\x0011'"));
  CHECK_THAT(warnings[4], Catch::Contains("<stdin>:7: column charge_B_C = '<cell of 20000 characters>'"));
  CHECK_THAT(warnings[5], Catch::Contains("<stdin>:8: column charge_A_C = '\\x1b[31m'"));
  CHECK_THAT(err, Catch::Contains("located 2 of 8 rows"));
  CHECK_THAT(err, Catch::Contains("6 malformed rows skipped"));
  bool clean = true;
  for (const char c : err) clean = clean && !((static_cast<unsigned char>(c) < 0x20 && c != '\n') || c == 0x7f);
  CHECK(clean);
  CHECK(std::count(out.begin(), out.end(), '\n') == 3);  // the header and the two good rows
  fs::remove_all(dir);
}
