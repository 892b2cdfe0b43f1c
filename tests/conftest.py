"""Shared fixtures: the built-in mechanisms, the test triad, and the nominal Jansen cycle (solved once)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

TESTS = Path(__file__).resolve().parent
if str(TESTS) not in sys.path:  # `import naive` whatever pytest's import mode
    sys.path.insert(0, str(TESTS))

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
