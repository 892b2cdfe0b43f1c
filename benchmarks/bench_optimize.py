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
from explorer.optimize import final_front, objective_matrix, run_optimize
from explorer.study import load_study


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
    if dom.any():
        give_up(study, df, front[dom])
    return 0


def give_up(study, df, chosen):
    """What the dominating designs give up: every walker metric the search did not score, re-solved at
    the study's steps with velocities for them and the nominal (the file stores only what the search
    read), as the range among them against the nominal and how many are worse."""
    from explorer.gait import DIRECTIONS, WALKER_METRICS, compute_metrics
    from explorer.kernels import simulate_batch
    mech = study.mech
    rows = df.iloc[[0, *chosen["variant"].tolist()]]
    nominal = mech.parameters()
    L = np.column_stack([rows[n].to_numpy(dtype=float) if n in rows.columns else np.full(len(rows), nominal[n])
                         for n in mech.link_names])
    r = rows["crank"].to_numpy(dtype=float) if "crank" in rows.columns else np.full(len(rows), nominal["crank"])
    assert not set(study.optimize.parameters) - set(mech.link_names) - {"crank"}, "links and crank only"
    b = simulate_batch(mech, L, r, study.steps, vertices=[mech.foot], velocities=True)
    m = compute_metrics(b.paths[mech.foot], b.velocities[mech.foot], b.status, list(WALKER_METRICS), mechanism=mech,
                        lengths=L, crank=r, walker=study.walker)
    others = [k for k in WALKER_METRICS if k not in study.optimize.objectives]
    print(f"  what the {len(chosen)} dominating designs give up (walker metrics not searched on, re-solved):")
    print("  metric              nominal   range among dominating        worse than the nominal")
    for k in others:
        v0, vals = float(m[k][0]), m[k][1:]
        worse = (vals < v0) if DIRECTIONS[k] == "max" else (vals > v0)
        print(f"  {k:<18} {v0:10.4g}   {vals.min():10.4g} to {vals.max():<10.4g}   {int(worse.sum()):>3} of {len(vals)}"
              f"   [{'higher' if DIRECTIONS[k] == 'max' else 'lower'} is better]")


if __name__ == "__main__":
    sys.exit(main())
