#!/usr/bin/env python3
"""Hostile sweep: hundreds of bad inputs thrown at pvdfkit, each checked against the README's promise.

The promise (README "The `pvdfkit` command"): bad input or usage exits 2 with one line on stderr,
`error: ...`, naming the input, the value and the fix, before any long work; a numerical failure
exits 3 with a status; never a crash, hang, abort, unbounded allocation, NaN or half-written
file; a failed write to stdout is an error. The Python package raises `pvdfkit.InputError` (one
line naming the argument) instead, never a pybind signature dump, a traceback or a NaN result.

Cases are generated, not listed: every subcommand x bad flag values (negative, zero, NaN, inf,
1e308, empty, text, wrong units, wrong counts); malformed scenes (missing keys, wrong types,
absurd physics, mm/GPa typed for m/Pa) x every scene reader; malformed CSVs and map files x every
reader; bad output destinations (/dev/full, a symbolic link, an input, a folder, a read-only
folder, a missing folder) x every writer; damaged map checkpoints; closed and full stdout; the
Python API with NaN, empty and wrongly shaped arrays. Each case runs in a folder of its own
(fixtures hard-linked in) with a timeout and a memory cap, and is classified:

  kept    exit code in the expected set; for exit 2 exactly one `error:` line that names the
          input; no traceback/abort/sanitizer/pybind text; no NaN on stdout; /dev/full still a
          device; no file in the folder created, changed or replaced except the command's output
          on success; finished within its timeout
  broken  anything else (every broken case is listed with the reason)

Usage:
  python3 tests/hostile/hostile_sweep.py --exe build/app/pvdfkit [--python build/python] [--jobs 1]
        [--quick] [--only SUBSTRING] [--list] [--keep]

--quick runs a fixed, deterministic subset (about 60 cases, under a minute; ctest
test_hostile_sweep_quick). Exit status 0 when at least --min-kept (default 0.99) of the cases
keep the promise (--quick: all of them), 1 otherwise.
"""

import argparse
import concurrent.futures
import hashlib
import json
import os
import re
import shutil
import signal
import stat
import struct
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))

# --------------------------------------------------------------------------------------------
# 1. Fixtures: written once into a base folder, hard-linked into each case's folder.
# --------------------------------------------------------------------------------------------

SMALL_SCENE = {
    "membrane": {"shape": "circle", "radius_m": 0.010, "thickness_m": 25e-6},
    "material": {"E1_Pa": 2.2e9, "E2_Pa": 1.8e9, "G12_Pa": 0.58e9, "nu12": 0.35,
                 "draw_angle_deg": 0.0, "d31_C_per_N": 6.5e-12, "d32_C_per_N": 0.65e-12},
    "electrodes": [
        {"name": "A", "center_m": [0.0, 0.004], "size_m": [0.0015, 0.0015]},
        {"name": "B", "center_m": [-0.0035, -0.002], "size_m": [0.0015, 0.0015]},
        {"name": "C", "center_m": [0.0035, -0.002], "size_m": [0.0015, 0.0015]},
    ],
    "probe": {"radius_m": 0.001},
    "model": {"kinematics": "auto", "tolerance": 0.02, "max_refinements": 0},
}

CHARGES = "2.4925e-12,1.87487e-11,1.87487e-11"
MAP_ARGS = ["--spacing-m", "0.004", "--setup-checks", "0", "--threads", "1", "--quiet", "--tolerance", "0.3"]
CKPT_ARGS = ["--spacing-m", "0.002", "--region", "-0.004,0.004,-0.002,0.002", "--setup-checks", "0",
             "--threads", "1", "--quiet"]


def patched(patch):
    """SMALL_SCENE with a JSON merge patch applied (None deletes a key)."""
    def merge(a, b):
        if not isinstance(b, dict) or not isinstance(a, dict):
            return b
        out = dict(a)
        for k, v in b.items():
            if v is None:
                out.pop(k, None)
            else:
                out[k] = merge(out.get(k), v)
        return out
    return merge(json.loads(json.dumps(SMALL_SCENE)), patch)


# Malformed scenes: (file stem, patch or raw text, text the error must name).
SCENES = [
    # missing keys
    ("no_membrane", {"membrane": None}, "membrane"),
    ("no_material", {"material": None}, "material"),
    ("no_radius", {"membrane": {"radius_m": None}}, "radius_m"),
    ("no_thickness", {"membrane": {"thickness_m": None}}, "thickness_m"),
    ("no_E1", {"material": {"E1_Pa": None}}, "material"),
    ("no_d31", {"material": {"d31_C_per_N": None}}, "d31"),
    ("no_e_center", {"electrodes": [{"name": "A", "size_m": [0.0015, 0.0015]}]}, "electrodes[0]"),
    ("no_e_name", {"electrodes": [{"center_m": [0.0, 0.004], "size_m": [0.0015, 0.0015]}]}, "electrodes[0]"),
    # wrong types
    ("str_thickness", {"membrane": {"thickness_m": "25e-6"}}, "thickness_m"),
    ("bool_radius", {"membrane": {"radius_m": True}}, "radius_m"),
    ("list_E1", {"material": {"E1_Pa": [2.2e9]}}, "E1_Pa"),
    ("obj_nu12", {"material": {"nu12": {"value": 0.35}}}, "nu12"),
    ("num_electrodes", {"electrodes": 3}, "electrodes"),
    ("str_membrane", {"membrane": "circle"}, "membrane"),
    ("center_3", {"electrodes": [{"name": "A", "center_m": [0, 0.004, 0], "size_m": [0.0015, 0.0015]}]}, "center_m"),
    ("center_str", {"electrodes": [{"name": "A", "center_m": ["0", "0.004"], "size_m": [0.0015, 0.0015]}]}, "center_m"),
    ("shape_hexagon", {"membrane": {"shape": "hexagon"}}, "shape"),
    ("kinematics_magic", {"model": {"kinematics": "magic"}}, "kinematics"),
    ("name_int", {"electrodes": [{"name": 7, "center_m": [0, 0.004], "size_m": [0.0015, 0.0015]}]}, "name"),
    ("dup_names", {"electrodes": [{"name": "A", "center_m": [0.0, 0.004], "size_m": [0.0015, 0.0015]},
                                  {"name": "A", "center_m": [-0.0035, -0.002], "size_m": [0.0015, 0.0015]}]}, "electrodes[1]"),
    ("no_electrodes", {"electrodes": []}, "electrodes"),
    # absurd physics
    ("thickness_neg", {"membrane": {"thickness_m": -25e-6}}, "thickness_m"),
    ("thickness_zero", {"membrane": {"thickness_m": 0}}, "thickness_m"),
    ("thickness_1m", {"membrane": {"thickness_m": 1.0}}, "thickness_m"),
    ("thickness_1e-15", {"membrane": {"thickness_m": 1e-15}}, "thickness_m"),
    ("radius_neg", {"membrane": {"radius_m": -0.01}}, "radius_m"),
    ("radius_1e308", {"membrane": {"radius_m": 1e308}}, "radius_m"),
    ("E1_zero", {"material": {"E1_Pa": 0}}, "E1_Pa"),
    ("E1_neg", {"material": {"E1_Pa": -2.2e9}}, "E1_Pa"),
    ("E_all_1e-30", {"material": {"E1_Pa": 1e-30, "E2_Pa": 1e-30, "G12_Pa": 1e-30}}, "E1_Pa"),
    ("E2_milli", {"material": {"E2_Pa": 2.2e-3}}, "E2_Pa"),
    ("E1_1e20", {"material": {"E1_Pa": 1e20}}, "E1_Pa"),
    ("G12_neg", {"material": {"G12_Pa": -1}}, "G12_Pa"),
    ("nu12_neg", {"material": {"nu12": -0.99}}, "nu12"),
    ("nu12_5", {"material": {"nu12": 5}}, "nu12"),
    ("pretension_-1e9", {"membrane": {"pretension_N_per_m": -1e9}}, "pretension_N_per_m"),
    ("pretension_1e9", {"membrane": {"pretension_N_per_m": 1e9}}, "pretension_N_per_m"),
    ("draw_1e308", {"material": {"draw_angle_deg": 1e308}}, "draw_angle_deg"),
    ("d31_1e10", {"material": {"d31_C_per_N": 1e10}}, "d31_C_per_N"),
    ("probe_zero", {"probe": {"radius_m": 0}}, "probe.radius_m"),
    ("probe_neg", {"probe": {"radius_m": -0.001}}, "probe.radius_m"),
    ("probe_film", {"probe": {"radius_m": 0.01}}, "probe.radius_m"),
    ("e_size_zero", {"electrodes": [{"name": "A", "center_m": [0, 0.004], "size_m": [0, 0.0015]}]}, "size_m"),
    ("e_outside", {"electrodes": [{"name": "A", "center_m": [0, 0.02], "size_m": [0.0015, 0.0015]}]}, "electrodes[0]"),
    ("tolerance_neg", {"model": {"tolerance": -0.02}}, "tolerance"),
    ("max_ref_1e9", {"model": {"max_refinements": 1000000000}}, "max_refinements"),
    ("load_force_neg", {"loads": [{"position_m": [0, 0], "force_N": -1}]}, "force_N"),
    ("load_force_1e-300", {"loads": [{"position_m": [0, 0], "force_N": 1e-300}]}, "force_N"),
    ("load_outside", {"loads": [{"position_m": [0, 0.05], "force_N": 1}]}, "loads[0]"),
    # wrong units: mm, um, GPa, pC typed where the key says m, Pa, C/N
    ("radius_mm", {"membrane": {"radius_m": 10}}, "radius_m"),
    ("thickness_um", {"membrane": {"thickness_m": 25}}, "thickness_m"),
    ("E_GPa", {"material": {"E1_Pa": 2.2, "E2_Pa": 1.8, "G12_Pa": 0.58}}, "E1_Pa"),
    ("d31_pC", {"material": {"d31_C_per_N": 6.5, "d32_C_per_N": 0.65}}, "d31_C_per_N"),
    ("e_center_mm", {"electrodes": [{"name": "A", "center_m": [0, 4], "size_m": [0.0015, 0.0015]}]}, "electrodes[0]"),
    ("probe_mm", {"probe": {"radius_m": 1}}, "probe.radius_m"),
    # syntax
    ("trunc", "TRUNC", "trunc.json"),
    ("empty", "", "empty.json"),
    ("bytes", b"\x00\x01\xff\xfe\x1b[2J\x7f", "bytes.json"),
    ("nan_literal", '{"membrane": {"radius_m": NaN}}', "nan_literal.json"),
    ("toplevel_list", "[1, 2, 3]", "toplevel_list.json"),
]

GOOD_FIT_CSV = "x_m,y_m,force_N,deflection_m\n0,0,1,0.0004\n0.002,0,1,0.0003\n"
MEAS_HEAD = "x_m,y_m,force_N,charge_A_C,charge_B_C,charge_C_C\n"
MEAS_ROW = "0.002,0.001,1,2e-12,1.8e-11,1.9e-11\n"
MEAS_OK = MEAS_ROW + "-0.005,0.004,1,3e-12,1.2e-11,1.1e-11\n0.01,-0.006,1,2.5e-12,1.5e-11,2.1e-11\n" \
    "0,0.015,1,4e-12,1.1e-11,1.2e-11\n"
