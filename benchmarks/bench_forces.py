"""What the forces effect costs, as ratios against the positions-only solve measured in the same run.

    python benchmarks/bench_forces.py [--variants 10000] [--steps 360] [--repeat 3] [--clock wall|cpu]

The default study's designs (±2 % Jansen variants, every link and the crank) built as
studies/mechanisms/jansen-plywood.toml states (plywood links, a steel crank, an 8 kg body on the
contact foot, 30 rpm, gravity), on the four-legged mirrored walker. Rows: block Newton with the
foot's positions only (the baseline); foot positions and velocities; and positions, velocities,
accelerations and forces (motor torque of the walker, every joint's reaction, the frame force and
the force metrics; every vertex is solved, FORCE_CHUNK variants at a time), with the body moving with
the contact foot (the default) and with the frame held (``[operating] body = "held"``). Best of --repeat runs
after a warm-up run that compiles (or loads the cached) kernels; read the ratios, not the figures.
"""

import argparse
from pathlib import Path


import explorer
from _timing import CLOCKS, best, variants


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--variants", type=int, default=10_000)
    ap.add_argument("--steps", type=int, default=360)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--clock", choices=sorted(CLOCKS), default="wall",
                    help="wall time, or this process's CPU time (on a machine shared with other work)")
    a = ap.parse_args(argv)
    clock = CLOCKS[a.clock]

    mech = explorer.load_mechanism(Path(__file__).parents[1] / "studies" / "mechanisms" / "jansen-plywood.toml")
    n = a.variants
    lengths, crank = variants(mech, n)
    configs = n * a.steps

    def batch(**kw):
        return lambda: explorer.simulate_batch(mech, lengths, crank, a.steps, **kw)

    base = best(batch(velocities=False), a.repeat, clock=clock)
    rows = [("block Newton, foot positions (baseline)", base),
            ("block Newton, foot + velocities", best(batch(velocities=True), a.repeat, clock=clock)),
            ("positions + vel + acc + forces (body moving)", best(batch(velocities=True, forces=True), a.repeat, clock=clock)),
            ("positions + vel + acc + forces (frame held)",
             best(batch(velocities=True, forces=True, operating={"body": "held"}), a.repeat, clock=clock))]
    print(f"{n} ±2 % Jansen variants x {a.steps} steps, plywood build, {explorer.__version__}; best of {a.repeat} "
          f"({a.clock} time)")
    print(f"{'what':44s} {'M configs/s':>12s} {'vs positions':>13s}")
    for name, t in rows:
        print(f"{name:44s} {1e-6 * configs / t:12.2f} {t / base:13.2f}")
    b = explorer.simulate_batch(mech, lengths[:1], crank[:1], a.steps, forces=True)
    print("nominal:", ", ".join(f"{k} {v[0]:.4g}" for k, v in b.force_metrics.items() if not k.startswith("pin_force.")))


if __name__ == "__main__":
    main()
