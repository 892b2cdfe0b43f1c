"""An exclusive lock on a results path, held by one run from the file's creation to its end.

Two runs started together on one output would otherwise both build the file under temporary names
and rename it into place, the second silently replacing the first. The lock is ``flock`` on a
hidden file beside the results (``.NAME.lock``, holding the owner's pid), so it is released by the
operating system when the process dies, kill -9 included; the file is removed when the run ends. A run
that opened the file just before its owner removed it would lock a file nobody else can find, so after
``flock`` a run checks that the path still names the file it locked, and starts again if not.
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
        for _ in range(100):
            fd = self._open()
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                try:
                    holder = os.read(fd, 64).decode(errors="replace").strip() or "?"
                finally:
                    os.close(fd)
                raise UserError(f"{self.path}: another explorer run (pid {holder}) is writing this file; wait for it "
                                f"to finish or choose another output with -o") from None
            if self._current(fd):
                break
            # the lock file was removed (its run ended) between our open and our flock: a lock on it
            # excludes nobody (the next run makes a new file), so take the lock on the file there now
            os.close(fd)
        else:  # pragma: no cover - a lock file replaced a hundred times in a row
            raise UserError(f"{self.path}: cannot take the lock {self.file.name}: it keeps being replaced")
        os.ftruncate(fd, 0)
        os.write(fd, str(os.getpid()).encode())
        self.fd = fd
        return self

    def _open(self) -> int:
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            return os.open(self.file, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise UserError(f"{self.path}: cannot create the results file (nor its lock {self.file.name}): "
                            f"{exc.strerror or exc}") from None

    def _current(self, fd: int) -> bool:
        """Whether the lock file's path still names the file ``fd`` is open on."""
        try:
            st = os.stat(self.file)
        except OSError:
            return False
        mine = os.fstat(fd)
        return (st.st_dev, st.st_ino) == (mine.st_dev, mine.st_ino)

    def release(self) -> None:
        if self.fd is None:
            return
        try:
            if self._current(self.fd):  # removed while held: a run that opened it meanwhile sees it gone
                self.file.unlink()      # after its flock (acquire checks) and makes a fresh one
        except OSError:
            pass
        os.close(self.fd)
        self.fd = None

    def __enter__(self):
        return self.acquire()

    def __exit__(self, *exc):
        self.release()
