"""The literature's path-synthesis problems as studies (studies/literature/*.toml): success over seeds.

    python benchmarks/bench_literature.py [--problems all|vertical-line,timed-five,...] [--seeds 10]
                                          [--jobs 1] [--cores 2] [--seconds S]

Each problem is ONE study file, run as ``explorer optimize`` runs it (``run_optimize``: DE rounds and
their polish, atlas starts when a curve atlas of the four-bar is cached, the stopping rule), once per
seed 0 … n−1 (``[study] seed``), each into its own results file. Success: the literature's objective
(the sum of squared distances to the points, M · path_error²) within 1 % of the best known value (below
1e-6 where it is 0). Printed per problem: successes, the median, worst and best objective, wall and
CPU seconds per seed (median and max), rounds, and what held the best answer (the stopping rule).

``--jobs N`` runs N seeds at once, each in its own process pinned to ``--cores`` CPUs (``taskset``;
Numba threads = cores): on a 16-core machine, ``--jobs 8 --cores 2`` measures "each seed on 2 cores"
eight at a time. The load average is printed before and after.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
STUDIES = HERE.parent / "studies" / "literature"
#: problem: (points M, best known sum of squares)
BEST = {"vertical-line": (6, 0.0), "timed-five": (5, 7.4158e-7), "closed-timed": (18, 9.029e-3),
        "closed-untimed": (18, 3.14e-3), "ellipse-ten": (10, 4.0199e-4)}


def one(problem: str, seed: int, out: str, seconds: float | None) -> dict:
    """Run one seed in this process; returns the record."""
    import numpy as np

    from explorer.optimize import run_optimize
    from explorer.study import load_study
    from explorer.mechanism import parse_toml
    path = STUDIES / f"{problem}.toml"
    data = parse_toml(path.read_text(), str(path))
    data["study"]["seed"] = seed
    data["study"]["mechanism"] = str(STUDIES / data["study"]["mechanism"])
    if seconds is not None:
        data["optimize"]["seconds"] = seconds
    study = load_study(data, source=str(path))
    t0, c0 = time.perf_counter(), time.process_time()
    s = run_optimize(study, output=out, force=True, progress=False)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    M, best = BEST[problem]
    pe = float(s.front["path_error"].iloc[0]) if len(s.front) else float("nan")
    f = M * pe * pe
    ok = f < 1e-6 if best == 0 else f <= 1.01 * best
    held = (s.polished or {}).get("held") or {}
    rounds = (s.rounds or {}).get("rounds") or []
    return {"problem": problem, "seed": seed, "f": f, "success": bool(ok), "wall": wall, "cpu": cpu,
            "rounds": len(rounds), "reason": (s.rounds or {}).get("reason"), "held": held,
            "atlas": ((s.rounds or {}).get("atlas") or {}).get("used", False), "load": os.getloadavg()[0],
            "best_round": int(np.nanargmin([r["best"] for r in rounds])) if rounds else None}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--problems", default="all")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--cores", type=int, default=2)
    ap.add_argument("--seconds", type=float, default=None, help="override [optimize] seconds")
    ap.add_argument("--one", nargs=3, metavar=("PROBLEM", "SEED", "OUT"), help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.one:
        rec = one(a.one[0], int(a.one[1]), a.one[2], a.seconds)
        print("RESULT " + json.dumps(rec), flush=True)
        return 0
    problems = list(BEST) if a.problems == "all" else a.problems.split(",")
    print(f"load before: {os.getloadavg()[0]:.2f}; {os.cpu_count()} CPUs; {a.jobs} seed(s) at a time on "
          f"{a.cores} core(s) each", flush=True)
    tmp = Path(tempfile.mkdtemp(prefix="bench-literature-"))
    tasks = [(p, s) for p in problems for s in range(a.seeds)]
    records, running = [], []
    ncpu = os.cpu_count() or 1
    free = list(range(0, ncpu - ncpu % a.cores, a.cores))[:a.jobs]
    while tasks or running:
        while tasks and free:
            p, s = tasks.pop(0)
            core = free.pop(0)
            env = dict(os.environ, NUMBA_NUM_THREADS=str(a.cores), OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
            cmd = [sys.executable, __file__, "--one", p, str(s), str(tmp / f"{p}-{s}.h5")]
            if a.seconds is not None:
                cmd += ["--seconds", str(a.seconds)]
            if a.jobs > 1:
                cmd = ["taskset", "-c", f"{core}-{core + a.cores - 1}"] + cmd
            running.append((subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env),
                            core, p, s))
        time.sleep(0.2)
        for item in list(running):
            proc, core, p, s = item
            if proc.poll() is None:
                continue
            running.remove(item)
            free.append(core)
            out = proc.stdout.read()
            line = [x for x in out.splitlines() if x.startswith("RESULT ")]
            if not line:
                print(f"  {p} seed {s}: FAILED\n{out[-2000:]}", flush=True)
                continue
            rec = json.loads(line[0][7:])
            records.append(rec)
            h = rec["held"]
            what = "exact" if h.get("exact") else ("; ".join(h.get("bounds", []) + h.get("constraints", [])) or "interior")
            print(f"  {p:<15} seed {s}: {rec['f']:.6g} {'ok ' if rec['success'] else 'MISS'} {rec['wall']:6.1f} s "
                  f"{rec['cpu']:6.1f} CPU-s, {rec['rounds']} rounds (best in round {rec['best_round']}), atlas "
                  f"{'yes' if rec['atlas'] else 'no'}; held: {what}; stopped: {rec['reason']}", flush=True)
    import numpy as np
    print(f"{'problem':<15} {'best known':>10} {'success':>8} {'median':>11} {'worst':>11} {'best':>11} "
          f"{'s/seed med':>10} {'s max':>6} {'CPU-s med':>9}")
    for p in problems:
        rs = [r for r in records if r["problem"] == p]
        if not rs:
            continue
        f = np.array([r["f"] for r in rs])
        print(f"{p:<15} {BEST[p][1]:>10.5g} {sum(r['success'] for r in rs):>5}/{len(rs):<2} {np.median(f):>11.5g} "
              f"{f.max():>11.5g} {f.min():>11.5g} {np.median([r['wall'] for r in rs]):>10.1f} "
              f"{max(r['wall'] for r in rs):>6.1f} {np.median([r['cpu'] for r in rs]):>9.1f}", flush=True)
    print(f"load after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
