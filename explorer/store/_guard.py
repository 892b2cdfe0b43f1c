"""Reading a results file's metadata first in a child process, so that damaged bytes cannot hang a verb.

HDF5 trusts the structures it parses. A damaged one can make it loop for ever in C, where neither a
signal handler nor a checksum can reach it: 16 zero bytes over an object header of the file's first
global heap collection (``GCOL``, where variable-length string attributes live) make
``H5HG__cache_heap_deserialize`` spin as soon as an attribute is read, and ``explorer rank``, ``show``,
``--resume``, ``run --force`` and :func:`~explorer.store.open_results` all hung until SIGKILL.

So every first read of a results file (the verification of :func:`~explorer.store.open_results`, the
root attributes a runner reads before it writes, a resume's salvage, the Dask stitch) runs in a child
process forked for it (:func:`call`), and the caller reads the file itself only once the child has read
every structure it will read (the metadata and every attribute, decoded; the chunk digests; the series'
chunk index) and said that it verifies. HDF5 parses the same bytes the same way twice, so what did not
hang in the child does not hang in the caller. The caller waits for the child in Python, with signals
handled: Ctrl-C and SIGTERM stop it at once (the child is killed).

The deadline is a budget of progress, not of wall time: the verification reports progress (every
object, attribute, block of rows and chunk-index entry: :data:`PROGRESS`),
and a child that burns :data:`STALL_CPU_S` CPU-seconds without any (HDF5 looping) is killed and the file
refused in one line, whatever its size; a child waiting on a slow disk burns none and is left alone.
A child that dies (HDF5 crashing on damaged bytes) is a refusal too, never a crash of the verb.

Linux only (fork, ``/proc``, ``prctl``); elsewhere the same functions run in the calling process.
"""

from __future__ import annotations

import os
import pickle
import select
import signal
import sys
import time
import warnings

#: Progress callback of a guarded child process: the checks (:mod:`explorer.store._integrity`) call
#: ``PROGRESS[0]()`` after every object, attribute, block of rows and chunk-index entry; the child sets it
#: to a tick its parent reads, so that a child making no progress (HDF5 looping) is told from a slow one.
PROGRESS: list = [None]

#: CPU-seconds a child may spend without reporting progress before it is taken for a loop. One step of
#: the verification (an object's metadata, a block of at most ~8 MB of rows, 256 chunk-index entries)
#: takes milliseconds.
STALL_CPU_S = 3.0
#: How often a child reports progress at most, s (a byte through a pipe each time).
TICK_S = 0.02

_MARK = b"\x00RESULT\x00"


class Unreadable(Exception):
    """The child looped (no progress for :data:`STALL_CPU_S` CPU-seconds) or died: ``str()`` says which,
    in words, for a message that names the file; ``how``: "loop", "crash" (a signal: ``signal`` its
    name) or "exit"."""

    def __init__(self, text: str, how: str, signal_name: str | None = None):
        super().__init__(text)
        self.how, self.signal = how, signal_name


def supported() -> bool:
    return hasattr(os, "fork") and sys.platform.startswith("linux") and os.path.isdir("/proc/self")


def _cpu(pid: int) -> float:
    """CPU-seconds (user + system) the process ``pid`` has used so far (0 if it cannot be read)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as fh:
            fields = fh.read().rsplit(b")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return 0.0


def _die_with_parent() -> None:
    """The child is killed when the process that forked it dies (even by SIGKILL), Linux's PR_SET_PDEATHSIG."""
    try:
        import ctypes
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def _child(fn, args, kwargs, wfd: int, parent: int) -> None:
    """The forked child: run fn, send its result (or the exception it raised) and leave at once
    (never through the parent's atexit handlers, buffers or open HDF5 files)."""
    code = 0
    try:
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, signal.SIG_DFL)
        _die_with_parent()
        import gc
        gc.disable()  # a collection would touch (and copy) every page of the parent's objects
        sys.unraisablehook = lambda unraisable: None  # h5py's "Exception ignored" on damaged bytes: the
        warnings.simplefilter("ignore")  # error itself is sent to the parent, which says it once
        if os.getppid() != parent:
            os._exit(1)
        last = [0.0]

        def tick():
            now = time.monotonic()
            if now - last[0] >= TICK_S:
                last[0] = now
                os.write(wfd, b".")

        PROGRESS[0] = tick
        try:
            out = ("ok", fn(*args, **kwargs))
        except BaseException as exc:  # noqa: BLE001 - sent to the parent, raised there
            out = ("exc", exc)
        try:
            data = pickle.dumps(out)
        except Exception:  # noqa: BLE001 - an unpicklable result or exception: its words
            data = pickle.dumps(("exc", RuntimeError(" ".join(str(out[1]).split()) or type(out[1]).__name__)))
        view = memoryview(_MARK + data)
        while view:
            view = view[os.write(wfd, view):]
    except BaseException:  # noqa: BLE001 - nothing may escape a forked child
        code = 3
    os._exit(code)


def call(fn, *args, stall: bool | None = True, **kwargs):
    """``fn(*args, **kwargs)`` run in a forked child process (see the module docstring; the arguments are
    the child's copy of the caller's memory, not pickled); its return value (picklable) is returned, an
    exception it raised is raised here. :class:`Unreadable` when the child makes no progress for
    :data:`STALL_CPU_S` CPU-seconds (``stall=None``: no budget, for work that reports no progress, such as
    ``explorer metrics`` computing into a copy) or dies. Where :func:`supported` is False, ``fn`` runs
    here."""
    if not supported():
        return fn(*args, **kwargs)
    rfd, wfd = os.pipe()
    parent = os.getpid()
    try:
        from h5py._objects import phil  # no other thread of ours is inside HDF5 while we fork
    except ImportError:  # pragma: no cover - another h5py
        import contextlib
        phil = contextlib.nullcontext()
    with warnings.catch_warnings():  # Python 3.12+ warns about fork in a threaded process: the child
        warnings.simplefilter("ignore", DeprecationWarning)  # runs one thread and HDF5 only, then _exit
        with phil:
            pid = os.fork()
    if pid == 0:
        os.close(rfd)
        _child(fn, args, kwargs, wfd, parent)
    os.close(wfd)
    data = bytearray()
    done = False
    try:
        base = _cpu(pid)
        while True:
            ready, _, _ = select.select([rfd], [], [], 0.05)
            if ready:
                chunk = os.read(rfd, 1 << 16)
                if not chunk:
                    break
                data += chunk
                base = _cpu(pid)  # progress (or the result coming): the stall budget starts again
            elif stall is not None and _cpu(pid) - base > STALL_CPU_S:
                raise Unreadable(f"reading it made HDF5 loop (no progress in {STALL_CPU_S:g} CPU-seconds); "
                                 f"its metadata is damaged", "loop")
        _, status = os.waitpid(pid, 0)
        done = True
    finally:
        os.close(rfd)
        if not done:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            try:
                os.waitpid(pid, 0)
            except ChildProcessError:
                pass
    head, sep, body = bytes(data).partition(_MARK)
    if not sep:
        if os.WIFSIGNALED(status):
            sig = os.WTERMSIG(status)
            name = signal.Signals(sig).name if sig in signal.Signals._value2member_map_ else str(sig)
            raise Unreadable(f"reading it crashed HDF5 ({name}); its metadata is damaged", "crash", name)
        raise Unreadable(f"reading it stopped with exit code {os.WEXITSTATUS(status)}", "exit")
    kind, value = pickle.loads(body)
    if kind == "exc":
        raise value
    return value
