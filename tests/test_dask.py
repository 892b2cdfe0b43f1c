"""Studies on a Dask cluster (issue 7): shards written by worker processes, stitched with virtual datasets.

The cluster tests need ``dask[distributed]`` (``pip install "explorer[dask]"``) and are skipped without
it; the shard-layout tests and the "no dask → one-line error" test run everywhere. One 2-worker
LocalCluster (processes, one thread each) serves every cluster test (~30-40 s in all on 2 cores).
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from explorer import UserError, open_results, run_study
from explorer.cli import main
from explorer.testing import MAX_SHARDS, ShardPlan, completed_shards, plan_shards, shard_name, shards_folder
from explorer.study import load_study

HAVE_DASK = importlib.util.find_spec("distributed") is not None
needs_dask = pytest.mark.skipif(not HAVE_DASK, reason='dask.distributed is not installed (pip install "explorer[dask]")')

#: 300 Jansen variants at ±5 %: ~40 % fail to assemble, so NaNs, failure codes and metrics all show up.
STUDY = {
    "study": {"name": "dk", "mechanism": "jansen", "variants": 300, "seed": 3, "steps": 36},
    "perturb": {"method": "uniform", "spread": 0.05},
    "scene": {"vertices": ["7"], "velocities": True, "metrics": True},
}
SHARD = 64  # → 5 shards (the last one 44 variants)


def datasets(f: h5py.File) -> list[str]:
    names: list[str] = []
    f.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) and not n.startswith("chunks") else None)
    return names


def assert_same_results(path, ref) -> None:
    """Every dataset of ``path`` equals ``ref``'s bit for bit (NaN payloads included), and so do the frames."""
    with h5py.File(path, "r") as a, h5py.File(ref, "r") as b:
        names = datasets(b)
        assert names == datasets(a)
        for n in names:
            x, y = a[n][...], b[n][...]
            assert x.dtype == y.dtype and x.shape == y.shape, n
            assert x.tobytes() == y.tobytes(), f"{n} differs"
        assert a["paths/7"].is_virtual and a["metrics/stride"].is_virtual
    with open_results(path) as r, open_results(ref) as s:
        fa, fb = r.frame(), s.frame()
        assert list(fa.columns) == list(fb.columns)
        assert fa.equals(fb)
        assert r.complete and r.status_counts() == s.status_counts()
        assert r.path(7).tobytes() == s.path(7).tobytes()
        assert r.velocity(slice(0, 300)).tobytes() == s.velocity(slice(0, 300)).tobytes()


# -- fixtures ------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The same study run by the single-process runner."""
    out = tmp_path_factory.mktemp("ref") / "dk.h5"
    run_study(STUDY, output=out, progress=False)
    return out


@pytest.fixture(scope="module")
def client():
    if not HAVE_DASK:
        pytest.skip('dask.distributed is not installed (pip install "explorer[dask]")')
    import logging

    from distributed import Client, LocalCluster
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=logging.CRITICAL)
    c = Client(cluster)
    yield c
    c.close()
    cluster.close()


# Functions run inside the workers (by client.run): they replace write_shard in the worker's copy of
# explorer.study._dask to inject a fault into one shard task, then put it back.
def _arm(mode: str, shard: int, marker: str) -> None:
    from explorer.testing import study_dask as d
    real = getattr(d, "_real_write_shard", d.write_shard)
    d._real_write_shard = real

    def faulty(folder, plan, i, study, solve):
        if i != shard or os.path.exists(marker):
            return real(folder, plan, i, study, solve)
        Path(marker).write_text(str(os.getpid()))
        if mode == "raise":
            raise RuntimeError(f"injected failure in shard {i}")

        def dying(a, b):  # called once the shard's temporary file exists
            os._exit(1)  # the worker process dies mid-shard, as if its node were lost
        return real(folder, plan, i, study, dying)

    d.write_shard = faulty


def _disarm() -> None:
    from explorer.testing import study_dask as d
    if hasattr(d, "_real_write_shard"):
        d.write_shard = d._real_write_shard


