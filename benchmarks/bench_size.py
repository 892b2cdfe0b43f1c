"""How plan and solve cost grow with a mechanism's size (issue 31 item 6).

Two families of mechanisms of n vertices, written as mechanism TOML and loaded like a user's file:

* ``chain`` — a crank-rocker four-bar followed by a chain of parallelogram stages: stage k adds a
  ground pivot g<k> and a moving vertex m<k> linked to the previous moving vertex and to g<k>. The
  plan splits it into one DYAD block per moving vertex (n ≈ 2 × stages + 1 vertices).
* ``ring`` — m moving vertices on a ring, each linked to its two ring neighbours and to a ground
  pivot, except one linked to the crank tip instead: one coupled (GENERAL) block of m vertices, the
  worst case of a coupled Assur group (n = 2 m + 1 vertices with the crank tip).

For each size a fresh subprocess (address space capped with ``RLIMIT_AS``, wall time with a
timeout) times and measures the peak resident memory after each stage: loading the TOML, planning,
the first ``simulate(mech, steps=36)`` (which compiles the kernel generated for the topology when
one is used) and ``simulate_batch`` of 10 designs (36 steps, the foot). Numba's cache is a fresh
folder per benchmark run, warmed by a small chain first, so each size compiles only its own
generated kernel, as a user's first run of a new mechanism does.

    python benchmarks/bench_size.py                      # chain and ring, n = 10 … 1000
    python benchmarks/bench_size.py --family chain --sizes 10 100 1000 --limit-gb 4 --timeout 60

``--study`` times the study path instead (issue 43): for each chain size, a study of 10 variants × 36
steps (``[scene] metrics = ["stride", "height"]``) through the command line, each step a fresh process
whose CPU-seconds (its own and its children's) and wall time are reported: ``explorer run``, ``explorer
describe`` of the mechanism, ``explorer show`` of a variant and ``open_results(...).frame()``. The
parameter table used to be rebuilt per parameter (2,999 vertices: ~30 CPU-s in ``run``), the four-bar
loops and describe's tables scanned every link per joint (9,999: ~140 CPU-s in ``describe``), and a
9,999-vertex file could not be written ("object header message is too large").

    python benchmarks/bench_size.py --study --sizes 2999 9999
    python benchmarks/bench_size.py --study --sizes 2999 --code /path/to/older/checkout   # the same, another version
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time

#: Crank-rocker four-bar of the chain's first stage: crank 1 about (0, 0), coupler 4, rocker 3 about
#: g1 = (4, 0); every later stage is a parallelogram: pivot STEP further along x, links STEP and 3.
CRANK, COUPLER, ROCKER, STEP = 1.0, 4.0, 3.0, 4.0


def chain_dict(n: int) -> dict:
    """A mechanism table (the TOML shape) of a chain of dyads with about ``n`` vertices: the crank
    tip t, then stages k = 1 … (n − 1) // 2 of a ground pivot g<k> and a moving vertex m<k> placed
    by links to the previous moving vertex (t for m1) and to g<k>. The foot is the last m."""
    stages = max(1, (n - 1) // 2)
    fixed, guess, links = {}, {}, []
    prev = "t"
    for k in range(1, stages + 1):
        gx = COUPLER + (k - 1) * STEP
        fixed[f"g{k}"] = [gx, 0.0]
        # the knee-up assembly: m<k> above its pivot (the rocker swings between about 40° and 110°)
        guess[f"m{k}"] = [gx + 0.5, 2.9]
        links.append({"a": prev, "b": f"m{k}", "length": COUPLER if k == 1 else STEP})
        links.append({"a": f"g{k}", "b": f"m{k}", "length": ROCKER})
        prev = f"m{k}"
    return {"name": f"chain{n}", "description": f"a chain of {stages} dyads", "foot": prev,
            "crank": {"center": [0.0, 0.0], "radius": CRANK, "tip": "t"}, "fixed": fixed, "guess": guess,
            "links": links}


def ring_dict(n: int) -> dict:
    """A mechanism table of one coupled block: m = (n − 1) // 2 moving vertices r<k> on a circle of
    radius R, each linked to its ring neighbours; r0 is linked to the crank tip (a small crank
    outside it), every other r<k> to a ground pivot p<k> outward of it. Lengths are the distances at
    θ = 0, so the guess is the exact assembly."""
    m = max(3, (n - 1) // 2)
    R, spoke, crank = m / math.pi, 1.0, 0.1  # ring links of about 2
    pts = {f"r{k}": (R * math.cos(2 * math.pi * k / m), R * math.sin(2 * math.pi * k / m)) for k in range(m)}
    # each spoke at 60° to its radius, all leaning the same way (radial spokes would let the ring turn)
    fixed = {}
    for k in range(1, m):
        x, y = pts[f"r{k}"]
        a = 2 * math.pi * k / m + math.pi / 3
        fixed[f"p{k}"] = [x + spoke * math.cos(a), y + spoke * math.sin(a)]
    # the crank tip at θ = 0 (centre + crank·(1, 0)) where p0 would be
    tip = (R + spoke * math.cos(math.pi / 3), spoke * math.sin(math.pi / 3))
    centre = (tip[0] - crank, tip[1])
    links = []
    for k in range(m):
        a, b = f"r{k}", f"r{(k + 1) % m}"
        links.append({"a": a, "b": b, "length": math.dist(pts[a], pts[b])})
    links.append({"a": "t", "b": "r0", "length": math.dist(tip, pts["r0"])})
    for k in range(1, m):
        links.append({"a": f"p{k}", "b": f"r{k}", "length": math.dist(fixed[f"p{k}"], pts[f"r{k}"])})
    return {"name": f"ring{n}", "description": f"one coupled block of {m} vertices", "foot": f"r{m // 2}",
            "crank": {"center": list(centre), "radius": crank, "tip": "t"}, "fixed": fixed,
            "guess": {k: list(v) for k, v in pts.items()}, "links": links}


FAMILIES = {"chain": chain_dict, "ring": ring_dict}


def to_toml(table: dict) -> str:
    """The mechanism table as TOML text (only the shapes these generators make)."""
    def value(v):
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(float(v))

    out = [f"{k} = {value(table[k])}" for k in ("name", "description", "foot")]
    for section in ("crank", "fixed", "guess"):
        out.append(f"\n[{section}]")
        out += [f"{json.dumps(k)} = {value(v)}" for k, v in table[section].items()]
    for link in table["links"]:
        out.append("\n[[links]]")
        out += [f"{k} = {value(v)}" for k, v in link.items()]
    return "\n".join(out) + "\n"


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def measure(family: str, n: int, kernel: str = "auto") -> None:
    """Time and peak RSS of each stage for one size, printed as JSON lines (run in a subprocess)."""
    def report(stage, t0, **extra):
        print(json.dumps({"stage": stage, "s": time.perf_counter() - t0, "rss_mb": _peak_mb(), **extra}), flush=True)

    t = time.perf_counter()
    import numpy as np

    import explorer
    from explorer.kernels import plan_for
    from explorer.mechanism import load_mechanism
    report("import", t, code=os.path.dirname(os.path.dirname(explorer.__file__)))
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, f"{family}{n}.toml")
        with open(path, "w", encoding="utf-8") as f:
            f.write(to_toml(FAMILIES[family](n)))
        t = time.perf_counter()
        mech = load_mechanism(path)
        report("load", t, vertices=len(mech.vertices))
    t = time.perf_counter()
    plan = plan_for(mech)
    report("plan", t, blocks=plan.n_blocks, largest=max(len(b.vertices) for b in plan.blocks))
    t = time.perf_counter()
    cyc = explorer.simulate(mech, steps=36)
    report("simulate", t, ok=bool(cyc.ok))
    rng = np.random.default_rng(1)
    lengths = mech.lengths * (1 + rng.uniform(-1e-3, 1e-3, (10, len(mech.links))))
    t = time.perf_counter()
    b = explorer.simulate_batch(mech, lengths, steps=36, kernel=kernel)
    report("batch", t, ok=int(np.sum(b.status == 0)))
    t = time.perf_counter()
    explorer.simulate_batch(mech, lengths, steps=36, kernel=kernel)
    report("batch2", t)


STAGES = ("load", "plan", "simulate", "batch", "batch2")


def run_size(family: str, n: int, limit_gb: float, timeout: float, env: dict, kernel: str = "auto",
             code_dir: str | None = None) -> dict:
    """One size in a subprocess capped at ``limit_gb`` of address space and ``timeout`` seconds;
    ``code_dir``: a folder holding another ``explorer`` package to measure (an editable install's
    finder is taken out of the way)."""
    other = ""
    if code_dir:
        other = (f"sys.meta_path[:] = [f for f in sys.meta_path if '__editable__' not in getattr(f, '__module__', '')]; "
                 f"sys.path.insert(0, {os.path.abspath(code_dir)!r}); ")
    code = (f"import resource, sys; {other}sys.path.insert(0, {os.path.dirname(os.path.abspath(__file__))!r}); "
            f"lim = int({limit_gb} * 2**30); resource.setrlimit(resource.RLIMIT_AS, (lim, lim)); "
            f"import bench_size; bench_size.measure({family!r}, {n}, {kernel!r})")
    rows, why = {}, ""
    t0 = time.perf_counter()
    try:
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout, env=env)
        out, err, rc = proc.stdout, proc.stderr, proc.returncode
    except subprocess.TimeoutExpired as exc:
        out = exc.stdout.decode() if isinstance(exc.stdout, bytes) else (exc.stdout or "")
        err, rc, why = "", None, f"over {timeout:.0f} s"
    for line in out.splitlines():
        if line.startswith("{"):
            r = json.loads(line)
            rows[r["stage"]] = r
    if rc not in (0, None):
        last = (err.strip().splitlines() or ["?"])[-1]
        why = "out of memory" if "MemoryError" in err or "std::bad_alloc" in err else last[:80]
    return {"family": family, "n": n, "rows": rows, "why": why, "wall": time.perf_counter() - t0}


STUDY_STEPS = ("run", "describe", "show", "frame")


def _timed(cmd: list[str], timeout: float, env: dict, cwd: str) -> dict:
    """Run ``cmd`` in ``cwd``; its wall time, the CPU-seconds of it and its children, and how it ended."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env, cwd=cwd)
        why = "" if p.returncode == 0 else ((p.stderr.strip().splitlines() or ["?"])[-1][:90])
    except subprocess.TimeoutExpired:
        why = f"over {timeout:.0f} s"
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall": time.perf_counter() - t0, "cpu": cpu, "why": why}


