"""The process's memory: hand the C heap's free pages back to the operating system between the phases of a
long read (``explorer report`` on a million-design file), so that its resident memory follows what it holds.

glibc's malloc keeps memory a program frees (tens of MB after a phase that held a million rows' columns) for
later allocations and returns it only when asked (``malloc_trim``); the next phase's allocations (a kernel's
code, a page's text) are often of other sizes and do not reuse it, so the resident memory of the phases adds
up. Elsewhere (macOS, musl) :func:`release` does nothing.
"""

from __future__ import annotations

_trim = None


def release() -> None:
    """Return the C heap's free pages to the operating system (glibc ``malloc_trim(0)``; costs about a
    millisecond); nothing where the C library has no such call."""
    global _trim
    if _trim is None:
        try:
            import ctypes
            import ctypes.util
            _trim = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6").malloc_trim
            _trim.argtypes = [ctypes.c_size_t]
        except (OSError, AttributeError):
            _trim = False
    if _trim:
        _trim(0)
