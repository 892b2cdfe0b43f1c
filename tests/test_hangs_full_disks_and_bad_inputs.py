"""Issue 43 (trust under faults, round three): a damaged global heap that made every verb hang, ``explorer
metrics`` on a full disk and on a damaged shard, big mechanisms in the study path, signals from the first
instruction, and the inputs that got through (zero masses, a byte-order mark, a long study name, a huge
``--yield``, argparse's several-line errors).

Every test that can hang runs the code under a CPU limit in a subprocess (``resource.setrlimit``), so that a
hang fails the test instead of blocking the suite."""

from __future__ import annotations

import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

import explorer
from explorer.cli import main
from explorer.errors import UserError

TESTS = Path(__file__).resolve().parent
SMALL = {"study": {"name": "f43", "mechanism": "jansen", "variants": 6, "steps": 24, "seed": 3},
         "perturb": {"spread": 0.01}, "scene": {"metrics": True, "vertices": ["7"], "velocities": True}}


def cli(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def python(code: str, *, cpu_s: int = 120, timeout: float = 300, env: dict | None = None, **kw):
    """``python -c code`` under a CPU limit of ``cpu_s`` seconds (RLIMIT_CPU: a loop in C is killed, SIGXCPU
    then SIGKILL) and a wall-time limit."""
    def limit():
        import resource
        resource.setrlimit(resource.RLIMIT_CPU, (cpu_s, cpu_s + 1))
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout,
                          preexec_fn=limit, env={**os.environ, **(env or {})}, **kw)


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    folder = tmp_path_factory.mktemp("f43")
    return explorer.run_study(SMALL, output=folder / "small.h5", progress=False).path


def gcol_headers(data: bytes) -> list[int]:
    """Offsets of the first object header of every global heap collection (``GCOL``, version 1, 8-byte
    lengths: signature 4, version 1, reserved 3, collection size 8; then each object: index 2, references
    2, reserved 4, size 8, data): where 16 zero bytes made HDF5 loop for ever."""
    out = []
    at = data.find(b"GCOL")
    while at >= 0:
        size = int.from_bytes(data[at + 8:at + 16], "little")
        if data[at + 4] == 1 and 4096 <= size <= len(data) - at:
            out.append(at + 16)
        at = data.find(b"GCOL", at + 4)
    return out


def zeroed(path: Path, out: Path, offset: int, length: int) -> Path:
    data = bytearray(path.read_bytes())
    data[offset:offset + length] = bytes(min(length, len(data) - offset))
    out.write_bytes(bytes(data))
    return out


# -- the global heap that hung every verb ---------------------------------------------------------------------
@pytest.mark.slow
def test_the_damaged_heap_makes_plain_hdf5_loop(small, tmp_path):
    """The reproduction: plain h5py reading the root attributes of the damaged file spins in C until the
    CPU limit kills it. (What explorer does with the same file is the next test.)"""
    bad = zeroed(small, tmp_path / "bad.h5", gcol_headers(small.read_bytes())[0], 16)
    p = python(f"import h5py\nf = h5py.File({str(bad)!r}, 'r')\nprint(dict(f.attrs))", cpu_s=4, timeout=120)
    assert p.returncode in (-signal.SIGXCPU, -signal.SIGKILL), (p.returncode, p.stderr[-300:])


def test_a_damaged_heap_is_refused_in_one_line_and_in_bounded_time(small, tmp_path):
    """16 zero bytes over the first object header of the first global heap collection: ``open_results``
    (in this process) and ``explorer rank`` (a subprocess under a CPU limit) refuse the file in one line;
    the verification ran in a child process, which looped and was stopped."""
    bad = zeroed(small, tmp_path / "bad.h5", gcol_headers(small.read_bytes())[0], 16)
    t0 = time.perf_counter()
    with pytest.raises(UserError, match=r"bad\.h5: not a readable explorer results file \(damaged: reading it made "
                                        r"HDF5 loop") as info:
        explorer.open_results(bad)
    assert "\n" not in str(info.value) and time.perf_counter() - t0 < 120
    p = python(f"import sys\nfrom explorer.cli import main\nsys.exit(main(['rank', {str(bad)!r}]))", cpu_s=60)
    assert p.returncode == 2, (p.returncode, p.stderr[-500:])
    assert p.stderr.count("\n") == 1 and "made HDF5 loop" in p.stderr, p.stderr
    assert not _orphans(tmp_path)


def _orphans(folder: Path) -> list[int]:
    """Processes of this test's user still holding a file of ``folder`` open (a guard child left behind)."""
    found = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            for fd in os.listdir(f"/proc/{pid}/fd"):
                if os.readlink(f"/proc/{pid}/fd/{fd}").startswith(str(folder)):
                    found.append(int(pid))
        except OSError:
            continue
    return [p for p in found if p != os.getpid()]


