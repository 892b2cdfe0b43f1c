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
SLOW_ELSEWHERE: set = set()  # (test_sweep_template's scalar-form test no longer compiles a kernel: quick)


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


# EXPLORER_COMPILE_LOG=DIR: each test process writes DIR/compile-<pid>.json, the seconds Numba spent
# compiling during each test (outermost compiles only: a function's callees compile inside it), to see
# where the suite's time goes (`python tests/compile_report.py DIR` sums it).
if os.environ.get("EXPLORER_COMPILE_LOG"):
    import json  # noqa: E402
    import time  # noqa: E402

    from numba.core import event as _nb_event  # noqa: E402

    class _CompileClock(_nb_event.Listener):
        def __init__(self):
            self.depth = 0
            self.t0 = 0.0
            self.current = "<collection>"
            self.per_test: dict[str, float] = {}
            self.count: dict[str, int] = {}
            self.per_function: dict[str, float] = {}
            self.name = ""

        def on_start(self, event):
            if self.depth == 0:
                self.t0 = time.perf_counter()
                disp = (event.data or {}).get("dispatcher")
                fn = getattr(disp, "py_func", None)
                self.name = f"{getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', '?')}"
            self.depth += 1

        def on_end(self, event):
            self.depth -= 1
            if self.depth == 0:
                key = self.current
                self.per_test[key] = self.per_test.get(key, 0.0) + time.perf_counter() - self.t0
                self.count[key] = self.count.get(key, 0) + 1
                self.per_function[self.name] = self.per_function.get(self.name, 0.0) + time.perf_counter() - self.t0

    _CLOCK = _CompileClock()
    _nb_event.register("numba:compile", _CLOCK)

    @pytest.hookimpl(tryfirst=True)
    def pytest_runtest_setup(item):
        _CLOCK.current = item.nodeid

    def pytest_sessionfinish(session):
        out = Path(os.environ["EXPLORER_COMPILE_LOG"])
        out.mkdir(parents=True, exist_ok=True)
        (out / f"compile-{os.getpid()}.json").write_text(json.dumps({"seconds": _CLOCK.per_test,
                                                                      "compiles": _CLOCK.count,
                                                                      "functions": _CLOCK.per_function}))
