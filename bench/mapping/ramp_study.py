#!/usr/bin/env python3
"""Does a press's force ramp single out one of the positions its peak charges allow?

With the force unknown, three charges usually fit several presses (docs/lookup.md §2). For a
pure membrane Q = F^(2/3) G(x, y): the charge *direction* does not change with the force, so
every candidate that fits the peak fits every sample of the ramp as well and a ramp cannot
help. Pretension (or bending) breaks the scaling: the direction turns with the force, differently
at different positions, so the loading curve may rule candidates out. This program measures it.

For each press (random position between the grid nodes, peak force log-uniform in a range):
  1. the peak charges with Gaussian noise are located with the force unknown (Locator):
     the candidates are the reported solutions;
  2. a ramp of n samples from r0*F to F (the peak is the last sample, independent noise on
     each) is tested against each candidate: "a press at this position whose force ramps".
     Two tests, both with the charge noise alone as sigma:
       fixed: the position held at the candidate; per sample the force alone is fitted
              (1-D in ln F on the map interpolant); chi2 summed over the ramp,
              dof = n (n_electrodes - 1);
       refit: the position is refined over the whole ramp (one position, one force per
              sample; Levenberg-Marquardt from the candidate with the forces profiled out),
              dof = n (n_electrodes - 1) - 2.
     A candidate is rejected when its chi2 exceeds the chi2 quantile 1 - alpha of its dof.
  3. counted: ambiguous at the peak (more than one candidate), ambiguous after the ramp (more
     than one candidate kept), the press's own candidate (the one nearest the truth, if within
     --match-m) rejected, no candidate kept.

The truth is the interpolant of --truth-map (default: the lookup map itself, so the only error
is the noise); a finer FEM map as truth for a coarser lookup map shows what the map's own
interpolation error does to the test.

Map interpolant facts used: Locator.predict is F^(2/3) G(x, y, ln F) with G linear in ln F
between the force levels and held constant beyond them (docs/mapping.md §2), so G at the
levels ("knots") gives the whole force curve of a position.

Run (Debian python3 with numpy and scipy; the module from the build tree):
    PYTHONPATH=build/python /usr/bin/python3 bench/mapping/ramp_study.py --map MAP.h5 \
        [--truth-map FINE.h5] [--noise-pC 0.05,0.2,1] [--presses 400] [--samples 30] [--json]
"""

import argparse
import json
import math
import sys

import numpy as np
from scipy.stats import chi2 as chi2_dist

import pvdfkit


def without_error_estimates(m):
    """A copy of a map without its per-node error estimates (the lookup's sigma is the noise)."""
    c = pvdfkit.ChargeMap()
    for name in ("scene_json", "pvdfkit_version", "model", "tolerance", "rim_margin_m", "description",
                 "electrode_names"):
        setattr(c, name, getattr(m, name))
    c.x_m, c.y_m, c.forces_N = m.x_m, m.y_m, m.forces_N
    c.electrode_centers_m = m.electrode_centers_m
    c.allocate()
    c.noise_C, c.mask, c.status = m.noise_C, m.mask, m.status
    c.charge_C, c.deflection_at_load_m = m.charge_C, m.deflection_at_load_m
    return c