@pytest.mark.slow
def test_every_verb_refuses_the_damaged_heap_and_run_force_replaces_it(small, tmp_path):
    """Every verb that reads the file, ``--resume``, ``metrics`` and ``physics`` included: one line, exit 2, under a CPU
    limit; ``run --force`` overwrites it (it used to hang before it could)."""
    bad = zeroed(small, tmp_path / "bad.h5", gcol_headers(small.read_bytes())[0], 16)
    study = tmp_path / "s.toml"
    from explorer.testing import dumps_toml
    study.write_text(dumps_toml(SMALL), encoding="utf-8")
    before = bad.read_bytes()
    argvs = [["rank", bad], ["show", bad, "--variant", "0"],
             ["export", bad, "--variant", "0", "--as", "csv", "-o", tmp_path / "x.csv"],
             ["plot", bad, "--top", "1", "-o", tmp_path / "x.png"], ["report", bad, "-o", tmp_path / "x.html"],
             ["metrics", bad, "--band", "0.02"], ["run", study, "-o", bad, "--resume", "-q"],
             ["physics", bad, "--variant", "0"]]
    # the stall budget (3 CPU-s by default) made 1 here: each verb refuses the same way, sooner
    for argv in argvs:
        p = python(f"import sys\nfrom explorer.testing import store_guard as g\ng.STALL_CPU_S = 1.0\n"
                   f"from explorer.cli import main\nsys.exit(main({[str(a) for a in argv]!r}))", cpu_s=60)
        assert p.returncode == 2, (argv, p.returncode, p.stderr[-500:])
        assert p.stderr.count("\n") == 1 and "damaged" in p.stderr, (argv, p.stderr)
        assert bad.read_bytes() == before
    p = python(f"import sys\nfrom explorer.cli import main\nsys.exit(main(['run', {str(study)!r}, '-o', {str(bad)!r}, "
               f"'--force', '-q']))", cpu_s=120)
    assert p.returncode == 0, p.stderr[-500:]
    with explorer.open_results(bad) as r:
        assert r.complete


@pytest.mark.slow
def test_a_signal_stops_the_wait_for_a_looping_verification(small, tmp_path):
    """SIGTERM while the guarded verification loops (its stall budget made endless here): the verb stops
    at once, in one line, and the looping child is gone with it."""
    bad = zeroed(small, tmp_path / "bad.h5", gcol_headers(small.read_bytes())[0], 16)
    code = ("import sys\nfrom explorer.testing import store_guard as g\ng.STALL_CPU_S = 1e9\nfrom explorer.cli import main\n"
            f"sys.exit(main(['rank', {str(bad)!r}]))")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 120
        child: list = []
        while time.time() < deadline and proc.poll() is None:  # the verb's handler is in, and its guard child
            kids = _children(proc.pid)                           # loops (not a fork about to exec a program)
            if kids and _handler_installed(proc.pid):
                time.sleep(0.3)
                child = [k for k in _children(proc.pid) if k in kids]
                if child:
                    break
            time.sleep(0.02)
        assert child, "the guarded child never started"
        t0 = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
        latency = time.monotonic() - t0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 143 and err.count("\n") == 1 and "terminated" in err and "Traceback" not in err, err
    assert latency < 5.0, latency  # a second or less on a quiet machine (the loop itself never ends)
    time.sleep(0.2)
    assert not any(os.path.exists(f"/proc/{c}") for c in child), "the looping child outlived the verb"


def _children(pid: int) -> list[int]:
    """The forked children of ``pid`` (the guard's: the same command line; not a program it ran)."""
    try:
        with open(f"/proc/{pid}/task/{pid}/children", encoding="ascii") as fh:
            kids = [int(x) for x in fh.read().split()]
        with open(f"/proc/{pid}/cmdline", "rb") as fh:
            mine = fh.read()
    except OSError:
        return []
    out = []
    for k in kids:
        try:
            with open(f"/proc/{k}/cmdline", "rb") as fh:
                if fh.read() == mine:
                    out.append(k)
        except OSError:
            continue
    return out


@pytest.mark.slow
def test_files_written_before_open_and_the_legacy_format_is_guarded_too(tmp_path, monkeypatch):
    """A file with the layout this version wrote before (version-1 object headers: HDF5's earliest format)
    still opens and reads the same; its damaged heap is refused the same way."""
    from explorer.testing import store_write as w
    monkeypatch.setattr(w, "LIBVER", ("earliest", "latest"))
    old = explorer.run_study(SMALL, output=tmp_path / "old.h5", progress=False).path
    monkeypatch.undo()
    new = explorer.run_study(SMALL, output=tmp_path / "new.h5", progress=False).path
    with h5py.File(old, "r") as f:
        assert f.id.get_create_plist().get_version()[0] == 0  # the superblock of the earliest format
    with explorer.open_results(old) as a, explorer.open_results(new) as b:
        assert a.frame().equals(b.frame())
        np.testing.assert_array_equal(a.path([0, 3, 5]), b.path([0, 3, 5]))
    bad = zeroed(old, tmp_path / "bad.h5", gcol_headers(old.read_bytes())[0], 16)
    with pytest.raises(UserError, match="made HDF5 loop"):
        explorer.open_results(bad)


# -- the fuzz: zeroed 4 KB pages and 16-byte runs over the metadata ---------------------------------------------
#: Byte signatures of HDF5's metadata structures, by region (the file format specification, section III).
SIGNATURES = {b"OHDR": "object headers", b"OCHK": "object headers", b"TREE": "v1 B-trees (chunk indexes)",
              b"GCOL": "global heap (string attributes)", b"FRHP": "fractal heaps and v2 B-trees (dense attributes)",
              b"FHIB": "fractal heaps and v2 B-trees (dense attributes)",
              b"FHDB": "fractal heaps and v2 B-trees (dense attributes)",
              b"BTHD": "fractal heaps and v2 B-trees (dense attributes)",
              b"BTIN": "fractal heaps and v2 B-trees (dense attributes)",
              b"BTLF": "fractal heaps and v2 B-trees (dense attributes)", b"FSHD": "free-space managers",
              b"FSSE": "free-space managers", b"HEAP": "local heaps and symbol nodes", b"SNOD": "local heaps and symbol nodes"}


