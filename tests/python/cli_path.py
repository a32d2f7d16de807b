"""The `pvdfkit` command of the build under test, for the tests that compare the Python package with
the command line (ctest sets PVDF_BINARY_DIR: tests/python/CMakeLists.txt)."""
import os

import pytest


def pvdfkit_cli():
    binary = os.environ.get("PVDF_BINARY_DIR")
    path = os.path.join(binary, "app", "pvdfkit") if binary else None
    if not path or not os.path.exists(path):
        pytest.fail("PVDF_BINARY_DIR/app/pvdfkit not found: run through ctest (tests/python/CMakeLists.txt)")
    return path