class ForceCurves:
    """Charges of fixed positions as a function of the force, from the map interpolant."""

    def __init__(self, locator, levels_N, lo_N, hi_N, n_grid=240):
        self.loc = locator
        self.levels_u = np.log(np.asarray(levels_N, float))
        self.levels_N = np.asarray(levels_N, float)
        self.grid_u = np.linspace(math.log(lo_N), math.log(hi_N), n_grid)
        self.lo_u, self.hi_u = math.log(lo_N), math.log(hi_N)

    def knots(self, xy):
        """G at the force levels for positions xy (M, 2): shape (M, nf, ne); NaN off the map."""
        nf = len(self.levels_N)
        x = np.repeat(xy[:, 0], nf)
        y = np.repeat(xy[:, 1], nf)
        f = np.tile(self.levels_N, len(xy))
        q = self.loc.predict(x, y, f).reshape(len(xy), nf, -1)
        return q / self.levels_N[None, :, None] ** (2.0 / 3.0)

    def charges(self, knots, u):
        """Q and dQ/du at ln-forces u (..., S) for knots (..., nf, ne): shapes (..., S, ne)."""
        u_c = np.clip(u, self.levels_u[0], self.levels_u[-1])
        j = np.clip(np.searchsorted(self.levels_u, u_c) - 1, 0, len(self.levels_u) - 2)
        du = self.levels_u[j + 1] - self.levels_u[j]
        t = ((u_c - self.levels_u[j]) / du)[..., None]
        ga = np.take_along_axis(knots, j[..., None].repeat(knots.shape[-1], -1), axis=-2)
        gb = np.take_along_axis(knots, (j + 1)[..., None].repeat(knots.shape[-1], -1), axis=-2)
        g = ga + (gb - ga) * t
        inside = ((u > self.levels_u[0]) & (u < self.levels_u[-1]))[..., None]
        slope = np.where(inside, (gb - ga) / du[..., None], 0.0)
        s = np.exp(2.0 * u / 3.0)[..., None]
        return s * g, s * (2.0 / 3.0 * g + slope)

    def fit_forces(self, knots, q, sigma, u0=None):
        """Per sample the best ln F at fixed positions.

        knots (M, nf, ne), q (M, n, ne) charges, sigma (ne,); u0 (M, n): starts (default: a
        search over the grid). Returns u (M, n) and chi2 (M, n)."""
        m, n, _ = q.shape
        if u0 is None:
            grid = np.broadcast_to(self.grid_u, (m, len(self.grid_u)))
            qg, _ = self.charges(knots, grid)                               # (M, K, ne)
            r = (qg[:, None, :, :] - q[:, :, None, :]) / sigma              # (M, n, K, ne)
            c = np.einsum("mnke,mnke->mnk", r, r)
            u = self.grid_u[np.argmin(c, axis=2)]
        else:
            u = u0.copy()
        for _ in range(4):                                                  # Gauss-Newton in ln F
            qm, dq = self.charges(knots, u)
            res = (qm - q) / sigma
            d = dq / sigma
            step = -np.einsum("mne,mne->mn", d, res) / np.maximum(np.einsum("mne,mne->mn", d, d), 1e-300)
            u = np.clip(u + step, self.lo_u, self.hi_u)
        qm, _ = self.charges(knots, u)
        res = (qm - q) / sigma
        return u, np.einsum("mne,mne->mn", res, res)


def refit_position(curves, xy, q, sigma, h_m=1e-5, iterations=40):
    """One position for the whole ramp (forces per sample profiled out), from xy (M, 2).

    Levenberg-Marquardt on the position with each sample's ln F profiled out (the Schur
    complement of the ln F block); the valley is long where the position's weak direction
    trades against the force, hence the damping. Returns the refined positions (M, 2) and the
    ramp chi2 (M,) (inf where off the map)."""
    xy = xy.copy()
    kn = curves.knots(xy)
    u, c = curves.fit_forces(kn, q, sigma)
    best = np.where(np.isfinite(c.sum(1)), c.sum(1), np.inf)
    lam = np.full(len(xy), 1e-3)
    offs = np.array([[h_m, 0.0], [-h_m, 0.0], [0.0, h_m], [0.0, -h_m]])
    active = np.isfinite(best)
    for _ in range(iterations):
        idx = np.where(active)[0]
        if len(idx) == 0:
            break
        k, uu, qq = kn[idx], u[idx], q[idx]
        kd = curves.knots((xy[idx, None, :] + offs[None]).reshape(-1, 2)).reshape(len(idx), 4, *kn.shape[1:])
        q0, dq = curves.charges(k, uu)
        jx = (curves.charges(kd[:, 0], uu)[0] - curves.charges(kd[:, 1], uu)[0]) / (2 * h_m)
        jy = (curves.charges(kd[:, 2], uu)[0] - curves.charges(kd[:, 3], uu)[0]) / (2 * h_m)
        r = (q0 - qq) / sigma                                                # (M, n, ne)
        jp = np.stack([jx, jy], -1) / sigma[:, None]                         # (M, n, ne, 2)
        ju = dq / sigma
        nu = np.maximum(np.einsum("mne,mne->mn", ju, ju), 1e-300)
        jp_p = jp - ju[..., None] * (np.einsum("mne,mnep->mnp", ju, jp) / nu[..., None])[:, :, None, :]
        r_p = r - ju * (np.einsum("mne,mne->mn", ju, r) / nu)[..., None]
        a = np.einsum("mnep,mneq->mpq", jp_p, jp_p)
        b = np.einsum("mnep,mne->mp", jp_p, r_p)
        ok = np.isfinite(a).all((1, 2)) & np.isfinite(b).all(1)
        a[~ok], b[~ok] = np.eye(2), 0.0
        damped = a + lam[idx, None, None] * (np.eye(2) * np.diagonal(a, axis1=1, axis2=2)[:, None, :] + 1e-30 * np.eye(2))
        step = -np.linalg.solve(damped, b[..., None])[..., 0]
        trial = xy[idx] + step
        kt = curves.knots(trial)
        ut, ct = curves.fit_forces(kt, qq, sigma, u0=uu)
        ct = ct.sum(1)
        better = ok & np.isfinite(ct) & (ct < best[idx])
        gain = np.where(better, best[idx] - ct, 0.0)
        j = idx[better]
        xy[j], kn[j], u[j], best[j] = trial[better], kt[better], ut[better], ct[better]
        lam[idx] = np.where(better, lam[idx] / 3, lam[idx] * 4)
        # converged: no gain worth 1e-3 in chi2 and the damping has grown (no descent left)
        active[idx] = ok & ~((~better & (lam[idx] > 1e6)) | (better & (gain < 1e-4)))
    return xy, best


