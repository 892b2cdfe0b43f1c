"""Reading verbs on a lean (metrics-only) results file at scale: peak resident memory and CPU-seconds of each
verb, each in a fresh process, on one file, measured in one run.

    python benchmarks/bench_reads.py [--designs 200000] [--file PATH] [--baseline TREE] [--dir DIR]

The file is the default study's ±2 % Jansen variants × 360 steps, every metric, ``[scene] store = "metrics"``
(built once per size under --dir, default a folder in the temporary directory; reused while it is there).
Each verb runs as ``python -m explorer.cli VERB ...`` under ``/usr/bin/time -v``: its "Maximum resident set
size" (the process and the child that verifies the file before it opens) and user + system CPU-seconds.

``--baseline TREE``: a source tree of explorer (for example ``git archive 10901b1 | tar -x -C /tmp/base``) whose
verbs run too, in turn with this tree's, on the same file: the table shows both and their ratio. The machines
are shared: read the ratios, with the load printed beside them.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: (label, arguments after ``explorer``): {f} is the results file, {o} a fresh output folder.
VERBS = (
    ("rank --top 3", ["rank", "{f}", "--top", "3"]),
    ("rank --by travel --where", ["rank", "{f}", "--by", "travel", "--where", "bob < 0.2 and travel > 0",
                                  "--top", "3"]),
    ("rank --pareto travel,bob", ["rank", "{f}", "--pareto", "travel,bob", "--top", "5"]),
    ("show --variant 7", ["show", "{f}", "--variant", "7"]),
    ("plot --top 3", ["plot", "{f}", "--top", "3", "-o", "{o}/top.png"]),
    ("plot --velocity 7", ["plot", "{f}", "--velocity", "7", "-o", "{o}/vel.png"]),
    ("export --as toml", ["export", "{f}", "--variant", "7", "-o", "{o}/v7.toml"]),
    ("export --as svg", ["export", "{f}", "--variant", "7", "-o", "{o}/v7.svg"]),
    ("export --as csv", ["export", "{f}", "--variant", "7", "-o", "{o}/v7.csv"]),
    ("export --as kit", ["export", "{f}", "--variant", "7", "--as", "kit", "-o", "{o}/kit"]),
    ("plot --scatter travel,bob", ["plot", "{f}", "--scatter", "travel,bob", "-o", "{o}/scatter.png"]),
    ("report", ["report", "{f}", "-o", "{o}/report.html"]),
)


def build(n: int, folder: Path, tree: Path) -> Path:
    """The lean study of ``n`` designs (built with ``tree``'s explorer unless it is there already)."""
    out = folder / f"lean-{n}.h5"
    if out.exists():
        return out
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bench_lean import lean_study  # the same study as the lean-run benchmark

    import explorer
    toml = folder / f"lean-{n}.toml"
    toml.write_text(explorer.mechanism.dumps_toml(lean_study(n, out)))
    print(f"building {out} ({n:,} designs) ...", flush=True)
    subprocess.run([sys.executable, "-m", "explorer.cli", "run", str(toml)], check=True, env=env_for(tree),
                   stdout=subprocess.DEVNULL, cwd=tree)
    return out


def env_for(tree: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree), OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    env.setdefault("NUMBA_CACHE_DIR", str(Path(tempfile.gettempdir()) / "numba-bench-reads"))
    return env


def measure(argv: list[str], tree: Path) -> dict:
    """Peak RSS (bytes), CPU-seconds (user + system) and wall of ``explorer ARGV`` run with ``tree``'s explorer."""
    p = subprocess.run(["/usr/bin/time", "-v", sys.executable, "-m", "explorer.cli", *argv], env=env_for(tree),
                       capture_output=True, text=True, cwd=tree)  # in the tree: `python -m` imports from there
    err = p.stderr

    def field(name: str) -> str:
        m = re.search(rf"{re.escape(name)}: (.+)", err)
        return m.group(1).strip() if m else "nan"

    wall = field("Elapsed (wall clock) time (h:mm:ss or m:ss)")
    parts = [float(x) for x in wall.split(":")] if wall != "nan" else [float("nan")]
    seconds = sum(x * 60 ** i for i, x in enumerate(reversed(parts)))
    tail = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("\t")][-1:]
    return {"rss": float(field("Maximum resident set size (kbytes)")) * 1024,
            "cpu": float(field("User time (seconds)")) + float(field("System time (seconds)")),
            "wall": seconds, "rc": p.returncode, "error": tail[0] if p.returncode and tail else ""}


def load() -> str:
    return "load average %.2f, %.2f, %.2f" % os.getloadavg()


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--designs", type=int, default=200_000, help="designs in the lean study (default 200,000)")
    ap.add_argument("--file", default=None, help="an existing lean results file to read instead of building one")
    ap.add_argument("--baseline", default=None, metavar="TREE", help="another explorer source tree to compare with")
    ap.add_argument("--dir", default=None, help="folder for the study and the outputs (default: a temporary one)")
    ap.add_argument("--only", default=None, help="comma-separated substrings: run the verbs whose label has one")
    ap.add_argument("--warm", action="store_true",
                    help="first run `plot --velocity 7` once per tree, unmeasured (its kernels into the Numba cache)")
    a = ap.parse_args(argv)
    folder = (Path(a.dir) if a.dir else Path(tempfile.gettempdir()) / "bench-reads").resolve()
    folder.mkdir(parents=True, exist_ok=True)
    f = Path(a.file).resolve() if a.file else build(a.designs, folder, ROOT)
    trees = [("this", ROOT)] + ([("baseline", Path(a.baseline).resolve())] if a.baseline else [])
    verbs = [v for v in VERBS if a.only is None or any(s in v[0] for s in a.only.split(","))]
    if a.warm:  # the re-solving verbs load the kernels from the cache, as a user's second command does
        for _, tree in trees:
            measure(["plot", str(f), "--velocity", "7", "-o", str(folder / "warm.png"), "--force"], tree)
    print(f"reading verbs on {f} ({f.stat().st_size / 1e6:,.1f} MB); {os.cpu_count()} cores; {load()}")
    head = f"{'verb':28s}" + "".join(f" {t + ' MB':>13s} {t + ' CPU-s':>14s}" for t, _ in trees)
    if len(trees) > 1:
        head += f" {'RSS ratio':>10s} {'CPU ratio':>10s}"
    print(head)
    for label, args in verbs:
        row = f"{label:28s}"
        got = []
        for tag, tree in trees:
            out = folder / f"out-{tag}"
            shutil.rmtree(out, ignore_errors=True)
            out.mkdir()
            r = measure([s.format(f=f, o=out) for s in args], tree)
            got.append(r)
            row += f" {r['rss'] / 1e6:13,.0f} {r['cpu']:14.2f}"
        if len(got) > 1:
            row += f" {got[0]['rss'] / got[1]['rss']:10.2f} {got[0]['cpu'] / got[1]['cpu']:10.2f}"
        for (tag, _), r in zip(trees, got):
            if r["rc"]:
                row += f"   [{tag} exit {r['rc']}: {r['error'][:80]}]"
        print(row, flush=True)
    print(f"({load()})")


if __name__ == "__main__":
    main()