def metadata_map(path: Path) -> dict:
    """{region: [(start, stop)]} of the metadata of ``path``: the superblock, each structure from its
    signature to the next structure or chunk (signatures only mark starts), the contiguous datasets. Chunk
    data (covered by Fletcher-32 and the chunk digests since round two) is left out."""
    data = path.read_bytes()
    chunks, contiguous = [], []

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset):
            if obj.chunks:
                for k in range(obj.id.get_num_chunks()):
                    info = obj.id.get_chunk_info(k)
                    chunks.append((info.byte_offset, info.byte_offset + info.size))
            elif obj.id.get_offset() is not None:
                contiguous.append((obj.id.get_offset(), obj.id.get_offset() + obj.id.get_storage_size()))

    with h5py.File(path, "r") as f:
        f.visititems(visit)
    starts = sorted([(m.start(), SIGNATURES[m.group()]) for m in re.finditer(b"|".join(SIGNATURES), data)]
                    + [(a, "chunk") for a, _ in chunks] + [(a, "contiguous datasets") for a, _ in contiguous])
    ends = {a: b for a, b in chunks + contiguous}
    out: dict = {"superblock": [(0, min(96, starts[0][0] if starts else 96))]}
    for (a, region), nxt in zip(starts, starts[1:] + [(len(data), None)]):
        if region == "chunk":
            continue
        b = ends.get(a, nxt[0]) if region == "contiguous datasets" else nxt[0]
        if b > a:
            out.setdefault(region, []).append((a, b))
    return out


def fuzz_trials(path: Path, pages: int | None, runs_per_region: int, seed: int) -> list[dict]:
    """The damage to do: zeroed 4 KB pages that hold metadata (all, or a sample of ``pages``), zeroed
    16-byte runs (``runs_per_region`` per region, at random starts), and the first object header of every
    global heap collection."""
    rng = random.Random(seed)
    data = path.read_bytes()
    spans = metadata_map(path)
    meta = np.zeros(len(data), dtype=np.int16) - 1
    names = sorted(spans)
    for k, region in enumerate(names):
        for a, b in spans[region]:
            meta[a:b] = k
    trials = []
    candidates = []
    for page in range(0, len(data), 4096):
        owners = meta[page:page + 4096]
        owners = owners[owners >= 0]
        if owners.size:
            candidates.append((page, names[int(np.bincount(owners).argmax())]))
    for page, region in (candidates if pages is None else rng.sample(candidates, min(pages, len(candidates)))):
        trials.append({"kind": "zeroed 4 KB page", "region": region, "offset": page, "length": 4096})
    for region in names:
        for _ in range(runs_per_region):
            a, b = rng.choice(spans[region])
            trials.append({"kind": "zeroed 16-byte run", "region": region, "offset": rng.randrange(a, max(a + 1, b)),
                           "length": 16})
    for at in gcol_headers(data):
        trials.append({"kind": "zeroed 16-byte run", "region": "global heap (string attributes)", "offset": at,
                       "length": 16})
    return trials


WORKER = """
import contextlib, io, json, resource, sys, time
sys.path.insert(0, {tests!r})
import numpy as np
import explorer
from explorer.testing import store_guard as guard
from explorer.cli import main
from explorer.errors import UserError
guard.STALL_CPU_S = {stall!r}
good, bad, trials = {good!r}, {bad!r}, json.load(open({trials!r}))

def cpu():
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime

def consume(path):
    try:
        with explorer.open_results(path) as r:
            out = [r.frame(), r.path([0, 3, 5]), r.velocity(2)]
    except UserError as exc:
        assert "\\n" not in str(exc)
        return ("refused", str(exc)), None
    for argv in (["rank", path], ["show", path, "--variant", "3"]):
        o, e = io.StringIO(), io.StringIO()
        with contextlib.redirect_stdout(o), contextlib.redirect_stderr(e):
            code = main([str(a) for a in argv])
        if code != 0:
            assert code == 2 and e.getvalue().count("\\n") == 1, (argv, code, e.getvalue())
            return ("refused", e.getvalue().strip()), None
        out.append(o.getvalue().replace(str(path), "R"))
    return ("read", None), out

_, ref = consume(good)
print(json.dumps({{"ready": True}}), flush=True)
data = open(good, "rb").read()
for t in trials:
    d = bytearray(data)
    d[t["offset"]:t["offset"] + t["length"]] = bytes(min(t["length"], len(d) - t["offset"]))
    open(bad, "wb").write(bytes(d))
    print(json.dumps({{"start": t}}), flush=True)
    t0 = cpu()
    try:
        (what, msg), out = consume(bad)
    except Exception as exc:
        print(json.dumps({{"trial": t, "outcome": "traceback", "detail": repr(exc)[:300], "cpu": cpu() - t0}}), flush=True)
        continue
    if what == "refused":
        outcome = ("refused: HDF5 loop stopped" if "made HDF5 loop" in msg else
                   "refused: HDF5 crash contained" if "crashed HDF5" in msg else "refused cleanly")
    else:
        same = (out[0].equals(ref[0]) and list(out[0].columns) == list(ref[0].columns)
                and all(np.array_equal(a, b, equal_nan=True) for a, b in zip(out[1:3], ref[1:3])) and out[3:] == ref[3:])
        outcome = "read correct" if same else "wrong numbers"
    print(json.dumps({{"trial": t, "outcome": outcome, "detail": (msg or "")[:200], "cpu": cpu() - t0}}), flush=True)
"""


