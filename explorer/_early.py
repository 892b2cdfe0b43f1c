"""The first instruction of the ``explorer`` command: SIGINT and SIGTERM are caught from here on.

``explorer/__init__.py`` imports this module before anything else (before ``importlib.metadata``, Numba,
h5py), so that a signal in the command's start-up is neither a ``KeyboardInterrupt`` traceback raised
inside an import nor a silent death: it is held in :data:`EARLY` and :func:`explorer.cli.main` reports it
as it starts (exit 130 or 143, one line). In a program that imports explorer (a test, a notebook) nothing
is changed. Only the standard library's lightest modules are imported here.
"""

import signal
import sys
import threading


def is_the_command() -> bool:
    """True in the process that runs the ``explorer`` command itself (its console script, or
    ``python -m explorer.cli``), not in a program that imports explorer (a test, a notebook)."""
    if threading.current_thread() is not threading.main_thread():
        return False
    argv0 = (sys.argv[0] if sys.argv else "").replace("\\", "/").rsplit("/", 1)[-1]
    orig = list(getattr(sys, "orig_argv", ()))
    module = "explorer.cli"
    as_module = any(a == "-m" and b == module for a, b in zip(orig, orig[1:])) or f"-m{module}" in orig
    return argv0 in ("explorer", "explorer.exe") or as_module


#: Signals (SIGINT, SIGTERM) that arrived while the command was still loading, before ``main``.
EARLY: list[int] = []
#: Whether this process is the ``explorer`` command.
COMMAND = is_the_command()


def _hold(signum, frame) -> None:
    EARLY.append(signum)


if COMMAND:
    for _sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(_sig, _hold)
