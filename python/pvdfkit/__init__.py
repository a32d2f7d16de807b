"""pvdfkit: PVDF piezoelectric tactile sensors from Python.

The C++ toolkit (FEM solver, charge maps, the lookup, layout design, scanner restore) with numpy
arrays in and out. Units are SI throughout and written into the names: ``x_m``, ``force_N``,
``charge_C``; convert to mm or pC only when printing or plotting.

Typical use::

    import pvdfkit
    scene = pvdfkit.load_scene("examples/scenes/seed001.json")   # or a dict, or default_scene()
    r = pvdfkit.solve(scene, loads=[[0.0, 0.0, 1.0]])             # 1 N at the centre
    r.charge_C, r.estimated_relative_error                        # (n_electrodes,) C
    m = pvdfkit.read_map("map.h5")                                # ChargeMap, arrays (nf, ny, nx, ne)
    loc = pvdfkit.Locator(m)
    presses = loc.locate(q)                                       # q: (N, n_electrodes) in C
    presses.x_m, presses.sigma_x_m, presses.flags                 # (N,) arrays

Errors: bad input raises :class:`InputError` (a ``ValueError``) with the same one-line message
as the command line (naming the input, the value and the fix). A numerical failure of
:func:`solve` raises :class:`NumericalError` (a ``RuntimeError``) unless ``check=False``, when
it is reported in ``result.status`` instead; ProbeSweep and the lookup always report it as a
status or flag, never as an exception.
"""

import json as _json
import os as _os

from . import _pvdfkit
from ._pvdfkit import (  # noqa: F401  (re-exported API)
    FLAGS,
    ChargeMap,
    DesignSummary,
    InputError,
    Locations,
    Locator,
    NumericalError,
    Scene,
    __version__,
    default_scene,
    design,
    flags_text,
    read_map,
    read_measurements,
    synthetic_map,
    validate_map,
    write_map,
)
from . import restore  # noqa: F401

has_fem = _pvdfkit.has_fem
if has_fem:
    from ._pvdfkit import ProbeSolutions, ProbeSweep, SolveResult, generate_map  # noqa: F401


def _json_text(value, source):
    """JSON text of a dict for the C++ reader; NaN/inf are refused as the reader refuses them."""
    try:
        return _json.dumps(value, allow_nan=False)
    except ValueError as e:
        raise InputError(f"{source}: {e}; use finite numbers") from None
    except TypeError as e:
        raise InputError(f"{source}: {e}; scene values must be numbers, strings, lists or dicts") from None


def load_scene(scene, source=None):
    """A validated :class:`Scene` from a scene file path or a dict with the scene-file keys.

    The checks and their messages are those of ``pvdfkit`` on the command line: an unknown key,
    a wrong type or an out-of-range value raises :class:`InputError` naming the key path, the
    value and the rule, e.g. ``scene: membrane.thickness_m = -2.5e-05 must be > 0``.
    ``source`` names a dict in those messages (default ``"scene"``).
    """
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, dict):
        source = source or "scene"
        return _pvdfkit._parse_scene_text(_json_text(scene, source), source)
    if isinstance(scene, (str, _os.PathLike)):
        return _pvdfkit._load_scene_file(_os.fspath(scene))
    raise InputError(f"load_scene: expected a file path or a dict, got {type(scene).__name__}")


def scene_to_dict(scene):
    """The scene as a dict with every key (defaults filled in), as ``load_scene`` accepts it."""
    return _json.loads(load_scene(scene)._json_text())


Scene.to_dict = lambda self: scene_to_dict(self)
Scene.to_dict.__doc__ = "The scene as a dict with every key (defaults filled in)."


def solve(scene, loads=None, samples=None, model=None, tolerance=None, max_refinements=None,
          vtu_dir="", check=True):
    """Solves the film under the scene's loads (or ``loads``) with the FEM solver.

    Parameters
    ----------
    scene : Scene, dict or path
    loads : array-like (n, 3), optional
        Probe presses ``[x_m, y_m, force_N]`` (m, m, N) replacing the scene's loads.
    samples : array-like (n, 2), optional
        Points ``[x_m, y_m]`` (m) at which displacement, membrane forces and charge density are
        returned (``result.displacement_m`` etc., one row per point).
    model : str, optional
        ``auto`` | ``linear`` | ``von-karman`` | ``large-rotation`` (default: the scene's).
    tolerance : float, optional
        Requested relative error of the outputs, in (0, 1) (default: the scene's, 0.01).
    max_refinements : int, optional
        Cap on adaptive refinement cycles.
    vtu_dir : str
        Write VTU files for ParaView into this folder when non-empty.
    check : bool
        True: a solve that did not converge raises :class:`NumericalError`. False: it is
        returned with ``result.ok`` False and ``result.status`` saying why (arrays empty).

    Returns
    -------
    SolveResult
        ``charge_C`` (n_electrodes,) in C, ``deflection_at_load_m``, ``max_deflection_m`` in m,
        ``estimated_relative_error``, ``summary`` (dict), sample fields (n_samples, ...).
    """
    if not has_fem:
        raise InputError("solve: this pvdfkit was built without the FEM modules (PVDF_WITH_FEM=OFF)")
    return _pvdfkit._solve(load_scene(scene), loads=loads, samples=samples, model=model,
                           tolerance=tolerance, max_refinements=max_refinements,
                           vtu_dir=_os.fspath(vtu_dir), check=check)


def grid_points(x_m, y_m):
    """All (x, y) pairs of a grid as an (len(y) * len(x), 2) array, x fastest (for ``samples``)."""
    import numpy as np
    xx, yy = np.meshgrid(np.asarray(x_m, float), np.asarray(y_m, float))
    return np.column_stack([xx.ravel(), yy.ravel()])


__all__ = [
    "FLAGS", "ChargeMap", "DesignSummary", "InputError", "Locations", "Locator", "NumericalError",
    "Scene", "default_scene", "design", "flags_text", "grid_points", "load_scene", "read_map",
    "read_measurements", "restore", "scene_to_dict", "solve", "synthetic_map", "validate_map",
    "write_map",
] + (["ProbeSolutions", "ProbeSweep", "SolveResult", "generate_map"] if has_fem else [])