def run_fuzz(path: Path, tmp: Path, trials: list[dict], stall: float = 1.0, per_trial_cpu: float = 30.0) -> list[dict]:
    """Every trial in one subprocess under a CPU limit (the trials' budget): a trial that hangs exhausts it and
    is reported as a hang instead of blocking the suite."""
    (tmp / "trials.json").write_text(json.dumps(trials), encoding="utf-8")
    code = WORKER.format(tests=str(TESTS), stall=stall, good=str(path), bad=str(tmp / "damaged.h5"),
                         trials=str(tmp / "trials.json"))
    budget = int(60 + per_trial_cpu * len(trials))
    p = python(code, cpu_s=budget, timeout=4 * budget)
    results, started = [], None
    for line in p.stdout.splitlines():
        if line.startswith("{"):
            row = json.loads(line)
            if "start" in row:
                started = row["start"]
            elif "trial" in row:
                results.append(row)
                started = None
    if started is not None or p.returncode != 0:
        results.append({"trial": started, "outcome": "hang" if p.returncode in (-signal.SIGXCPU, -signal.SIGKILL)
                        else f"worker died ({p.returncode}): {p.stderr[-300:]}", "cpu": None})
    return results


def summary(results: list[dict]) -> dict:
    """{(kind, region): {outcome: count}}."""
    out: dict = {}
    for r in results:
        t = r["trial"] or {"kind": "?", "region": "?"}
        cell = out.setdefault(f"{t['kind']} / {t['region']}", {})
        cell[r["outcome"]] = cell.get(r["outcome"], 0) + 1
    return out


def _check_fuzz(results: list[dict], n: int) -> None:
    table = summary(results)
    print(json.dumps(table, indent=1))
    bad = [r for r in results if r["outcome"] not in ("refused cleanly", "refused: HDF5 loop stopped",
                                                       "refused: HDF5 crash contained", "read correct")]
    assert not bad, bad[:5]
    assert len(results) == n
    slow = [r for r in results if r["cpu"] is not None and r["cpu"] > 30]
    assert not slow, slow[:3]


def test_quick_fuzz_of_pages_and_runs(small, tmp_path):
    """A sample for the quick loop: the heap's object header, two zeroed pages, one 16-byte run in three
    regions."""
    trials = fuzz_trials(small, pages=2, runs_per_region=1, seed=43)
    regions = sorted({t["region"] for t in trials})
    keep = [t for t in trials if t["kind"] == "zeroed 4 KB page"]
    keep += [t for t in trials if t["kind"] == "zeroed 16-byte run" and t["region"] in regions[:3]]
    keep.append(next(t for t in reversed(trials) if t["region"].startswith("global heap")))
    results = run_fuzz(small, tmp_path, keep)
    _check_fuzz(results, len(keep))
    assert any(r["outcome"] == "refused: HDF5 loop stopped" for r in results)


@pytest.mark.slow
def test_fuzz_every_metadata_page_and_runs_in_every_region(small, tmp_path):
    """Every 4 KB page that holds metadata, zeroed, and ``EXPLORER_FUZZ_RUNS`` (default 6) zeroed 16-byte
    runs in every metadata region: refused in one line (a loop or crash of HDF5 contained) or read exactly
    as the undamaged file, never a wrong number, never a hang (each trial's CPU is bounded)."""
    runs = int(os.environ.get("EXPLORER_FUZZ_RUNS", "6"))
    trials = fuzz_trials(small, pages=None, runs_per_region=runs, seed=4343)
    results = run_fuzz(small, tmp_path, trials)
    _check_fuzz(results, len(trials))


# -- explorer metrics: a copy renamed over the file, space reserved first -------------------------------------
def _mount_tmpfs(folder: Path, size: str):
    folder.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)], capture_output=True,
                          text=True)
    if done.returncode != 0:
        why = done.stderr.strip() or "mount failed"
        pytest.skip(f"NOT RUN: cannot mount a small tmpfs in this sandbox ({why}); the full-disk test of "
                    f"`explorer metrics` needs one (root, or a user namespace)")


def _fill(folder: Path, leave: int) -> Path:
    """Another writer (a separate process) fills the disk of ``folder`` but ``leave`` bytes."""
    filler = folder / "filler"
    code = (f"import os\nst = os.statvfs({str(folder)!r})\nfree = st.f_bavail * st.f_frsize\n"
            f"with open({str(filler)!r}, 'wb') as fh:\n    fh.write(bytes(max(0, free - {leave})))\n")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)
    return filler


FULL = {"study": {"name": "full", "mechanism": "jansen", "variants": 2000, "steps": 24, "seed": 1},
        "perturb": {"spread": 0.01}, "scene": {"metrics": ["stride"], "vertices": ["7"]}}


#: Makes the child that writes the copy die of SIGSEGV as soon as an error reaches it (as HDF5 can when a
#: write fails on a full disk), instead of sending the error to the caller.
CRASH_ON_ERROR = ("import os, pickle, signal\nfrom explorer.testing import store_guard as g\nclass P:\n"
                  "    loads = staticmethod(pickle.loads)\n    @staticmethod\n    def dumps(out):\n"
                  "        if out[0] == 'exc':\n            os.kill(os.getpid(), signal.SIGSEGV)\n"
                  "        return pickle.dumps(out)\ng.pickle = P\n")


@pytest.mark.parametrize("mode", ["reserve", pytest.param("none", marks=pytest.mark.slow),
                                  pytest.param("crash", marks=pytest.mark.slow)])
