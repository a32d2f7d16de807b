"""Shared fixtures of the pvdfkit Python tests (run by ctest: tests/python/CMakeLists.txt)."""
import os
import pathlib

import pytest

SOURCE_DIR = pathlib.Path(os.environ.get("PVDF_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))


@pytest.fixture
def source_dir():
    return SOURCE_DIR


@pytest.fixture
def scenes(source_dir):
    return source_dir / "examples" / "scenes"
