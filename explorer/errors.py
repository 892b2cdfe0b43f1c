"""User-facing errors.

Every mistake a user can make (a malformed file, an unknown key or vertex, a bad length, an
unwritable path) raises :class:`UserError`. Its message is one line that names the file, the key
and the offending value; the CLI prints it without a traceback and exits with code 2.
"""


class UserError(ValueError):
    """A one-line, user-facing error (CLI exit code 2)."""

    exit_code = 2


def where(source: str, key: str) -> str:
    """Format ``source: key`` for an error message (``source`` is a file path or ``builtin:NAME``)."""
    return f"{source}: {key}" if key else source