def test_metrics_on_a_full_disk_leaves_the_file_as_it_was(tmp_path, mode):
    """On a real 8 MB tmpfs filled by another writer: with the space reservation (``fallocate``) the
    update is refused before anything is written; without it (a filesystem that has none: made to fail,
    the free-space check fooled) the copy fills the disk and HDF5's write fails, and the process writing
    the copy may even crash ("crash": made to die of SIGSEGV there). Every time: exit 2, one line saying
    the disk is full and what to do, no crash of the command, no hidden copy left, and the file byte for
    byte as it was."""
    disk = tmp_path / "disk"
    _mount_tmpfs(disk, "8m")
    try:
        out = explorer.run_study(FULL, output=disk / "full.h5", progress=False).path
        before = out.read_bytes()
        size = len(before)
        _fill(disk, size + (200_000 if mode != "reserve" else 100_000))
        prelude = "" if mode == "reserve" else (
            "import errno, shutil, collections\nfrom explorer.testing import store_write as w\n"
            "w._fallocate = lambda *a, **k: errno.ENOTSUP\n"
            "U = collections.namedtuple('U', 'total used free')\nshutil.disk_usage = lambda p: U(1 << 40, 0, 1 << 40)\n")
        prelude += CRASH_ON_ERROR if mode == "crash" else ""
        p = python(f"import sys\n{prelude}from explorer.cli import main\n"
                   f"sys.exit(main(['metrics', {str(out)!r}, '--metrics', 'all', '-q']))", cpu_s=120)
        assert p.returncode == 2, (p.returncode, p.stderr[-800:])
        assert p.stderr.count("\n") == 1 and "disk is full" in p.stderr and "unchanged" in p.stderr, p.stderr
        assert "Exception ignored" not in p.stderr and "--resume" not in p.stderr
        assert out.read_bytes() == before
        assert not list(disk.glob(".*partial")) and not list(disk.glob(".*lock"))
        (disk / "filler").unlink()  # room again: the same command works, and only the metrics changed
        assert main(["metrics", str(out), "--metrics", "all", "-q"]) == 0
        with explorer.open_results(out) as r:
            assert len(r.metric_names) > 5 and r.complete
            with h5py.File(disk / "ref.h5", "w") as f:
                f["p"] = r.path(slice(None))
        with h5py.File(disk / "ref.h5", "r") as f, explorer.store.open_results(out) as r:
            np.testing.assert_array_equal(f["p"][...], r.path(slice(None)))
    finally:
        subprocess.run(["umount", str(disk)], capture_output=True)


def test_a_writer_that_crashes_with_room_on_the_disk_is_not_called_a_full_disk(small, tmp_path):
    path = tmp_path / "m.h5"
    shutil.copy(small, path)
    before = path.read_bytes()
    prelude = CRASH_ON_ERROR + ("import explorer.gait as m\n"
                                "def boom(*a, **k):\n    raise OSError(5, 'Input/output error')\n"
                                "m.compute_metrics = boom\n")
    p = python(f"import sys\n{prelude}from explorer.cli import main\n"
               f"sys.exit(main(['metrics', {str(path)!r}, '--band', '0.02', '-q']))", cpu_s=120)
    assert p.returncode == 2, (p.returncode, p.stderr[-800:])
    assert p.stderr.count("\n") == 1 and "stopped (SIGSEGV)" in p.stderr and "unchanged" in p.stderr, p.stderr
    assert "disk is full" not in p.stderr
    assert path.read_bytes() == before and not list(tmp_path.glob(".*partial"))


def test_metrics_writes_a_copy_and_renames_it(small, tmp_path, monkeypatch):
    """A failure after the copy was written (here: the rename) leaves the file as it was; the update itself
    replaces the file by a new one (a new inode), never writes into it."""
    path = tmp_path / "m.h5"
    shutil.copy(small, path)
    before, ino = path.read_bytes(), path.stat().st_ino
    from explorer.testing import store_write as w

    def broken(tmp, p):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(w, "replace_with", broken)
    from explorer.testing import analysis_metrics as m
    monkeypatch.setattr(m, "replace_with", broken)
    with pytest.raises(UserError, match="the disk is full .* is unchanged"):
        explorer.recompute_metrics(path, band=0.02)
    assert path.read_bytes() == before and not list(tmp_path.glob(".*partial"))
    monkeypatch.undo()
    explorer.recompute_metrics(path, band=0.02)
    assert path.stat().st_ino != ino
    with explorer.open_results(path) as r:
        assert r.band == 0.02


def _stitched(folder: Path) -> tuple[Path, Path]:
    from explorer.store import plan_shards, shards_folder, stitch, write_shard
    from explorer.study import load_study
    from explorer.testing import chunk_solver
    study = load_study({**SMALL, "study": {**SMALL["study"], "variants": 40}})
    out = folder / "stitched.h5"
    plan = plan_shards(study, workers=2, shard_size=16, chunk_size=16)
    shards = shards_folder(out)
    plan.write(shards)
    for i in range(plan.n_shards):
        write_shard(shards, plan, i, study, chunk_solver(study))
    stitch(out, shards, plan)
    return out, shards


