"""Better Jansen legs by search: the front ``explorer optimize`` finds over walker metrics, against
Jansen's own leg (the nominal, variant 0).

    python benchmarks/bench_optimize.py [--study studies/jansen-optimize.toml] [-o /tmp/jo.h5]

Runs the study (NSGA-II over every link and the crank radius within ±5 %, travel up, bob down, peak
torque down, under the buildability screen and a 1-unit swing clearance) and prints: designs solved
and feasible, wall time and designs per second, the final front's size, how many of its designs
dominate the nominal (at least as good in every objective, better in one), and by how much: the
best improvement of each objective among the dominating designs, in per cent of the nominal's
value, and those designs' median improvement.
"""

import argparse
import sys
import time

import numpy as np

from explorer import open_results
from explorer.study import final_front, load_study, objective_matrix, run_optimize


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--study", default="studies/jansen-optimize.toml")
    ap.add_argument("-o", "--output", default="/tmp/bench-optimize.h5")
    a = ap.parse_args(argv)
    study = load_study(a.study)
    opt = study.optimize
    t0 = time.perf_counter()
    s = run_optimize(study, output=a.output, force=True, progress=False)
    wall = time.perf_counter() - t0
    with open_results(s) as res:
        df = res.frame()
    F, _, feasible = objective_matrix(df, opt, study.screen)
    front = final_front(df, study)
    nominal = df.iloc[0]
    assert nominal["variant"] == 0 and feasible[0], "the nominal design is not feasible in this study"
    f0 = F[0]
    idx = front["variant"].to_numpy()
    Ff = F[idx]
    dom = np.all(Ff <= f0, axis=1) & np.any(Ff < f0, axis=1)
    print(f"{study.name}: {opt.algorithm}, population {opt.population} x {opt.generations} generations")
    print(f"  {s.evaluations:,} designs solved, {s.feasible:,} feasible, {wall:.2f} s "
          f"({s.evaluations / wall:,.0f} designs/s, {s.evaluations * study.steps / wall / 1e6:.2f} M configurations/s)")
    print(f"  final front: {len(front)} designs; {int(dom.sum())} dominate the nominal")
    print("  objective      nominal      best among dominating   median among dominating")
    for j, (name, d) in enumerate(zip(opt.objectives, opt.directions)):
        v0 = float(nominal[name])
        vals = front[name].to_numpy()[dom]
        if len(vals) == 0:
            print(f"  {name:<14} {v0:10.4g}      -")
            continue
        gain = (vals - v0) / abs(v0) * 100 * (1 if d == "max" else -1)  # positive = better
        best = vals[np.argmax(gain)]
        med = float(np.median(vals))

        def change(x):  # the value's own change (a reduction prints as −), and whether that is better
            pct = (x - v0) / abs(v0) * 100
            good = (pct > 0) == (d == "max")
            return f"{pct:+.1f} %, {'better' if good else 'worse' if pct else 'same'}".replace("-", "−")

        print(f"  {name:<14} {v0:10.4g}  {best:10.4g} ({change(best)})   {med:10.4g} ({change(med)})   "
              f"[{'higher' if d == 'max' else 'lower'} is better]")
    return 0


if __name__ == "__main__":
    sys.exit(main())
