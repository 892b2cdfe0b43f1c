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


# -- the one output policy, for every writing verb (item 4) -------------------------------------------------
@pytest.fixture(scope="module")
def results(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("faults31")
    study = tmp / "study.toml"
    study.write_text(SMALL + "[perturb]\nspread = 0.01\n", encoding="utf-8")
    out = tmp / "r.h5"
    assert main(["run", str(study), "-o", str(out), "-q"]) == 0
    return out


#: verb → (its arguments with T the file it writes, T's extension)
WRITERS = {
    "plot": (["plot", "R", "--top", "2", "-o", "T"], ".png"),
    "animate": (["animate", "R", "--variant", "0", "--frames", "4", "-o", "T"], ".gif"),
    "export-svg": (["export", "R", "--variant", "0", "--as", "svg", "-o", "T"], ".svg"),
    "export-dxf": (["export", "R", "--variant", "0", "--as", "dxf", "-o", "T"], ".dxf"),
    "export-csv": (["export", "R", "--variant", "0", "--as", "csv", "-o", "T"], ".csv"),
    "export-toml": (["export", "R", "--variant", "0", "--as", "toml", "-o", "T"], ".toml"),
    "export-kit": (["export", "R", "--variant", "0", "--as", "kit", "-o", "K"], "parts.svg"),
    "report": (["report", "R", "-o", "T"], ".html"),
    "sensitivity": (["sensitivity", "R", "-o", "T"], ".png"),
}


class _Drain:
    """Reads a FIFO's other end (so that a writer that wrongly opens it does not block the test) and keeps
    what came through."""

    def __init__(self, fifo):
        import threading
        self.data = b""
        self.fd = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.stop = False
        self.thread.start()

    def _read(self):
        while not self.stop:
            try:
                chunk = os.read(self.fd, 65536)
            except BlockingIOError:
                time.sleep(0.005)
                continue
            if chunk:
                self.data += chunk
            else:
                time.sleep(0.005)

    def close(self):
        self.stop = True
        self.thread.join()
        os.close(self.fd)


def _target(tmp_path, verb, kind, results):
    args, ext = WRITERS[verb]
    if verb == "export-kit":
        folder = tmp_path / "kit"
        folder.mkdir()
        target = folder / ext
        args = [folder if a == "K" else a for a in args]
    else:
        target = tmp_path / f"out{ext}"
        args = [target if a == "T" else a for a in args]
    args = [results if a == "R" else a for a in args]
    if kind == "link-to-results":
        target.symlink_to(results)
    elif kind == "link-to-other":
        other = tmp_path / "precious.txt"
        other.write_text("precious", encoding="utf-8")
        target.symlink_to(other)
    elif kind == "hard-link":
        os.link(results, target)
    elif kind == "fifo":
        os.mkfifo(target)
    elif kind == "device":
        import stat
        try:
            os.mknod(target, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # a /dev/null of its own
        except (PermissionError, OSError):
            pytest.skip("making a device node needs root")
    return args + ["--force"], target


@pytest.mark.parametrize("kind", ["link-to-results", "link-to-other", "hard-link", "fifo", "device"])
@pytest.mark.parametrize("verb", list(WRITERS))
def test_every_writing_verb_refuses_inputs_links_and_special_files(results, tmp_path, capsys, verb, kind):
    """Even with --force: never the results file read (through a link or another name), never through a
    symbolic link, never over a device or a FIFO (a write would block on it, or fill a disk through it)."""
    before = results.read_bytes()
    args, target = _target(tmp_path, verb, kind, results)
    drain = _Drain(target) if kind == "fifo" else None
    try:
        code, _, err = cli(capsys, *args)
    finally:
        if drain is not None:
            drain.close()
    assert code == 2 and err.count("\n") == 1 and err.startswith("explorer: error: "), err
    assert str(target.name) in err
    assert results.read_bytes() == before
    if kind.startswith("link"):
        assert target.is_symlink()
    if kind == "link-to-other":
        assert (tmp_path / "precious.txt").read_text(encoding="utf-8") == "precious"
    if kind == "fifo":
        import stat
        assert stat.S_ISFIFO(os.lstat(target).st_mode) and drain.data == b""
    assert not [p for p in target.parent.iterdir() if ".tmp" in p.name]


def test_force_still_replaces_a_regular_file(results, tmp_path, capsys):
    for verb in ("plot", "export-svg", "sensitivity"):
        args, ext = WRITERS[verb]
        target = tmp_path / f"{verb}{ext}"
        target.write_text("old", encoding="utf-8")
        args = [target if a == "T" else results if a == "R" else a for a in args]
        code, _, err = cli(capsys, *args)
        assert code == 2 and "file exists; pass --force" in err and target.read_text(encoding="utf-8") == "old"
        code, _, err = cli(capsys, *args, "--force")
        assert code == 0, err
        assert target.read_bytes() != b"old" and not target.is_symlink()
        assert not [p for p in tmp_path.iterdir() if ".tmp" in p.name]


def test_library_writers_replace_a_link_never_follow_it(results, tmp_path):
    """save_figure and animate (which overwrite, as a Python call asks) write a temporary file renamed into
    place: a link at the path is replaced, the file it pointed to untouched."""
    from explorer.view import animate, plot_top, save_figure
    other = tmp_path / "precious.txt"
    other.write_text("precious", encoding="utf-8")
    for name, write in (("fig.png", lambda p: save_figure(plot_top(explorer.open_results(results), top=2), p)),
                        ("movie.gif", lambda p: animate(explorer.load_mechanism("jansen"), p, frames=3))):
        link = tmp_path / name
        link.symlink_to(other)
        write(link)
        assert not link.is_symlink() and link.stat().st_size > 0
        assert other.read_text(encoding="utf-8") == "precious"
    fifo = tmp_path / "pipe.png"
    os.mkfifo(fifo)
    from explorer.errors import UserError
    with pytest.raises(UserError, match="not a regular file"):
        save_figure(plot_top(explorer.open_results(results), top=2), fifo)


# -- the output lock's race (item 5) -------------------------------------------------------------------------
STALLED = """
import sys, time, fcntl
from explorer.testing import store_lock as lock
marker, stall = sys.argv[1], float(sys.argv[2])

class Stalled:  # fcntl, with a stall before the first flock (as a busy machine may make)
    LOCK_EX, LOCK_NB, LOCK_UN = fcntl.LOCK_EX, fcntl.LOCK_NB, fcntl.LOCK_UN
    calls = 0
    def flock(self, fd, op):
        Stalled.calls += 1
        if Stalled.calls == 1:
            open(marker, "w").close()
            time.sleep(stall)
        return fcntl.flock(fd, op)

lock.fcntl = Stalled()
from explorer.cli import main
sys.exit(main(sys.argv[3:]))
"""


def test_a_run_stalled_before_its_flock_does_not_share_the_lock(tmp_path):
    """Run A opens the lock file, stalls; its owner finishes and removes the file; run C takes a new one. A
    used to lock the removed file and run beside C (both exit 0, one's results lost): now it sees that the
    path names another file, tries that one, and stops in one line."""
    from explorer.testing import OutputLock
    study = tmp_path / "study.toml"
    study.write_text(SMALL, encoding="utf-8")
    out, marker = tmp_path / "out.h5", tmp_path / "opened"
    owner = OutputLock(out).acquire()
    proc = subprocess.Popen([sys.executable, "-c", STALLED, str(marker), "2.0", "run", str(study), "-o", str(out), "-q"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 120
        while not marker.exists() and proc.poll() is None and time.time() < deadline:
            time.sleep(0.01)
        assert marker.exists(), proc.communicate()[1]
        owner.release()                      # the first run ends while A stalls
        other = OutputLock(out).acquire()    # and another starts
        try:
            _, err = proc.communicate(timeout=120)
        finally:
            other.release()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 2, err
    assert err.count("\n") == 1 and f"another explorer run (pid {os.getpid()})" in err, err
    assert not out.exists() and not list(tmp_path.glob(".*lock"))


def test_the_lock_is_not_removed_from_under_its_next_owner(tmp_path):
    from explorer.testing import OutputLock, lock_path
    out = tmp_path / "out.h5"
    a = OutputLock(out).acquire()
    os.unlink(lock_path(out))                # removed by hand (or by a run that lost the race)
    b = OutputLock(out).acquire()            # a new lock file, a new owner
    a.release()                              # must not remove b's file
    assert lock_path(out).exists()
    with pytest.raises(explorer.UserError, match="another explorer run"):
        OutputLock(out).acquire()
    b.release()
    assert not lock_path(out).exists()


# -- inputs that gave tracebacks (item 7) ---------------------------------------------------------------------
def test_a_nul_byte_in_a_path_is_one_line(results, tmp_path, capsys):
    study = tmp_path / "study.toml"
    study.write_text(SMALL + '[output]\npath = "out\\u0000.h5"\n', encoding="utf-8")
    code, _, err = cli(capsys, "run", study)
    assert code == 2 and err.count("\n") == 1 and "NUL byte" in err, err
    study.write_text(SMALL.replace('"jansen"', '"leg\\u0000.toml"'), encoding="utf-8")
    code, _, err = cli(capsys, "run", study, "-o", tmp_path / "x.h5")
    assert code == 2 and err.count("\n") == 1 and "\x00" not in err and "leg\\x00.toml" in err, err
    for args in (["run", tmp_path / "s.toml", "-o", "x\0.h5"], ["plot", results, "--top", "2", "-o", "a\0.png"],
                 ["export", results, "--variant", "0", "--as", "svg", "-o", "x\0.svg"], ["show", "r\0.h5", "--variant", "0"]):
        code, _, err = cli(capsys, *args)
        assert code == 2 and err.count("\n") == 1 and "\x00" not in err, (args, err)
    assert not list(tmp_path.glob("x*"))


def _jansen_text():
    from importlib import resources
    return (resources.files("explorer.mechanism") / "builtin" / "jansen.toml").read_text(encoding="utf-8")


@pytest.mark.parametrize("old,new,key", [('name = "jansen"', 'name = "jan\\u0001sen"', "name"),
                                         ('name = "jansen"', 'name = "jan\\u001b[31msen"', "name"),
                                         ('description = "', 'description = "\\u0007', "description"),
                                         ('"2" = [-38.0, -7.8]', '"2\\n" = [-38.0, -7.8]', "fixed.2")])
def test_a_control_character_in_a_name_is_refused_at_load(tmp_path, capsys, old, new, key):
    mech = tmp_path / "leg.toml"
    text = _jansen_text()
    assert old in text
    mech.write_text(text.replace(old, new, 1), encoding="utf-8")
    with pytest.raises(explorer.UserError, match=f"leg.toml: {key}"):
        explorer.load_mechanism(mech)
    code, _, err = cli(capsys, "export", mech, "--as", "kit", "-o", tmp_path / "kit")
    assert code == 2 and err.count("\n") == 1 and f"leg.toml: {key}" in err, err
    assert "\x1b" not in err and "\x07" not in err and "\x01" not in err
    assert not (tmp_path / "kit").exists()


@pytest.mark.filterwarnings("ignore:Glyph")
def test_svg_is_well_formed_whatever_a_name_holds(tmp_path):
    """A Mechanism built in Python is not checked by the loader: the SVG writers keep the XML well-formed."""
    import dataclasses
    import xml.dom.minidom
    from explorer.fabrication import build_kit, export_svg, write_kit
    mech = dataclasses.replace(explorer.load_mechanism("jansen"), name="jan\x01sen\x1b")
    export_svg(mech, tmp_path / "parts.svg")
    xml.dom.minidom.parse(str(tmp_path / "parts.svg"))
    write_kit(build_kit(mech), tmp_path / "kit")
    xml.dom.minidom.parse(str(tmp_path / "kit" / "parts.svg"))


def test_where_powers_are_exact_where_finite():
    import numpy as np
    import pandas as pd
    from explorer.testing import evaluate_filter
    df = pd.DataFrame({"x": [1e64, 1e100, 2e100, 1.0]})
    assert evaluate_filter(df, "x == 10**100").tolist() == [False, True, False, False]
    assert evaluate_filter(df, "x >= 10**100").tolist() == [False, True, True, False]
    assert evaluate_filter(df, "x < 2**-1074 * 10**400").all()           # 10**400 overflows to inf
    assert not evaluate_filter(df, "x < 10**-400").any()                  # underflows to 0
    assert evaluate_filter(df, "10**10**10 > x").all()                    # inf, at once
    assert evaluate_filter(df, "x > -(10**(3*100))").all() and np.isfinite(1e300)


def test_show_and_report_say_when_a_metric_is_not_one_per_variant(results, tmp_path, capsys):
    import shutil

    import h5py
    import numpy as np
    path = tmp_path / "wide.h5"
    shutil.copy(results, path)
    with h5py.File(path, "r+") as f:
        f["metrics/wide"] = np.zeros((f["status"].shape[0], 2))
    seal = getattr(explorer.store, "seal", None)
    if seal is not None:
        seal(path)  # edited on purpose: re-checksummed
    code, out, err = cli(capsys, "show", path, "--variant", "0")
    assert code == 0 and err.count("\n") == 1, err
    assert "warning" in err and "metrics/wide has shape (6, 2), not (6,)" in err and "ignored" in err
    code, out, err = cli(capsys, "report", path, "-o", tmp_path / "r.html")
    assert code == 0 and "metrics/wide has shape (6, 2), not (6,)" in err, err


# -- held signals are passed on, never dropped -----------------------------------------------------------------
def _recording_handler(seen):
    def handler(signum, frame):
        seen.append(signum)
    return handler


def test_a_signal_held_inside_an_except_block_is_passed_on():
    """signals_held() delivers a signal it held to the handler it replaced even where the block runs while
    an ordinary exception is being handled (it used to check ``sys.exc_info()`` and drop the signal
    there); a block inside ``except KeyboardInterrupt`` (the cleanup after Ctrl-C) still drops it."""
    from explorer.errors import signals_held
    seen = []
    old = signal.signal(signal.SIGTERM, _recording_handler(seen))
    try:
        try:
            raise ValueError("handled")
        except ValueError:
            with signals_held():
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(0.05)
                assert seen == []  # held, not delivered inside the block
        assert seen == [signal.SIGTERM]
        seen.clear()
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            with signals_held():
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(0.05)
        assert seen == []
    finally:
        signal.signal(signal.SIGTERM, old)


def test_a_signal_sent_again_while_held_is_not_lost():
    """An interrupt the command's handler put off (inside an import) or lost (inside a callback from C) is
    sent again a moment later (``cli._send_again``); if that moment falls inside a signals_held() block
    (every chunk's thread starts), the signal goes to the block's hold and on to the handler when the
    block ends. It used to be skipped there, because the handler in place was not the command's, and the
    run went on to finish with exit 0."""
    import threading

    from explorer import cli
    from explorer.errors import signals_held
    seen = []
    handler = _recording_handler(seen)
    old = signal.signal(signal.SIGTERM, handler)
    saved = (cli._Stop.handler, cli._Stop.stopping)
    cli._Stop.handler = handler
    try:
        before = threading.active_count()
        with signals_held():
            cli._send_again(signal.SIGTERM)
            deadline = time.time() + 10
            while threading.active_count() > before and time.time() < deadline:  # the sender has finished
                time.sleep(0.005)
            assert threading.active_count() == before
            assert seen == []
        assert seen == [signal.SIGTERM]
    finally:
        cli._Stop.handler, cli._Stop.stopping = saved
        signal.signal(signal.SIGTERM, old)


def _as_the_command():
    """Install the command's own signal handlers (``cli._catch_signals(True)``) in this process for a
    test; returns what to restore."""
    from explorer import cli
    saved = ({s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)},
             {k: getattr(cli._Stop, k) for k in ("stopping", "handler", "signal", "deferred_at", "raised")})
    cli._catch_signals(True)
    return saved


def _restore(saved):
    from explorer import cli
    handlers, stop = saved
    cli._Stop.raised = None  # every watcher stands down
    for k, v in stop.items():
        setattr(cli._Stop, k, v)
    for s, h in handlers.items():
        signal.signal(s, h)


def _swallow_one(sig, handled=False):
    """The command's handler raises the interrupt inside code that catches everything (a library's bare
    ``except:``)."""
    from explorer import cli
    try:
        os.kill(os.getpid(), sig)
        time.sleep(2)  # the interrupt lands here
        raise AssertionError("the signal was not delivered")
    except BaseException as exc:  # noqa: BLE001 - what a library may do
        assert isinstance(exc, KeyboardInterrupt), exc
        if handled:
            cli._interrupt_handled()


@pytest.mark.parametrize("sig,kind", [(signal.SIGTERM, "Terminated"), (signal.SIGINT, "Interrupted")])
def test_an_interrupt_swallowed_on_its_way_is_raised_again(sig, kind):
    """An interrupt the command's handler raised that something catches and drops (a bare ``except:`` in
    a library) is not lost: the signal is sent again (``cli._watch``) and its interrupt raised where the
    code is then. (The command ignores further signals once it has raised one, so a swallowed interrupt
    used to leave the run to finish with exit 0, as a clean-clone CI run once saw.)"""
    saved = _as_the_command()
    try:
        _swallow_one(sig)
        deadline = time.time() + 20
        with pytest.raises(KeyboardInterrupt) as info:
            while time.time() < deadline:
                time.sleep(0.01)
        assert type(info.value).__name__ == kind
    finally:
        _restore(saved)


def test_an_interrupt_a_verb_stops_on_is_not_raised_again():
    """The editor stops on Ctrl-C or SIGTERM by design (``cli._interrupt_handled``): nothing is sent again."""
    saved = _as_the_command()
    try:
        _swallow_one(signal.SIGTERM, handled=True)
        time.sleep(1.5)  # several of the watcher's looks (cli.WATCH_S)
    finally:
        _restore(saved)