@pytest.mark.parametrize("damage", ["row", pytest.param("metadata", marks=pytest.mark.slow)])
def test_metrics_verifies_a_stitched_file_and_its_shards_before_writing(tmp_path, damage):
    """A Dask-stitched file whose shard is damaged (a committed row, or a metadata byte): ``explorer
    metrics`` refuses it in one line before it computes or writes anything (it used to write metrics, or
    print ten lines of h5py's "Exception ignored"), and the study file is unchanged."""
    out, shards = _stitched(tmp_path)
    shard = shards / "shard-00001.h5"
    data = bytearray(shard.read_bytes())
    if damage == "row":
        with h5py.File(shard, "r") as f:
            info = f["variants/lengths"].id.get_chunk_info(0)
        data[info.byte_offset + 8] ^= 0x40
    else:
        at = data.find(b"OHDR", 2048)
        data[at + 40] ^= 0xFF
    shard.write_bytes(bytes(data))
    before = out.read_bytes()
    p = python(f"import sys\nfrom explorer.cli import main\nsys.exit(main(['metrics', {str(out)!r}, '--band', '0.02']))",
               cpu_s=120)
    assert p.returncode == 2, (p.returncode, p.stderr[-800:])
    assert p.stderr.count("\n") == 1 and "shard" in p.stderr and "Exception ignored" not in p.stderr, p.stderr
    assert out.read_bytes() == before and not list(tmp_path.glob(".*partial"))


# -- signals from the first instruction ---------------------------------------------------------------------------
def _handler_installed(pid: int) -> bool:
    """Whether ``pid`` catches SIGTERM (explorer's first instruction installs the command's handler; Python
    itself catches only SIGINT)."""
    try:
        with open(f"/proc/{pid}/status", encoding="ascii") as fh:
            fields = dict(line.split(":", 1) for line in fh if ":" in line)
    except OSError:
        return True
    return bool(int(fields.get("SigCgt", "0").strip(), 16) >> (signal.SIGTERM - 1) & 1)


