"""Seed 000's cylindrical scanner: simulate scans, identify inverse filters, restore forces.

Typical use::

    from pvdfkit import restore
    a = restore.simulate(restore.load_scanner_scene("examples/restore/edge_a.json"))
    b = restore.simulate(restore.load_scanner_scene("examples/restore/edge_b.json"))
    f = restore.identify([(a, 0.6, 0.9, -0.0125), (b, 0.2, 1.0, -0.0125)], beta=1e-4)
    forces = restore.apply(f, restore.read_scan("surface.csv"))   # .x_m, .fx_N, .fz_N, .mu

Bad input raises pvdfkit.InputError with the command line's message.
"""

import os as _os

from ._pvdfkit import restore as _r
from ._pvdfkit import RestoredForces  # noqa: F401
from ._pvdfkit.restore import (  # noqa: F401
    InverseFilter,
    Scan,
    ScannerScene,
    apply,
    default_scanner_scene,
    identify,
    load_filter,
    read_scan,
    save_filter,
    simulate,
    write_scan,
)


def load_scanner_scene(scene, source=None):
    """A validated :class:`ScannerScene` from a JSON file path or a dict with the same keys."""
    if isinstance(scene, ScannerScene):
        return scene
    if isinstance(scene, dict):
        from . import _json_text
        source = source or "scanner scene"
        return _r._parse_scanner_scene_text(_json_text(scene, source), source)
    return _r._load_scanner_scene_file(_os.fspath(scene))


__all__ = ["InverseFilter", "RestoredForces", "Scan", "ScannerScene", "apply", "default_scanner_scene",
           "identify", "load_filter", "load_scanner_scene", "read_scan", "save_filter", "simulate",
           "write_scan"]
