"""User-facing errors.

Every mistake a user can make (a malformed file, an unknown key or vertex, a bad length, an
unwritable path) raises :class:`UserError`. Its message is one line that names the file, the key
and the offending value; the CLI prints it without a traceback and exits with code 2.

Interrupts live here too (every layer needs them): :class:`Terminated` (SIGTERM, raised like
Ctrl-C), :class:`Interrupted` (Ctrl-C in the command) and :func:`signals_held`, which defers both over a block that must not be cut.
"""

import contextlib
import signal
import sys
import threading


class UserError(ValueError):
    """A one-line, user-facing error (CLI exit code 2)."""

    exit_code = 2


def where(source: str, key: str) -> str:
    """Format ``source: key`` for an error message (``source`` is a file path or ``builtin:NAME``)."""
    return f"{source}: {key}" if key else source


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C so that a run stops between commits and says how to resume
    (``explorer`` exits 143 for it, 130 for Ctrl-C)."""


class Interrupted(KeyboardInterrupt):
    """Ctrl-C (SIGINT) as the ``explorer`` command raises it: a KeyboardInterrupt like Python's own, but
    not of its exact class, which CPython remembers when it escapes code run by ``PyRun_String`` (a
    library deep in a run may do that) and then, after the command has reported it and returned 130,
    exits by killing itself with SIGINT instead (exit -2)."""


@contextlib.contextmanager
def signals_held():
    """Hold SIGINT and SIGTERM over a block that must not be cut: a results file being closed or the
    commit thread stopped (a second Ctrl-C there used to interrupt a flush in progress and crash the
    process), worker threads being started (``kernels.parallel_rows``). They are delivered
    (raised) once the block has finished. Only the main thread can hold signals; elsewhere a no-op."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pending = []
    old = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}

    def hold(signum, frame):
        pending.append(signum)

    hold.passes_on = True  # what it holds goes to the handler it replaced (``cli._send_again`` may send here)
    for sig in old:
        signal.signal(sig, hold)
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
    # an interrupt raised in the handled code takes precedence (it skips this), and so does one being
    # handled around the block (a cleanup after Ctrl-C); one held here is not lost silently: it goes to
    # the handler it was held from (which may ignore it: the command stopping already), or is raised
    # where that handler is the system's default. (Any other exception being handled around the block
    # does not drop it: a block run inside ``except OSError:`` would lose a SIGTERM for good.)
    if pending and not isinstance(sys.exc_info()[1], KeyboardInterrupt):
        sig = signal.SIGTERM if signal.SIGTERM in pending else signal.SIGINT
        handler = old[sig]
        if handler == signal.SIG_IGN:
            return
        if callable(handler):
            handler(sig, None)
            return
        raise Terminated() if sig == signal.SIGTERM else KeyboardInterrupt()