def signal_at_random(study: Path, out: Path, trials: int, seed: int, extra: list | None = None) -> list[dict]:
    """Start ``explorer run`` and send SIGINT or SIGTERM at a random delay from 0 to 0.5 s; what came back."""
    rng = random.Random(seed)
    rows = []
    for _ in range(trials):
        sig = rng.choice([signal.SIGINT, signal.SIGTERM])
        delay = rng.uniform(0.0, 0.5)
        out.unlink(missing_ok=True)
        proc = subprocess.Popen([sys.executable, "-m", "explorer.cli", "run", str(study), "-o", str(out), "-q",
                                 *(extra or [])], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            time.sleep(delay)
            installed = _handler_installed(proc.pid)
            t0 = time.monotonic()
            proc.send_signal(sig)
            _, err = proc.communicate(timeout=120)
            rows.append({"sig": sig, "delay": delay, "installed": installed, "rc": proc.returncode, "err": err,
                         "latency": time.monotonic() - t0})
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    return rows


def _check_signals(rows: list[dict], folder: Path) -> None:
    for r in rows:
        code = 143 if r["sig"] == signal.SIGTERM else 130
        if r["installed"] or r["rc"] in (130, 143, 0):
            # explorer's handler had it: one line (or the run was already done: exit 0, nothing said)
            assert "Traceback" not in r["err"], r
            if r["rc"] != 0:
                assert r["rc"] == code and r["err"].count("\n") == 1 and r["err"].startswith("explorer: "), r
        else:
            # before explorer's first instruction (the interpreter starting): Python's own answer, which no
            # code of explorer ran to give; never from inside explorer
            assert r["rc"] in (-signal.SIGTERM, -signal.SIGINT, 1), r
            assert "explorer/" not in r["err"].replace("explorer/__init__.py", ""), r
    assert not list(folder.glob(".*lock")) and not list(folder.glob(".*partial"))


def test_signals_at_random_moments_of_the_start_up(tmp_path):
    from explorer.testing import dumps_toml
    study = tmp_path / "s.toml"
    study.write_text(dumps_toml({**SMALL, "study": {**SMALL["study"], "variants": 20000}}), encoding="utf-8")
    rows = signal_at_random(study, tmp_path / "o.h5", trials=6, seed=43)
    _check_signals(rows, tmp_path)


@pytest.mark.slow
def test_signals_at_random_moments_many(tmp_path):
    """40 runs, each signalled at a random moment of its first half second (the interpreter starting,
    explorer's imports, Numba's, the study loading): never a traceback from explorer; and what the
    handler caught ends within a second or so (the latency printed; a loaded machine adds its own)."""
    from explorer.testing import dumps_toml
    study = tmp_path / "s.toml"
    study.write_text(dumps_toml({**SMALL, "study": {**SMALL["study"], "variants": 20000}}), encoding="utf-8")
    rows = signal_at_random(study, tmp_path / "o.h5", trials=40, seed=4343)
    _check_signals(rows, tmp_path)
    caught = [r["latency"] for r in rows if r["installed"]]
    print(f"{len(caught)} of {len(rows)} caught by explorer's handler; latency max {max(caught):.2f} s, "
          f"median {sorted(caught)[len(caught) // 2]:.2f} s")
    assert max(caught) < 5.0


@pytest.mark.slow
def test_a_signal_during_a_cold_compile_acts_at_once(tmp_path):
    """A fresh Numba cache: the run compiles its kernels (tens of seconds on 2 cores) in worker threads
    that no signal can stop; SIGTERM or SIGINT during it ends the command at once (it used to wait for the
    compile to finish: 10-24 s)."""
    from explorer.testing import dumps_toml
    study = tmp_path / "s.toml"
    study.write_text(dumps_toml(SMALL), encoding="utf-8")
    rng = random.Random(7)
    latencies = []
    for sig in (signal.SIGTERM, signal.SIGINT):
        cache = tmp_path / f"cache-{sig}"
        proc = subprocess.Popen([sys.executable, "-m", "explorer.cli", "run", str(study), "-o", str(tmp_path / "o.h5"),
                                 "-q", "--force"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                env={**os.environ, "NUMBA_CACHE_DIR": str(cache)})
        try:
            time.sleep(rng.uniform(3.0, 6.0))
            t0 = time.monotonic()
            proc.send_signal(sig)
            _, err = proc.communicate(timeout=120)
            latencies.append(time.monotonic() - t0)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        if proc.returncode == 0:
            continue  # compiled and ran before the signal (a fast machine)
        assert proc.returncode == (143 if sig == signal.SIGTERM else 130) and err.count("\n") == 1, err
        assert "Traceback" not in err
    print("latencies", latencies)
    assert max(latencies) < 5.0


def test_the_first_instruction_catches_signals_and_metadata_is_imported_late():
    code = ("import sys, signal\nsys.argv = ['explorer']\nimport explorer\n"
            "print(signal.getsignal(signal.SIGTERM) is explorer._early._hold, 'importlib.metadata' in sys.modules)")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert p.stdout.split() == ["True", "False"], p.stderr
    assert explorer.__version__  # still there, on first use


# -- inputs --------------------------------------------------------------------------------------------------------
def _jansen_text() -> str:
    from importlib import resources
    return (resources.files("explorer.mechanism") / "builtin" / "jansen.toml").read_text(encoding="utf-8")


@pytest.mark.parametrize("key,text", [
    ("links[0].mass", ("length = 50.0", "length = 50.0\nmass = 0")),
    ("crank.mass", ("[crank]", "[crank]\nmass = 0.0")),
    ("mass.link_density", (None, "\n[mass]\nlink_density = 0\n")),
])
def test_zero_masses_are_refused_as_documented(tmp_path, capsys, key, text):
    base = _jansen_text()
    old, new = text
    body = base.replace(old, new, 1) if old else base + new
    assert body != base
    leg = tmp_path / "leg.toml"
    leg.write_text(body, encoding="utf-8")
    with pytest.raises(UserError, match=f"leg.toml: {re.escape(key)}: expected .* > 0") as info:
        explorer.load_mechanism(leg)
    assert "\n" not in str(info.value)


def test_a_zero_body_mass_or_inertia_is_refused():
    from explorer.mechanism import mechanism_from_dict
    d = {"name": "b", "foot": "c", "crank": {"center": [0, 0], "radius": 1, "tip": "t"},
         "fixed": {"g": [4, 0]}, "guess": {"m": [4.5, 2.9], "c": [5, 4]},
         "links": [{"a": "t", "b": "m", "length": 4}, {"a": "g", "b": "m", "length": 3}, {"a": "g", "b": "c", "length": 4.1}],
         "bodies": [{"name": "k", "joints": {"m": [0.0, 0.0], "c": [1.5, 0.0]}, "mass": 1.0, "inertia": 0.0}]}
    with pytest.raises(UserError, match=r"bodies.*inertia: expected .* > 0"):
        mechanism_from_dict(d, "b.toml")
    d["bodies"][0].update(mass=0, inertia=0.01)
    with pytest.raises(UserError, match=r"bodies.*mass: expected .* > 0"):
        mechanism_from_dict(d, "b.toml")


def test_a_byte_order_mark_is_accepted(tmp_path, capsys):
    """What Windows editors write at the start of a UTF-8 file: the mechanism and the study load, and run."""
    from explorer.testing import dumps_toml
    leg = tmp_path / "leg.toml"
    leg.write_bytes(b"\xef\xbb\xbf" + _jansen_text().encode("utf-8"))
    assert explorer.load_mechanism(leg).lengths.tolist() == explorer.load_mechanism("jansen").lengths.tolist()
    study = tmp_path / "s.toml"
    text = dumps_toml({**SMALL, "study": {**SMALL["study"], "mechanism": "leg.toml"}})
    study.write_bytes(b"\xef\xbb\xbf" + text.encode("utf-8"))
    code, _, err = cli(capsys, "run", study, "-o", tmp_path / "o.h5", "-q")
    assert code == 0, err
    assert main(["metrics", str(tmp_path / "o.h5"), "--band", "0.02", "-q"]) == 0  # the stored text has it too
    with explorer.open_results(tmp_path / "o.h5") as r:
        assert r.mechanism.lengths.tolist() == explorer.load_mechanism("jansen").lengths.tolist()


def test_study_names_are_bounded(tmp_path, capsys):
    from explorer.testing import dumps_toml
    for name, ok in (("a" * 100, True), ("a" * 101, False), ("x" * 2_000_000, False), ("ok\n", False)):
        study = tmp_path / "s.toml"
        study.write_text(dumps_toml({**SMALL, "study": {**SMALL["study"], "name": name}}), encoding="utf-8")
        if ok:
            explorer.load_study(study)
            continue
        code, _, err = cli(capsys, "run", study, "-o", tmp_path / "o.h5")
        assert code == 2 and err.count("\n") == 1 and "study.name: expected 1 to 100" in err and len(err) < 400, err[:300]
    assert not (tmp_path / "o.h5").exists()


def test_yield_tolerances_are_bounded(small, capsys):
    for tol, words in (("1e9", "at most 32.85 model units"), ("1e300", "at most"), ("60%", "at most 50%"),
                       ("inf", "expected a tolerance > 0"), ("0", "expected a tolerance > 0")):
        code, _, err = cli(capsys, "rank", small, "--yield", tol)
        assert code == 2 and err.count("\n") == 1 and words in err, (tol, err)
    with pytest.raises(UserError, match=r"robustness.tolerance: expected at most"):
        explorer.load_study({**SMALL, "robustness": {"tolerance": 100.0, "unit": "model"}})


@pytest.mark.parametrize("argv", [["rank", "R", "--top"],
                                  ["export", "R", "--variant", "0", "--as", "kit", "--crank-mm", "x"],
                                  ["frobnicate"], ["run", "--nope"], ["bench", "nope"], ["show"]])
def test_every_argparse_error_is_one_line(small, argv, capsys):
    argv = [str(small) if a == "R" else a for a in argv]
    with pytest.raises(SystemExit) as info:
        main(argv)
    err = capsys.readouterr().err
    assert info.value.code == 2 and err.count("\n") == 1 and ": error: " in err, err
    assert "--help" in err and "usage:" not in err


@pytest.mark.parametrize("sheet", ["1e9x1e9", "600x5001"])
def test_kit_sheets_are_bounded(tmp_path, capsys, sheet):
    """A 10^9 mm sheet was accepted (and drawn): at most 5 m a side, one line, nothing written."""
    code, _, err = cli(capsys, "export", "jansen", "--as", "kit", "-o", tmp_path / "k", "--sheet", sheet)
    assert code == 2 and err.count("\n") == 1 and "--sheet: " in err and "at most 5000" in err, err
    assert not (tmp_path / "k").exists()


# -- big mechanisms in the study path ----------------------------------------------------------------------------
def test_the_parameter_table_is_built_once_per_mechanism(monkeypatch):
    """A study of a 2,001-vertex chain asks for parameter kinds per parameter, for the disk estimate, the
    sampler and the chunk solver: the table is built once (it was built per call: quadratic)."""
    sys.path.insert(0, str(TESTS.parent / "benchmarks"))
    from bench_size import chain_dict

    from explorer.mechanism import Mechanism, mechanism_from_dict
    from explorer.study import load_study
    study = load_study({"study": {"name": "c", "mechanism": "jansen", "variants": 4, "steps": 12}})
    calls = []
    real = Mechanism._parameter_items
    monkeypatch.setattr(Mechanism, "_parameter_items", lambda self: calls.append(1) or real(self))
    mech = mechanism_from_dict(chain_dict(2001), "chain.toml")
    object.__setattr__(study, "_mech", mech)
    names = study.parameter_names
    assert len(names) == len(mech.links) + 1
    for _ in range(3):
        study.geometry_names
        [mech.parameter_kind(n) for n in names]
    assert len(calls) <= 1
    # the table answers as a scan of the mechanism would
    assert list(mech.parameters()) == [lk.name for lk in mech.links] + ["crank", "crank.x", "crank.y"] + \
        [f"{v}.{a}" for v in mech.fixed for a in "xy"]
    assert all(mech.parameter_kind(lk.name) == "length" for lk in mech.links)
    assert mech.parameter_kind("g7.y") == "coordinate" and mech.parameter_kind("crank") == "length"
    assert mech.link_index(mech.links[-1].name) == len(mech.links) - 1


def test_the_sampler_draws_only_the_rows_a_chunk_needs_and_the_same_numbers():
    """Rows of a block drawn alone (the uniform generator advanced, the normal one drawn up to them) equal
    the block drawn whole, as the documented draws define them (written out here)."""
    from explorer.testing import BLOCK, Sampler
    k = 7
    for method in ("uniform", "normal"):
        s = Sampler(method, 3 * BLOCK, k, 0.05, seed=11)
        for a, b in ((1, 9), (BLOCK - 3, BLOCK + 5), (2 * BLOCK + 10, 2 * BLOCK + 12)):
            got = s.rows(a, b)
            for i, row in zip(range(a, b), got):
                blk, r = divmod(i - 1, BLOCK)
                rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence(11, spawn_key=(blk,))))
                whole = rng.uniform(-1.0, 1.0, (BLOCK, k)) if method == "uniform" else rng.standard_normal((BLOCK, k))
                np.testing.assert_array_equal(row, 1.0 + 0.05 * whole[r])


