"""The first instruction of the ``explorer`` command: SIGINT and SIGTERM are caught from here on.

``explorer/__init__.py`` imports this module before anything else (before ``importlib.metadata``, Numba,
h5py), so that a signal in the command's start-up is neither a ``KeyboardInterrupt`` traceback raised
inside an import nor a silent death: it is held in :data:`EARLY` and :func:`explorer.cli.main` reports it
as it starts (exit 130 or 143, one line). In a program that imports explorer (a test, a notebook) nothing
is changed.

The handlers go in before this module imports anything that has a file: ``sys`` and ``_signal`` are
built into the interpreter, so between the import of this module and the handlers there are a few
instructions (a signal there, a microsecond's window, is Python's own traceback), not the tens of
milliseconds that ``import signal`` (its enums) and ``import threading`` would take.
"""

import sys
import _signal


def _argv_is_the_command() -> bool:
    """Whether the command line is the ``explorer`` command's (its console script, or ``python -m
    explorer.cli``); plain string work on ``sys.argv`` and ``sys.orig_argv``, no import."""
    argv0 = (sys.argv[0] if sys.argv else "").replace("\\", "/").rsplit("/", 1)[-1]
    orig = list(getattr(sys, "orig_argv", ()))
    module = "explorer.cli"
    as_module = any(a == "-m" and b == module for a, b in zip(orig, orig[1:])) or f"-m{module}" in orig
    return argv0 in ("explorer", "explorer.exe") or as_module


#: Signals (SIGINT, SIGTERM) that arrived while the command was still loading, before ``main``.
EARLY: list[int] = []


def _hold(signum, frame) -> None:
    EARLY.append(signum)


def _install() -> bool:
    if not _argv_is_the_command():
        return False
    try:  # only the main thread may set handlers (ValueError elsewhere: an import from a thread)
        _signal.signal(_signal.SIGINT, _hold)
        _signal.signal(_signal.SIGTERM, _hold)
    except ValueError:
        return False
    return True


#: Whether this process is the ``explorer`` command (and its handlers hold early signals).
COMMAND = _install()


def is_the_command() -> bool:
    """True in the process that runs the ``explorer`` command itself (its console script, or
    ``python -m explorer.cli``), on its main thread; not in a program that imports explorer (a test, a
    notebook)."""
    import threading
    return threading.current_thread() is threading.main_thread() and _argv_is_the_command()