STREAM_HEAD = "t_s,charge_A_C,charge_B_C,charge_C_C\n"
STREAM_ROW = "0," + CHARGES + "\n"
SCAN_HEAD = "x_m,m1_V,m2_V\n"


def csv_variants(head, row, prefix):
    """Malformed variants of a CSV with header `head` and one good row `row`: (stem, bytes)."""
    cols = head.strip().split(",")
    cells = row.strip().split(",")
    v = [
        ("empty", b""),
        ("header_only", head.encode()),
        ("nan", (head + ",".join(cells[:-1] + ["nan"]) + "\n").encode()),
        ("inf", (head + ",".join(["inf"] + cells[1:]) + "\n").encode()),
        ("text_cell", (head + ",".join(cells[:-1] + ["abc"]) + "\n").encode()),
        ("random_bytes", bytes((i * 73 + 11) % 256 for i in range(4000))),
        ("few_fields", (head + ",".join(cells[:2]) + "\n").encode()),
        ("many_fields", (head + row.strip() + ",1,2,3\n").encode()),
        ("missing_col", (",".join(cols[:-1]) + "\n" + ",".join(cells[:-1]) + "\n").encode()),
        ("dup_col", (head.strip() + "," + cols[-1] + "\n" + row.strip() + "," + cells[-1] + "\n").encode()),
        ("nul", (head + row.replace(",", ",\x00", 1)).encode()),
        ("big_cell", (head + ",".join(cells[:-1] + ["7" * 60000]) + "\n").encode()),
        ("e400", (head + ",".join(cells[:-1] + ["1e400"]) + "\n").encode()),
        ("no_header", (row * 3).encode()),
    ]
    return [(prefix + "_" + s, b) for s, b in v]


