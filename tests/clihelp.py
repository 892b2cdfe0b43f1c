"""The command line as the tests call it: ``main`` in-process, with pytest's ``capsys`` capturing."""

from __future__ import annotations

from explorer.cli import main


def cli(capsys, *args):
    """(exit code, stdout, stderr) of ``explorer ARGS``."""
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def ok_cli(capsys, *args) -> str:
    """stdout of ``explorer ARGS``, asserting it exits 0 and writes nothing to stderr."""
    code, out, err = cli(capsys, *args)
    assert code == 0 and err == "", err
    return out
