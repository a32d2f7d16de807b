"""Seed 000's cylindrical scanner: simulate scans, identify inverse filters, restore forces.

Typical use::

    from pvdfkit import restore
    a = restore.simulate(restore.load_scanner_scene("examples/restore/edge_a.json"))
    b = restore.simulate(restore.load_scanner_scene("examples/restore/edge_b.json"))
    f = restore.identify([(a, 0.6, 0.9, -0.0125), (b, 0.2, 1.0, -0.0125)], beta=1e-4)
    forces = restore.apply(f, restore.read_scan("surface.csv"))   # .x_m, .fx_N, .fz_N, .mu

Bad input raises pvdfkit.InputError with the command line's message; every argument is checked
(type, finite values, shapes), and a Scan's arrays read as read-only copies.
"""


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
    from . import _load_json_object
    return _load_json_object("load_scanner_scene", scene, source, "scanner scene", _r._parse_scanner_scene_text,
                             _r._load_scanner_scene_file,
                             "a pvdfkit.restore.ScannerScene, a dict of scanner-scene keys or a file path")


def _check_restore_calls():
    from . import _check_calls, _checked_python, _made_elsewhere
    _made_elsewhere(InverseFilter, "restore.identify(scans) or restore.load_filter(path)")
    _made_elsewhere(ScannerScene, "restore.load_scanner_scene(path or dict) or restore.default_scanner_scene()")
    _made_elsewhere(RestoredForces, "restore.apply(filter, scan)")
    _check_calls(globals(), "restore.", _r)
    globals()["load_scanner_scene"] = _checked_python(load_scanner_scene, "restore.load_scanner_scene")


_check_restore_calls()

__all__ = ["InverseFilter", "RestoredForces", "Scan", "ScannerScene", "apply", "default_scanner_scene",
           "identify", "load_filter", "load_scanner_scene", "read_scan", "save_filter", "simulate",
           "write_scan"]
