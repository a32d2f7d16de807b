"""Key-for-key comparison of a Python dict with a command's --json object (the tests that hold the
Python package and the command line to one serializer per result)."""
import math

# Measured times and the process's memory: properties of a run, not of the result.
TIMING_KEYS = {"wall_s", "cpu_s", "seconds", "setup_s", "time_breakdown_s", "peak_resident_bytes", "memory"}


def assert_same_json(py, cl, path="", skip=TIMING_KEYS, rel=1e-9):
    """py and cl have the same keys at every depth and the same values (numbers within `rel`, NaN
    and None alike), the keys of `skip` aside (their presence still has to agree)."""
    if isinstance(py, dict):
        assert isinstance(cl, dict), f"{path}: dict against {type(cl).__name__}"
        assert set(py) == set(cl), f"{path}: keys only in Python {sorted(set(py) - set(cl))}, only in the command {sorted(set(cl) - set(py))}"
        for key in py:
            if key not in skip:
                assert_same_json(py[key], cl[key], f"{path}.{key}", skip, rel)
    elif isinstance(py, list):
        assert isinstance(cl, list) and len(py) == len(cl), f"{path}: lists of different lengths"
        for i, (a, b) in enumerate(zip(py, cl)):
            assert_same_json(a, b, f"{path}[{i}]", skip, rel)
    elif isinstance(py, bool) or isinstance(cl, bool) or isinstance(py, str) or py is None or cl is None:
        if py is None or cl is None:
            nan_like = lambda v: v is None or (isinstance(v, float) and math.isnan(v))
            assert nan_like(py) and nan_like(cl), f"{path}: {py!r} against {cl!r}"
        else:
            assert py == cl, f"{path}: {py!r} against {cl!r}"
    else:
        assert math.isclose(py, cl, rel_tol=rel, abs_tol=0) or py == cl, f"{path}: {py!r} against {cl!r}"