# -- the proof ---------------------------------------------------------------------------------------
@pytest.mark.slow
@needs_dask
def test_stitched_equals_single_process(client, reference, tmp_path):
    import numba
    from explorer.study import run_study_dask
    out = tmp_path / "res" / "dk.h5"
    threads = numba.config.NUMBA_NUM_THREADS  # every core (2 on the CI machines)
    numba.set_num_threads(threads)
    s = run_study_dask(client, STUDY, output=out, shard_size=SHARD, progress=False)
    assert os.fspath(s) == str(out) and s.ran == 300 and not s.resumed
    # the client warmed the kernels up on one thread, then gave this process its threads back
    assert numba.get_num_threads() == threads
    folder = shards_folder(out)
    assert folder == tmp_path / "res" / "dk.shards"
    assert sorted(p.name for p in folder.glob("shard-*.h5")) == [shard_name(i) for i in range(5)]
    assert not list(folder.glob(".*partial"))
    assert_same_results(out, reference)
    with open_results(reference) as r:
        assert s.counts == {k: v for k, v in r.status_counts().items()}
    # each shard holds its own rows only (HDF5 allocates no space for chunks never written)
    with h5py.File(folder / shard_name(1)) as f:
        assert f.attrs["shard_done"] and (f.attrs["shard_start"], f.attrs["shard_stop"]) == (64, 128)
        assert list(np.flatnonzero(f["status"][...] != -1)) == list(range(64, 128))
    # the stitched file maps with relative paths
    with h5py.File(out) as f:
        srcs = {m.file_name for m in f["paths/7"].virtual_sources()}
        assert srcs == {f"dk.shards/{shard_name(i)}" for i in range(5)}
    # rerunning: refused without a flag, nothing to do with --resume
    with pytest.raises(UserError, match="exists"):
        run_study_dask(client, STUDY, output=out, shard_size=SHARD)
    again = run_study_dask(client, STUDY, output=out, resume=True, progress=False)
    assert again.already_complete and again.ran == 0
    # a plain single-process --resume also sees the stitched file as complete
    assert run_study(STUDY, output=out, resume=True, progress=False).already_complete


@pytest.mark.slow
@needs_dask
def test_worker_killed_mid_study_still_completes(client, reference, tmp_path):
    """The worker running shard 1 dies (os._exit) the first time; the nanny restarts it, the
    scheduler reschedules the shard, and the results are still identical to a single-process run."""
    from explorer.study import run_study_dask
    marker = tmp_path / "killed"
    pids = set(client.run(os.getpid).values())
    client.run(_arm, "kill", 1, str(marker))
    try:
        out = tmp_path / "dk.h5"
        s = run_study_dask(client, STUDY, output=out, shard_size=SHARD, progress=False)
    finally:
        client.run(_disarm)
        client.wait_for_workers(2, timeout=60)
    assert marker.exists(), "the fault was not injected"
    killed = int(marker.read_text())
    assert killed in pids and killed not in set(client.run(os.getpid).values()), "no worker died"
    assert s.ran == 300
    assert not list(shards_folder(out).glob(".*partial")), "the killed attempt's temporary file was left"
    assert_same_results(out, reference)