def study_size(n: int, folder: str, timeout: float, env: dict, code_dir: str | None = None) -> dict:
    """Time the study path of a chain of ``n`` vertices (see the module docstring), one process per step."""
    mech = os.path.join(folder, f"chain{n}.toml")
    with open(mech, "w", encoding="utf-8") as f:
        f.write(to_toml(chain_dict(n)))
    study = os.path.join(folder, f"study{n}.toml")
    with open(study, "w", encoding="utf-8") as f:
        f.write(f'[study]\nname = "chain{n}"\nmechanism = "chain{n}.toml"\nvariants = 10\nsteps = 36\n'
                f'[scene]\nmetrics = ["stride", "height"]\n')
    out = os.path.join(folder, f"chain{n}.h5")
    prefix = [sys.executable, "-m", "explorer.cli"]
    env = dict(env)
    if code_dir:
        env["PYTHONPATH"] = os.path.abspath(code_dir)
    # in the temporary folder: `python -m` puts the working directory first on sys.path, where a checkout's
    # own explorer/ would shadow --code's
    rows = {"run": _timed(prefix + ["run", study, "-o", out, "-q", "--force"], timeout, env, folder)}
    rows["describe"] = _timed(prefix + ["describe", mech], timeout, env, folder)
    ok = not rows["run"]["why"]
    rows["show"] = _timed(prefix + ["show", out, "3"], timeout, env, folder) if ok else {"why": "no file"}
    frame = f"import explorer\nwith explorer.open_results({out!r}) as r:\n    r.frame()\n"
    rows["frame"] = _timed([sys.executable, "-c", frame], timeout, env, folder) if ok else {"why": "no file"}
    return rows


