"""The ``explorer`` command line: one subcommand (verb) per module ``explorer/cli/_<verb>.py``.

A verb module defines ``register(subparsers)``, which adds its subparser and sets ``func`` (a
callable taking the parsed ``argparse.Namespace`` and returning an exit code or None)::

    def register(sub):
        p = sub.add_parser("rank", help="rank the variants of a results file")
        p.add_argument("results")
        p.set_defaults(func=run)

Modules are discovered automatically (no edit here needed to add a verb). A verb formats what
library calls return (``Results.rank``, ``Results.row``, ``explorer.analysis.sensitivity``, ...), so a
Python user can get every figure it prints; shared argument types (``--top``, ``--weights``, a
variant, whole numbers) are in :mod:`._args` and the one table formatter in :mod:`._format`. A
:class:`~explorer.errors.UserError` raised by a verb is printed as one line on stderr
(``explorer: error: ...``) and the exit code is 2; argparse usage errors also exit with 2.
"""

from __future__ import annotations

import argparse
import errno
import importlib
import os
import pkgutil
import signal
import sys
import threading
import time
import weakref

from .._early import COMMAND as _COMMAND  # the command catches signals from explorer's first instruction
from .._early import EARLY as _EARLY  # (explorer/_early.py): those that came before main, held here
from .._early import is_the_command as _is_the_command  # noqa: F401
from ..errors import Interrupted, Terminated, UserError

#: Verbs listed first in ``explorer --help``, in this order; other discovered verbs follow A→Z.
VERB_ORDER = ("run", "rank", "show", "metrics", "plot", "animate", "bench")


def _verb_modules():
    names = [m.name for m in pkgutil.iter_modules(__path__) if m.name.startswith("_") and not m.name.startswith("__")]
    names.sort(key=lambda n: (VERB_ORDER.index(n[1:]) if n[1:] in VERB_ORDER else len(VERB_ORDER), n))
    for name in names:
        try:
            mod = importlib.import_module(f"{__name__}.{name}")
        except Exception as exc:  # a broken verb must not take the others down
            yield name[1:], exc
            continue
        if hasattr(mod, "register"):
            yield name[1:], mod


def _broken(verb: str, exc: Exception):
    def run(args):
        raise UserError(f"explorer {verb}: unavailable ({type(exc).__name__}: {exc})")
    return run


class _Parser(argparse.ArgumentParser):
    """argparse's parser, whose usage errors are one line like every other error (argparse prints the
    usage, several lines, before its message): ``explorer VERB: error: MESSAGE (see explorer VERB --help)``,
    exit 2. Every verb's subparser is of this class (``add_subparsers`` makes them of its parser's)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {_one_line(message)} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with every discovered verb registered."""
    from .. import __version__
    parser = _Parser(
        prog="explorer",
        description="Explore the design space of planar linkages (Jansen's Strandbeest leg first).")
    parser.add_argument("--version", action="version", version=f"explorer {__version__}")
    sub = parser.add_subparsers(dest="verb", metavar="VERB", required=True)
    for verb, mod in _verb_modules():
        if isinstance(mod, Exception):
            p = sub.add_parser(verb, help=f"(unavailable: {type(mod).__name__})")
            p.set_defaults(func=_broken(verb, mod))
        else:
            mod.register(sub)
    return parser


class _Stop:
    #: the command is stopping (an interrupt was raised, or its work is done): further signals are
    #: ignored, so a second Ctrl-C (impatience), or one in the interpreter's shutdown, cannot turn the
    #: exit code into a kill or add a traceback
    stopping = False
    #: the handler ``main`` installed (an interrupt lost in a callback is sent to it again)
    handler = None
    #: the signal that stopped the command (once its interrupt was raised), and when a signal that landed in
    #: an import was first put off
    signal = None
    deferred_at = None
    #: a weak reference to the interrupt the handler raised last, while :func:`_watch` watches it
    raised = None


#: Longest a signal that lands in an import waits for the import to finish, s: after it the interrupt is
#: raised inside the import (the command is stopping: a module left half made is not used again).
IMPORT_GRACE_S = 0.5
#: How often the command looks whether the interrupt its handler raised is still on its way, s.
WATCH_S = 0.2


def _catch_signals(command: bool):
    """SIGTERM stops a run like Ctrl-C (between commits, saying how to resume): it raises
    :class:`~explorer.errors.Terminated` (already loaded with this module: a handler that imported it
    could find its module half loaded, and fail or be lost). In the command itself, SIGINT too goes
    through the handler, and once the first has been raised further signals are ignored. Returns the
    handlers it replaced (None outside the main thread)."""
    if threading.current_thread() is not threading.main_thread():
        return None

    def stop(signum, frame):
        if command:
            if _Stop.stopping:
                return
            if _importing(frame):  # raising inside an import leaves that module half made (numba.core missing,
                # then a traceback from whatever uses it next): let the import finish, and be signalled again,
                # for at most IMPORT_GRACE_S (an import can take seconds: Numba's, on a loaded machine)
                now = time.monotonic()
                _Stop.deferred_at = _Stop.deferred_at or now
                if now - _Stop.deferred_at < IMPORT_GRACE_S:
                    _send_again(signum)
                    return
            _Stop.stopping = True
            _Stop.signal = signum
            raise _watch(Terminated() if signum == signal.SIGTERM else Interrupted(), signum)  # (no local
            # refers to it: the traceback's frame of this handler would keep it alive)
        raise Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()

    _Stop.handler = stop
    previous = {signal.SIGTERM: signal.signal(signal.SIGTERM, stop)}
    if command:
        previous[signal.SIGINT] = signal.signal(signal.SIGINT, stop)
    return previous


