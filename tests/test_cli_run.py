"""``explorer run`` as a real process: summary, exit codes, overwrite safety, and kill -9 then --resume."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from explorer import open_results, run_study
from explorer.cli import main

STUDY = """\
[study]
name = "cli"
mechanism = "jansen"
variants = {variants}
seed = 5
steps = {steps}

[perturb]
method = "uniform"
spread = 0.02

[scene]
vertices = ["7"]
velocities = true
"""


def explorer_cmd(*args) -> list[str]:
    return [sys.executable, "-m", "explorer.cli", *map(str, args)]


def run_cli(*args, cwd=None, timeout=300) -> subprocess.CompletedProcess:
    return subprocess.run(explorer_cmd(*args), cwd=cwd, capture_output=True, text=True, timeout=timeout)


def write_study(tmp_path: Path, variants=40, steps=36) -> Path:
    p = tmp_path / "cli.toml"
    p.write_text(STUDY.format(variants=variants, steps=steps))
    return p


def test_entry_point_installed():
    exe = shutil.which("explorer")
    if exe is None:
        pytest.skip("the explorer script is not on PATH (package not installed)")
    out = subprocess.run([exe, "run", "--help"], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and "--resume" in out.stdout and "--force" in out.stdout


@pytest.mark.slow
def test_run_summary_and_refusals(tmp_path):
    study = write_study(tmp_path)
    r = run_cli("run", study, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    out = tmp_path / "results" / "cli.h5"  # [output] default, relative to the working directory
    assert out.is_file()
    assert "ran 40 of 40 variants" in r.stdout and "ok " in r.stdout and "configurations/s" in r.stdout
    with open_results(out) as res:
        counts = res.status_counts()
    assert f"ok {counts['ok']:,}" in r.stdout and sum(counts.values()) == 40

    before = out.read_bytes()
    r = run_cli("run", study, cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--force" in r.stderr and "Traceback" not in r.stderr
    assert out.read_bytes() == before

    r = run_cli("run", study, "--resume", cwd=tmp_path)
    assert r.returncode == 0 and "already complete" in r.stdout
    assert out.read_bytes() == before

    r = run_cli("run", study, "--force", "--quiet", cwd=tmp_path)
    assert r.returncode == 0 and r.stdout == "" and r.stderr == ""

    with pytest.raises(SystemExit) as info:  # argparse: mutually exclusive
        main(["run", str(study), "--force", "--resume"])
    assert info.value.code == 2


@pytest.mark.slow
def test_output_option_and_unwritable_path(tmp_path):
    study = write_study(tmp_path)
    r = run_cli("run", study, "-o", "sub/dir/o.h5", "--quiet", cwd=tmp_path)
    assert r.returncode == 0 and (tmp_path / "sub" / "dir" / "o.h5").is_file()
    (tmp_path / "blocker").write_text("")
    r = run_cli("run", study, "-o", tmp_path / "blocker" / "x.h5", cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "cannot create the results file" in r.stderr


@pytest.mark.slow
def test_default_study_runs_with_no_argument(tmp_path):
    """The README's main job: `explorer run` in an empty folder writes results/jansen-2pct.h5."""
    r = run_cli("run", cwd=tmp_path, timeout=600)
    assert r.returncode == 0, r.stderr
    with open_results(tmp_path / "results" / "jansen-2pct.h5") as res:
        assert res.complete and res.n_variants == 10_000 and res.steps == 360
        assert sum(res.status_counts().values()) == 10_000
    assert "10,000 of 10,000 variants" in r.stdout


def _chunks_done(path: Path):
    """Committed chunks of a file another process is writing, or None if it cannot be read right now."""
    try:
        with h5py.File(path, "r", locking=False) as f:
            return int(f["chunks/done"][...].sum()), int(f["chunks/done"].shape[0])
    except Exception:
        return None


def _kill_after_first_chunk(study: Path, out: Path, chunk: int) -> bool:
    """Start `explorer run`, SIGKILL it once a chunk is committed; False if it finished first."""
    proc = subprocess.Popen(explorer_cmd("run", study, "-o", out, "--chunk-size", chunk, "--quiet"),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline:
            if proc.poll() is not None:
                return False
            state = _chunks_done(out) if out.exists() else None
            if state is not None and state[0] >= 1:
                os.kill(proc.pid, signal.SIGKILL)
                proc.wait(timeout=60)
                return True
            time.sleep(0.002)
        pytest.fail("no chunk was committed within 300 s")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


@pytest.mark.slow
def test_kill_9_then_resume_is_identical_to_an_uninterrupted_run(tmp_path):
    study = write_study(tmp_path, variants=6400, steps=90)
    out = tmp_path / "killed.h5"
    for chunk in (64, 16):
        if out.exists():
            out.unlink()
        if _kill_after_first_chunk(study, out, chunk):
            break
    else:
        pytest.skip("the run finished before it could be killed, twice (machine too fast for this test)")

    # the killed file opens, is incomplete, and knows which chunks are done
    with open_results(out) as res:
        assert not res.complete
        counts = res.status_counts()
        assert sum(counts.values()) == 6400 and 0 < counts["not-run"] < 6400
        df = res.frame()
        assert len(df) == 6400
    with h5py.File(out, "r") as f:
        done = f["chunks/done"][...]
        assert done.any() and not done.all()
    n_done_rows = int(done.sum()) * chunk

    r = run_cli("run", study, "-o", out, "--resume")
    assert r.returncode == 0, r.stderr
    assert f"resumed {6400 - n_done_rows:,} of 6,400 variants" in r.stdout

    ref = run_study(study, output=tmp_path / "ref.h5", progress=False, chunk_size=chunk).path
    with h5py.File(ref, "r") as a, h5py.File(out, "r") as b:
        assert bool(b.attrs["complete"]) and b["chunks/done"][...].all()
        names = []
        a.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        assert set(names) >= {"theta", "variants/lengths", "variants/crank", "status", "fail_theta", "fail_block",
                              "paths/7", "velocities/7", "chunks/done"}
        for n in names:
            x, y = a[n][...], b[n][...]
            assert x.shape == y.shape and x.dtype == y.dtype and x.tobytes() == y.tobytes(), n
        for k in ("study", "format", "n_variants", "steps", "study_fingerprint", "mechanism"):
            assert a.attrs[k] == b.attrs[k]
        assert np.array_equal(a["status"][...], b["status"][...])