def main_study(args, env) -> None:
    import explorer  # the code measured (a --code checkout's, below, in each step's process)
    print(f"study path of a chain: 10 variants x 36 steps (CPU-s / wall s per step, one process each; "
          f"code: {args.code or os.path.dirname(os.path.dirname(explorer.__file__))})")
    print(f"load average: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    with tempfile.TemporaryDirectory(prefix="bench-size-study-") as folder:
        # the kernels compiled into Numba's cache, not timed: the metric kernels first (a run starts this
        # warm-up in the background when they are missing, and its CPU would count in the run's)
        warm_env = dict(env, **({"PYTHONPATH": os.path.abspath(args.code)} if args.code else {}))
        subprocess.run([sys.executable, "-m", "explorer.gait._warm"], env=warm_env, cwd=folder, check=False)
        study_size(41, folder, args.timeout, env, args.code)  # 20 blocks: the general kernel, as big chains use
        print(f"{'n':>6}" + "".join(f" {s:>18}" for s in STUDY_STEPS))
        for n in args.sizes:
            rows = study_size(n, folder, args.timeout, env, args.code)
            line = f"{n:>6}"
            notes = []
            for s in STUDY_STEPS:
                r = rows[s]
                line += f" {r['cpu']:8.2f} /{r['wall']:7.2f}" if "cpu" in r else f" {'-':>18}"  # (failed: noted)
                if r["why"]:
                    notes.append(f"{s}: {r['why']}")
            print(line + (f"  ({'; '.join(notes)})" if notes else ""), flush=True)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--family", choices=sorted(FAMILIES), nargs="*", default=["chain", "ring"])
    ap.add_argument("--sizes", type=int, nargs="*", default=[10, 30, 100, 300, 1000])
    ap.add_argument("--limit-gb", type=float, default=4.0, help="address space cap per size (default 4)")
    ap.add_argument("--timeout", type=float, default=120.0, help="wall time cap per size, s (default 120)")
    ap.add_argument("--kernel", default="auto", help="simulate_batch's kernel (auto, general, generated)")
    ap.add_argument("--warm-cache", action="store_true", help="use the usual Numba cache, not a fresh folder")
    ap.add_argument("--code", help="measure the explorer package in this folder (e.g. an older release's)")
    ap.add_argument("--study", action="store_true", help="time the study path (run, describe, show, frame) of chains "
                                                         "of --sizes vertices instead (default sizes 2999 9999)")
    args = ap.parse_args(argv)
    env = dict(os.environ)
    if args.study:
        if args.sizes == [10, 30, 100, 300, 1000]:
            args.sizes = [2999, 9999]
        if args.timeout == 120.0:
            args.timeout = 600.0
        main_study(args, env)
        return
    tmp = None
    if not args.warm_cache:
        tmp = tempfile.TemporaryDirectory(prefix="bench-size-")
        env["NUMBA_CACHE_DIR"] = tmp.name
        print("warming a fresh Numba cache with a 5-vertex chain ...", flush=True)
        run_size("chain", 5, args.limit_gb, 600, env, args.kernel, args.code)
    print(f"time s / peak RSS MB per stage (cap {args.limit_gb:g} GB, {args.timeout:g} s; kernel {args.kernel})")
    head = f"{'family':6} {'n':>5} {'blocks':>6} {'largest':>7}" + "".join(f" {s:>15}" for s in STAGES)
    print(head)
    for family in args.family:
        for n in args.sizes:
            r = run_size(family, n, args.limit_gb, args.timeout, env, args.kernel, args.code)
            plan = r["rows"].get("plan", {})
            line = f"{family:6} {r['rows'].get('load', {}).get('vertices', n):>5} {plan.get('blocks', '-'):>6} " \
                   f"{plan.get('largest', '-'):>7}"
            for s in STAGES:
                row = r["rows"].get(s)
                line += f" {row['s']:7.2f} {row['rss_mb']:6.0f}M" if row else f" {'-':>15}"
            print(line + (f"  stopped: {r['why']}" if r["why"] else ""), flush=True)
            if r["why"]:
                break  # larger sizes of this family would fail the same way
    if tmp is not None:
        tmp.cleanup()


if __name__ == "__main__":
    main()