def study(args, lookup_map, truth_map, noise_C, rng):
    ne = lookup_map.n_electrodes
    sigma = np.full(ne, noise_C)
    loc = pvdfkit.Locator(lookup_map, noise_C=noise_C)
    truth = pvdfkit.Locator(truth_map, noise_C=noise_C)
    levels = np.asarray(lookup_map.forces_N, float)
    # ramp forces are fitted down to the ramp's start below the lookup's plausible range
    lo, hi = 0.5 * args.ramp_start * levels[0], 2.0 * levels[-1]
    curves = ForceCurves(loc, levels, lo, hi)
    truth_curves = ForceCurves(truth, np.asarray(truth_map.forces_N, float), lo, hi)

    # presses: uniform in the square, peak force log-uniform; the truth must be on both maps
    n = args.presses
    xy = rng.uniform(-args.half_width_m, args.half_width_m, size=(4 * n, 2))
    keep = np.isfinite(loc.predict(xy[:, 0], xy[:, 1], 1.0)).all(1) & np.isfinite(
        truth.predict(xy[:, 0], xy[:, 1], 1.0)).all(1)
    xy = xy[keep][:n]
    n = len(xy)
    f_lo, f_hi = args.peak_force_N
    peak = np.exp(rng.uniform(math.log(f_lo), math.log(f_hi), n))
    ramp = peak[:, None] * np.linspace(args.ramp_start, 1.0, args.samples)[None, :]      # (n, S)
    q_true, _ = truth_curves.charges(truth_curves.knots(xy), np.log(ramp))               # (n, S, ne)
    q = q_true + rng.normal(0.0, noise_C, q_true.shape)

    found = loc.locate(q[:, -1, :])
    cands, owner = [], []
    for i in range(n):
        if not found.has_position[i]:
            continue
        cands.append((found.x_m[i], found.y_m[i]))
        owner.append(i)
        for a in range(int(found.n_solutions[i]) - 1):
            cands.append(tuple(found.alternatives[i, a, :2]))
            owner.append(i)
    cands, owner = np.asarray(cands), np.asarray(owner)

    dof_fixed = args.samples * (ne - 1)
    dof_refit = dof_fixed - 2
    lim_fixed = chi2_dist.ppf(1 - args.alpha, dof_fixed)
    lim_refit = chi2_dist.ppf(1 - args.alpha, dof_refit)
    _, c_fixed = curves.fit_forces(curves.knots(cands), q[owner], sigma)
    c_fixed = c_fixed.sum(1)
    c_fixed[~np.isfinite(c_fixed)] = np.inf
    _, c_refit = refit_position(curves, cands, q[owner], sigma)

    out = {"noise_pC": noise_C * 1e12, "presses": n, "located": int(found.has_position.sum()),
           "dof_fixed": dof_fixed, "limit_fixed": lim_fixed, "dof_refit": dof_refit, "limit_refit": lim_refit}
    dist = np.hypot(*(cands - xy[owner]).T)
    for name, c, lim in (("fixed", c_fixed, lim_fixed), ("refit", c_refit, lim_refit)):
        amb_peak = amb_after = truth_in = truth_rejected = none_kept = resolved = 0
        for i in np.unique(owner):
            sel = owner == i
            kept = c[sel] <= lim
            nearest = np.argmin(dist[sel])
            own = dist[sel][nearest] <= args.match_m
            amb_peak += sel.sum() > 1
            amb_after += kept.sum() > 1
            none_kept += kept.sum() == 0
            truth_in += own
            truth_rejected += own and not kept[nearest]
            resolved += sel.sum() > 1 and kept.sum() == 1 and own and kept[nearest]
        located = len(np.unique(owner))
        out[name] = {"ambiguous_at_peak": amb_peak / located, "ambiguous_after_ramp": amb_after / located,
                     "resolved_to_truth": resolved / located, "truth_among_candidates": truth_in / located,
                     "truth_rejected": truth_rejected / located, "none_kept": none_kept / located,
                     "median_chi2_per_dof_of_own_candidate": float(np.median(
                         [c[owner == i][np.argmin(dist[owner == i])] for i in np.unique(owner)]) / (
                         dof_fixed if name == "fixed" else dof_refit))}
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--map", required=True, help="lookup map (HDF5, several force levels)")
    p.add_argument("--truth-map", help="map whose interpolant is the truth (default: --map)")
    p.add_argument("--noise-pC", default="0.05,0.2,1", help="1-sigma charge noise per electrode, pC, list")
    p.add_argument("--presses", type=int, default=400)
    p.add_argument("--samples", type=int, default=30, help="ramp samples (the peak is the last)")
    p.add_argument("--ramp-start", type=float, default=0.25, help="first ramp sample as a fraction of the peak (1: held at the peak, the averaging baseline)")
    p.add_argument("--peak-force-N", default="1,2", help="peak force range MIN,MAX (N), log-uniform")
    p.add_argument("--half-width-m", type=float, default=0.012, help="presses in |x|, |y| <= this (m)")
    p.add_argument("--alpha", type=float, default=1e-3, help="false-rejection rate of the chi2 test")
    p.add_argument("--match-m", type=float, default=1e-3, help="a candidate this near the truth is the press's own (m)")
    p.add_argument("--keep-map-error", action="store_true", help="let the lookup use the maps' error estimates")
    p.add_argument("--seed", type=int, default=17)
    p.add_argument("--json", action="store_true")
    args = p.parse_args()
    args.peak_force_N = [float(v) for v in args.peak_force_N.split(",")]
    if args.samples < 2 or not 0 < args.ramp_start <= 1:
        sys.exit("error: --samples must be >= 2 and --ramp-start in (0, 1] (1: the force held at the peak)")

    lookup_map = pvdfkit.read_map(args.map)
    truth_map = pvdfkit.read_map(args.truth_map) if args.truth_map else lookup_map
    if not args.keep_map_error:
        lookup_map, truth_map = without_error_estimates(lookup_map), without_error_estimates(truth_map)
    rng = np.random.default_rng(args.seed)
    rows = [study(args, lookup_map, truth_map, float(s) * 1e-12, rng) for s in args.noise_pC.split(",")]
    if args.json:
        print(json.dumps({"map": args.map, "truth_map": args.truth_map or args.map, "results": rows}, indent=1))
        return
    print(f"map {args.map}, truth {args.truth_map or args.map}; {args.samples} ramp samples "
          f"{args.ramp_start:g}F..F, peaks {args.peak_force_N[0]:g}-{args.peak_force_N[1]:g} N, alpha {args.alpha:g}")
    print("noise_pC test  ambiguous@peak  after_ramp  resolved_to_truth  truth_found  truth_rejected  none_kept  own_chi2/dof")
    for r in rows:
        for name in ("fixed", "refit"):
            s = r[name]
            print(f"{r['noise_pC']:8.3g} {name:5s} {100 * s['ambiguous_at_peak']:13.1f}% "
                  f"{100 * s['ambiguous_after_ramp']:10.1f}% {100 * s['resolved_to_truth']:17.1f}% "
                  f"{100 * s['truth_among_candidates']:11.1f}% "
                  f"{100 * s['truth_rejected']:14.1f}% {100 * s['none_kept']:9.1f}% "
                  f"{s['median_chi2_per_dof_of_own_candidate']:12.2f}")


if __name__ == "__main__":
    main()