@pytest.mark.slow
@needs_dask
def test_failed_shard_then_resume(client, reference, tmp_path):
    """A shard that fails for good stops the run with a --resume hint; the resume runs only the
    shards that were not complete and gives the same results."""
    from explorer.study import run_study_dask
    marker = tmp_path / "failed"
    out = tmp_path / "dk.h5"
    client.run(_arm, "raise", 2, str(marker))
    try:
        with pytest.raises(UserError, match="--resume"):
            run_study_dask(client, STUDY, output=out, shard_size=SHARD, progress=False, retries=0)
    finally:
        client.run(_disarm)
    assert marker.exists() and not out.exists()
    folder = shards_folder(out)
    plan = ShardPlan.read(folder)
    done = completed_shards(folder, plan)
    assert not done[2]
    remaining = sum(b - a for a, b in (plan.range(i) for i, ok in enumerate(done) if not ok))
    with pytest.raises(UserError, match="unfinished run"):  # neither --resume nor --force
        run_study_dask(client, STUDY, output=out, progress=False)
    s = run_study_dask(client, STUDY, output=out, resume=True, progress=False)
    assert s.resumed and s.ran == remaining and 0 < s.ran < 300
    assert_same_results(out, reference)
    # --force starts over (every shard rewritten)
    s = run_study_dask(client, STUDY, output=out, force=True, shard_size=100, progress=False)
    assert s.ran == 300 and ShardPlan.read(folder).shard_rows == 100 and len(list(folder.glob("shard-*.h5"))) == 3
    assert_same_results(out, reference)


@pytest.mark.slow
@needs_dask
def test_relocated_folder_opens(client, reference, tmp_path, monkeypatch):
    from explorer.study import run_study_dask
    out = tmp_path / "a" / "dk.h5"
    run_study_dask(client, STUDY, output=out, shard_size=SHARD, progress=False)
    moved = tmp_path / "elsewhere" / "deeper"
    moved.parent.mkdir()
    shutil.move(str(tmp_path / "a"), str(moved))
    monkeypatch.chdir(tmp_path / "elsewhere")  # neither the old folder nor the new one
    assert_same_results(moved / "dk.h5", reference)
    # the study file without its shards folder: a clear error, not silent NaNs
    alone = tmp_path / "alone.h5"
    shutil.copy(moved / "dk.h5", alone)
    with pytest.raises(UserError, match="dk.shards.*missing|missing.*dk.shards"):
        open_results(alone)


@pytest.mark.slow
@needs_dask
def test_cli_connects_to_a_scheduler(client, reference, tmp_path, capsys):
    out = tmp_path / "cli.h5"
    study = tmp_path / "dk.toml"
    from explorer.study import dumps_toml
    study.write_text(dumps_toml(STUDY))
    code = main(["run", str(study), "--dask", client.scheduler_info()["address"], "--shard-size", "128", "-o", str(out), "-q"])
    assert code == 0
    assert_same_results(out, reference)
    assert main(["run", str(study), "--dask", "local:0", "-o", str(out), "--force"]) == 2
    assert "local:N" in capsys.readouterr().err
    assert main(["run", str(study), "--shard-size", "10", "-o", str(out), "--force"]) == 2
    assert "--dask" in capsys.readouterr().err


@pytest.mark.slow
@needs_dask
def test_run_study_takes_a_client(client, reference, tmp_path):
    """client= is the one way to hand a runner a cluster: run_study(client=...) runs the shards and stitches
    them, bit for bit the single-process file (as run_study_dask does)."""
    out = tmp_path / "dk.h5"
    s = run_study(STUDY, output=out, client=client, shard_size=SHARD, progress=False)
    assert s.ran == 300 and os.fspath(s) == str(out)
    assert sorted(p.name for p in shards_folder(out).glob("shard-*.h5")) == [shard_name(i) for i in range(5)]
    assert_same_results(out, reference)


@needs_dask
def test_client_must_be_a_client(tmp_path):
    from explorer.optimize import run_optimize
    with pytest.raises(UserError, match="run_study_dask: expected a dask.distributed.Client"):
        run_study(STUDY, output=tmp_path / "x.h5", client=object())
    if importlib.util.find_spec("pymoo") is not None:
        with pytest.raises(UserError, match="run_optimize: expected a dask.distributed.Client"):
            run_optimize(OPT_STUDY, output=tmp_path / "o.h5", client="tcp://nowhere:8786")
    assert not list(tmp_path.iterdir())  # refused before any file was made


def test_shard_size_needs_a_client(tmp_path):
    with pytest.raises(UserError, match="Dask cluster only"):
        run_study(STUDY, output=tmp_path / "x.h5", shard_size=10)
    assert not (tmp_path / "x.h5").exists()