def _importing(frame) -> bool:
    """Whether the interrupted code runs inside an import (a frame of importlib's bootstrap on the stack)."""
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib"):
            return True
        frame = frame.f_back
    return False


def _one_line(text: str) -> str:
    """A message as one line: newlines become spaces, other control characters (a NUL, an escape
    sequence from a name in a file) are shown escaped, not sent to the terminal."""
    text = " ".join(text.split("\n")).strip()
    return "".join(c if c.isprintable() or c == " " else repr(c)[1:-1] for c in text)


def _interrupted(exc: KeyboardInterrupt, command: bool = False) -> int:
    terminated = isinstance(exc, Terminated) or type(exc).__name__ == "Terminated"
    word = "terminated" if terminated else "interrupted"
    text = " ".join(str(exc).split("\n")).strip()
    print(f"explorer: {text if text.split(': ', 1)[-1].startswith(word) else word + (': ' + text if text else '')}",
          file=sys.stderr)
    code = 143 if terminated else 130
    if command:
        _leave_now(code)
    return code


def _leave_now(code: int) -> None:
    """The command was stopped and has said so: exit now, without waiting for threads of its own that
    still run (a worker compiling a kernel, which no signal can stop, for seconds) nor for the
    interpreter's shutdown (Numba's and LLVM's, most of a second on a busy machine). Everything the
    verb wrote is closed or committed by now (its ``finally`` blocks ran), as a kill would leave it.
    multiprocessing's exit finalizers do run (a verb's stopped worker pool: its semaphores unlinked, or its
    resource tracker prints leak warnings after the one line)."""
    try:
        util = sys.modules.get("multiprocessing.util")
        if util is not None:
            try:
                util._run_finalizers(0)
            except Exception:  # noqa: BLE001 - leaving anyway
                pass
        sys.stdout.flush()
        sys.stderr.flush()
    finally:
        os._exit(code)


def main(argv=None) -> int:
    """Entry point of the ``explorer`` command; returns the exit code (0 ok, 2 user error, 130 Ctrl-C,
    143 SIGTERM)."""
    # the command itself (not a program calling main, which keeps its own signal handling afterwards)
    command = argv is None and _COMMAND and threading.current_thread() is threading.main_thread()
    hook = sys.unraisablehook
    previous = None
    try:
        try:
            sys.unraisablehook = _unraisable
            previous = _catch_signals(command)  # before the verbs load (they import Numba: seconds)
            if command and _EARLY:
                _Stop.stopping = True
                _Stop.signal = signal.SIGTERM if signal.SIGTERM in _EARLY else signal.SIGINT
                raise Terminated() if signal.SIGTERM in _EARLY else Interrupted()
            parser = build_parser()
            args = parser.parse_args(argv)
            code = args.func(args)
            if command:
                _Stop.stopping = True  # done: a signal from here on cannot undo the work
            return int(code or 0)
        except KeyboardInterrupt:
            if command:
                _Stop.stopping = True
            raise
    except UserError as exc:
        print(f"explorer: error: {_one_line(str(exc))}", file=sys.stderr)
        return getattr(exc, "exit_code", 2)
    except KeyboardInterrupt as exc:
        return _interrupted(exc, command)
    except BrokenPipeError:  # e.g. `explorer rank ... | head`
        return 0
    except OSError as exc:  # a damaged results file (a checksum that fails), a full disk, …: one line, exit 2
        if command and _Stop.signal is not None:
            return _interrupted(Terminated() if _Stop.signal == signal.SIGTERM else Interrupted(), command)
        what = " ".join(str(exc).split()) or type(exc).__name__
        if "checksum" in what.lower() or "filter returned failure" in what.lower():
            what = f"corrupt data in a results file (a chunk fails its checksum): {what}"
        if _disk_full(exc):
            _exit_disk_full(what)
        print(f"explorer: error: {what[:400]}", file=sys.stderr)
        return 2
    except Exception as exc:
        if command and _Stop.signal is not None:  # raised while stopping (a module an import left half made):
            # what the user sees is the stop they asked for
            return _interrupted(Terminated() if _Stop.signal == signal.SIGTERM else Interrupted(), command)
        if isinstance(exc, ValueError) and "embedded null byte" in str(exc):  # a path from an input file
            given = [a for a in (sys.argv[1:] if argv is None else argv) if "\0" in str(a)]
            what = f"{given[0]!r}: " if given else "a path in the study or mechanism file: "
            print(f"explorer: error: {what}a file name cannot hold a NUL byte", file=sys.stderr)
            return 2
        if not _from_h5py(exc):
            raise  # a bug: its traceback is what a report needs
        what = " ".join(str(exc).split()) or type(exc).__name__
        if _disk_full(exc):  # h5py reports a full disk as RuntimeError too
            _exit_disk_full(what)
        # damaged HDF5 metadata deep inside a results file (h5py raises RuntimeError, ValueError, …)
        print(f"explorer: error: a results file is damaged or unreadable: {what[:300]}", file=sys.stderr)
        return 2
    finally:
        sys.unraisablehook = hook
        if command:
            # the command exits now: a signal in the interpreter's shutdown must not turn the exit code
            # into a kill (-2) or a traceback (the interpreter resets handlers it did not ignore)
            _Stop.stopping = True
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            signal.signal(signal.SIGTERM, signal.SIG_IGN)
        elif previous is not None:
            for sig, handler in previous.items():
                signal.signal(sig, handler)


