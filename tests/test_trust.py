"""Trust under careless input: a run never overwrites its own inputs or anything that is not a results
file, never resumes a file made from other inputs, and never shares its output with another run; a
damaged or foreign file is a one-line error, never a number; the API does what its call says."""

from __future__ import annotations

import os
from importlib import resources

import numpy as np
import pytest

import explorer
from explorer.cli import main
from explorer.errors import UserError
from explorer.testing import OutputLock

STUDY = """[study]
name = "trust"
mechanism = "leg.toml"
variants = 6
steps = 24
[perturb]
spread = 0.01
[scene]
metrics = true
[output]
path = "out.h5"
"""


@pytest.fixture
def files(tmp_path):
    leg = tmp_path / "leg.toml"
    leg.write_text((resources.files("explorer.mechanism") / "builtin" / "jansen.toml").read_text(), encoding="utf-8")
    study = tmp_path / "study.toml"
    study.write_text(STUDY, encoding="utf-8")
    return tmp_path, study, leg


def cli(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.mark.parametrize("which", ["study", "leg"])
def test_output_that_is_an_input_is_refused(files, capsys, which):
    tmp, study, leg = files
    target = study if which == "study" else leg
    before = target.read_bytes()
    code, _, err = cli(capsys, "run", study, "-o", target, "--force", "-q")
    assert code == 2 and err.count("\n") == 1
    assert ("run's own study file" if which == "study" else "run's own mechanism file") in err
    assert target.read_bytes() == before


def test_force_overwrites_results_files_only(files, capsys):
    tmp, study, leg = files
    text = tmp / "notes.txt"
    text.write_text("precious", encoding="utf-8")
    code, _, err = cli(capsys, "run", study, "-o", text, "--force", "-q")
    assert code == 2 and "not an explorer results file" in err and text.read_text() == "precious"
    fifo = tmp / "pipe"
    os.mkfifo(fifo)
    code, _, err = cli(capsys, "run", study, "-o", fifo, "--force", "-q")
    assert code == 2 and "not a regular file" in err and not fifo.is_file()
    # a results file is replaced
    out = tmp / "out.h5"
    assert cli(capsys, "run", study, "-o", out, "-q")[0] == 0
    assert cli(capsys, "run", study, "-o", out, "--force", "-q")[0] == 0
    assert not list(tmp.glob(".*lock")) and not list(tmp.glob(".*partial"))


def test_resume_refuses_a_changed_mechanism_or_version(files, capsys, monkeypatch):
    tmp, study, leg = files
    out = tmp / "out.h5"
    assert cli(capsys, "run", study, "-o", out, "-q")[0] == 0
    import h5py
    with h5py.File(out, "r+") as f:  # as if the run had been interrupted
        f.attrs["complete"] = False
        f["chunks/done"][-1] = False
    explorer.store.seal(out)  # the edit made on purpose, re-checksummed (else the resume refuses a damaged file)
    leg.write_text(leg.read_text().replace("length = 50.0", "length = 50.5", 1), encoding="utf-8")
    code, _, err = cli(capsys, "run", study, "-o", out, "--resume", "-q")
    assert code == 2 and "the mechanism file's content changed" in err and "--force" in err
    leg.write_text(leg.read_text().replace("length = 50.5", "length = 50.0", 1), encoding="utf-8")
    monkeypatch.setattr(explorer, "__version__", "99.0")
    code, _, err = cli(capsys, "run", study, "-o", out, "--resume", "-q")
    assert code == 2 and "explorer is now version 99.0" in err
    monkeypatch.undo()
    assert cli(capsys, "run", study, "-o", out, "--resume", "-q")[0] == 0


def test_a_second_run_on_one_output_is_refused(files, capsys):
    tmp, study, leg = files
    out = tmp / "out.h5"
    with OutputLock(out):  # another run holds it
        code, _, err = cli(capsys, "run", study, "-o", out, "-q")
        assert code == 2 and f"another explorer run (pid {os.getpid()})" in err
        assert not out.exists()
    assert cli(capsys, "run", study, "-o", out, "-q")[0] == 0
    assert not list(tmp.glob(".*lock"))
    with pytest.raises(UserError, match="another explorer run"):
        with OutputLock(out):
            explorer.run_study(str(study), output=out, force=True, progress=False)


# -- damaged and foreign results files ---------------------------------------------------------------------
@pytest.fixture
def results(files, capsys):
    tmp, study, leg = files
    out = tmp / "out.h5"
    assert cli(capsys, "run", study, "-o", out, "-q")[0] == 0
    return out


def _scramble_chunk(path, name, chunk=0):
    import h5py
    with h5py.File(path, "r") as f:
        info = f[name].id.get_chunk_info(chunk)
    with open(path, "r+b") as fh:
        fh.seek(info.byte_offset + info.size // 2)
        fh.write(b"\x5a\xa5\x5a\xa5")


def test_a_corrupt_chunk_is_an_error_never_a_number(results, capsys, tmp_path):
    import h5py
    with h5py.File(results, "r") as f:
        stride_before = f["metrics/stride"][...].tobytes()
    _scramble_chunk(results, "paths/7")
    for argv in (["plot", results, "--top", "2", "-o", tmp_path / "p.png"], ["metrics", results, "--band", "0.02"]):
        code, _, err = cli(capsys, *argv)
        assert code == 2 and err.count("\n") == 1 and ("checksum" in err or "corrupt" in err), err
    with h5py.File(results, "r") as f:  # the failed recompute left the stored metrics as they were
        assert f["metrics/stride"][...].tobytes() == stride_before
        assert "metrics_partial" not in f
    _scramble_chunk(results, "metrics/travel")
    code, _, err = cli(capsys, "rank", results)
    assert code == 2 and ("checksum" in err or "corrupt" in err), err


def test_truncated_and_foreign_files_give_one_line(results, capsys, tmp_path):
    import h5py
    trunc = tmp_path / "trunc.h5"
    trunc.write_bytes(results.read_bytes()[: results.stat().st_size // 3])
    code, _, err = cli(capsys, "rank", trunc)
    assert code == 2 and err.count("\n") == 1 and "in use" not in err and "truncated or corrupt" in err, err
    bare = tmp_path / "bare.h5"
    with h5py.File(bare, "w") as f:
        f.attrs["format"] = "explorer-results"
    for verb in (["rank", bare], ["show", bare, "--variant", "0"], ["plot", bare, "--top", "1", "-o", tmp_path / "x.png"]):
        code, _, err = cli(capsys, *verb)
        assert code == 2 and err.count("\n") == 1 and "not a readable explorer results file" in err, err
    broken = tmp_path / "broken.h5"
    broken.write_bytes(results.read_bytes())
    with h5py.File(broken, "r+") as f:
        f.attrs["study_resolved"] = "{not json"
    code, _, err = cli(capsys, "rank", broken)
    assert code == 2 and "not a readable explorer results file" in err, err


# -- API surprises ---------------------------------------------------------------------------------------
def test_results_path_takes_any_order_and_repeats(results):
    with explorer.open_results(results) as r:
        whole = r.file["paths/7"][...]
        order = [4, 1, 4, 0, -1]
        np.testing.assert_array_equal(r.path(order), whole[[4, 1, 4, 0, 5]])
        np.testing.assert_array_equal(r.path(np.array([3, 2])), whole[[3, 2]])
        with pytest.raises(UserError, match="variant 6 out of range"):
            r.path([1, 6])


def test_one_vertex_name_is_not_its_characters():
    m = explorer.load_mechanism("jansen")
    b = explorer.simulate_batch(m, m.lengths[None], [15.0], 12, vertices="7")
    assert list(b.paths) == ["7"]
    assert repr(b).startswith("<Batch 1 variants x 12 steps") and "\n" not in repr(b)
    c = explorer.simulate(m, 12)
    assert repr(c) == "<Cycle jansen: 12 steps, 7 vertices + velocities; ok>"


def test_bounded_dpi_and_help_without_double_percent(results, capsys, tmp_path):
    code, _, err = cli(capsys, "plot", results, "--top", "1", "--dpi", "1e9", "-o", tmp_path / "a.png")
    assert code == 2 and "--dpi: expected a number from 1 to 1200" in err
    for verb in ("show", "run", "--variant", "plot", "rank"):
        with pytest.raises(SystemExit):
            main([verb, "--help"])
        assert "%%" not in capsys.readouterr().out


def test_closed_needs_no_velocities_flag_and_batch_agrees_with_simulate_on_a_failed_nominal():
    m = explorer.load_mechanism("jansen")
    c = explorer.simulate(m, 36, method="closed")  # positions only, by default
    assert c.ok and c.velocities is None
    b = explorer.simulate_batch(m, m.lengths[None], [15.0], 36, method="closed")
    assert b.velocities == {} and b.status[0] == 0
    with pytest.raises(UserError, match="positions only"):
        explorer.simulate(m, 36, method="closed", velocities=True)
    # a nominal that cannot assemble: simulate reports it, simulate_batch too (no exception)
    broken = m.with_lengths({"1-3": 5.0})
    one = explorer.simulate(broken, 36)
    assert not one.ok and one.failure.kind == "assembly"
    many = explorer.simulate_batch(broken, np.tile(broken.lengths, (3, 1)), np.full(3, 15.0), 36)
    assert many.status.tolist() == [1, 1, 1] and np.isnan(many.paths["7"]).all()
    assert (many.fail_theta == one.failure.theta).all()
    assert set(many.fail_block.tolist()) == {one.failure.block}


def test_help_and_loading_stay_light():
    """`explorer --help` and loading a study file import neither Numba nor h5py nor pandas."""
    import subprocess
    import sys
    code = ("import sys\nfrom explorer.cli import main\n"
            "try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
            "import explorer\nexplorer.UserError\n"
            "heavy = [m for m in ('numba', 'h5py', 'pandas', 'matplotlib') if m in sys.modules]\n"
            "assert not heavy, heavy\nprint('light')")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip().endswith("light"), out.stderr


# -- signals ----------------------------------------------------------------------------------------------
def _start_and_signal(tmp_path, out, signals, gap):
    import signal
    import subprocess
    import sys
    import time
    study = tmp_path / "big.toml"
    study.write_text('[study]\nname = "big"\nmechanism = "jansen"\nvariants = 150000\nsteps = 72\n'
                     '[scene]\nmetrics = true\n', encoding="utf-8")
    proc = subprocess.Popen([sys.executable, "-m", "explorer.cli", "run", str(study), "-o", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while not out.exists() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.02)
    time.sleep(0.4)  # a chunk or two in
    for sig in signals:
        proc.send_signal({"INT": signal.SIGINT, "TERM": signal.SIGTERM}[sig])
        time.sleep(gap)
    _, err = proc.communicate(timeout=120)
    return proc.returncode, err, study


@pytest.mark.slow
@pytest.mark.parametrize("signals,gap,code", [(("INT", "INT"), 0.0, 130), (("INT", "INT"), 0.03, 130),
                                             (("TERM",), 0.0, 143)])
def test_interrupts_stop_cleanly_and_resume(tmp_path, capsys, signals, gap, code):
    out = tmp_path / "big.h5"
    rc, err, study = _start_and_signal(tmp_path, out, signals, gap)
    if rc == 0:
        pytest.skip("the run finished before the signal arrived (a very fast machine)")
    assert rc == code, err                               # not a negative code: no crash
    assert err.strip().count("\n") == 0 and "--resume" in err, err
    assert ("terminated" if code == 143 else "interrupted") in err
    assert not list(tmp_path.glob(".*lock")) and not list(tmp_path.glob(".*partial"))
    assert main(["run", str(study), "-o", str(out), "--resume", "-q"]) == 0
    with explorer.open_results(out) as r:
        assert r.complete and (r.file["status"][...] >= 0).all()


def test_one_way_to_name_a_variant(results, capsys, tmp_path):
    a = cli(capsys, "show", results, "--variant", "3")
    b = cli(capsys, "show", results, "--variant", "3")
    assert a[0] == b[0] == 0 and a[1] == b[1]
    assert cli(capsys, "show", results)[0] == 2
    assert cli(capsys, "plot", results, "--velocity", "--variant", "1", "-o", tmp_path / "v.png")[0] == 0
    assert cli(capsys, "plot", results, "--velocity", "--variant", "1", "-o", tmp_path / "w.png")[0] == 0
    code, _, err = cli(capsys, "plot", results, "--top", "2", "--variant", "1", "-o", tmp_path / "t.png")
    assert code == 2 and "--variant goes with --velocity" in err


@pytest.mark.slow
def test_a_disk_that_fills_mid_run_is_one_line_and_resumable(tmp_path):
    """On a 5 MB tmpfs (where the test can mount one), with the size check bypassed so the disk fills
    while chunks are committed: one line, exit 2, no crash, and the committed chunks resume."""
    import subprocess
    import sys
    disk = tmp_path / "small"
    disk.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=5m", "tmpfs", str(disk)], capture_output=True,
                             text=True)
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here ({mounted.stderr.strip() or 'mount failed'})")
    try:
        study = tmp_path / "big.toml"
        study.write_text('[study]\nname = "big"\nmechanism = "jansen"\nvariants = 150000\nsteps = 72\n',
                         encoding="utf-8")
        out = disk / "big.h5"
        code = ("import sys\nfrom explorer.testing import study_output as r\nr._check_disk_space = lambda *a: None\n"
                "from explorer.cli import main\n"
                f"sys.exit(main(['run', {str(study)!r}, '-o', {str(out)!r}, '-q']))")
        p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
        assert p.returncode == 2, (p.returncode, p.stderr)            # not 139: no segmentation fault
        assert p.stderr.count("\n") == 1 and "the disk is full" in p.stderr and "--resume" in p.stderr, p.stderr
        assert not list(disk.glob(".*partial")) and not list(disk.glob(".*lock"))
        with explorer.open_results(out) as r:
            assert not r.complete and r.file["chunks/done"][...].any()  # what was committed is readable
        moved = tmp_path / "big.h5"  # "free some space": here, move the file to a disk with room
        moved.write_bytes(out.read_bytes())
        assert main(["run", str(study), "-o", str(moved), "--resume", "-q"]) == 0
        with explorer.open_results(moved) as r:
            assert r.complete and (r.file["status"][...] >= 0).all()
    finally:
        subprocess.run(["umount", str(disk)], capture_output=True)


def test_corrupt_headers_give_one_line(results, capsys, tmp_path):
    """Scrambled bytes in the file's first 4 kB (superblock, root group, attributes), ten times: every
    verb answers with exit 0 or one line and exit 2, never a traceback."""
    rng = np.random.default_rng(11)
    good = results.read_bytes()
    for k in range(10):
        data = bytearray(good)
        for pos in rng.integers(0, 4096, 8):
            data[pos] = int(rng.integers(0, 256))
        bad = tmp_path / f"bad{k}.h5"
        bad.write_bytes(bytes(data))
        for argv in (["rank", bad], ["show", bad, "--variant", "0"]):
            code, _, err = cli(capsys, *argv)
            assert code in (0, 2), (k, argv, err)
            assert code == 0 or (err.count("\n") == 1 and err.startswith("explorer: error: ")), (k, err)


@pytest.mark.slow
def test_simulate_batch_takes_parameters_by_name():
    """A frame with its columns in any order is the design it names (it used to be read by position)."""
    import pandas as pd
    m = explorer.load_mechanism("jansen")
    rng = np.random.default_rng(3)
    L = m.lengths * rng.uniform(0.99, 1.01, (4, 10))
    r = 15.0 * rng.uniform(0.99, 1.01, 4)
    ref = explorer.simulate_batch(m, L, r, 24)
    df = pd.DataFrame(L, columns=m.link_names).assign(crank=r)
    reversed_df = df[list(df.columns)[::-1]]
    for given in (reversed_df, {k: reversed_df[k].to_numpy() for k in reversed_df.columns}):
        got = explorer.simulate_batch(m, given, None, 24)
        np.testing.assert_array_equal(got.paths["7"], ref.paths["7"])
    with pytest.raises(UserError, match="no column for link '1-3'"):
        explorer.simulate_batch(m, df.drop(columns="1-3"), None, 24)


# -- a disk that fills before the first commit (issue 31 item 2) --------------------------------------------------
DISK_STUDY = ('[study]\nname = "dfull"\nmechanism = "jansen"\nvariants = 1500\nsteps = 72\n'
              '[scene]\nmetrics = true\n')


def _run_cli(args, prelude=""):
    import subprocess
    import sys
    code = (f"import sys\n{prelude}\nfrom explorer.cli import main\n"
            f"sys.exit(main({[str(a) for a in args]!r}))")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)


@pytest.mark.slow
@pytest.mark.parametrize("reserve", [True, False])
def test_a_disk_that_fills_before_the_first_commit_is_resumable(tmp_path, reserve):
    """A real full disk: an 8 MB tmpfs (mounted where the test may; skipped otherwise), a filler file
    written after the run's start checks (as another writer would) leaving ~300 kB, so the first
    commit cannot fit. reserve=True: the commit's space is reserved before it is written (fallocate),
    so the run stops before writing anything: one line, exit 2, the file intact. reserve=False: as on
    a filesystem without fallocate (it is made to fail) and with the free-space check fooled, HDF5
    itself hits ENOSPC in the middle of the first commit and leaves a file no one can read; the
    resume starts it over (nothing was committed). Either way, once the filler is deleted,
    ``--resume`` finishes it, and the result equals an uninterrupted run."""
    import subprocess
    disk = tmp_path / "small"
    disk.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=8m", "tmpfs", str(disk)], capture_output=True,
                             text=True)
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a small tmpfs here ({mounted.stderr.strip() or 'mount failed'})")
    try:
        study = tmp_path / "dfull.toml"
        study.write_text(DISK_STUDY, encoding="utf-8")
        out = disk / "dfull.h5"
        filler = disk / "filler"
        # the start checks pass (the disk is empty), then another writer fills it before the first commit
        prelude = (f"import os, shutil\nfrom explorer.testing import study_run as run\nreal = run.chunk_solver\n"
                   f"def solver(study, *args):\n    solve = real(study, *args)\n"
                   f"    def first(a, b):\n        if not os.path.exists({str(filler)!r}):\n"
                   f"            st = os.statvfs({str(disk)!r})\n            free = st.f_bavail * st.f_frsize\n"
                   f"            with open({str(filler)!r}, 'wb') as fh:\n"
                   f"                fh.write(bytes(free - 300_000))\n"
                   f"        return solve(a, b)\n    return first\nrun.chunk_solver = solver\n")
        if not reserve:
            prelude += ("from explorer.testing import store_write as w\nimport errno\nw._fallocate = lambda *a, **k: errno.ENOTSUP\n"
                        "import shutil, collections\nU = collections.namedtuple('U', 'total used free')\n"
                        "shutil.disk_usage = lambda p: U(1 << 40, 0, 1 << 40)\n")
        p = _run_cli(["run", study, "-o", out, "-q"], prelude)
        assert p.returncode == 2, (p.returncode, p.stderr)
        assert p.stderr.count("\n") == 1 and "disk is full" in p.stderr and "--resume" in p.stderr, p.stderr
        if reserve:
            assert "no chunk was committed yet" in p.stderr, p.stderr
            with explorer.open_results(out) as r:  # the file is as it was created: intact, nothing run
                assert not r.complete and r.status_counts()["not-run"] == 1500
        assert not list(disk.glob(".*partial")) and not list(disk.glob(".*lock"))
        filler.unlink()  # space freed
        assert main(["run", str(study), "-o", str(out), "--resume", "-q"]) == 0
        ref = tmp_path / "ref.h5"
        assert main(["run", str(study), "-o", str(ref), "-q"]) == 0
        import h5py
        with explorer.open_results(out) as r, explorer.open_results(ref) as s:
            assert r.complete and r.frame().equals(s.frame())
        with h5py.File(out, "r") as a, h5py.File(ref, "r") as b:
            assert a["paths/7"][...].tobytes() == b["paths/7"][...].tobytes()
            assert a["chunks/digest"][...].tobytes() == b["chunks/digest"][...].tobytes()
    finally:
        subprocess.run(["umount", str(disk)], capture_output=True)


def test_a_full_disk_at_the_first_commit_stops_cleanly_and_resumes(tmp_path, monkeypatch):
    """Simulated (runs everywhere): the space reservation of the first commit fails with ENOSPC, as
    fallocate(2) answers on a full disk. Nothing of the commit is written, the error is one line
    saying so, and --resume (space freed: the reservation works again) finishes the file."""
    import errno

    from explorer.testing import store_write as w
    study = tmp_path / "d.toml"
    study.write_text(DISK_STUDY.replace("1500", "40").replace("72", "24"), encoding="utf-8")
    out = tmp_path / "d.h5"
    monkeypatch.setattr(w, "_fallocate", lambda *a, **k: errno.ENOSPC)
    with pytest.raises(UserError, match="the disk is full: committing chunk 1 of 1 needs up to .* no chunk was "
                                        "committed yet: free some space and run again with --resume") as info:
        explorer.run_study(study, output=out, progress=False)
    assert "\n" not in str(info.value)
    with explorer.open_results(out) as r:
        assert not r.complete and r.status_counts()["not-run"] == 40
    monkeypatch.undo()
    s = explorer.run_study(study, output=out, resume=True, progress=False)
    assert s.resumed and s.ran == 40
    with explorer.open_results(out) as r:
        assert r.complete and r.status_counts().get("not-run", 0) == 0


def test_a_write_that_fails_in_the_first_commit_is_started_over_by_resume(tmp_path, monkeypatch):
    """Simulated: h5py's write of the first commit raises OSError(ENOSPC) (what a full disk does where
    space cannot be reserved). No chunk was committed, so --resume starts the file over."""
    import errno

    import h5py
    study = tmp_path / "d.toml"
    study.write_text(DISK_STUDY.replace("1500", "40").replace("72", "24"), encoding="utf-8")
    out = tmp_path / "d.h5"
    real = h5py.Dataset.__setitem__

    def full(self, key, value):
        if self.name.startswith("/paths"):
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(self, key, value)

    from explorer.testing import store_write
    real_rows = store_write.write_rows  # the series go to HDF5 as whole chunks (write_direct_chunk)

    def full_rows(d, a, b, values, chunk_filter):
        if d.name.startswith("/paths"):
            raise OSError(errno.ENOSPC, "No space left on device")
        return real_rows(d, a, b, values, chunk_filter)

    monkeypatch.setattr(h5py.Dataset, "__setitem__", full)
    monkeypatch.setattr(store_write, "write_rows", full_rows)
    with pytest.raises(OSError):
        explorer.run_study(study, output=out, progress=False)
    monkeypatch.undo()
    s = explorer.run_study(study, output=out, resume=True, progress=False)
    assert s.resumed and s.ran == 40
    with explorer.open_results(out) as r:
        assert r.complete and r.status_counts().get("not-run", 0) == 0


def test_resume_demands_only_the_room_still_needed(tmp_path, monkeypatch):
    """A run with 3 of 4 chunks committed needs room for one more chunk only, not for the whole study."""
    import shutil
    from collections import namedtuple

    import h5py

    from explorer.testing import check_disk_space as _check_disk_space, estimated_bytes
    study = explorer.load_study({"study": {"name": "r", "mechanism": "jansen", "variants": 64, "steps": 24}})
    out = tmp_path / "r.h5"
    explorer.run_study(study, output=out, progress=False, chunk_size=16)
    with h5py.File(out, "r+") as f:  # as if killed after three commits
        f["chunks/done"][3] = False
    whole = estimated_bytes(study)
    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(1 << 40, 0, whole // 2))
    with pytest.raises(UserError, match="would write up to"):
        _check_disk_space(study, out)                     # a fresh run: the whole study
    _check_disk_space(study, out, resume=True)            # a resume: the 16 variants left fit
    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(1 << 40, 0, 1000))
    with pytest.raises(UserError, match="the 16 variants not yet committed"):
        _check_disk_space(study, out, resume=True)


def test_the_size_estimate_bounds_small_files(tmp_path):
    """The start check's estimate is an upper bound of the file even for tiny studies (it used to be
    1.3x-69x under: it counted the data only)."""
    import os

    from explorer.testing import estimated_bytes
    for n, steps in ((1, 36), (20, 36), (100, 72)):
        study = explorer.load_study({"study": {"name": "e", "mechanism": "jansen", "variants": n, "steps": steps},
                                     "scene": {"metrics": True}})
        out = tmp_path / f"e{n}.h5"
        explorer.run_study(study, output=out, progress=False)
        assert os.path.getsize(out) <= estimated_bytes(study), n