# -- without a cluster -------------------------------------------------------------------------------
def test_without_dask_one_line_error(tmp_path, monkeypatch, capsys):
    for mod in ("distributed", "dask", "dask.distributed"):
        monkeypatch.setitem(sys.modules, mod, None)  # `import distributed` now raises ImportError
    code = main(["run", "default", "--dask", "local:2", "-o", str(tmp_path / "x.h5")])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and 'pip install "explorer[dask]"' in err
    from explorer.study import run_study_dask
    with pytest.raises(UserError, match=r'pip install "explorer\[dask\]"'):
        run_study_dask(object(), STUDY, output=tmp_path / "y.h5")
    with pytest.raises(UserError, match=r'pip install "explorer\[dask\]"'):
        run_study(STUDY, output=tmp_path / "y.h5", client=object())
    assert not (tmp_path / "x.h5").exists() and not (tmp_path / "x.shards").exists()


def test_shard_layout():
    default = load_study("default")  # 10,000 variants × 360 steps, foot path + velocities
    p = plan_shards(default, workers=2)
    assert (p.shard_rows, p.chunk_rows, p.n_shards) == (1280, 1280, 8)  # 4 shards per worker
    assert plan_shards(default, workers=1).n_shards == 4
    p = plan_shards(default, workers=64)  # ≥ 2^19 configurations per shard: 1,457 → 1,536 variants
    assert p.shard_rows == 1536 and p.n_shards == 7
    p = plan_shards(default, workers=3)  # 7 shards of ≥ 1,457 → 9 (3 per worker) of 1,112 → 1,152
    assert p.shard_rows == 1152 and p.n_shards == 9
    big = load_study({**STUDY, "study": {**STUDY["study"], "variants": 2_000_000, "steps": 360}})
    p = plan_shards(big, workers=16)
    assert p.n_shards <= MAX_SHARDS and p.shard_rows % p.chunk_rows == 0 and p.chunk_rows <= 2048
    small = load_study(STUDY)
    for size in (1, 7, 64, 299, 300, 5000):
        p = plan_shards(small, workers=2, shard_size=size)
        assert p.shard_rows % p.chunk_rows == 0
        assert p.range(p.n_shards - 1)[1] == 300 and p.n_shards == -(-300 // p.shard_rows)
        if size < 300:
            assert p.shard_rows == size
    assert plan_shards(small, shard_size=5000).n_shards == 1
    p = plan_shards(default, shard_size=3000)  # kept whole: 2 chunks of 1,536 (12 HDF5 chunks each)
    assert (p.shard_rows, p.chunk_rows) == (3072, 1536)


OPT_STUDY = {"study": {"name": "dk-opt", "mechanism": "jansen", "seed": 2, "steps": 36},
             "optimize": {"algorithm": "nsga2", "population": 10, "generations": 3, "objectives": ["travel", "bob"],
                          "spread": 0.04, "parameters": ["1-3", "2-6", "crank"]},
             "scene": {"velocities": False}}


@pytest.mark.slow
@needs_dask
def test_optimize_on_dask_equals_single_process(client, tmp_path):
    """explorer optimize --dask: each generation split over the workers; the file is the local run's, bit
    for bit, and this process keeps its Numba threads."""
    import numba
    from explorer.optimize import run_optimize
    threads = numba.config.NUMBA_NUM_THREADS
    numba.set_num_threads(threads)
    a = run_optimize(OPT_STUDY, output=tmp_path / "local.h5", progress=False)
    b = run_optimize(OPT_STUDY, output=tmp_path / "dask.h5", progress=False, client=client)
    assert numba.get_num_threads() == threads
    assert a.evaluations == b.evaluations == 30
    with h5py.File(a.path, "r") as fa, h5py.File(b.path, "r") as fb:
        names = []
        fa.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        assert "variants/generation" in names and "metrics/travel" in names
        for n in names:
            assert fa[n][...].tobytes() == fb[n][...].tobytes(), n
