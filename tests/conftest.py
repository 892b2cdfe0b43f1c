"""Shared fixtures: the built-in mechanisms, the test triad, and the nominal Jansen cycle (solved once)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

TESTS = Path(__file__).resolve().parent
if str(TESTS) not in sys.path:  # `import naive` whatever pytest's import mode
    sys.path.insert(0, str(TESTS))

# no test sees the user's cached curve atlases (explorer optimize's algorithm "auto" would start from them):
# each test process gets an empty atlas directory of its own; a test that needs an atlas builds a small one
import os  # noqa: E402
import tempfile  # noqa: E402

os.environ["EXPLORER_ATLAS_DIR"] = tempfile.mkdtemp(prefix="explorer-atlas-test-")

from naive import TRIAD  # noqa: E402

from explorer import load_mechanism, simulate  # noqa: E402


@pytest.fixture(scope="session")
def jansen():
    return load_mechanism("jansen")


@pytest.fixture(scope="session")
def fourbar():
    return load_mechanism("fourbar")


@pytest.fixture(scope="session")
def triad():
    return load_mechanism(TRIAD)


@pytest.fixture(scope="session")
def jansen_cycle(jansen):
    """The nominal Jansen leg at 360 steps, block method, tolerance 1e-12, with velocities."""
    return simulate(jansen, 360, tolerance=1e-12, method="block", velocities=True)


@pytest.fixture(scope="session")
def thetas360():
    return 2.0 * np.pi * np.arange(360) / 360


#: Slow tests marked here rather than in their file (files another change owns; move the mark into the
#: file with @pytest.mark.slow when it is next edited). Node ids without parameters.
SLOW_ELSEWHERE = {
    "test_codegen.py::test_generated_kernel_equals_the_general_sweep_bit_for_bit",
    "test_codegen.py::test_threads_share_one_generated_kernel",
    "test_sweep_template.py::test_scalar_form_is_valid_python_without_holes",
}


@pytest.hookimpl(tryfirst=True)  # before -k and -m deselect anything
def pytest_collection_modifyitems(config, items):
    """Mark :data:`SLOW_ELSEWHERE` slow; fail loudly when one no longer names a collected test."""
    seen = set()
    for item in items:
        key = f"{item.path.name}::{item.originalname}"
        if key in SLOW_ELSEWHERE:
            item.add_marker(pytest.mark.slow)
            seen.add(key)
    files = {item.path.name for item in items}
    stale = {k for k in SLOW_ELSEWHERE - seen if k.split("::")[0] in files}
    if stale:
        raise pytest.UsageError(f"tests/conftest.py SLOW_ELSEWHERE names tests that do not exist: {sorted(stale)}")
