"""The one output policy of everything that writes a file a person asked for (the CLI's writing verbs and
the library's writers: ``explorer.view``'s exports, figures, movies, the report, the build kit):
:func:`output_path` checks a path before any work, :func:`write_replacing` writes it (a temporary file
renamed into place)."""

from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path

from .errors import UserError


def output_path(path, force: bool, option: str = "-o", *, formats=None, protect=()) -> Path:
    """The one output policy of the verbs that write a file (plot, animate, export, report, sensitivity
    -o): ``path`` as a Path, checked before any work is done.

    * ``formats`` (extensions such as ``{".png": ...}``): its extension must be one of them;
    * never one of ``protect`` (the inputs a verb reads: the results file), even with ``force``, nor a
      symbolic link to one, nor another name (a hard link) of one;
    * an existing regular file is replaced only with ``force`` (``--force``); anything else that exists
      there is refused even with ``force``: a folder, a symbolic link (which the write would replace or,
      for another program, follow), a device such as /dev/null, a FIFO, a socket;
    * missing parent folders are created, silently (as ``explorer run -o new/folder/x.h5`` does).

    The writers then write a temporary file beside it and rename it into place (:func:`write_replacing`):
    a link put there meanwhile is replaced, never written through, and a failed write leaves nothing.

    ``explorer run`` and ``explorer optimize`` follow the same policy for their results files (missing
    folders created, an existing file kept unless --force), with --resume besides; the results writer
    itself enforces it (it must also tell a results file from any other file before replacing it).
    ``option`` names the option in the messages."""
    text = os.fspath(path)
    if not str(text).strip():
        raise UserError(f"{option}: expected a file name, got {str(path)!r}")
    if "\0" in str(text):
        raise UserError(f"{option}: {str(text)!r}: a file name cannot hold a NUL byte")
    p = Path(text)
    if formats is not None and p.suffix.lower() not in formats:
        raise UserError(f"{p}: unknown output extension {p.suffix or '(none)'!r} "
                        f"(expected one of {', '.join(sorted(formats))})")
    st = _lstat(p)
    if st is not None:
        for q in protect:
            if q is not None and _same(p, q):
                link = " (a link to it)" if stat.S_ISLNK(st.st_mode) else ""
                raise UserError(f"{p}: refusing to write over the results file it reads{link}")
        if stat.S_ISDIR(st.st_mode):
            raise UserError(f"{p}: cannot write: it is a folder")
        if stat.S_ISLNK(st.st_mode):
            raise UserError(f"{p}: is a symbolic link (to {os.readlink(p)}): refusing to write through it or "
                            f"replace it, even with --force; remove it or name another file")
        if not stat.S_ISREG(st.st_mode):
            raise UserError(f"{p}: not a regular file (a {_kind(st.st_mode)}): refusing to replace it, even with "
                            f"--force")
        if not force:
            raise UserError(f"{p}: file exists; pass --force to overwrite it")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        if parent.exists() or parent.is_symlink():
            raise UserError(f"{p}: cannot write: {parent} is not a folder")
        try:
            parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise UserError(f"{p}: cannot write: cannot create the folder {parent}: {exc.strerror or exc}") from None
    if not os.access(parent, os.W_OK) or (st is not None and not os.access(p, os.W_OK)):
        raise UserError(f"{p}: cannot write: permission denied")
    return p


def writable_kind(path) -> None:
    """The library writers' part of the policy (they overwrite, as a Python call asked): UserError if
    ``path`` is there and is not a regular file or a symbolic link (a folder, a device, a FIFO, a socket),
    which a write would block on, fill or destroy."""
    p = Path(os.fspath(path))
    if "\0" in str(p):
        raise UserError(f"{str(p)!r}: a file name cannot hold a NUL byte")
    st = _lstat(p)
    if st is None or stat.S_ISREG(st.st_mode) or stat.S_ISLNK(st.st_mode):
        return
    if stat.S_ISDIR(st.st_mode):
        raise UserError(f"{p}: cannot write: it is a folder")
    raise UserError(f"{p}: not a regular file (a {_kind(st.st_mode)}): refusing to replace it")


def write_replacing(path, write) -> Path:
    """Call ``write(tmp)`` on a new temporary file beside ``path`` (with ``path``'s extension, so that a
    writer choosing its format by it still does), then rename it onto ``path``: a symbolic link (or
    anything else) at ``path`` is replaced, never written through, and a failure leaves nothing
    half-written there (nor the temporary file). OSError becomes a one-line UserError."""
    path = Path(os.fspath(path))
    parent = path.parent if str(path.parent) else Path(".")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}", dir=parent)
    except OSError as exc:
        raise UserError(f"{path}: cannot write: {exc.strerror or exc}") from None
    os.close(fd)
    try:
        write(Path(tmp))
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except OSError as exc:
        raise UserError(f"{path}: cannot write: {exc.strerror or exc}") from None
    finally:
        if os.path.lexists(tmp):
            os.unlink(tmp)
    return path


def _lstat(p: Path):
    try:
        return os.lstat(p)
    except (OSError, ValueError):
        return None


def _same(p: Path, q) -> bool:
    """Whether ``p`` (followed if a link) is the file ``q``."""
    try:
        return os.path.samefile(p, os.fspath(q))
    except (OSError, ValueError):
        return False


def _kind(mode: int) -> str:
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "device"
    if stat.S_ISFIFO(mode):
        return "FIFO"
    if stat.S_ISSOCK(mode):
        return "socket"
    return "special file"


def format_size(n: float) -> str:
    """A byte count for a message: "1.2 GB", "300.0 kB", "12 bytes" (decimal units)."""
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:,.1f} {unit}"
    return f"{int(n)} bytes"
