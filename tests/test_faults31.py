"""Issue 31 (trust under faults, round two): signals in the start-up and the shutdown of a run, the one
output policy for every writing verb (inputs, symlinks, device nodes and FIFOs), the output lock's race,
and the inputs that gave tracebacks (a NUL byte in a path, a control character in a name, ``**`` in
``--where``, a metric of the wrong length)."""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import explorer
from explorer.cli import main

BIG = ('[study]\nname = "big"\nmechanism = "jansen"\nvariants = 150000\nsteps = 72\n'
       '[scene]\nmetrics = true\n')
SMALL = '[study]\nname = "small"\nmechanism = "jansen"\nvariants = 6\nsteps = 24\n[scene]\nmetrics = true\n'


def cli(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


# -- signals in the start-up and the shutdown (item 3) ------------------------------------------------------
def _handles_sigterm(pid: int) -> bool:
    """True once the process has a handler for SIGTERM (explorer's first line installs one). Before it, a
    signal is the interpreter's business: SIGTERM kills it, SIGINT is Python's KeyboardInterrupt."""
    try:
        with open(f"/proc/{pid}/status", encoding="ascii") as f:
            fields = dict(line.split(":", 1) for line in f if ":" in line)
    except OSError:
        return True
    caught = int(fields.get("SigCgt", "0").strip(), 16) | int(fields.get("SigIgn", "0").strip(), 16)
    return bool(caught >> (signal.SIGTERM - 1) & 1)


def _run_and_signal(tmp_path: Path, text: str, sig: str, delay: float, after_summary: bool = False):
    study = tmp_path / "study.toml"
    study.write_text(text, encoding="utf-8")
    out = tmp_path / "out.h5"
    out.unlink(missing_ok=True)
    cmd = [sys.executable, "-m", "explorer.cli", "run", str(study), "-o", str(out)] + ([] if after_summary else ["-q"])
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        if after_summary:  # the run's summary is its last work: the signal lands in the shutdown
            proc.stdout.readline()
        time.sleep(delay)
        deadline = time.time() + 60
        while not after_summary and not _handles_sigterm(proc.pid) and proc.poll() is None and time.time() < deadline:
            time.sleep(0.005)
        proc.send_signal(getattr(signal, f"SIG{sig}"))
        rest, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return proc.returncode, err, out


def _check_stopped(tmp_path, sig, rc, err, out, finished_allowed=False):
    code, word = {"TERM": (143, "terminated"), "INT": (130, "interrupted")}[sig]
    assert "Traceback" not in err, err
    if rc == 0 and finished_allowed:  # the run finished before the signal: the results are whole
        assert err == "", err
        with explorer.open_results(out) as r:
            assert r.complete
    else:
        assert rc == code, (rc, err)
        assert err.count("\n") == 1 and err.startswith("explorer: ") and word in err, err
    assert not list(tmp_path.glob(".*lock")) and not list(tmp_path.glob(".*partial"))


@pytest.mark.parametrize("sig,delay", [("TERM", 0.25), ("TERM", 0.55), ("INT", 0.4)])
def test_a_signal_in_the_start_up_stops_the_run_in_one_line(tmp_path, sig, delay):
    """SIGTERM (exit 143) and SIGINT (exit 130) while the command loads its verbs and Numba: one line,
    never a traceback (the handler used to import Terminated from a half-loaded explorer.study), never
    lost (the run used to finish with exit 0)."""
    rc, err, out = _run_and_signal(tmp_path, BIG, sig, delay)
    _check_stopped(tmp_path, sig, rc, err, out)


def test_ctrl_c_in_the_shutdown_is_not_a_kill(tmp_path):
    """Ctrl-C once the run has printed its summary: exit 0 with the results whole, or 130 in one line,
    never -2 (CPython kills itself with SIGINT when a bare KeyboardInterrupt escaped code it ran)."""
    rc, err, out = _run_and_signal(tmp_path, SMALL, "INT", 0.0, after_summary=True)
    _check_stopped(tmp_path, "INT", rc, err, out, finished_allowed=True)


@pytest.mark.slow
def test_signals_at_random_moments_of_a_run(tmp_path):
    rng = random.Random(31)
    for i in range(20):
        sig = rng.choice(["TERM", "INT"])
        delay = rng.uniform(0.0, 1.5)
        rc, err, out = _run_and_signal(tmp_path, BIG, sig, delay)
        _check_stopped(tmp_path, sig, rc, err, out)
    for i in range(5):
        rc, err, out = _run_and_signal(tmp_path, SMALL, rng.choice(["TERM", "INT"]), rng.uniform(0, 0.05),
                                       after_summary=True)
        _check_stopped(tmp_path, "TERM" if rc == 143 else "INT", rc, err, out, finished_allowed=True)


def test_terminated_lives_in_errors():
    import explorer.errors
    import explorer.study
    assert explorer.study.Terminated is explorer.errors.Terminated
    assert issubclass(explorer.errors.Interrupted, KeyboardInterrupt)