@pytest.mark.slow
def test_a_study_of_a_9999_vertex_chain_runs_and_reads(tmp_path, capsys):
    """10 variants x 36 steps of a 9,999-vertex chain: the run writes its file (link names, nominal lengths
    and the mechanism's 700 kB text in dense attribute storage: version-1 object headers refused them),
    the file verifies and reads, describe and show work. Times: benchmarks/bench_size.py --study."""
    sys.path.insert(0, str(TESTS.parent / "benchmarks"))
    from bench_size import chain_dict, to_toml
    mech = tmp_path / "chain.toml"
    mech.write_text(to_toml(chain_dict(9999)), encoding="utf-8")
    study = tmp_path / "s.toml"
    study.write_text('[study]\nname = "chain"\nmechanism = "chain.toml"\nvariants = 10\nsteps = 36\n'
                     '[scene]\nmetrics = ["stride", "height"]\n', encoding="utf-8")
    code, _, err = cli(capsys, "run", study, "-o", tmp_path / "c.h5", "-q")
    assert code == 0, err
    with explorer.open_results(tmp_path / "c.h5") as r:
        counts = r.status_counts()  # ±2 % on 9,998 links: most variants of so long a chain cannot assemble
        assert len(r.link_names) == 9998 and sum(counts.values()) == 10 and counts.get("not-run", 0) == 0
        assert r.frame().loc[0, "status"] == "ok" and len(r.nominal) == 9999
    assert cli(capsys, "describe", mech)[0] == 0
    assert cli(capsys, "show", tmp_path / "c.h5", "--variant", "3")[0] == 0
