"""An exclusive lock on a results path, held by one run from the file's creation to its end.

Two runs started together on one output would otherwise both build the file under temporary names
and rename it into place, the second silently replacing the first. The lock is ``flock`` on a
hidden file beside the results (``.NAME.lock``, holding the owner's pid), so it is released by the
operating system when the process dies, kill -9 included; the file is removed when the run ends.
Where ``fcntl`` does not exist (Windows) no lock is taken.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import UserError

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None


def lock_path(path) -> Path:
    p = Path(path)
    return p.with_name(f".{p.name}.lock")


class OutputLock:
    """``with OutputLock(path):`` — the exclusive right to write ``path``; UserError (exit 2) naming the
    holder's pid if another process has it."""

    def __init__(self, path):
        self.path = Path(path)
        self.file = lock_path(self.path)
        self.fd = None

    def acquire(self) -> "OutputLock":
        if fcntl is None:
            return self
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(self.file, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise UserError(f"{self.path}: cannot create the results file (nor its lock {self.file.name}): "
                            f"{exc.strerror or exc}") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            try:
                holder = os.read(fd, 64).decode(errors="replace").strip() or "?"
            finally:
                os.close(fd)
            raise UserError(f"{self.path}: another explorer run (pid {holder}) is writing this file; wait for it to "
                            f"finish or choose another output with -o") from None
        os.ftruncate(fd, 0)
        os.write(fd, str(os.getpid()).encode())
        self.fd = fd
        return self

    def release(self) -> None:
        if self.fd is None:
            return
        try:
            self.file.unlink(missing_ok=True)  # unlinked while held: the next run makes a fresh one
        except OSError:
            pass
        os.close(self.fd)
        self.fd = None

    def __enter__(self):
        return self.acquire()

    def __exit__(self, *exc):
        self.release()
