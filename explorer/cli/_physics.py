"""``explorer physics RESULTS [--top N | --variant V ...] [--pitch held|free] [--turns K] [--workers W]``: the
physics check of a shortlist in MuJoCo, stored in the results file as its ``physics`` metrics."""

from __future__ import annotations

import math


def register(sub) -> None:
    from ._args import add_force, add_top, add_variant, add_where

    p = sub.add_parser(
        "physics", help="check a shortlist in a physics engine (MuJoCo): does the machine rock, do feet fight",
        description="Check designs of a results file in MuJoCo: each design's walker scene (the legs at their "
                    "phases, mirrored legs mirrored, the body with the [operating] load as its mass, the feet small "
                    "spheres with friction on the ground, the crank driven at the stated rpm by a stiff servo) as a "
                    "planar model, settled for half a turn and measured over whole turns. Stores physics_travel "
                    "(m/turn), physics_bob (m), physics_pitch (rad), physics_loaded_feet_max, physics_friction_work "
                    "(J/turn), physics_torque_peak and physics_torque_rms (N·m), physics_impact_peak (N) and "
                    "physics_travel_diff (% of the kinematic travel) in the file (through a renamed copy), where "
                    "rank, show, frame() and the report see them; designs not checked are NaN. Needs the physics "
                    "extra: pip install 'explorer[physics]'.")
    p.add_argument("results", metavar="RESULTS", help="a complete results file (.h5) of a crank-driven walker with an "
                                                      "[operating] table (unit, rpm, load = the body's mass)")
    add_top(p, "check the default ranking's top N designs (`explorer rank RESULTS --top N`)", "5")
    add_variant(p, "check these variants (--variant 3 7 12) instead of a top N", many=True)
    add_where(p, "the top N of the designs it keeps, as `explorer rank RESULTS --where EXPR --top N`")
    p.add_argument("--pitch", metavar="held|free", default="held",
                   help="held (default): the body slides in x and y but does not turn, as the kinematic walker "
                        "holds it level; free: it may pitch about the crank centre (does it rock?)")
    p.add_argument("--turns", metavar="K", default="3", help="whole crank turns measured after half a turn of "
                                                             "settling (default 3)")
    p.add_argument("--workers", metavar="W", default=None,
                   help="worker processes (default: the CPUs this process may use, at most one per design)")
    add_force(p, "replace physics figures the file holds from a check with other settings (--pitch, --turns)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar and no table; errors only")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..physics import physics_check
    from ._args import whole

    top = None if args.top is None else (args.top or None)  # 0 = every ranked design
    if args.top == 0:
        from ..study import open_results  # with explorer's re-solver (store only reads files)
        with open_results(args.results) as res:
            top = res.n_variants
    variants = args.variant
    turns = whole(args.turns, "--turns", 1)
    workers = whole(args.workers, "--workers", 1) if args.workers is not None else None
    out = physics_check(args.results, variants=variants, top=top, pitch=args.pitch, turns=turns, workers=workers,
                        progress=not args.quiet, force=args.force, where=args.where)
    if not args.quiet:
        try:
            print("\n".join(summary_lines(out)))
        except KeyboardInterrupt as exc:  # the check is done and written: say so, not a bare "interrupted"
            word = "terminated" if type(exc).__name__ == "Terminated" else "interrupted"
            n = len(out["checked"]) + len(out["failed"])
            kept = (f"the physics figures of {n} design{'s' if n != 1 else ''} are written" if out["written"]
                    else "nothing was written")
            raise type(exc)(f"{out['path']}: {word} while printing the table, after the check: {kept}") from None
    return 0


def summary_lines(out) -> list[str]:
    """The table of checked designs, the lines of those skipped or failed, and the totals."""
    from ..physics._compare import verdict
    from ..study import open_results  # with explorer's re-solver (store only reads files)

    s = out["settings"]
    p = out["path"]
    n_ok, n_failed, n_skipped = len(out["checked"]), len(out["failed"]), len(out["skipped"])
    lines = [f"{p}: physics check (MuJoCo {out['mujoco']}) of {out['how']}: {out['legs']} legs, pitch {s['pitch']}, "
             f"{s['turns']} turns after {s['settle']:g} settling, timestep ≤ {s['timestep'] * 1e3:g} ms, foot spheres "
             f"{s['foot_radius']:g} × the crank radius, friction {s['friction']:g}"]
    op = out["operating"]
    rows = [("variant", "travel[m/turn]", "Δtravel", "bob[mm]", "kin.bob[mm]", "pitch[rad]", "loaded",
             "friction[J/turn]", "torque_peak[N·m]", "forces_peak[N·m]", "torque_rms[N·m]", "impact[N]", "cpu[s]",
             "verdict")]
    if n_ok or n_failed:
        with open_results(p) as res:
            df = res.frame_rows(list(dict.fromkeys(out["order"])))  # the rows shown alone (indexed by variant)
        for v in out["order"]:
            if v in out["failed"]:
                rows.append((str(v),) + ("-",) * 12 + (f"failed: {out['failed'][v]}",))
                continue
            if v not in out["checked"]:
                continue
            row = df.loc[v]
            o = out["checked"][v]

            def num(x, fmt):
                return format(x, fmt) if math.isfinite(x) else "-"

            mp = float(row["motor_torque_peak"]) if "motor_torque_peak" in row.index else math.nan
            kb = float(row["bob"]) * float(op.unit) * 1e3 if "bob" in row.index else math.nan
            rows.append((str(v), num(o["physics_travel"], ".4f"), num(o["physics_travel_diff"], "+.2f") + " %",
                         num(o["physics_bob"] * 1e3, ".3f"), num(kb, ".3f"), num(o["physics_pitch"], ".3g"),
                         str(int(o["physics_loaded_feet_max"])), num(o["physics_friction_work"], ".3g"),
                         num(o["physics_torque_peak"], ".3f"), num(mp, ".3f"), num(o["physics_torque_rms"], ".3f"),
                         num(o["physics_impact_peak"], ".4g"), f"{o['cpu_s']:.2f}", verdict(row, op)))
        widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]) - 1)]
        lines.append("")
        for r in rows:
            lines.append("  ".join(c.rjust(widths[i]) for i, c in enumerate(r[:-1])) + "  " + r[-1])
        lines.append("")
    for v, why in out["skipped"]:
        lines.append(f"skipped variant {v}: {why}")
    light = max((o.get("massless", 0) for o in out["checked"].values()), default=0)
    if light:
        from ..physics._model import MIN_MASS_FRACTION
        lines.append(f"note: {light} members of the machine have no mass data (no [mass] link_density, body or crank "
                     f"mass): each got {100 * MIN_MASS_FRACTION:g} % of the body's mass, and the figures depend on it; "
                     f"give the mechanism its masses")
    per = out["cpu_s"] / n_ok if n_ok else math.nan
    lines.append(f"checked {n_ok:,} design{'s' if n_ok != 1 else ''}" + (f", {n_failed:,} failed" if n_failed else "")
                 + (f", {n_skipped:,} skipped" if n_skipped else "")
                 + f" in {out['wall_s']:.1f} s ({out['cpu_s']:.2f} CPU-s in MuJoCo, {per:.2f} per design)"
                 + (f"; wrote physics_* into {p} (designs not checked: NaN)" if out["written"] else ""))
    lines.append("Δtravel: against the kinematic walker's travel; forces_peak: the forces effect's motor_torque_peak; "
                 "impact: the largest normal force on a landing foot (it depends on the contact stiffness); "
                 "`explorer show RESULTS --variant V` sets them beside the kinematic figures")
    return lines