def write(path, data):
    with open(path, "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def run_quiet(args, cwd, timeout=300):
    p = subprocess.run(args, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, timeout=timeout)
    if p.returncode != 0:
        raise SystemExit("fixture command failed: %s\n%s" % (" ".join(args), p.stderr.decode(errors="replace")))


def make_fixtures(base, exe, need_checkpoint):
    write(os.path.join(base, "s.json"), json.dumps(SMALL_SCENE, indent=1))
    good = json.dumps(SMALL_SCENE, indent=1)
    for stem, patch, _ in SCENES:
        p = os.path.join(base, stem + ".json")
        if patch == "TRUNC":
            write(p, good[: len(good) // 2])
        elif isinstance(patch, (str, bytes)):
            write(p, patch)
        else:
            write(p, json.dumps(patched(patch), indent=1))
    run_quiet([exe, "synthetic-map", "-o", "map.h5", "--spacing-m", "0.002"], base)
    with open(os.path.join(base, "map.h5"), "rb") as f:
        m = f.read()
    write(os.path.join(base, "map_trunc.h5"), m[: len(m) // 2])
    write(os.path.join(base, "map_empty.h5"), b"")
    write(os.path.join(base, "map_bytes.h5"), bytes((i * 31 + 7) % 256 for i in range(8192)))
    write(os.path.join(base, "map_json.h5"), good)
    write(os.path.join(base, "fit_ok.csv"), GOOD_FIT_CSV)
    write(os.path.join(base, "meas_ok.csv"), MEAS_HEAD + MEAS_OK)
    write(os.path.join(base, "stream_ok.csv"), STREAM_HEAD + STREAM_ROW)
    write(os.path.join(base, "scan_ok.csv"), SCAN_HEAD + "".join("%g,0,0\n" % (i * 1e-3) for i in range(32)))
    for head, row, prefix in ((MEAS_HEAD, MEAS_ROW, "meas"), ("x_m,y_m,force_N,deflection_m\n", "0,0,1,0.0004\n", "fit"),
                              (STREAM_HEAD, STREAM_ROW, "stream"), (SCAN_HEAD, "0.001,0.1,0.2\n", "scan")):
        for stem, data in csv_variants(head, row, prefix):
            write(os.path.join(base, stem + ".csv"), data)
    # a million rows: the readers must refuse (bounded), not parse them all
    with open(os.path.join(base, "meas_1e6.csv"), "w") as f:
        f.write(MEAS_HEAD)
        f.write(MEAS_ROW * 1000000)
    with open(os.path.join(base, "fit_1e6.csv"), "w") as f:
        f.write("x_m,y_m,force_N,deflection_m\n")
        f.write("0,0,1,0.0004\n" * 1000000)
    # unit mistakes in CSVs: mm positions, pC charges, mN forces
    write(os.path.join(base, "meas_mm.csv"), MEAS_HEAD + "2,1,1,2e-12,1.8e-11,1.9e-11\n")
    write(os.path.join(base, "meas_pC.csv"), MEAS_HEAD + "0.002,0.001,1,2,18,19\n")
    write(os.path.join(base, "meas_mN.csv"), MEAS_HEAD + "0.002,0.001,1000000,2e-12,1.8e-11,1.9e-11\n")
    write(os.path.join(base, "fit_mm.csv"), "x_m,y_m,force_N,deflection_m\n0,0,1,0.4\n2,0,1,0.3\n")
    write(os.path.join(base, "fit_neg_force.csv"), "x_m,y_m,force_N,deflection_m\n0,0,-1,0.0004\n")
    write(os.path.join(base, "stream_pC.csv"), STREAM_HEAD + "0,2.49,18.7,18.7\n")
    # restore inputs
    shutil.copy(os.path.join(REPO, "examples", "restore", "scanner.json"), os.path.join(base, "scanner.json"))
    write(os.path.join(base, "filter_ok.json"), json.dumps({
        "format": "pvdfkit-restore-filter", "format_version": 1, "sample_spacing_m": 0.001, "taps": 2,
        "delay_samples": 1, "beta": {}, "filters": {"h11": [1, 0], "h12": [0, 0], "h21": [0, 0], "h22": [0, 1]}}))
    write(os.path.join(base, "filter_nan.json"), '{"format": "pvdfkit-restore-filter", "format_version": 1, '
          '"sample_spacing_m": 0.001, "taps": 2, "delay_samples": 1, "beta": {}, '
          '"filters": {"h11": [NaN, 0], "h12": [0, 0], "h21": [0, 0], "h22": [0, 1]}}')
    write(os.path.join(base, "filter_taps.json"), json.dumps({
        "format": "pvdfkit-restore-filter", "format_version": 1, "sample_spacing_m": 0.001, "taps": 1000000000,
        "delay_samples": 1, "beta": {}, "filters": {"h11": [1, 0], "h12": [0, 0], "h21": [0, 0], "h22": [0, 1]}}))
    write(os.path.join(base, "target.txt"), "the link's target: must stay unchanged\n")
    if need_checkpoint:
        # a checkpoint of a 5 x 3 map of the small film stopped after 4 solved positions
        subprocess.run([exe, "map", "s.json", "-o", "ck.h5", "--checkpoint", "ck0"] + CKPT_ARGS +
                       ["--stop-after-positions", "4"], cwd=base, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL, timeout=300)
        if not os.path.exists(os.path.join(base, "ck0")):
            raise SystemExit("fixture: the map checkpoint ck0 was not written")
        with open(os.path.join(base, "ck0"), "rb") as f:
            ck = bytearray(f.read())
        for stem, data in checkpoint_variants(ck):
            write(os.path.join(base, stem), data)


def fnv1a(data):
    h = 0xcbf29ce484222325
    for b in data:
        h = ((h ^ b) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
    return h


def checkpoint_variants(ck):
    """Damaged copies of a map checkpoint (docs/map-generation.md §7): (file name, bytes)."""
    start = ck.index(b"\nchecksum ") + 1
    data = ck.index(b"\n", start) + 1
    out = []
    n = len(ck)
    for cut in (0, 1, 10, start, data, data + 7, (data + n) // 2, n - 9, n - 1):
        out.append(("ck_trunc_%d" % cut, bytes(ck[:cut])))
    for off in (0, 5, start + 12, data, data + 8, data + 50, (data + n) // 2, n - 5, n - 1):
        d = bytearray(ck)
        d[off] ^= 0x01
        out.append(("ck_flip_%d" % off, bytes(d)))

    def resummed(d):
        h = fnv1a(bytes(d[:start]) + bytes(d[data:]))
        return bytes(d[:start]) + b"checksum %016x\n" % h + bytes(d[data:])

    for name, value in (("nan", float("nan")), ("inf", float("inf")), ("one_coulomb", 1.0), ("neg", -1e-9)):
        d = bytearray(ck)
        d[data + 48:data + 56] = struct.pack("d", value)
        out.append(("ck_edit_%s" % name, bytes(d)))
        out.append(("ck_resum_%s" % name, resummed(d)))
    d = bytearray(ck)
    d[data:data + 8] = struct.pack("d", 1e12)  # grid index far outside the grid
    out.append(("ck_resum_index", resummed(d)))
    txt = bytes(ck)
    for name, old, new in (("count_1e10", rb"\nrecords \d+\n", b"\nrecords 10000000000\n"),
                           ("count_neg", rb"\nrecords \d+\n", b"\nrecords -3\n"),
                           ("format_2", rb"pvdfkit-map-checkpoint 3", b"pvdfkit-map-checkpoint 2"),
                           ("format_99", rb"pvdfkit-map-checkpoint 3", b"pvdfkit-map-checkpoint 99")):
        out.append(("ck_" + name, re.sub(old, new, txt, count=1)))
    out.append(("ck_no_newline", txt[:10] + b"x" * 1000000))
    out.append(("ck_bytes", bytes((i * 97 + 3) % 256 for i in range(5000))))
    out.append(("ck_json", b'{"format": "pvdfkit-map-checkpoint"}'))
    out.append(("ck_doubled", txt + txt[data:]))
    return out


# --------------------------------------------------------------------------------------------
# 2. Cases.
# --------------------------------------------------------------------------------------------


class Case:
    def __init__(self, cat, cid, argv=None, shell=None, python=None, expect=(2,), names=None, outputs=(),
                 timeout=30, stdin=None, unprivileged=False, check_stdout_nan=True, outputs_on_failure=False):
        self.cat, self.id, self.argv, self.shell, self.python = cat, cid, argv, shell, python
        self.expect, self.outputs, self.timeout, self.stdin = set(expect), set(outputs), timeout, stdin
        self.names = [names] if isinstance(names, str) else list(names or [])
        self.unprivileged, self.check_stdout_nan = unprivileged, check_stdout_nan
        self.outputs_on_failure = outputs_on_failure


def numeric_bad_values(lo, hi, lo_open=False, integer=False, zero_ok=None):
    """Values outside [lo, hi] (or (lo, hi]) or not numbers at all, from a fixed pool."""
    pool = ["-1", "0", "nan", "inf", "1e308", "1e-320", "", "abc", "5e5"]
    if integer:
        pool += ["1.5", "99999999999999999999"]
    bad = []
    for v in pool:
        try:
            x = float(v) if not v.startswith("0x") else None
        except ValueError:
            x = None
        if x is None or x != x or x in (float("inf"), float("-inf")):
            bad.append(v)
            continue
        if integer and not float(x).is_integer():
            bad.append(v)
            continue
        if integer and abs(x) > 2 ** 62:
            bad.append(v)
            continue
        if x < lo or x > hi or (lo_open and x == lo):
            bad.append(v)
    return bad


def flag_cases():
    """Every subcommand's numeric and list flags with values outside their documented range."""
    C = []
    loc = ["locate", "map.h5", "--charges-C", CHARGES]
    mp = ["map", "s.json", "-o", "o.h5"] + ["--quiet", "--threads", "1"]
    # (base argv, flag, lo, hi, lo_open, integer)
    numeric = [
        (["solve", "s.json"], "--tolerance", 1e-8, 0.5, False, False),
        (["solve", "s.json"], "--max-refinements", 0, 20, False, True),
        (mp, "--spacing-m", 1e-5, 0.1, False, False),
        (mp, "--tolerance", 1e-8, 0.5, False, False),
        (mp, "--threads", 0, 1024, False, True),
        (mp, "--rim-margin-m", 0, 1, False, False),
        (mp, "--scaling-check-stride", 1, 1000, False, True),
        (mp, "--setup-checks", 0, 3, False, True),
        (mp, "--adaptive-levels", 1, 5, False, True),
        (mp, "--stop-after-positions", 1, 1e9, False, True),
        (loc, "--force-N", 0, 1e4, True, False),
        (["rays", "map.h5"], "--force-N", 0, 1e4, True, False),
        (["rays", "map.h5"], "--angle-step-deg", 0.01, 360, False, False),
        (["rays", "map.h5"], "--d-min-m", 0, 10, True, False),
        (["rays", "map.h5"], "--d-max-m", 0, 10, True, False),
        (["rays", "map.h5"], "--n-samples", 2, 100000, False, True),
        (["rays", "map.h5"], "--min-points", 2, 100000, False, True),
        (["rays", "map.h5"], "--angle-tolerance-deg", 0, 180, True, False),
        (["synthetic-map", "-o", "o.h5"], "--spacing-m", 1e-4, 0.02, False, False),
        (["synthetic-map", "-o", "o.h5"], "--rim-margin-m", 0, 1, False, False),
        (["synthetic-map", "-o", "o.h5"], "--noise-C", 0, 1e-6, True, False),
        (["lookup-accuracy", "map.h5"], "--presses", 10, 1e6, False, True),
        (["lookup-accuracy", "map.h5"], "--radius-m", 0, 10, True, False),
        (["lookup-accuracy", "map.h5"], "--seed", 0, 2 ** 32 - 1, False, True),
        (["isocharge", "map.h5", "--out-dir", "iso"], "--force-N", 0, 1e4, True, False),
        (["isocharge", "map.h5", "--out-dir", "iso"], "--zoom-m", 0, 10, False, False),
        (["compare", "map.h5", "meas_ok.csv"], "--min-map-charge-C", 0, 1e-3, False, False),
        (["fit", "s.json", "fit_ok.csv", "-o", "f.json"], "--tolerance", 1e-8, 0.5, False, False),
        (["fit", "s.json", "fit_ok.csv", "-o", "f.json"], "--max-iterations", 1, 10000, False, True),
        (["fit", "s.json", "fit_ok.csv", "-o", "f.json"], "--residual-stiffness", 0, 0.999999, False, False),
        (["mesh", "s.json", "-o", "k.msh"], "--size-factor", 0.01, 100, False, False),
        (["restore", "apply", "filter_ok.json", "scan_ok.csv", "-o", "r.csv"], "--mu-threshold-N", 0, 1e300, False, False),
        (["restore", "apply", "filter_ok.json", "scan_ok.csv", "-o", "r.csv"], "--block", 1, 1e9, False, True),
        (["restore", "apply", "filter_ok.json", "scan_ok.csv", "-o", "r.csv"], "--speed-m-per-s", 0, 1e3, False, False),
        (["restore", "apply", "filter_ok.json", "scan_ok.csv", "-o", "r.csv"], "--baseline-scale-m", 0, 10, True, False),
        (["acquire", "--device", "sim:", "--quiet", "--duration-s", "0.01"], "--gain-mV-per-pC", 0, 1e6, True, False),
        (["acquire", "--device", "sim:", "--quiet"], "--duration-s", 0, 1e6, False, False),
        (["acquire", "--device", "sim:", "--quiet", "--duration-s", "0.01"], "--stall-timeout-s", 0, 1e6, True, False),
        (["acquire", "--device", "sim:", "--quiet", "--duration-s", "0.01"], "--transfers", 1, 1024, False, True),
    ]
    for base, flag, lo, hi, lo_open, integer in numeric:
        for v in numeric_bad_values(lo, hi, lo_open, integer):
            cmd = base[0] if base[0] != "restore" else "restore-apply"
            C.append(Case("flags", "%s %s=%r" % (cmd, flag, v), argv=base + [flag, v], names=[flag] + ([v] if len(v) > 2 else []),
                          outputs=("o.h5", "f.json", "k.msh", "k.png", "r.csv", "iso")))
    # list and text flags: wrong counts, units, NaN, order
    lists = [
        (["solve", "s.json"], "--load", ["0,0", "0,0,1,2", "nan,0,1", "0,0,inf", "0,0,-1", "0,0,0", "5,0,1",
                                          "0,0,1e9", "", "a,b,c", "0;0;1", "1e308,0,1"]),
        (["solve", "s.json", "--load", "0,0,1"], "--sample", ["0", "0,0,0", "nan,0", "0.5,0", "", "x,y"]),
        (["solve", "s.json"], "--model", ["magic", "", "LINEAR "]),
        (["solve", "s.json"], "--refinement", ["magic", ""]),
        (mp, "--forces-N", ["", "0", "-1", "nan", "inf", "1e-300", "1e5", "1,1", "1,1.0000000000000002", "a,b", "1,,2"]),
        (mp, "--region", ["", "0,0,0,0", "1,2,3", "1,2,3,4,5", "nan,0,0,1", "-1e10,1e10,-1e10,1e10", "-5,5,-5,5",
                          "0.001,-0.001,-0.001,0.001"]),
        (mp, "--noise-C", ["", "0,0,0", "-1e-14,5e-14,5e-14", "5e-14,5e-14", "nan,5e-14,5e-14", "0.05,0.05,0.05",
                           "5e-14,5e-14,5e-14,5e-14"]),
        (mp, "--model", ["magic", ""]),
        (mp, "--placement", ["magic", ""]),
        (mp, "--rim-model", ["magic", ""]),
        (mp, "--direct-solves", ["magic"]),
        (mp, "--probe-refinement", ["coarse", ""]),
        (loc[:2], "--charges-C", ["", "1e-11,2e-11", "nan,1e-11,1e-11", "inf,1e-11,1e-11", "146.1,165.1,160.2",
                                   "1e-11,2e-11,3e-11,4e-11", "a,b,c", "1e300,1e300,1e300", "0,0,0"]),
        (loc, "--noise-C", ["", "0", "-1e-14", "nan", "1e-14,1e-14", "1", "inf"]),
        (loc, "--force-range-N", ["", "2,1", "0,1", "-1,1", "nan,1", "1", "1,2,3", "1,inf"]),
        (["lookup-accuracy", "map.h5"], "--noise-C", ["", "-1e-14", "nan", "0", "1e-14,,1e-14", "inf"]),
        (["synthetic-map", "-o", "o.h5"], "--forces-N", ["", "0", "-1", "nan", "1,1", "1e5", "1e-300"]),
        (["rays", "map.h5"], "--plot-angles-deg", ["", "nan", "a,b", "1e308"]),
        (["rays", "map.h5", "--plot", "r.png"], "--electrode", ["Z", ""]),
        (["isocharge", "map.h5", "--out-dir", "iso"], "--charges-C", ["", "1e-11", "nan,1e-11,1e-11", "1,2,3"]),
        (["isocharge", "map.h5", "--out-dir", "iso"], "--at-m", ["", "0", "nan,0", "5,5", "1e308,0"]),
        (["fit", "s.json", "fit_ok.csv", "-o", "f.json"], "--params", ["", "magic", "E_scale,E_scale", ",", "E_scale,,"]),
        (["fit", "s.json", "fit_ok.csv", "-o", "f.json"], "--start", ["", "E_scale=nan", "E_scale=-1", "E_scale",
                                                                       "magic=1", "E_scale=1e308", "E_scale=abc"]),
        (["moduli"], "--angles-deg", ["", "0:0:90", "0:-5:90", "nan:1:2", "0:1e-9:90", "0:5", "a:b:c", "90:5:0",
                                      "0:5:1e308"]),
        (["export-map", "map.h5", "-o", "x.flat"], "--format", ["magic", ""]),
        (["export-map", "map.h5", "-o", "x.h"], "--symbol", ["", "1abc", "a b", "a;b"]),
        (["calibrate", "map.h5", "meas_ok.csv", "-o", "cal.h5"], "--noise-C", ["", "-1", "nan", "1e-14,1e-14"]),
        (["acquire", "--quiet", "--duration-s", "0.01"], "--device", ["", "magic", "usb:zz:yy", "replay:", "replay:nofile",
                                                                       "sim:nofile.json", "usb:12", "serial:/dev/ttyS0"]),
        (["acquire", "--device", "sim:", "--quiet", "--duration-s", "0.01"], "--channels", ["", "a", "-1", "0,0", "99"]),
        (["acquire", "--device", "sim:", "--quiet", "--duration-s", "0.01"], "--rate-Hz", ["-1", "nan", "1e308"]),
        (["acquire", "--device", "sim:", "--quiet", "--duration-s", "0.01"], "--force-range-N", ["2,1", "nan,1", "a"]),
        (["acquire", "--device", "sim:", "--quiet", "--duration-s", "0.01"], "--locate", ["nofile.h5", "map_bytes.h5", "."]),
        (["acquire", "--device", "sim:", "--quiet", "--duration-s", "0.01"], "--restore", ["nofile.json", "filter_nan.json"]),
    ]
    for base, flag, values in lists:
        for v in values:
            cmd = base[0]
            # zero charges are no press: the lookup's "no_press" status (exit 3) is the answer
            expect = (2, 3) if flag == "--charges-C" and v == "0,0,0" else (2,)
            C.append(Case("flags", "%s %s=%r" % (cmd, flag, v[:40]), argv=base + [flag, v], expect=expect,
                          names=[flag] + ([v, v.split(":")[-1]] if len(v) > 2 else []) + (["'.'", ".:"] if v == "." else []),
                          outputs=("o.h5", "f.json", "x.flat", "x.h", "cal.h5", "iso", "r.png")))
    # repeated single-valued flags, unknown flags, missing arguments
    for base, flag, a, b in ((mp, "--spacing-m", "0.004", "0.002"), (["solve", "s.json"], "--tolerance", "0.1", "0.2"),
                             (["fit", "s.json", "fit_ok.csv", "-o", "f.json"], "--start", "E_scale=1", "E_scale=2"),
                             (loc, "--force-N", "1", "2"), (["rays", "map.h5"], "--force-N", "1", "2")):
        C.append(Case("flags", "%s %s twice" % (base[0], flag), argv=base + [flag, a, flag, b], names=flag,
                      outputs=("o.h5", "f.json")))
    for cmd in ("solve", "map", "locate", "export-map", "fit", "compare", "calibrate", "mesh", "rays", "synthetic-map",
                "isocharge", "lookup-accuracy", "moduli", "acquire", "design"):
        C.append(Case("flags", "%s --bogus" % cmd, argv=[cmd, "--bogus"], names=["--bogus", "required", "bogus"]))
        if cmd not in ("moduli", "mesh", "acquire", "synthetic-map"):
            C.append(Case("flags", "%s no args" % cmd, argv=[cmd], names=["required", "--"]))
    C.append(Case("flags", "unknown command", argv=["frobnicate"], names="frobnicate"))
    C.append(Case("flags", "no command", argv=[], names="command"))
    C.append(Case("flags", "restore no subcommand", argv=["restore"], names=["restore", "subcommand"]))
    return C


MATERIAL_ONLY = ("no_E1", "no_d31", "str_thickness_", "list_E1", "obj_nu12", "E1_zero", "E1_neg", "E_all_1e-30", "E2_milli",
                 "E1_1e20", "G12_neg", "nu12_neg", "nu12_5", "draw_1e308", "d31_1e10", "E_GPa", "d31_pC", "no_material")
MISSING_WITH_DEFAULTS = ("no_membrane", "no_material", "no_radius", "no_thickness", "no_E1", "no_d31", "no_e_name")

SCENE_READERS = [
    ("solve", lambda f: ["solve", f], ()),
    ("map", lambda f: ["map", f, "-o", "o.h5"] + MAP_ARGS, ("o.h5",)),
    ("mesh", lambda f: ["mesh", f, "-o", "k.msh", "--no-preview"], ("k.msh",)),
    ("fit", lambda f: ["fit", f, "fit_ok.csv", "-o", "f.json", "--quiet"], ("f.json",)),
    ("moduli", lambda f: ["moduli", "--scene", f], ()),
]


def scene_cases():
    C = []
    for stem, _, names in SCENES:
        for cmd, argv, outs in SCENE_READERS:
            expect = (2,)
            if stem == "no_electrodes" and cmd != "map":
                expect = (0, 2)  # a film without electrodes still deflects (solve, mesh, a deflection fit)
            if cmd == "mesh" and stem in MATERIAL_ONLY:
                expect = (0, 2)  # the mesh does not depend on the material
            if stem in MISSING_WITH_DEFAULTS:
                # docs/scene.md gives these keys defaults (the seed-001 film): the reader may fill
                # them in; map and fit would then do a whole film's work, so only the cheap readers
                if cmd in ("map", "fit"):
                    continue
                expect = (0, 2)
            # moduli reads the material only; a scene whose material is fine may pass
            if cmd == "moduli" and not (names.startswith(("E", "G12", "nu12", "material", "draw", "d31", "no_material"))
                                        or stem in ("trunc", "empty", "bytes", "nan_literal", "toplevel_list",
                                                    "E_GPa", "d31_pC", "no_E1", "no_d31", "list_E1", "obj_nu12")):
                expect = (0, 2)
            C.append(Case("scenes", "%s %s" % (cmd, stem), argv=argv(stem + ".json"), expect=expect,
                          names=[names, stem + ".json"], timeout=60, outputs=outs))
    for cmd, argv, outs in SCENE_READERS:
        C.append(Case("scenes", "%s missing file" % cmd, argv=argv("nofile.json"), names="nofile.json"))
        C.append(Case("scenes", "%s folder as scene" % cmd, argv=argv("realdir"), names="realdir"))
    return C


def csv_cases():
    C = []
    readers = [
        ("compare", lambda f: ["compare", "map.h5", f], "meas", ()),
        ("calibrate", lambda f: ["calibrate", "map.h5", f, "-o", "cal.h5"], "meas", ("cal.h5",)),
        ("rays --measured", lambda f: ["rays", "map.h5", "--plot", "r.png", "--measured", f], "meas", ("r.png",)),
        ("fit", lambda f: ["fit", "s.json", f, "-o", "f.json", "--quiet"], "fit", ("f.json",)),
        ("locate --input --strict", lambda f: ["locate", "map.h5", "--input", f, "--strict"], "stream", ()),
        ("restore apply", lambda f: ["restore", "apply", "filter_ok.json", f, "-o", "r.csv"], "scan", ("r.csv",)),
    ]
    for cmd, argv, prefix, outs in readers:
        for stem, _ in csv_variants("a\n", "1\n", prefix):
            expect = (2,)
            if prefix == "stream" and stem.endswith(("many_fields",)):
                expect = (2,)
            if stem.endswith("no_header") or stem.endswith("header_only") and prefix == "stream":
                expect = (0, 2)  # no rows: nothing located is a valid (empty) answer for a stream
            if stem.endswith("many_fields") and prefix != "stream":
                expect = (0, 2)  # extra unnamed cells may be ignored
            C.append(Case("csv", "%s %s" % (cmd, stem), argv=argv(stem + ".csv"), expect=expect,
                          names=[stem + ".csv"], timeout=60))
        C.append(Case("csv", "%s missing file" % cmd, argv=argv("nofile.csv"), names="nofile.csv"))
        C.append(Case("csv", "%s folder" % cmd, argv=argv("realdir"), names="realdir"))
    for cmd, argv, f in (("compare", lambda f: ["compare", "map.h5", f], "meas_1e6.csv"),
                         ("calibrate", lambda f: ["calibrate", "map.h5", f, "-o", "cal.h5"], "meas_1e6.csv"),
                         ("fit", lambda f: ["fit", "s.json", f, "-o", "f.json"], "fit_1e6.csv")):
        C.append(Case("csv", "%s 1e6 rows" % cmd, argv=argv(f), names=f, timeout=20))
    for cmd, argv, f, n in (("compare", lambda f: ["compare", "map.h5", f], "meas_mm.csv", "meas_mm.csv"),
                            ("compare", lambda f: ["compare", "map.h5", f], "meas_pC.csv", "meas_pC.csv"),
                            ("compare", lambda f: ["compare", "map.h5", f], "meas_mN.csv", "meas_mN.csv"),
                            ("calibrate", lambda f: ["calibrate", "map.h5", f, "-o", "cal.h5"], "meas_mm.csv", "meas_mm.csv"),
                            ("calibrate", lambda f: ["calibrate", "map.h5", f, "-o", "cal.h5"], "meas_pC.csv", "meas_pC.csv"),
                            ("fit", lambda f: ["fit", "s.json", f, "-o", "f.json"], "fit_mm.csv", "fit_mm.csv"),
                            ("fit", lambda f: ["fit", "s.json", f, "-o", "f.json"], "fit_neg_force.csv", "fit_neg_force.csv"),
                            ("locate --strict", lambda f: ["locate", "map.h5", "--input", f, "--strict"], "stream_pC.csv",
                             "stream_pC.csv")):
        expect = (2,)
        if f == "meas_mm.csv":
            expect = (2, 3)  # the presses lie outside the map: an "outside" answer (exit 3) is a status
        if f == "stream_pC.csv":
            expect = (0, 2)  # a stream reports each row's failure as flags (docs/lookup.md)
        C.append(Case("csv", "%s %s" % (cmd, f), argv=argv(f), names=n, timeout=60, expect=expect))
    # stdin stream (lenient): malformed rows skipped with a warning, no NaN in the located rows
    for stem, _ in csv_variants("a\n", "1\n", "stream"):
        C.append(Case("csv", "locate --stream <%s" % stem, argv=["locate", "map.h5", "--stream"], stdin=stem + ".csv",
                      expect=(0, 2), names=["<stdin>", "stream"], timeout=30))
    # map files: missing, empty, truncated, random bytes, JSON, a folder x every map reader
    map_readers = [
        ("locate", lambda f: ["locate", f, "--charges-C", CHARGES]),
        ("export-map", lambda f: ["export-map", f, "-o", "x.flat"]),
        ("compare", lambda f: ["compare", f, "meas_ok.csv"]),
        ("calibrate", lambda f: ["calibrate", f, "meas_ok.csv", "-o", "cal.h5"]),
        ("rays", lambda f: ["rays", f]),
        ("isocharge", lambda f: ["isocharge", f, "--out-dir", "iso"]),
        ("lookup-accuracy", lambda f: ["lookup-accuracy", f, "--presses", "10"]),
        ("acquire --locate", lambda f: ["acquire", "--device", "sim:", "--quiet", "--duration-s", "0.01", "--locate", f]),
    ]
    for cmd, argv in map_readers:
        for f in ("map_trunc.h5", "map_empty.h5", "map_bytes.h5", "map_json.h5", "nofile.h5", "realdir"):
            # compare also takes a scene in place of the map (it then solves the presses)
            expect = (0, 2) if cmd == "compare" and f == "map_json.h5" else (2,)
            C.append(Case("csv", "%s map %s" % (cmd, f), argv=argv(f), names=[f, "meas_ok.csv"] if expect != (2,) else f,
                          timeout=60, expect=expect))
    # restore filter files
    for f in ("filter_nan.json", "filter_taps.json", "map_bytes.h5", "s.json", "nofile.json"):
        C.append(Case("csv", "restore apply filter %s" % f, argv=["restore", "apply", f, "scan_ok.csv", "-o", "r.csv"],
                      names=f, timeout=30))
    return C


WRITERS = [
    # (label, argv with {OUT}, inputs of the command, the output may be a folder)
    ("compare -o", ["compare", "map.h5", "meas_ok.csv", "-o", "{OUT}"], ["meas_ok.csv", "map.h5"], False),
    ("compare --plot", ["compare", "map.h5", "meas_ok.csv", "--plot", "{OUT}.png"], ["map.h5"], False),
    ("fit -o", ["fit", "s.json", "fit_ok.csv", "-o", "{OUT}", "--quiet"], ["s.json", "fit_ok.csv"], False),
    ("fit --plot", ["fit", "s.json", "fit_ok.csv", "-o", "f.json", "--plot", "{OUT}.png", "--quiet"], ["s.json"], False),
    ("map -o", ["map", "s.json", "-o", "{OUT}"] + MAP_ARGS, ["s.json"], False),
    ("map --checkpoint", ["map", "s.json", "-o", "o.h5", "--checkpoint", "{OUT}"] + MAP_ARGS, ["s.json"], False),
    ("calibrate -o", ["calibrate", "map.h5", "meas_ok.csv", "-o", "{OUT}"], ["map.h5", "meas_ok.csv"], False),
    ("mesh -o", ["mesh", "s.json", "-o", "{OUT}", "--no-preview"], ["s.json"], False),
    ("mesh --preview", ["mesh", "s.json", "-o", "k.msh", "--preview", "{OUT}.png"], ["s.json"], False),
    ("rays --csv", ["rays", "map.h5", "--csv", "{OUT}"], ["map.h5"], False),
    ("rays --plot", ["rays", "map.h5", "--plot", "{OUT}.png"], ["map.h5"], False),
    ("synthetic-map -o", ["synthetic-map", "-o", "{OUT}", "--spacing-m", "0.002"], [], False),
    ("export-map -o", ["export-map", "map.h5", "-o", "{OUT}"], ["map.h5"], False),
    ("restore apply -o", ["restore", "apply", "filter_ok.json", "scan_ok.csv", "-o", "{OUT}"], ["scan_ok.csv", "filter_ok.json"], False),
    ("restore simulate -o", ["restore", "simulate", "scanner.json", "-o", "{OUT}"], ["scanner.json"], False),
    ("locate --plot", ["locate", "map.h5", "--charges-C", CHARGES, "--plot", "{OUT}.png"], ["map.h5"], False),
    ("lookup-accuracy --plot", ["lookup-accuracy", "map.h5", "--presses", "10", "--plot", "{OUT}.png"], ["map.h5"], False),
    ("moduli --plot", ["moduli", "--plot", "{OUT}.png"], [], False),
    ("acquire --output", ["acquire", "--device", "sim:", "--quiet", "--duration-s", "0.01", "--output", "{OUT}"], [], False),
    ("acquire --record", ["acquire", "--device", "sim:", "--quiet", "--duration-s", "0.01", "--record", "{OUT}"], [], False),
    ("isocharge --out-dir", ["isocharge", "map.h5", "--out-dir", "{OUT}"], ["map.h5"], True),
    ("locate --pictures", ["locate", "map.h5", "--pictures", "{OUT}"], ["map.h5"], True),
    ("solve --vtu", ["solve", "s.json", "--vtu", "{OUT}", "--tolerance", "0.3"], ["s.json"], True),
]


def output_cases():
    C = []
    for label, argv, inputs, is_dir in WRITERS:
        def sub(dest, keep_ext=False):
            return [a.replace("{OUT}.png", dest if not keep_ext else dest + ".png").replace("{OUT}", dest) for a in argv]
        dests = [
            ("/dev/full", "/dev/full", ["/dev/full"]),
            ("symlink to a file", "link.out", ["link.out", "symbolic link"]),
            ("symlink to stdout", "link_stdout.out", ["link_stdout.out", "symbolic link"]),
            ("dangling symlink", "link_dangling.out", ["link_dangling.out", "symbolic link"]),
            ("missing folder", "nodir/x.out", ["nodir"]),
            ("empty path", "", ["output", "--", "path", "empty", "''"]),
            ("a long name", "n" * 300, ["n" * 20]),
        ]
        if not is_dir:
            dests.append(("a folder", "realdir", ["realdir"]))
        else:
            dests.append(("a file", "target.txt", ["target.txt"]))
            dests.append(("symlink to a folder", "link_dir", ["link_dir", "symbolic link"]))
        for inp in inputs:
            dests.append(("the input " + inp, inp, [inp, "input"]))
        for what, dest, names in dests:
            a = sub(dest)
            C.append(Case("outputs", "%s %s" % (label, what), argv=a, names=names, timeout=60))
        # read-only folder: only meaningful without root's privileges
        a = sub("ro/x.out" if not is_dir else "ro/d")
        C.append(Case("outputs", "%s read-only folder (uid nobody)" % label, argv=a, names=["ro"], timeout=60,
                      unprivileged=True))
    # an output that is another output of the same run
    C.append(Case("outputs", "compare report == plot", argv=["compare", "map.h5", "meas_ok.csv", "--plot", "p.png",
                                                                "-o", "p.png"], names="p.png"))
    C.append(Case("outputs", "mesh preview == output", argv=["mesh", "s.json", "-o", "k.msh", "--preview", "k.msh"],
                  names="k.msh"))
    C.append(Case("outputs", "map -o == --checkpoint", argv=["map", "s.json", "-o", "mc.h5", "--checkpoint", "mc.h5"] + MAP_ARGS,
                  names=["mc.h5", "--checkpoint"]))
    C.append(Case("outputs", "rays csv == plot", argv=["rays", "map.h5", "--csv", "r.png", "--plot", "r.png"],
                  names="r.png"))
    C.append(Case("outputs", "fit -o == --plot", argv=["fit", "s.json", "fit_ok.csv", "-o", "f.png", "--plot", "f.png"],
                  names="f.png"))
    # figure formats the plotter cannot write
    for label, argv in (("compare --plot .bmp", ["compare", "map.h5", "meas_ok.csv", "--plot", "p.bmp"]),
                        ("fit --plot .txt", ["fit", "s.json", "fit_ok.csv", "-o", "f.json", "--plot", "p.txt"]),
                        ("rays --plot .jpg", ["rays", "map.h5", "--plot", "p.jpg"]),
                        ("moduli --plot noext", ["moduli", "--plot", "plot"]),
                        ("locate --plot .h5", ["locate", "map.h5", "--charges-C", CHARGES, "--plot", "p.h5"]),
                        ("mesh --preview .gif", ["mesh", "s.json", "-o", "k.msh", "--preview", "p.gif"])):
        C.append(Case("outputs", label, argv=argv, names=["figure format", "p.", "plot"]))
    return C


def stdout_cases():
    """Full and closed stdout for every command that prints."""
    C = []
    printers = [
        ("solve", "solve s.json --tolerance 0.3"),
        ("solve --json", "solve s.json --tolerance 0.3 --json"),
        ("locate", "locate map.h5 --charges-C " + CHARGES),
        ("locate --json", "locate map.h5 --charges-C " + CHARGES + " --json"),
        ("locate --input", "locate map.h5 --input stream_ok.csv"),
        ("moduli", "moduli"),
        ("moduli --json", "moduli --json"),
        ("moduli --csv", "moduli --csv"),
        ("rays", "rays map.h5"),
        ("rays --json", "rays map.h5 --json"),
        ("compare", "compare map.h5 meas_ok.csv"),
        ("compare --json", "compare map.h5 meas_ok.csv --json"),
        ("lookup-accuracy", "lookup-accuracy map.h5 --presses 10"),
        ("lookup-accuracy --json", "lookup-accuracy map.h5 --presses 10 --json"),
        ("mesh --json", "mesh s.json -o k.msh --no-preview --json"),
        ("acquire", "acquire --device sim: --quiet --duration-s 0.05"),
        ("calibrate --json", "calibrate map.h5 meas_ok.csv -o cal.h5 --json"),
        ("--help", "--help"),
        ("solve --help", "solve --help"),
    ]
    for label, args in printers:
        C.append(Case("stdout", "%s >/dev/full" % label, shell="$X %s >/dev/full" % args, names="stdout", timeout=60,
                      outputs=("k.msh", "cal.h5"), outputs_on_failure=True))
        # closed stdout: EBADF on the first write; a clean exit 2 naming stdout, or nothing written at all
        C.append(Case("stdout", "%s >&-" % label, shell="$X %s >&-" % args, expect=(2,), names="stdout", timeout=60,
                      outputs=("k.msh", "cal.h5"), outputs_on_failure=True))
    return C


def checkpoint_cases(base):
    C = []
    names = sorted(n for n in os.listdir(base) if n.startswith("ck_"))
    for n in names:
        # A plausible value written with a recomputed checksum cannot be told from a solved one:
        # the map may be finished from it (the checkpoint is then removed, as after any map).
        undetectable = n == "ck_resum_neg"
        C.append(Case("checkpoints", "map resume %s" % n, argv=["map", "s.json", "-o", "ck.h5", "--checkpoint", n] + CKPT_ARGS,
                      names=n, timeout=60, expect=(0, 2) if undetectable else (2,),
                      outputs=("ck.h5", n) if undetectable else ()))
    # a checkpoint of another scene, grid, force set or tolerance: refused, naming it
    foreign = [
        ("other scene", ["map", "thickness_um.json"], "thickness_m"),
        ("other film", ["map", "E1_1e20.json"], "E1_Pa"),
    ]
    for label, head, nm in foreign:
        C.append(Case("checkpoints", "map resume ck0 for %s" % label,
                      argv=head + ["-o", "ck.h5", "--checkpoint", "ck0"] + CKPT_ARGS, names=[nm, "ck0"], timeout=60))
    for label, extra in (("another spacing", ["--spacing-m", "0.001"]), ("other forces", ["--forces-N", "1,2"]),
                         ("another tolerance", ["--tolerance", "0.05"]), ("another region",
                                                                          ["--region", "-0.002,0.002,-0.002,0.002"])):
        args = list(CKPT_ARGS)
        if extra[0] in args:
            i = args.index(extra[0])
            args[i + 1] = extra[1]
        else:
            args += extra
        argv = ["map", "thick2.json", "-o", "ck.h5", "--checkpoint", "ck0"] + args
        C.append(Case("checkpoints", "map resume ck0 with %s on a foreign scene" % label, argv=argv, names=["ck0", "thick2"],
                      timeout=60))
    C.append(Case("checkpoints", "map checkpoint is a folder", argv=["map", "s.json", "-o", "ck.h5", "--checkpoint", "realdir"]
                  + CKPT_ARGS, names="realdir"))
    C.append(Case("checkpoints", "map checkpoint symlink", argv=["map", "s.json", "-o", "ck.h5", "--checkpoint", "link.out"]
                  + CKPT_ARGS, names="link.out"))
    return C


# Python API cases: (label, code, names). The code runs after `import numpy as np, pvdfkit`, with
# `m` a synthetic map and `L` its Locator prepared by the prelude; it must raise pvdfkit.InputError.
PY_PRELUDE = """
import sys, os, numpy as np
import pvdfkit
from pvdfkit import restore as R
S = pvdfkit.load_scene('s.json')
m = pvdfkit.read_map('map.h5')
L = pvdfkit.Locator(m)
q = L.predict([0.002], [0.001], 1.0)
"""

NAN = "float('nan')"
INF = "float('inf')"


def python_cases():
    P = []
    bad_scalars = [NAN, INF, "-1.0", "0.0", "1e308", "'abc'", "[1, 2]"]
    # Locator options
    for kw in ("noise_C", "known_force_N", "min_force_N", "max_force_N", "chi2_limit", "max_starts", "max_iterations",
               "no_press_snr"):
        for v in bad_scalars:
            if v == "None":
                continue
            if v == "0.0" and kw in ("known_force_N", "min_force_N", "max_force_N", "chi2_limit", "no_press_snr"):
                continue  # documented: 0 = automatic/unknown/never
            if v == "1e308" and kw in ("chi2_limit", "no_press_snr"):
                continue
            if v in ("[1, 2]", "np.array([1.0, 2.0])") and kw == "noise_C":
                v = "[1e-14, 1e-14]"  # wrong count for 3 electrodes
            P.append(("Locator(%s=%s)" % (kw, v), "pvdfkit.Locator(m, %s=%s)" % (kw, v), kw))
    # Locator.locate: charges
    charges = [
        ("NaN row", "np.array([[%s, 1e-11, 1e-11]])" % NAN),
        ("inf row", "np.array([[%s, 1e-11, 1e-11]])" % INF),
        ("wrong width", "np.zeros((2, 2))"),
        ("3-D", "np.zeros((2, 3, 1))"),
        ("empty", "np.zeros((0, 3))"),
        ("strings", "[['a', 'b', 'c']]"),
        ("None", "None"),
        ("ragged", "[[1e-11, 1e-11], [1e-11, 1e-11, 1e-11]]"),
        ("complex", "np.array([[1e-11 + 1j, 1e-11, 1e-11]])"),
        ("object dtype", "np.array([[1e-11, None, 1e-11]], dtype=object)"),
        ("pC", "np.array([[2.49, 18.7, 18.7]])"),
        ("1e300", "np.full((1, 3), 1e300)"),
        ("a dict", "{'A': 1e-11}"),
        ("scalar", "1e-11"),
    ]
    for label, c in charges:
        P.append(("Locator.locate %s" % label, "L.locate(%s)" % c, "charges"))
    for v in (NAN, INF, "-1.0", "'x'", "1e308"):
        P.append(("Locator.locate known_force_N=%s" % v, "L.locate(q, %s)" % v, "force"))
    # Locator.predict
    for label, args in (("NaN x", "[%s], [0.0], 1.0" % NAN), ("inf y", "[0.0], [%s], 1.0" % INF),
                        ("lengths differ", "[0.0, 0.001], [0.0], 1.0"), ("force NaN", "[0.0], [0.0], %s" % NAN),
                        ("force 0", "[0.0], [0.0], 0.0"), ("force -1", "[0.0], [0.0], -1.0"),
                        ("outside", "[5.0], [0.0], 1.0"), ("empty", "[], [], 1.0"), ("strings", "['a'], ['b'], 1.0"),
                        ("2-D x", "[[0.0]], [[0.0]], 1.0"), ("mm", "[2.0], [1.0], 1.0")):
        P.append(("Locator.predict %s" % label, "L.predict(%s)" % args, ["x_m", "y_m", "force", "length", "predict"]))
    P.append(("Locator(map=None)", "pvdfkit.Locator(None)", "map"))
    P.append(("Locator(map='nofile.h5')", "pvdfkit.Locator('nofile.h5')", "nofile.h5"))
    # ChargeMap attributes: assignments of bad arrays
    for attr, val in (("charge_C", "np.full(m.charge_C.shape, %s)" % NAN), ("charge_C", "np.zeros((1, 2))"),
                      ("charge_C", "'abc'"), ("x_m", "np.array([%s, 1.0])" % NAN), ("x_m", "np.zeros(0)"),
                      ("y_m", "np.array([1.0, 0.0])"), ("forces_N", "np.array([-1.0])"), ("forces_N", "np.array([%s])" % NAN),
                      ("estimated_relative_error", NAN), ("estimated_relative_error", "-1.0"), ("noise_C", "np.array([%s] * 3)" % NAN),
                      ("scene_json", "'{not json'"), ("scene_json", "5"), ("electrode_names", "['A']"),
                      ("electrode_names", "[1, 2, 3]"), ("status", "np.full(m.status.shape, 200, dtype=np.uint8)"),
                      ("model", "None"), ("tolerance", NAN), ("rim_margin_m", "-1.0"), ("mask", "np.zeros((1,))")):
        P.append(("ChargeMap.%s = %s" % (attr, val[:40]), "m.%s = %s\npvdfkit.write_map('w.h5', m)" % (attr, val),
                  [attr, "w.h5", "map"]))
    # in-place edit of a read-only array: refused by numpy, the map unchanged (exit 0 when kept)
    P.append(("ChargeMap.charge_C in-place edit", "a = m.charge_C\n"
              "try:\n    a[0, 0, 0, 0] = 1.0\nexcept ValueError:\n    pass\n"
              "assert m.charge_C[0, 0, 0, 0] != 1.0, 'in-place edit reached the map'\nsys.exit(0)", None))
    # write_map / read_map destinations and files
    for label, code, nm in (("write_map /dev/full", "pvdfkit.write_map('/dev/full', m)", "/dev/full"),
                            ("write_map symlink", "pvdfkit.write_map('link.out', m)", "link.out"),
                            ("write_map folder", "pvdfkit.write_map('realdir', m)", "realdir"),
                            ("write_map missing folder", "pvdfkit.write_map('nodir/m.h5', m)", "nodir"),
                            ("write_map over input map", "pvdfkit.write_map('s.json', m)", ["s.json"]),
                            ("write_map path None", "pvdfkit.write_map(None, m)", "path"),
                            ("write_map map None", "pvdfkit.write_map('w.h5', None)", "map"),
                            ("write_map empty map", "pvdfkit.write_map('w.h5', pvdfkit.ChargeMap())", ["map", "w.h5"]),
                            ("read_map missing", "pvdfkit.read_map('nofile.h5')", "nofile.h5"),
                            ("read_map bytes", "pvdfkit.read_map('map_bytes.h5')", "map_bytes.h5"),
                            ("read_map truncated", "pvdfkit.read_map('map_trunc.h5')", "map_trunc.h5"),
                            ("read_map json", "pvdfkit.read_map('s.json')", "s.json"),
                            ("read_map folder", "pvdfkit.read_map('realdir')", "realdir"),
                            ("read_map int", "pvdfkit.read_map(5)", "path"),
                            ("read_map empty string", "pvdfkit.read_map('')", "path"),
                            ("validate_map empty", "pvdfkit.validate_map(pvdfkit.ChargeMap())", "map"),
                            ("validate_map not a map", "pvdfkit.validate_map(5)", "map"),
                            ("flags_text -1", "pvdfkit.flags_text(-1)", "flags"),
                            ("flags_text 'x'", "pvdfkit.flags_text('x')", "flags"),
                            ("flags_text NaN", "pvdfkit.flags_text(%s)" % NAN, "flags")):
        P.append((label, code, nm))
    # scenes from dicts
    for stem, patch, nm in SCENES:
        if isinstance(patch, dict) and len(P) < 10000:
            P.append(("load_scene(dict %s)" % stem, "pvdfkit.load_scene(%r)" % (patched(patch),), nm))
    for label, code, nm in (("load_scene NaN", "d = pvdfkit.load_scene('s.json').to_dict() if hasattr(S, 'to_dict') else "
                             "__import__('json').load(open('s.json'))\nd['membrane']['radius_m'] = float('nan')\n"
                             "pvdfkit.load_scene(d)", ["radius_m", "scene:"]),
                            ("load_scene None", "pvdfkit.load_scene(None)", "scene"),
                            ("load_scene int", "pvdfkit.load_scene(5)", "scene"),
                            ("load_scene missing file", "pvdfkit.load_scene('nofile.json')", "nofile.json"),
                            ("load_scene bytes file", "pvdfkit.load_scene('bytes.json')", "bytes.json"),
                            ("load_scene list", "pvdfkit.load_scene([1, 2])", "scene")):
        P.append((label, code, nm))
    # synthetic_map / design
    for kw, v in (("spacing_m", "0.0"), ("spacing_m", NAN), ("spacing_m", "-1.0"), ("spacing_m", "1e308"),
                  ("spacing_m", "'x'"), ("force_N", "0.0"), ("force_N", NAN), ("force_N", "-1.0"), ("noise_C", "-1.0"),
                  ("noise_C", NAN), ("noise_C", "0.0"), ("scene", "5"), ("scene", "'nofile.json'")):
        code = "pvdfkit.synthetic_map(%s)" % ("S, %s=%s" % (kw, v) if kw != "scene" else v)
        P.append(("synthetic_map %s=%s" % (kw, v), code, [kw, "nofile.json"]))
    for kw, v in (("force_N", NAN), ("force_N", "-1.0"), ("min_force_N", NAN), ("max_force_N", "-1.0"),
                  ("noise_C", NAN), ("noise_C", "[1e-14]"), ("target_m", "0.0"), ("target_m", NAN), ("adc_bits", "99"),
                  ("adc_bits", "-1"), ("full_scale_C", NAN), ("full_scale_C", "-1.0"), ("map", "None")):
        code = "pvdfkit.design(%s)" % ("m, %s=%s" % (kw, v) if kw != "map" else v)
        P.append(("design %s=%s" % (kw, v), code, kw))
    # read_measurements
    for f in ("meas_nan.csv", "meas_empty.csv", "meas_header_only.csv", "meas_random_bytes.csv", "meas_dup_col.csv",
              "meas_nul.csv", "meas_big_cell.csv", "nofile.csv", "meas_1e6.csv"):
        P.append(("read_measurements %s" % f, "pvdfkit.read_measurements(%r, ['A', 'B', 'C'])" % f, f))
    P.append(("read_measurements names None", "pvdfkit.read_measurements('meas_ok.csv', None)", ["names", "electrode"]))
    P.append(("read_measurements names int", "pvdfkit.read_measurements('meas_ok.csv', [1, 2, 3])", ["names", "electrode"]))
    # solve / ProbeSweep / generate_map (the FEM build)
    for label, code, nm in (
            ("solve loads NaN", "pvdfkit.solve(S, loads=[[%s, 0, 1]])" % NAN, "loads"),
            ("solve loads inf force", "pvdfkit.solve(S, loads=[[0, 0, %s]])" % INF, "loads"),
            ("solve loads empty", "pvdfkit.solve(S, loads=np.zeros((0, 3)))", "loads"),
            ("solve loads (2,)", "pvdfkit.solve(S, loads=[0, 0])", "loads"),
            ("solve loads (1,2)", "pvdfkit.solve(S, loads=[[0, 0]])", "loads"),
            ("solve loads strings", "pvdfkit.solve(S, loads=[['a', 'b', 'c']])", "loads"),
            ("solve loads outside", "pvdfkit.solve(S, loads=[[0.5, 0, 1]])", "loads"),
            ("solve loads force 0", "pvdfkit.solve(S, loads=[[0, 0, 0]])", "loads"),
            ("solve loads force 1e-300", "pvdfkit.solve(S, loads=[[0, 0, 1e-300]])", "loads"),
            ("solve samples NaN", "pvdfkit.solve(S, loads=[[0, 0, 1]], samples=[[%s, 0]])" % NAN, "samples"),
            ("solve samples (3,)", "pvdfkit.solve(S, loads=[[0, 0, 1]], samples=[0, 0, 0])", "samples"),
            ("solve samples outside", "pvdfkit.solve(S, loads=[[0, 0, 1]], samples=[[1.0, 0]])", "samples"),
            ("solve tolerance NaN", "pvdfkit.solve(S, loads=[[0, 0, 1]], tolerance=%s)" % NAN, "tolerance"),
            ("solve tolerance 0.9", "pvdfkit.solve(S, loads=[[0, 0, 1]], tolerance=0.9)", "tolerance"),
            ("solve tolerance str", "pvdfkit.solve(S, loads=[[0, 0, 1]], tolerance='x')", "tolerance"),
            ("solve model magic", "pvdfkit.solve(S, loads=[[0, 0, 1]], model='magic')", "model"),
            ("solve max_refinements -1", "pvdfkit.solve(S, loads=[[0, 0, 1]], max_refinements=-1)", "max_refinements"),
            ("solve max_refinements 1.5", "pvdfkit.solve(S, loads=[[0, 0, 1]], max_refinements=1.5)", "max_refinements"),
            ("solve vtu_dir /dev/full", "pvdfkit.solve(S, loads=[[0, 0, 1]], vtu_dir='/dev/full')", "/dev/full"),
            ("solve scene None", "pvdfkit.solve(None)", "scene"),
            ("solve unknown keyword", "pvdfkit.solve(S, lods=[[0, 0, 1]])", "lods"),
            ("solve absurd scene dict", "pvdfkit.solve(%r)" % (patched({"material": {"E1_Pa": 1e-30, "E2_Pa": 1e-30,
                                                                                     "G12_Pa": 1e-30}}),), "E1_Pa"),
            ("ProbeSweep tolerance NaN", "pvdfkit.ProbeSweep(S, tolerance=%s)" % NAN, "tolerance"),
            ("ProbeSweep forces_N []", "pvdfkit.ProbeSweep(S, forces_N=[])", "forces_N"),
            ("ProbeSweep forces_N NaN", "pvdfkit.ProbeSweep(S, forces_N=[%s])" % NAN, "forces_N"),
            ("ProbeSweep n_setup_checks -1", "pvdfkit.ProbeSweep(S, n_setup_checks=-1)", "n_setup_checks"),
            ("ProbeSweep rim_margin_m NaN", "pvdfkit.ProbeSweep(S, rim_margin_m=%s)" % NAN, "rim_margin_m"),
            ("generate_map spacing 0", "pvdfkit.generate_map(S, spacing_m=0.0)", "spacing_m"),
            ("generate_map spacing NaN", "pvdfkit.generate_map(S, spacing_m=%s)" % NAN, "spacing_m"),
            ("generate_map spacing mm", "pvdfkit.generate_map(S, spacing_m=2.0)", "spacing_m"),
            ("generate_map forces []", "pvdfkit.generate_map(S, forces_N=[])", "forces_N"),
            ("generate_map forces 1e-300", "pvdfkit.generate_map(S, forces_N=[1e-300])", "forces_N"),
            ("generate_map forces dup", "pvdfkit.generate_map(S, forces_N=[1.0, 1.0000000000000002])", "forces_N"),
            ("generate_map region 3", "pvdfkit.generate_map(S, region_m=(0, 1, 2))", "region_m"),
            ("generate_map region NaN", "pvdfkit.generate_map(S, region_m=(%s, 0.001, -0.001, 0.001))" % NAN, "region_m"),
            ("generate_map region 1e10", "pvdfkit.generate_map(S, region_m=(-1e10, 1e10, -1e10, 1e10))", "region_m"),
            ("generate_map threads -1", "pvdfkit.generate_map(S, threads=-1)", "threads"),
            ("generate_map model magic", "pvdfkit.generate_map(S, model='magic')", "model"),
            ("generate_map tolerance 0", "pvdfkit.generate_map(S, tolerance=0.0)", "tolerance"),
    ):
        P.append((label, code, nm))
    # restore
    for label, code, nm in (
            ("Scan NaN x", "R.Scan(np.array([0.0, %s, 0.002]), np.zeros(3), np.zeros(3))" % NAN, "x_m"),
            ("Scan inf m1", "R.Scan(np.arange(3) * 1e-3, np.array([0, %s, 0]), np.zeros(3))" % INF, "m1_V"),
            ("Scan NaN m2", "R.Scan(np.arange(3) * 1e-3, np.zeros(3), np.array([0, %s, 0]))" % NAN, "m2_V"),
            ("Scan lengths differ", "R.Scan(np.arange(3) * 1e-3, np.zeros(2), np.zeros(3))", ["m1_V", "length"]),
            ("Scan empty", "R.Scan(np.zeros(0), np.zeros(0), np.zeros(0))", ["x_m", "empty"]),
            ("Scan 2-D", "R.Scan(np.zeros((3, 2)), np.zeros(3), np.zeros(3))", "x_m"),
            ("Scan not uniform", "R.Scan(np.array([0, 0.001, 0.005]), np.zeros(3), np.zeros(3))", "x_m"),
            ("Scan decreasing", "R.Scan(np.array([0.002, 0.001, 0.0]), np.zeros(3), np.zeros(3))", "x_m"),
            ("Scan strings", "R.Scan(['a', 'b'], [0, 0], [0, 0])", "x_m"),
            ("Scan fx NaN", "R.Scan(np.arange(3) * 1e-3, np.zeros(3), np.zeros(3), fx_N=np.array([0, %s, 0]))" % NAN, "fx_N"),
            ("identify empty list", "R.identify([])", "scans"),
            ("identify NaN sample", "sc = R.simulate(R.load_scanner_scene('scanner.json'), noise=False)\n"
             "x = np.array(sc.x_m); m1 = np.array(sc.m1_V); m1[len(m1) // 2] = %s\n"
             "bad = R.Scan(x, m1, np.array(sc.m2_V), np.array(sc.fx_N), np.array(sc.fz_N))\n"
             "R.identify([(bad, 0.6, 0.9, 0.0), (sc, 0.2, 1.0, 0.0)], taps=64)" % NAN, ["m1_V", "scan", "NaN"]),
            ("identify taps 0", "sc = R.simulate(R.load_scanner_scene('scanner.json'), noise=False)\n"
             "R.identify([(sc, 0.6, 0.9, 0.0), (sc, 0.2, 1.0, 0.0)], taps=0)", "taps"),
            ("identify taps 1e12", "sc = R.simulate(R.load_scanner_scene('scanner.json'), noise=False)\n"
             "R.identify([(sc, 0.6, 0.9, 0.0), (sc, 0.2, 1.0, 0.0)], taps=10**12)", "taps"),
            ("identify beta NaN", "sc = R.simulate(R.load_scanner_scene('scanner.json'), noise=False)\n"
             "R.identify([(sc, 0.6, 0.9, 0.0), (sc, 0.2, 1.0, 0.0)], beta=%s, taps=64)" % NAN, "beta"),
            ("identify forces NaN", "sc = R.simulate(R.load_scanner_scene('scanner.json'), noise=False)\n"
             "R.identify([(sc, %s, 0.9, 0.0), (sc, 0.2, 1.0, 0.0)], taps=64)" % NAN, ["force", "scans"]),
            ("load_filter NaN taps", "R.load_filter('filter_nan.json')", "filter_nan.json"),
            ("load_filter huge taps", "R.load_filter('filter_taps.json')", "filter_taps.json"),
            ("load_filter missing", "R.load_filter('nofile.json')", "nofile.json"),
            ("save_filter /dev/full", "R.save_filter('/dev/full', R.load_filter('filter_ok.json'))", "/dev/full"),
            ("save_filter symlink", "R.save_filter('link.out', R.load_filter('filter_ok.json'))", "link.out"),
            ("save_filter not a filter", "R.save_filter('f.json', 5)", "filter"),
            ("apply NaN scan", "R.apply(R.load_filter('filter_ok.json'), R.Scan(np.arange(4) * 1e-3, "
             "np.array([0, %s, 0, 0]), np.zeros(4)))" % NAN, ["m1_V", "scan"]),
            ("apply mu_threshold NaN", "R.apply(R.load_filter('filter_ok.json'), R.read_scan('scan_ok.csv'), "
             "mu_threshold_N=%s)" % NAN, "mu_threshold"),
            ("apply block -5", "R.apply(R.load_filter('filter_ok.json'), R.read_scan('scan_ok.csv'), block_samples=-5)",
             "block"),
            ("apply scan None", "R.apply(R.load_filter('filter_ok.json'), None)", "scan"),
            ("read_scan NaN", "R.read_scan('scan_nan.csv')", "scan_nan.csv"),
            ("read_scan bytes", "R.read_scan('scan_random_bytes.csv')", "scan_random_bytes.csv"),
            ("read_scan speed NaN", "R.read_scan('scan_ok.csv', speed_m_per_s=%s)" % NAN, "speed"),
            ("write_scan /dev/full", "R.write_scan('/dev/full', R.read_scan('scan_ok.csv'))", "/dev/full"),
            ("write_scan over input", "R.write_scan('scan_ok.csv', R.read_scan('scan_ok.csv'))", ["scan_ok.csv"]),
            ("simulate scene None", "R.simulate(None)", "scene"),
            ("load_scanner_scene NaN dict", "import json\nd = json.load(open('scanner.json'))\n"
             "d['layer']['thickness_m'] = float('nan')\nR.load_scanner_scene(d)", ["thickness_m", "scanner scene:"]),
    ):
        P.append((label, code, nm))
    # Documented behaviour, not refusals: the lookup reports charges it cannot place as flags
    # (docs/lookup.md), an empty batch gives an empty answer, the predictions outside the map
    # are checked for NaN below, missing scene keys take their documented defaults, one noise
    # value applies to every electrode, and the Python writers write where they are told.
    may_pass = {"Locator.locate empty", "Locator.locate pC", "Locator.locate 1e300", "design noise_C=[1e-14]",
                "write_map over input map", "write_scan over input"}
    may_pass |= {"load_scene(dict %s)" % st for st in MISSING_WITH_DEFAULTS + ("no_electrodes",)}
    C = []
    for label, code, nm in P:
        expect = (0,) if nm is None else (0, 2) if label in may_pass else (2,)
        if label.startswith("Locator.predict"):
            expect = (0, 2)  # off the map the prediction is NaN by contract (help(Locator.predict))
        outputs = ()
        if label == "write_map over input map":
            outputs = ("s.json",)  # the Python writers write where they are told (no input list to protect)
        if label == "write_scan over input":
            outputs = ("scan_ok.csv",)
        C.append(Case("python", label, python=code, names=nm, expect=expect, timeout=60, outputs=outputs))
    return C


def scene_misc(base):
    """A second film for the foreign-checkpoint cases (valid, but not the checkpoint's scene)."""
    write(os.path.join(base, "thick2.json"), json.dumps(patched({"membrane": {"thickness_m": 50e-6}}), indent=1))


def all_cases(base):
    cases = flag_cases() + scene_cases() + csv_cases() + output_cases() + stdout_cases() + checkpoint_cases(base) \
        + python_cases()
    seen = set()
    for c in cases:
        key = c.cat + ":" + c.id
        n = 2
        while key in seen:
            key = c.cat + ":" + c.id + " #%d" % n
            n += 1
        c.id = key.split(":", 1)[1]
        seen.add(key)
    return cases


# The quick subset (ctest): every category, fixed ids, cheap commands only.
QUICK_EVERY = 12


def quick_subset(cases):
    out = []
    for cat in ("flags", "scenes", "csv", "outputs", "stdout", "checkpoints", "python"):
        cc = [c for c in cases if c.cat == cat and "1e6" not in c.id and "(uid nobody)" not in c.id
              and (cat == "checkpoints" or not c.id.startswith(("map ", "fit "))) and "fit " not in c.id
              and "resum" not in c.id and "foreign" not in c.id]
        step = max(1, len(cc) // {"flags": 14, "scenes": 8, "csv": 10, "outputs": 10, "stdout": 6, "checkpoints": 5,
                                  "python": 8}[cat])
        out += cc[::step]
    return out


# --------------------------------------------------------------------------------------------
# 3. Running and classifying one case.
# --------------------------------------------------------------------------------------------

BAD_TEXT = ["Traceback (most recent call last)", "terminate called", "Aborted", "core dumped", "AddressSanitizer",
            "LeakSanitizer", "UndefinedBehaviorSanitizer", "runtime error:", "Segmentation fault", "HDF5-DIAG",
            "what():", "Invoked with:", "incompatible function arguments", "Check failed", "*** Check failure",
            "std::bad_alloc", "Assertion", "pybind11::"]
NAN_RE = re.compile(r"(?<![A-Za-z_])[-+]?(nan|inf|infinity)(?![A-Za-z_])", re.IGNORECASE)


def snapshot(d):
    out = {}
    for root, dirs, files in os.walk(d):
        for n in dirs + files:
            p = os.path.join(root, n)
            st = os.lstat(p)
            key = os.path.relpath(p, d)
            link = os.readlink(p) if stat.S_ISLNK(st.st_mode) else None
            out[key] = (stat.S_IFMT(st.st_mode), st.st_ino, st.st_size, st.st_mtime_ns, link,
                        stat.S_IMODE(st.st_mode))
    return out


def prepare_dir(base, d, unprivileged):
    os.makedirs(d)
    for n in os.listdir(base):
        src = os.path.join(base, n)
        if os.path.isfile(src) and not os.path.islink(src):
            os.link(src, os.path.join(d, n))
    os.symlink("target.txt", os.path.join(d, "link.out"))
    os.symlink("/proc/self/fd/1", os.path.join(d, "link_stdout.out"))
    os.symlink("no_such_target.txt", os.path.join(d, "link_dangling.out"))
    os.makedirs(os.path.join(d, "realdir"))
    os.symlink("realdir", os.path.join(d, "link_dir"))
    os.makedirs(os.path.join(d, "ro"))
    os.chmod(os.path.join(d, "ro"), 0o555)
    if unprivileged:
        os.chmod(d, 0o777)


def run_case(case, exe, base, work, pyexe, pypath, case_no):
    d = os.path.join(work, "c%04d" % case_no)
    prepare_dir(base, d, case.unprivileged)
    before = snapshot(d)
    with open(os.path.join(base, "target.txt"), "rb") as f:
        target_before = f.read()
    env = dict(os.environ)
    env["LC_ALL"] = "C"
    env.pop("PVDF_TEST_SIGMA_SCALE", None)
    # address space cap: a case that allocates without bound fails here, not on the machine
    limit = "ulimit -v 4000000; "
    if case.python is not None:
        code = PY_PRELUDE + "\ntry:\n" + "".join("    " + ln + "\n" for ln in case.python.split("\n")) + \
            "except pvdfkit.InputError as e:\n" \
            "    print('error: ' + str(e), file=sys.stderr); sys.exit(2)\n" \
            "except pvdfkit.NumericalError as e:\n" \
            "    print('error: ' + str(e), file=sys.stderr); sys.exit(3)\n" \
            "print('returned without an error', file=sys.stderr)\n"
        with open(os.path.join(work, "c%04d.py" % case_no), "w") as f:
            f.write(code)
        env["PYTHONPATH"] = pypath + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
        script = limit + "exec %s %s" % (sh_quote(pyexe), sh_quote(os.path.join(work, "c%04d.py" % case_no)))
    elif case.shell is not None:
        script = limit + case.shell.replace("$X", sh_quote(exe))
    else:
        script = limit + "exec " + " ".join(sh_quote(a) for a in [exe] + case.argv)
    if case.stdin:
        script = script + " < " + sh_quote(case.stdin)
    elif case.python is None:
        script = script + " </dev/null"
    argv = ["bash", "-c", script]
    if case.unprivileged:
        argv = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups"] + argv
    t0 = time.monotonic()
    p = subprocess.Popen(argv, cwd=d, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True)
    timed_out = False
    try:
        out, err = p.communicate(timeout=case.timeout)
    except subprocess.TimeoutExpired:
        timed_out = True
        os.killpg(p.pid, signal.SIGKILL)
        out, err = p.communicate()
    wall = time.monotonic() - t0
    rc = p.returncode
    reasons = []
    err_t = err.decode("utf-8", errors="replace")
    out_t = out.decode("utf-8", errors="replace")
    if timed_out:
        reasons.append("timed out after %d s" % case.timeout)
    elif rc < 0 or rc >= 128:
        reasons.append("killed by a signal (%d)" % rc)
    elif rc not in case.expect:
        reasons.append("exit %d, expected %s" % (rc, "/".join(str(e) for e in sorted(case.expect))))
    for t in BAD_TEXT:
        if t in err_t or t in out_t:
            reasons.append("stderr/stdout holds %r" % t)
            break
    error_lines = [ln for ln in err_t.split("\n") if ln.startswith("error:")]
    if rc in (2, 3) and not timed_out:
        if len(error_lines) != 1 and not (rc == 3 and len(error_lines) == 0 and out_t.strip()):
            reasons.append("%d `error:` lines on stderr" % len(error_lines))
        elif rc == 2 and case.names and not any(n in error_lines[0] for n in case.names):
            reasons.append("the error line names none of %s" % ", ".join(repr(n[:30]) for n in case.names))
        if error_lines and len(error_lines[0]) > 600:
            reasons.append("error line of %d characters" % len(error_lines[0]))
        if any((ord(c) < 0x20 and c not in "\n\t") or ord(c) == 0x7f for c in err_t):
            reasons.append("raw control bytes on stderr")
    if case.check_stdout_nan and NAN_RE.search(out_t):
        reasons.append("NaN/inf on stdout: %r" % NAN_RE.search(out_t).group(0))
    try:
        if not stat.S_ISCHR(os.stat("/dev/full").st_mode):
            reasons.append("/dev/full is no longer a device")
    except OSError:
        reasons.append("/dev/full is gone")
    after = snapshot(d)
    allowed = set(case.outputs) if rc == 0 or case.outputs_on_failure else set()
    for k in sorted(set(before) | set(after)):
        top = k.split(os.sep)[0]
        if top in allowed:
            continue
        if k not in after:
            reasons.append("%s removed" % k)
        elif k not in before:
            reasons.append("%s left behind" % k)
        elif before[k] != after[k]:
            reasons.append("%s changed" % k)
    with open(os.path.join(base, "target.txt"), "rb") as f:
        if f.read() != target_before:
            reasons.append("the symbolic link's target changed")
    return {"cat": case.cat, "id": case.id, "rc": rc, "wall": wall, "reasons": reasons,
            "error": error_lines[0][:300] if error_lines else err_t.strip().split("\n")[-1][:300] if err_t.strip() else "",
            "cmd": case.shell or case.python or " ".join(case.argv)}


def sh_quote(s):
    return "'" + s.replace("'", "'\\''") + "'"


# --------------------------------------------------------------------------------------------
# 4. Main: fixtures, cases, table.
# --------------------------------------------------------------------------------------------


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--exe", required=True, help="the pvdfkit command (build/app/pvdfkit)")
    ap.add_argument("--python", help="folder holding the pvdfkit package (build/python); no Python cases without it")
    ap.add_argument("--python-exe", default="/usr/bin/python3" if os.path.exists("/usr/bin/python3") else sys.executable,
                    help="interpreter the module was built for (default /usr/bin/python3)")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--quick", action="store_true", help="the fixed quick subset (ctest)")
    ap.add_argument("--only", help="run only cases whose category:id contains this text")
    ap.add_argument("--list", action="store_true", help="list the cases and exit")
    ap.add_argument("--keep", action="store_true", help="keep the work folder")
    ap.add_argument("--min-kept", type=float, default=0.99)
    ap.add_argument("--verbose", action="store_true", help="print every case with its error line")
    a = ap.parse_args()
    exe = os.path.abspath(a.exe)
    if not os.access(exe, os.X_OK):
        print("error: --exe %s is not an executable" % a.exe, file=sys.stderr)
        return 2
    work = tempfile.mkdtemp(prefix="pvdf_sweep_")
    os.chmod(work, 0o755)
    base = os.path.join(work, "fixtures")
    os.makedirs(base)
    try:
        t0 = time.monotonic()
        make_fixtures(base, exe, need_checkpoint=True)
        scene_misc(base)
        cases = all_cases(base)
        if a.python is None:
            cases = [c for c in cases if c.python is None]
        if a.quick:
            cases = quick_subset(cases)
        if a.only:
            cases = [c for c in cases if a.only in c.cat + ":" + c.id]
        if a.list:
            for c in cases:
                print("%-12s %s" % (c.cat, c.id))
            print("%d cases" % len(cases))
            return 0
        pypath = os.path.abspath(a.python) if a.python else ""
        results = [None] * len(cases)
        with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, a.jobs)) as ex:
            futs = {ex.submit(run_case, c, exe, base, work, a.python_exe, pypath, i): i for i, c in enumerate(cases)}
            for f in concurrent.futures.as_completed(futs):
                i = futs[f]
                results[i] = f.result()
                r = results[i]
                if a.verbose:
                    print("%s %-11s %-60s rc=%s %.1fs %s" % ("ok " if not r["reasons"] else "BAD", r["cat"], r["id"][:60],
                                                            r["rc"], r["wall"], r["error"][:150]), flush=True)
        wall = time.monotonic() - t0
        cpu = os.times()
        cats = []
        for r in results:
            if r["cat"] not in cats:
                cats.append(r["cat"])
        print("\nhostile sweep: %s" % ("quick subset" if a.quick else "full"))
        print("%-12s %6s %6s %6s" % ("category", "cases", "kept", "broken"))
        tot = kept = 0
        for cat in cats:
            rs = [r for r in results if r["cat"] == cat]
            k = sum(1 for r in rs if not r["reasons"])
            print("%-12s %6d %6d %6d" % (cat, len(rs), k, len(rs) - k))
            tot += len(rs)
            kept += k
        share = kept / tot if tot else 1.0
        print("%-12s %6d %6d %6d   kept %.1f %%, wall %.0f s, CPU of the cases %.0f s" % (
            "total", tot, kept, tot - kept, 100 * share, wall, cpu.children_user + cpu.children_system))
        broken = [r for r in results if r["reasons"]]
        if broken:
            print("\nbroken cases:")
            for r in broken:
                print("- [%s] %s: %s" % (r["cat"], r["id"], "; ".join(r["reasons"][:4])))
                print("    cmd: %s" % r["cmd"].replace("\n", " | ")[:300])
                if r["error"]:
                    print("    last stderr line: %s" % r["error"][:200])
        need = 1.0 if a.quick else a.min_kept
        return 0 if share >= need else 1
    finally:
        if not a.keep:
            for root, dirs, files in os.walk(work):
                for n in dirs:
                    try:
                        os.chmod(os.path.join(root, n), 0o755)
                    except OSError:
                        pass
            shutil.rmtree(work, ignore_errors=True)
        else:
            print("work folder kept: %s" % work)


if __name__ == "__main__":
    sys.exit(main())
