"""What starting costs: a cold process on a warm cache, and a new topology's first compile, as CPU-seconds.

    python benchmarks/bench_warm.py [--base PATH] [--variants 10000]

Each figure is one fresh Python process (its CPU time and its children's, from ``getrusage``, and its
wall time), on its own empty kernel cache (``NUMBA_CACHE_DIR`` in a temporary folder):

* **cold run after warm**: ``explorer warm`` (the default study's kernels into the cache), then a
  fresh ``explorer run`` of the default study (--variants of it): what every run after an install
  that warmed the cache costs. Beside it the same run on an empty cache (what a first run costs).
* **a user topology's first solve**: the cache warmed by the default study, then a fresh process
  solving a topology no built-in has (Jansen's leg with one more dyad hanging off its foot, 1,000
  variants x 360 steps, foot and velocities) with kernel "auto" (what a user gets: for a job this
  size, the general kernel unless the topology's generated kernel is cached,
  ``explorer.kernels.GENERATED_MIN_CONFIGS``), then with kernel "generated": **its generated
  kernel's compile** (what a large study of it, or ``explorer warm`` on it, pays once), then again
  (loaded from the cache). Nothing else is compiled: the new vertex's place is computed from the
  leg's positions written out, not by a simulate call. Against the same process on the same warm
  cache solving the built-in Jansen leg.

With ``--base PATH`` (a checkout of another explorer, e.g. the commit before a change), every figure is
measured for that tree too, in the same run, so the two are compared on one machine under one load.
CPU-seconds are the fair figure on a shared machine; state ``uptime`` beside them.
"""

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]

USER_TOPOLOGY = r'''
import numpy as np, explorer
from explorer.mechanism import mechanism_from_dict, mechanism_toml, parse_toml
name = NAME
base = explorer.load_mechanism("jansen")
if name == "user":  # one more dyad off the leg: vertex X held by the foot 7 and vertex 5
    # where 7 and 5 are at θ = 0 (explorer.simulate(base, 4).positions[0]), written out: that call's kernel
    # (every vertex, with velocities) is not in the warm cache, and its compile is not this topology's
    p7, p5 = np.array([-43.16011052, -91.75693293]), np.array([-59.23151496, -28.05293023])
    x = p7 + np.array([12.0, 9.0])
    text = mechanism_toml(base) + (f'\n[[links]]\na = "7"\nb = "X"\nlength = {float(np.hypot(*(x - p7)))!r}\n'
                                   f'\n[[links]]\na = "5"\nb = "X"\nlength = {float(np.hypot(*(x - p5)))!r}\n')
    text = text.replace("[guess]", f"[guess]\nX = [{float(x[0])!r}, {float(x[1])!r}]", 1)
    mech = mechanism_from_dict(parse_toml(text, "user.toml"), "user.toml")
else:
    mech = base
rng = np.random.default_rng(1)
L = mech.lengths * (1 + rng.uniform(-0.02, 0.02, (1000, len(mech.links))))
b = explorer.simulate_batch(mech, L, None, 360, vertices=[mech.foot] + (["X"] if name == "user" else []),
                           kernel=KERNEL)
assert (b.status == 0).mean() > 0.5, np.unique(b.status, return_counts=True)
'''


def _code(name: str, kernel: str = "auto") -> str:
    return USER_TOPOLOGY.replace("name = NAME", f"name = {name!r}", 1).replace("kernel=KERNEL", f"kernel={kernel!r}")


def _study(tmp: Path, variants: int) -> Path:
    text = (HERE / "studies" / "default.toml").read_text()
    text = "\n".join(f"variants = {variants}" if ln.split("#")[0].strip().startswith("variants") else ln
                     for ln in text.splitlines())
    path = tmp / "study.toml"
    path.write_text(text)
    return path


def _run(tree: Path, cache: Path, args, cwd: Path) -> tuple[float, float]:
    """(CPU-s of the process and its children, wall s) of one fresh process."""
    env = {**os.environ, "PYTHONPATH": str(tree), "NUMBA_CACHE_DIR": str(cache), "OMP_NUM_THREADS": "1",
           "OPENBLAS_NUM_THREADS": "1"}
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, *args], check=True, env=env, cwd=cwd, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime), wall


def measure(tree: Path, variants: int) -> dict:
    out = {}
    with tempfile.TemporaryDirectory(prefix="bench-warm-") as t:
        tmp = Path(t)
        study = _study(tmp, variants)
        run = ["-m", "explorer.cli", "run", str(study), "-o", str(tmp / "r.h5"), "--force", "-q"]
        out["first run, empty cache"] = _run(tree, tmp / "c1", run, tmp)
        warm = ["-m", "explorer.cli", "warm", "-q"] if (tree / "explorer" / "cli" / "_warm.py").exists() else run
        out["explorer warm (or a first run)"] = _run(tree, tmp / "c2", warm, tmp)
        out["cold run after warm"] = _run(tree, tmp / "c2", run, tmp)
        out["built-in Jansen, 1000 x 360, warm cache"] = _run(tree, tmp / "c2", ["-c", _code("jansen")],
                                                               tmp)
        # what a user gets (kernel "auto"), then, on a copy of the warm cache as it was, the topology's
        # generated kernel compiled (kernel "generated", which "auto" takes for a job of
        # GENERATED_MIN_CONFIGS or once cached), then loaded from that cache
        shutil.copytree(tmp / "c2", tmp / "c3")
        out["user topology's first solve, warm cache"] = _run(tree, tmp / "c2", ["-c", _code("user")],
                                                              tmp)
        out["user topology, its generated kernel compiled"] = _run(tree, tmp / "c3",
                                                                   ["-c", _code("user", "generated")], tmp)
        out["user topology again (its kernel cached)"] = _run(tree, tmp / "c3", ["-c", _code("user", "generated")],
                                                              tmp)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--base", type=Path, default=None, help="another explorer checkout measured in the same run")
    ap.add_argument("--variants", type=int, default=10_000, help="variants of the default study run (default 10000)")
    a = ap.parse_args(argv)
    trees = {"this tree": HERE} | ({"base": a.base.resolve()} if a.base else {})
    res = {k: measure(v, a.variants) for k, v in trees.items()}
    print(f"load before: {os.getloadavg()}; default study with {a.variants} variants; CPU-s (wall s)")
    print(f"{'':44s}" + "".join(f"{k:>22s}" for k in trees))
    for row in res["this tree"]:
        print(f"{row:44s}" + "".join(f"{res[k][row][0]:13.1f} ({res[k][row][1]:5.1f})" for k in trees))
    if a.base:
        for row, what in (("user topology's first solve, warm cache", "a new topology's first solve"),
                          ("user topology, its generated kernel compiled", "its generated kernel's compile")):
            new = res["this tree"][row][0] - res["this tree"]["built-in Jansen, 1000 x 360, warm cache"][0]
            old = res["base"][row][0] - res["base"]["built-in Jansen, 1000 x 360, warm cache"][0]
            print(f"{what} (less the built-in's solve on the same warm cache): {new:.1f} CPU-s, base {old:.1f}: "
                  f"ratio {new / old:.2f}")
    print(f"load after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