def _unraisable(unraisable) -> None:
    """Errors Python cannot raise where they happen (a callback from C, a ``__del__``):

    * an interrupt the signal handler raised inside one (Numba compiling calls back from LLVM) would be
      lost, the run going on to exit 0: it is sent again a moment later, to land in ordinary code;
    * h5py reports a write that failed (a full disk) once more from every object it frees, as
      "Exception ignored in ObjectID.__dealloc__" tracebacks; the error itself is reported once, as one
      line.

    Everything else goes to Python's default hook."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt) and _Stop.handler is not None:
        _send_again(signal.SIGTERM if isinstance(unraisable.exc_value, Terminated) else signal.SIGINT)
        return
    _quiet_failed_writes(unraisable)


def _watch(exc: BaseException, signum: int) -> BaseException:
    """Send ``signum`` again if the interrupt ``exc`` the command's handler raised is swallowed on its way
    to ``main``: code that catches every exception (a bare ``except:`` in a library, C code that clears
    the error it was handed) would otherwise lose it for good, the further signals being ignored and the
    run going on to finish with exit 0. While the interrupt travels (raised, re-raised, or the context of
    the one-line message raised in its place) something refers to it; once nothing does, a thread that
    looks every :data:`WATCH_S` sends the signal again. A verb that stops on an interrupt by design (the
    editor's server) says so with :func:`_interrupt_handled`. (One dropped inside a reference cycle is
    seen when Python's garbage collector frees it.) Returns ``exc``, to raise."""
    ref = weakref.ref(exc)
    _Stop.raised = ref

    def watch():
        while _Stop.raised is ref:
            time.sleep(WATCH_S)
            if _Stop.raised is ref and ref() is None:
                _send_again(signum)
                return

    threading.Thread(target=watch, daemon=True, name="explorer-stop-watch").start()
    return exc


def _interrupt_handled() -> None:
    """The interrupt the command's handler raised was caught on purpose (the verb stops on it): not
    sent again (:func:`_watch`)."""
    _Stop.raised = None


def _send_again(signum: int) -> None:
    handler = _Stop.handler
    _Stop.stopping = False
    _Stop.raised = None  # what is sent now is watched when it is raised

    def send():
        time.sleep(0.01)
        # still the command's (not restored, not ignored), or held over a block that must not be cut
        # (``errors.signals_held``: it passes the signal on to the command's handler when the block
        # ends; skipping the send there would lose the signal for good, the run finishing with exit 0)
        now = signal.getsignal(signum)
        if now is handler or getattr(now, "passes_on", False):
            os.kill(os.getpid(), signum)

    threading.Thread(target=send, daemon=True).start()


def _quiet_failed_writes(unraisable) -> None:
    """h5py's "Exception ignored in ObjectID.__dealloc__" after a failed write are not shown (above);
    everything else goes to Python's default hook."""
    text = f"{unraisable.object} {unraisable.exc_value}"
    if "h5py" in text and ("write failed" in text or "errno = 28" in text or "No space left" in text):
        return
    sys.__unraisablehook__(unraisable)


def _disk_full(exc: BaseException) -> bool:
    text = str(exc)
    return getattr(exc, "errno", None) in (errno.ENOSPC, errno.EDQUOT) or "No space left" in text or "errno = 28" in text


def _exit_disk_full(what: str) -> None:
    """One line, then leave at once: HDF5 would try to flush the open file again at interpreter exit,
    fail, and crash the process (everything committed is already on disk)."""
    short = what.split("(")[0].strip()
    print(f"explorer: error: the disk is full ({short[:120]}); the chunks committed so far are kept: free some "
          f"space and run again with --resume", file=sys.stderr)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(2)


def _from_h5py(exc: BaseException) -> bool:
    """True if ``exc`` was raised inside h5py (reading a file), not in explorer's own code."""
    tb = exc.__traceback__
    last = None
    while tb is not None:
        last = tb
        tb = tb.tb_next
    if last is None:
        return False
    module = last.tb_frame.f_globals.get("__name__", "")
    return module.startswith("h5py") or "h5py" in last.tb_frame.f_code.co_filename
