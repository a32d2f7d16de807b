#!/usr/bin/env python3
"""Effectivity of the bending-left-out estimate over a film: stated / true at chosen presses.

    bench/fem/bending_left_out.py [--force-N 1] [--refs FILE] [--reference-tolerance 0.002]
        [--json OUT] PVDFKIT SCENE -- X,Y [X,Y ...]

(the `--` lets a press start with a minus sign)

For each press (metres) two solves of the same scene:

- the bending-free membrane with the plain clamp and what it states bending would change:
  `PVDFKIT solve SCENE --load X,Y,F --tolerance P --json` (--plain-tolerance, default 2 %: `auto`
  leaves bending out wherever its estimated effect is below P/2); a press where it did not (`clamp_layer.treatment` not "none", or bending kept) is reported and
  skipped. Its stated model error is `estimated_model_error` (relative to the largest charge);
- the reference with bending kept: `PVDFKIT solve SCENE --load X,Y,F --model large-rotation
  --tolerance T --json` (the full plate, the rim graded to the clamp's layer, its own mesh;
  its own estimate is printed). Cached in --refs, keyed by scene and press.

true = max_k |Q_k − Q_ref,k| / max_k |Q_ref,k| (the membrane's whole error: bending's effect plus
its discretization error, which its own estimate states at ~1e-5 here). Prints one row per press
and the median and range of stated / true. Exit 0 when every press has stated / true in [0.5, 3],
1 otherwise, 2 on bad arguments.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys


def solve(pvdfkit, scene, x, y, force, extra):
    cmd = [pvdfkit, "solve", scene, f"--load={x!r},{y!r},{force!r}", "--json"] + extra
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode not in (0,):
        raise RuntimeError(f"{' '.join(cmd)}: exit {p.returncode}: {p.stderr.strip()[-300:]}")
    return json.loads(p.stdout)


def charges(result):
    return [e["charge_C"] for e in result["electrodes"]]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("pvdfkit")
    ap.add_argument("scene")
    ap.add_argument("presses", nargs="+", help="X,Y in metres")
    ap.add_argument("--force-N", type=float, default=1.0)
    ap.add_argument("--reference-tolerance", type=float, default=0.002)
    ap.add_argument("--plain-tolerance", type=float, default=0.02,
                    help="tolerance of the bending-free solve (auto leaves bending out below half of it)")
    ap.add_argument("--refs", help="JSON cache of the reference solves")
    ap.add_argument("--json", help="write the rows here")
    a = ap.parse_args()
    try:
        presses = [tuple(float(v) for v in p.split(",")) for p in a.presses]
        if any(len(p) != 2 for p in presses):
            raise ValueError
    except ValueError:
        print(f"bending_left_out.py: a press '{a.presses}' is not X,Y in metres; give e.g. 0.01,-0.02", file=sys.stderr)
        return 2
    refs = {}
    if a.refs and os.path.exists(a.refs):
        with open(a.refs) as f:
            refs = json.load(f)
    rows = []
    print(f"{'press (mm)':>18} {'plain DOFs':>10} {'stated':>8} {'true':>8} {'stated/true':>11} {'ref DOFs':>9} {'ref est.':>8}")
    for x, y in presses:
        key = f"{os.path.basename(a.scene)} {x!r},{y!r},{a.force_N!r} tol {a.reference_tolerance!r}"
        plain = solve(a.pvdfkit, a.scene, x, y, a.force_N, ["--tolerance", str(a.plain_tolerance)])
        if plain["clamp_layer"]["treatment"] != "none" or "bending left out" not in plain["model_reason"]:
            print(f"({x * 1e3:7.2f}, {y * 1e3:7.2f}) skipped: bending not left out at {a.plain_tolerance} "
                  f"({plain['clamp_layer']['treatment']}); try a larger --plain-tolerance")
            continue
        if key not in refs:
            refs[key] = solve(a.pvdfkit, a.scene, x, y, a.force_N,
                              ["--model", "large-rotation", "--tolerance", str(a.reference_tolerance)])
            if a.refs:
                with open(a.refs, "w") as f:
                    json.dump(refs, f)
        ref = refs[key]
        q, qr = charges(plain), charges(ref)
        scale = max(abs(v) for v in qr)
        true = max(abs(u - v) for u, v in zip(q, qr)) / scale
        stated = plain["estimated_model_error"]
        ratio = stated / true if true > 0 else float("nan")
        rows.append({"x_m": x, "y_m": y, "plain_dofs": plain["n_dofs"], "stated": stated, "true": true,
                     "ratio": ratio, "reference_dofs": ref["n_dofs"],
                     "reference_estimate": ref["estimated_relative_error"],
                     "plain_discretization": plain["estimated_discretization_error"]})
        print(f"({x * 1e3:7.2f}, {y * 1e3:7.2f}) {plain['n_dofs']:10d} {stated:8.2e} {true:8.2e} {ratio:11.2f} "
              f"{ref['n_dofs']:9d} {ref['estimated_relative_error']:8.1e}", flush=True)
    ratios = [r["ratio"] for r in rows]
    if not ratios:
        print("no press measured")
        return 1
    ok = all(0.5 <= r <= 3 for r in ratios)  # NaN fails
    print(f"stated/true: median {statistics.median(ratios):.2f}, range {min(ratios):.2f} .. {max(ratios):.2f}, "
          f"in [0.5, 3] at {sum(0.5 <= r <= 3 for r in ratios)} of {len(ratios)}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
