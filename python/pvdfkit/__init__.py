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

Errors: every bad argument — wrong type, NaN or inf, empty, wrong shape or dtype, out of range,
an unknown keyword — raises :class:`InputError` (a ``ValueError``) with a one-line message naming
the argument, the value, the rule and the fix, checked with the command line's rules and defaults
(``solve(tolerance=0.7)`` is refused as ``pvdfkit solve --tolerance 0.7`` is). Array attributes of
ChargeMap and Scan read as read-only copies (assign a whole array to change a map). A numerical failure of
:func:`solve` raises :class:`NumericalError` (a ``RuntimeError``) unless ``check=False``, when
it is reported in ``result.status`` instead; ProbeSweep and the lookup always report it as a
status or flag, never as an exception.
"""

import functools as _functools
import inspect as _inspect
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
    OptimizeSummary,
    Scene,
    __version__,
    default_scene,
    design,
    flags_text,
    optimize_layouts,
    rank_designs,
    read_map,
    read_measurements,
    synthetic_map,
    validate_map,
    write_map,
)

has_fem = _pvdfkit.has_fem
if has_fem:
    from ._pvdfkit import ProbeSolutions, ProbeSweep, SolveResult, generate_map  # noqa: F401
    from ._pvdfkit import make_atlas, map_from_atlas  # noqa: F401  (docs/atlas.md)


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
    return _load_json_object("load_scene", scene, source, "scene", _pvdfkit._parse_scene_text,
                             _pvdfkit._load_scene_file, "a pvdfkit.Scene, a dict of scene keys or a scene file path")


def _load_json_object(function, scene, source, default_source, parse_text, load_file, accepted):
    """The shared body of load_scene and load_scanner_scene: a dict is parsed as JSON text named
    ``source``, a path is read by ``load_file``; anything else raises InputError naming ``accepted``."""
    if source is not None and not isinstance(source, str):
        raise InputError(f"{function}: source = {_shown(source)} ({type(source).__name__}) must be a str naming the dict")
    if isinstance(scene, dict):
        source = source or default_source
        return parse_text(_json_text(scene, source), source)
    if isinstance(scene, (str, _os.PathLike)):
        path = _os.fspath(scene)
        if not isinstance(path, str) or not path:
            raise InputError(f"{function}: scene = {_shown(scene)} must be a non-empty file path (str or pathlib.Path)")
        return load_file(path)
    raise InputError(f"{function}: scene = {_shown(scene)} ({type(scene).__name__}) must be {accepted}")


def scene_to_dict(scene):
    """The scene as a dict with every key (defaults filled in), as ``load_scene`` accepts it."""
    return _json.loads(load_scene(scene)._json_text())


Scene.to_dict = lambda self: scene_to_dict(self)
Scene.to_dict.__doc__ = "The scene as a dict with every key (defaults filled in)."


def solve(scene, loads=None, samples=None, model=None, tolerance=None, max_refinements=None,
          vtu_dir=None, check=True):
    """Solves the film under the scene's loads (or ``loads``) with the FEM solver.

    Parameters
    ----------
    scene : Scene, dict or path
    loads : array-like (n, 3), optional
        Probe presses ``[x_m, y_m, force_N]`` (m, m, N) replacing the scene's loads: at least one
        row, finite, ``|force_N| <= 1e4``, each footprint clear of the rim (the rules of
        ``pvdfkit solve --load``).
    samples : array-like (n, 2), optional
        Points ``[x_m, y_m]`` (m) inside the film at which displacement, membrane forces and
        charge density are returned (``result.displacement_m`` etc., one row per point).
    model : str, optional
        ``auto`` | ``linear`` | ``von-karman`` | ``large-rotation`` (default: the scene's).
    tolerance : float, optional
        Requested relative error of the outputs, in [1e-8, 0.5] as ``pvdfkit solve --tolerance``
        (default: the scene's ``model.tolerance``, 0.01).
    max_refinements : int, optional
        Cap on adaptive refinement cycles, 0..20 (default: the scene's).
    vtu_dir : str or path, optional
        Write VTU files for ParaView into this folder (created when missing).
    check : bool
        True: a solve that did not converge raises :class:`NumericalError`. False: it is
        returned with ``result.ok`` False and ``result.status`` saying why (arrays empty).

    Returns
    -------
    SolveResult
        ``charge_C`` (n_electrodes,) in C, ``deflection_at_load_m``, ``max_deflection_m`` in m,
        ``estimated_relative_error``, ``summary`` (dict with the keys of ``pvdfkit solve --json``:
        ``wall_s``, ``time_breakdown_s`` = {setup, assembly, linear_solve}, ...), sample fields
        (n_samples, ...).
    """
    if not has_fem:
        raise InputError("solve: this pvdfkit was built without the FEM modules (PVDF_WITH_FEM=OFF)")
    if isinstance(vtu_dir, str) and not vtu_dir:
        vtu_dir = None  # "" = no VTU output, as before
    return _pvdfkit._solve(scene, loads=loads, samples=samples, model=model, tolerance=tolerance,
                           max_refinements=max_refinements, vtu_dir=vtu_dir, check=check)


def grid_points(x_m, y_m):
    """All (x, y) pairs of a grid as an (len(y) * len(x), 2) array, x fastest (for ``samples``)."""
    import numpy as np
    xx, yy = np.meshgrid(_finite_vector(x_m, "grid_points: x_m"), _finite_vector(y_m, "grid_points: y_m"))
    return np.column_stack([xx.ravel(), yy.ravel()])


def _shown(value):
    """repr(value) for messages, at most 80 characters."""
    text = " ".join(repr(value).split())  # numpy's repr spans lines
    return text if len(text) <= 80 else text[:77] + "..."


def _finite_vector(value, what):
    """A non-empty 1-D float array of finite numbers, or InputError naming `what`."""
    import numpy as np
    if value is None or isinstance(value, (str, bytes, dict)):
        raise InputError(f"{what} = {_shown(value)} ({type(value).__name__}) must be an array of numbers (m)")
    try:
        a = np.asarray(value)
    except (ValueError, TypeError):
        raise InputError(f"{what} = {_shown(value)} is not an array of numbers (ragged rows?)") from None
    if a.dtype.kind not in "iuf":
        raise InputError(f"{what} = {_shown(value)} has dtype {a.dtype}; it must hold real numbers (m)")
    a = np.atleast_1d(a.astype(float))
    if a.ndim != 1:
        raise InputError(f"{what} has shape {a.shape}; expected a 1-D array of coordinates (m)")
    if a.size == 0:
        raise InputError(f"{what} is empty; give at least one coordinate (m)")
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise InputError(f"{what}[{bad[0]}] = {a[bad[0]]} is not finite; every coordinate must be a finite number (m)")
    return a


# --- Calls with an unknown keyword, too many or too few arguments: InputError, not TypeError ---------
# pybind11 answers such a call with a TypeError listing every overload's signature; a Python function
# with a TypeError of its own. Both become an InputError naming the call and its arguments.

def _split_top_level(text):
    """Splits a signature's parameter list on commas outside brackets and quotes."""
    parts, depth, quote, start = [], 0, None, 0
    for i, c in enumerate(text):
        if quote:
            if c == quote:
                quote = None
        elif c in "'\"":
            quote = c
        elif c in "([{":
            depth += 1
        elif c in ")]}":
            depth -= 1
        elif c == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return [p.strip() for p in parts if p.strip()]


def _native_parameters(function):
    """(names, required names) of a pybind11 function from the signature on its docstring's first line."""
    first = (getattr(function, "__doc__", None) or "").lstrip().split("\n", 1)[0]
    open_at = first.find("(")
    if open_at < 0:
        return None
    depth, close_at = 0, -1
    for i in range(open_at, len(first)):
        if first[i] == "(":
            depth += 1
        elif first[i] == ")":
            depth -= 1
            if depth == 0:
                close_at = i
                break
    names, required = [], []
    for part in _split_top_level(first[open_at + 1:close_at]):
        name = part.split(":", 1)[0].split("=", 1)[0].strip()
        if name == "self":
            continue
        names.append(name)
        if "=" not in part:
            required.append(name)
    return names, required


def _call_problem(label, names, required, args, kwargs):
    """One line saying what is wrong with a call, given the parameter names of the callee."""
    listed = ", ".join(names)
    unknown = [k for k in kwargs if k not in names]
    if unknown:
        return f"{label}: no argument named {unknown[0]!r}; the arguments are ({listed})"
    if len(args) > len(names):
        return f"{label}: takes at most {len(names)} arguments ({listed}), got {len(args)}"
    given = set(names[:len(args)]) | set(kwargs)
    twice = [n for n in names[:len(args)] if n in kwargs]
    if twice:
        return f"{label}: argument {twice[0]!r} is given twice (by position and by name)"
    missing = [n for n in required if n not in given]
    if missing:
        return f"{label}: argument {missing[0]!r} is missing; the arguments are ({listed})"
    return f"{label}: these arguments are not accepted; the arguments are ({listed})"


def _checked_native(function, label, is_method):
    names_required = _native_parameters(function)
    if names_required is None:
        return function
    names, required = names_required

    @_functools.wraps(function)
    def checked(*args, **kwargs):
        try:
            return function(*args, **kwargs)
        except TypeError as e:
            text = str(e)
            if "incompatible function arguments" not in text and "incompatible constructor arguments" not in text:
                raise
            call_args = args[1:] if is_method else args
            raise InputError(_call_problem(label, names, required, call_args, kwargs)) from None
    return checked


def _checked_python(function, label):
    signature = _inspect.signature(function)

    @_functools.wraps(function)
    def checked(*args, **kwargs):
        try:
            signature.bind(*args, **kwargs)
        except TypeError as e:
            names = ", ".join(signature.parameters)
            raise InputError(f"{label}: {e}; the arguments are ({names})") from None
        return function(*args, **kwargs)
    return checked


def _check_calls(namespace, module_label, native_module):
    """Wraps every public function and class method of a pybind11 module (in `namespace`, the
    package's globals) and every Python function listed, so a bad call raises InputError."""
    native_function = type(_pvdfkit.default_scene)
    for name, value in list(namespace.items()):
        if name.startswith("_") and name != "_solve":
            continue
        if isinstance(value, native_function) and getattr(value, "__module__", "").startswith("pvdfkit"):
            namespace[name] = _checked_native(value, f"{module_label}{name}", False)
        elif isinstance(value, type) and getattr(value, "__module__", "").startswith("pvdfkit._pvdfkit"):
            for attr, member in list(vars(value).items()):
                if attr != "__init__" and attr.startswith("_"):
                    continue
                if type(member).__name__ != "instancemethod":
                    continue
                label = value.__name__ if attr == "__init__" else f"{value.__name__}.{attr}"
                setattr(value, attr, _checked_native(member.__func__, label, True))


def _made_elsewhere(cls, how):
    """Result classes have no constructor: calling one raises InputError saying where they come from
    (instead of pybind11's TypeError "No constructor defined!")."""
    def __init__(self, *args, **kwargs):
        raise InputError(f"{cls.__name__} cannot be made directly; it comes from {how}")
    __init__.__doc__ = f"Not callable: a {cls.__name__} comes from {how}."
    cls.__init__ = __init__


_made_elsewhere(Scene, "pvdfkit.load_scene(path or dict) or pvdfkit.default_scene()")
_made_elsewhere(Locations, "Locator.locate(charges_C)")
_made_elsewhere(DesignSummary, "pvdfkit.design(map)")
_made_elsewhere(OptimizeSummary, "pvdfkit.optimize_layouts(scene, atlas=...)")
if has_fem:
    _made_elsewhere(SolveResult, "pvdfkit.solve(scene)")
    _made_elsewhere(ProbeSolutions, "ProbeSweep.solve(x_m, y_m, force_N)")
_check_calls(globals(), "", _pvdfkit)
if has_fem:
    _pvdfkit._solve = _checked_native(_pvdfkit._solve, "solve", False)
for _name in ("load_scene", "scene_to_dict", "solve", "grid_points"):
    globals()[_name] = _checked_python(globals()[_name], _name)
Scene.to_dict = lambda self: scene_to_dict(self)
Scene.to_dict.__doc__ = "The scene as a dict with every key (defaults filled in)."

from . import restore  # noqa: E402,F401  (after the helpers restore.py uses)

__all__ = [
    "FLAGS", "ChargeMap", "DesignSummary", "InputError", "Locations", "Locator", "NumericalError",
    "OptimizeSummary", "Scene", "default_scene", "design", "flags_text", "grid_points", "load_scene",
    "optimize_layouts", "rank_designs", "read_map",
    "read_measurements", "restore", "scene_to_dict", "solve", "synthetic_map", "validate_map",
    "write_map",
] + (["ProbeSolutions", "ProbeSweep", "SolveResult", "generate_map", "make_atlas", "map_from_atlas"] if has_fem else [])
