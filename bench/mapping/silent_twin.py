#!/usr/bin/env python3
"""The "silent twin" of docs/lookup.md §1, measured on FEM maps: does the lookup answer a press it
cannot place with a confident wrong position ("silent"), or does its σ / its list of solutions hold
the truth?

For each press (x, y, F) the truth is a direct FEM solve (`pvdfkit.solve` at --truth-tolerance,
bending as the scene's model decides), not a map. Charge noise (the map's 1-sigma, or --noise-C) is
drawn --draws times (seeded); every draw is located on every map given, with the force known and
unknown. Per map and press it prints:

- ok: answers flagged `ok` (no flag);
- covered: the truth lies within 2 σ of the best answer in x and in y, or within --near-m of one of
  the other reported solutions (flag `ambiguous`; default 2 mm);
- silent: flagged `ok` and not covered — a confident wrong answer;
- median |error| and median σ of the best answer (mm).

Usage:
  silent_twin.py SCENE MAP [MAP ...] [--press X,Y,F ...] [--draws 100] [--seed 1] [--json FILE]

Exit 2 on bad arguments or an unreadable map; exit 3 when a truth solve does not converge.
"""
import argparse
import json
import math
import sys

import numpy as np
import pvdfkit


def parse_press(text):
    try:
        x, y, f = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--press {text!r}: give X,Y,F in m, m, N, e.g. -0.006,0.002,1")
    if not all(math.isfinite(v) for v in (x, y, f)) or f <= 0:
        raise argparse.ArgumentTypeError(f"--press {text!r}: X, Y finite (m), F > 0 (N)")
    return x, y, f


def covered(loc, i, x, y, near_m):
    """Truth within 2σ of the best answer (x and y), or within near_m of another solution."""
    if loc.has_position[i] and abs(loc.x_m[i] - x) <= 2 * loc.sigma_x_m[i] and abs(loc.y_m[i] - y) <= 2 * loc.sigma_y_m[i]:
        return True
    for alt in loc.alternatives[i]:
        if np.isfinite(alt[0]) and math.hypot(alt[0] - x, alt[1] - y) <= near_m:
            return True
    return False


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("maps", nargs="+")
    ap.add_argument("--press", type=parse_press, action="append", help="X,Y,F (m, m, N); default -0.006,0.002,1 and 0.006,-0.004,1")
    ap.add_argument("--draws", type=int, default=100)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--noise-C", type=float, default=0.0, help="1-sigma charge noise (C); default the map's")
    ap.add_argument("--near-m", type=float, default=0.002, help="an alternative solution this close to the truth covers it (m; default 2 mm)")
    ap.add_argument("--truth-tolerance", type=float, default=0.002)
    ap.add_argument("--json", default="")
    a = ap.parse_args()
    if not 1 <= a.draws <= 100000:
        ap.error(f"--draws {a.draws}: give 1..100000")
    if a.noise_C < 0 or a.noise_C > 1e-6:
        ap.error(f"--noise-C {a.noise_C:g}: give 0 (the map's) or a 1-sigma in (0, 1e-6] C")
    presses = a.press or [(-0.006, 0.002, 1.0), (0.006, -0.004, 1.0)]
    try:
        maps = [(path, pvdfkit.read_map(path)) for path in a.maps]
    except (pvdfkit.InputError, OSError) as e:
        print(f"silent_twin.py: {e}", file=sys.stderr)
        return 2

    rows = []
    for (x, y, force) in presses:
        truth = pvdfkit.solve(a.scene, loads=[[x, y, force]], tolerance=a.truth_tolerance, check=False)
        if not truth.ok:
            print(f"silent_twin.py: the truth solve at ({1e3 * x:g}, {1e3 * y:g}) mm did not converge: {truth.message}",
                  file=sys.stderr)
            return 3
        q = np.array(truth.charge_C)
        for path, m in maps:
            sigma = np.broadcast_to(a.noise_C if a.noise_C > 0 else np.array(m.noise_C), q.shape)
            rng = np.random.default_rng(a.seed)
            draws = q + rng.standard_normal((a.draws, q.size)) * sigma
            locator = pvdfkit.Locator(m, noise_C=sigma)
            for known in (True, False):
                loc = locator.locate(draws, known_force_N=force if known else None)
                ok = [int(loc.flags[i]) == 0 for i in range(a.draws)]
                cov = [covered(loc, i, x, y, a.near_m) for i in range(a.draws)]
                err = [math.hypot(loc.x_m[i] - x, loc.y_m[i] - y) for i in range(a.draws) if loc.has_position[i]]
                sig = [math.hypot(loc.sigma_x_m[i], loc.sigma_y_m[i]) for i in range(a.draws) if loc.has_position[i]]
                row = dict(map=path, x_m=x, y_m=y, force_N=force, force_known=known, draws=a.draws,
                           ok=sum(ok), covered=sum(cov), silent=sum(1 for o, c in zip(ok, cov) if o and not c),
                           median_error_m=float(np.median(err)) if err else None,
                           median_sigma_m=float(np.median(sig)) if sig else None)
                rows.append(row)
                print(f"{path:28} ({1e3 * x:6.2f}, {1e3 * y:6.2f}) mm {force:g} N force {'known  ' if known else 'unknown'}: "
                      f"ok {row['ok']:4d}, covered {row['covered']:4d}, silent {row['silent']:4d} of {a.draws}; "
                      f"median |error| {1e3 * (row['median_error_m'] or math.nan):.3f} mm, "
                      f"median |σ| {1e3 * (row['median_sigma_m'] or math.nan):.3f} mm", flush=True)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(dict(scene=a.scene, seed=a.seed, rows=rows), f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
