#!/usr/bin/env python3
"""The `solve` default near the clamp against stored bending-kept references: the table of
docs/fem.md §3.4 "Near the served edge".

    bench/fem/clamp_layer_edge.py [--refs FILE] [--max-clamp-distance-m 0.0065] [--json OUT] PVDFKIT SCENE

--refs (default bench/mapping/data/seed001_whole_film_refs.json) holds references keyed
"X,Y,F,T,MODEL" as `bench/mapping/audit_whole_film.py` writes them (`solve --tolerance T --model
MODEL`, bending kept, the rim graded). Every reference press of force F whose centre lies within
--max-clamp-distance-m of the clamp (the film's outline, from SCENE) is solved again with the scene's
own settings, `PVDFKIT solve SCENE --load X,Y,F --json`, and compared:

- off = max_k |Q_k − Q_ref,k| / max_k |Q_ref,k|;
- stated = `estimated_relative_error`; eta = `clamp_layer.estimated_error`; correction =
  `clamp_layer.correction`; the path (`clamp_layer.treatment`), DOFs and the solve's CPU seconds.

One row per press, then how many presses have stated / off in [0.5, 3] and how many are off by more
than the scene's tolerance. Exit 0 when every press is within the band, 1 otherwise, 2 on bad
arguments or an unreadable file. A solve that fails (exit 3) is reported as such and counts as
outside the band.
"""
import argparse
import json
import math
import os
import subprocess
import sys


def fail(message):
    print(f"clamp_layer_edge.py: {message}", file=sys.stderr)
    sys.exit(2)


def clamp_distance_m(scene, x, y):
    """Distance from (x, y) to the clamp of a circular film (the shapes this bench is run on)."""
    m = scene.get("membrane", {})
    if m.get("shape") != "circle":
        fail(f"{m.get('shape')!r} film: only circular films are supported (their clamp distance is R − r)")
    return m["radius_m"] - math.hypot(x, y)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("pvdfkit")
    ap.add_argument("scene")
    ap.add_argument("--refs", default=os.path.join(here, "..", "mapping", "data", "seed001_whole_film_refs.json"))
    ap.add_argument("--max-clamp-distance-m", type=float, default=0.0065)
    ap.add_argument("--json", default="")
    a = ap.parse_args()
    if not (a.max_clamp_distance_m > 0):
        fail(f"--max-clamp-distance-m = {a.max_clamp_distance_m}: give a positive distance in metres")
    try:
        with open(a.scene) as f:
            scene = json.load(f)
        with open(a.refs) as f:
            refs = json.load(f)
    except (OSError, ValueError) as e:
        fail(f"cannot read the scene or the references: {e}")
    tolerance = scene.get("model", {}).get("tolerance", 0.01)

    presses = []
    for key, ref in refs.items():
        parts = key.split(",")
        if len(parts) != 5 or not isinstance(ref, dict) or not ref.get("ok"):
            continue  # the file's "_about" and failed references
        x, y, force = float(parts[0]), float(parts[1]), float(parts[2])
        d = clamp_distance_m(scene, x, y)
        if d <= a.max_clamp_distance_m:
            presses.append((d, x, y, force, ref))
    presses.sort(key=lambda p: -p[0])
    if not presses:
        fail(f"no reference press within {a.max_clamp_distance_m} m of the clamp in {a.refs}")

    rows = []
    print(f"{'x_mm':>8} {'y_mm':>8} {'clamp_mm':>8} {'off_%':>7} {'stated_%':>8} {'eta_%':>6} {'corr_%':>6} "
          f"{'st/off':>6} {'path':>18} {'dofs':>7} {'cpu_s':>6}")
    for d, x, y, force, ref in presses:
        cmd = [a.pvdfkit, "solve", a.scene, f"--load={x!r},{y!r},{force!r}", "--json"]
        p = subprocess.run(cmd, capture_output=True, text=True)
        row = {"x_m": x, "y_m": y, "clamp_distance_m": d, "force_N": force, "exit": p.returncode}
        if p.returncode != 0 or not p.stdout.strip():
            row["message"] = p.stderr.strip()[-300:]
            rows.append(row)
            print(f"{1e3 * x:8.2f} {1e3 * y:8.2f} {1e3 * d:8.2f}  exit {p.returncode}: {row['message'][:120]}")
            continue
        r = json.loads(p.stdout)
        q = [e["charge_C"] for e in r["electrodes"]]
        q_ref = ref["charge_C"]
        scale = max(abs(v) for v in q_ref)
        off = max(abs(u - v) for u, v in zip(q, q_ref)) / scale
        cl = r.get("clamp_layer", {})
        row.update(off=off, stated=r["estimated_relative_error"], eta=cl.get("estimated_error", 0.0),
                   correction=cl.get("correction", 0.0), path=cl.get("treatment", "none"), n_dofs=r["n_dofs"],
                   cpu_s=r.get("cpu_s"), reference_estimate=ref.get("estimate"),
                   signed_off=[(u - v) / scale for u, v in zip(q, q_ref)])
        row["effectivity"] = row["stated"] / off if off > 0 else math.inf
        rows.append(row)
        print(f"{1e3 * x:8.2f} {1e3 * y:8.2f} {1e3 * d:8.2f} {100 * off:7.3f} {100 * row['stated']:8.3f} "
              f"{100 * row['eta']:6.3f} {100 * row['correction']:6.2f} {row['effectivity']:6.2f} {row['path']:>18} "
              f"{row['n_dofs']:7d} {row['cpu_s'] or 0:6.1f}", flush=True)

    in_band = [r for r in rows if "off" in r and 0.5 <= r["effectivity"] <= 3]
    above = [r for r in rows if "off" in r and r["off"] > tolerance]
    print(f"\n{len(rows)} presses within {1e3 * a.max_clamp_distance_m:g} mm of the clamp: stated / off in [0.5, 3] at "
          f"{len(in_band)}; off by more than the tolerance ({100 * tolerance:g} %) at {len(above)}; "
          f"failed solves {sum(1 for r in rows if 'off' not in r)}")
    if a.json:
        with open(a.json + ".tmp", "w") as f:
            json.dump({"scene": a.scene, "refs": a.refs, "tolerance": tolerance, "rows": rows}, f, indent=1)
        os.replace(a.json + ".tmp", a.json)
    return 0 if len(in_band) == len(rows) else 1


if __name__ == "__main__":
    sys.exit(main())
