"""What the physics check (`explorer physics`) costs per design, and what its timestep buys.

    python benchmarks/bench_physics.py [--designs 5] [--turns 3]

The designs: the nominal and ±2 % variants of studies/mechanisms/jansen-plywood.toml (plywood links, a
steel crank, the 8 kg body, 30 rpm, drag 0.1), on the study's four-legged mirrored walker. Every figure
is CPU-seconds of this process (``time.process_time``: the machine is shared, so wall time would measure
the neighbours), measured in one run; the load average is printed beside them.

1. Per design, 4 legs, pitch held, ``--turns`` measured turns after half a turn of settling (the verb's
   default; the budget is 3 CPU-s): building the model, stepping it natively (``mujoco.rollout``, one C
   call per turn) and measuring; against the same model stepped by a Python loop of ``mj_step`` (one
   call per step, the baseline of a Python callback per step), and against the kinematic solve with the
   forces effect of the same design (what ``explorer run`` spends on it).
2. Eight legs, pitch free (the heaviest case the issue names).
3. The timestep: the nominal at 1, 0.5 (the default) and 0.25 ms; its figures' change against 0.25 ms.
"""

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import explorer  # noqa: E402
from _timing import variants  # noqa: E402
from explorer.mechanism import Walker  # noqa: E402
from explorer.physics import Settings, build_model, run_model  # noqa: E402


def cpu(fn):
    t = time.process_time()
    out = fn()
    return time.process_time() - t, out


def python_loop(model, samples: int) -> float:
    """CPU-s of the same run stepped by ``mj_step`` from Python, one call per step (reading the sensors)."""
    import mujoco
    from explorer.physics._simulate import steps_per_turn
    m = mujoco.MjModel.from_xml_string(model.xml)
    n = steps_per_turn(model.omega, model.settings.timestep, samples)
    dt = 2 * math.pi / model.omega / n
    m.opt.timestep = dt
    d = mujoco.MjData(m)
    d.qvel[:] = model.qvel0
    total = int(round(model.settings.settle * n)) + model.settings.turns * n
    rows = np.empty((total, m.nsensordata))
    t = time.process_time()
    for k in range(total):
        d.ctrl[:] = (model.omega * k * dt, model.omega, -model.walk * model.drag)
        mujoco.mj_step(m, d)
        rows[k] = d.sensordata
    return time.process_time() - t


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--designs", type=int, default=5)
    ap.add_argument("--turns", type=int, default=3)
    a = ap.parse_args(argv)
    import mujoco

    mech = explorer.load_mechanism(ROOT / "studies" / "mechanisms" / "jansen-plywood.toml")
    op = mech.operating
    four = Walker(4, (), (False, True, False, True), 0.1)
    eight = Walker(8, (), tuple(j % 2 == 1 for j in range(8)), 0.1)
    S = 360
    lengths, crank = variants(mech, a.designs)
    print(f"explorer {explorer.__version__}, MuJoCo {mujoco.__version__}; load average "
          f"{', '.join(f'{x:.2f}' for x in os.getloadavg())} (2 shared cores); CPU-seconds of this process")
    explorer.simulate(mech, S, velocities=True, forces=True, operating=op, walker=four)  # compile / load kernels

    print(f"\n1. per design: 4 legs, pitch held, {a.turns} turns after 0.5 settling, timestep <= 0.5 ms "
          f"(budget 3 CPU-s)")
    print(f"{'design':>6s} {'build':>7s} {'rollout':>8s} {'py loop':>8s} {'loop/rollout':>12s} {'kinematic+forces':>16s}"
          f" {'physics/kinematic':>17s} {'sim s per CPU-s':>15s}")
    per = []
    for i in range(a.designs):
        des = {l.name: float(x) for l, x in zip(mech.links, lengths[i])}
        mv = mech.with_lengths(des, float(crank[i]))
        t_kin, cyc = cpu(lambda: explorer.simulate(mv, S, velocities=True, forces=True, operating=op, walker=four))
        st = Settings(turns=a.turns)
        t_build, model = cpu(lambda: build_model(mv, cyc.positions, cyc.velocities, four, op, st))
        t_run, out = cpu(lambda: run_model(model, S))
        t_loop = python_loop(model, S)
        sim = (st.settle + st.turns) * 60.0 / op.rpm
        per.append(t_build + t_run)
        print(f"{i:6d} {t_build:7.3f} {t_run:8.3f} {t_loop:8.3f} {t_loop / t_run:12.2f} {t_kin:16.4f} "
              f"{(t_build + t_run) / t_kin:17.0f} {sim / t_run:15.2f}")
    print(f"mean {np.mean(per):.3f} CPU-s per design (model + run), max {np.max(per):.3f}; the budget is 3")

    print("\n2. eight legs, pitch free (the nominal)")
    cyc = explorer.simulate(mech, S, velocities=True)
    st = Settings(turns=a.turns, pitch="free")
    t_build, model = cpu(lambda: build_model(mech, cyc.positions, cyc.velocities, eight, op, st))
    t_run, out = cpu(lambda: run_model(model, S))
    print(f"build {t_build:.3f} + run {t_run:.3f} CPU-s; loaded feet at most {out['physics_loaded_feet_max']:.0f}, "
          f"friction work {out['physics_friction_work']:.3g} J/turn, pitch {out['physics_pitch']:.3g} rad")

    print("\n3. the timestep (nominal, 4 legs, pitch held): what accuracy costs")
    keys = ("physics_travel", "physics_bob", "physics_torque_peak", "physics_torque_rms", "physics_impact_peak")
    rows = []
    for dt in (1e-3, 5e-4, 2.5e-4):
        st = Settings(turns=a.turns, timestep=dt)
        model = build_model(mech, cyc.positions, cyc.velocities, four, op, st)
        try:
            t_run, out = cpu(lambda: run_model(model, S))
        except Exception as exc:  # noqa: BLE001 - a timestep too long for the stiff model: say so
            rows.append((dt, None, str(exc)))
            continue
        rows.append((dt, t_run, out))
    ref = rows[-1][2]
    print(f"{'timestep':>9s} {'CPU-s':>7s} " + " ".join(f"{k[8:]:>16s}" for k in keys))
    for dt, t, out in rows:
        if t is None:
            print(f"{dt * 1e3:7.2f}ms   fails: {out}")
            continue
        cells = " ".join(f"{out[k]:9.4g} {100 * (out[k] - ref[k]) / ref[k]:+5.1f}%" for k in keys)
        print(f"{dt * 1e3:7.2f}ms {t:7.3f} {cells}")
    print("(each figure and its change against the 0.25 ms run; the impact depends on the contact stiffness, "
          "whose time constant is two timesteps)")


if __name__ == "__main__":
    main()
