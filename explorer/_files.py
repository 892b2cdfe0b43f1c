"""The one output policy of everything that writes a file a person asked for (the CLI's writing verbs and
the library's writers: ``explorer.view``'s exports, the report, the build kit): :func:`output_path`."""

from __future__ import annotations

import os
from pathlib import Path

from .errors import UserError


def output_path(path, force: bool, option: str = "-o", *, formats=None, protect=()) -> Path:
    """The one output policy of the verbs that write a file (plot, animate, export, report, sensitivity
    --plot): ``path`` as a Path, checked before any work is done.

    * ``formats`` (extensions such as ``{".png": ...}``): its extension must be one of them;
    * it is not a folder, and never one of ``protect`` (the results file a verb reads), even with ``force``;
    * an existing file is replaced only with ``force`` (``--force``); otherwise a one-line UserError naming it;
    * missing parent folders are created, silently (as ``explorer run -o new/folder/x.h5`` does).

    ``explorer run`` and ``explorer optimize`` follow the same policy for their results files (missing
    folders created, an existing file kept unless --force), with --resume besides; the results writer
    itself enforces it (it must also tell a results file from any other file before replacing it).
    ``option`` names the option in the messages."""
    p = Path(os.fspath(path))
    if not str(path).strip():
        raise UserError(f"{option}: expected a file name, got {str(path)!r}")
    if formats is not None and p.suffix.lower() not in formats:
        raise UserError(f"{p}: unknown output extension {p.suffix or '(none)'!r} "
                        f"(expected one of {', '.join(sorted(formats))})")
    if p.is_dir():
        raise UserError(f"{p}: cannot write: it is a folder")
    for q in protect:
        try:
            if p.exists() and Path(os.fspath(q)).exists() and os.path.samefile(p, q):
                raise UserError(f"{p}: refusing to write over the results file it reads")
        except OSError:
            pass
    if (p.exists() or p.is_symlink()) and not force:
        raise UserError(f"{p}: file exists; pass --force to overwrite it")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        if parent.exists() or parent.is_symlink():
            raise UserError(f"{p}: cannot write: {parent} is not a folder")
        try:
            parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise UserError(f"{p}: cannot write: cannot create the folder {parent}: {exc.strerror or exc}") from None
    if not os.access(parent, os.W_OK) or (p.exists() and not os.access(p, os.W_OK)):
        raise UserError(f"{p}: cannot write: permission denied")
    return p
