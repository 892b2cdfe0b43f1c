"""The physics figures beside the kinematic ones, and a plain verdict where they disagree.

One home for the comparison that ``explorer physics`` prints per design and ``explorer show`` prints for
one: :func:`comparison` (each figure, its kinematic or forces-model counterpart and the difference) and
:func:`verdict` ("agrees with the kinematic walker" or "disagrees: rocks: pitch 0.066 rad, travel −3.1 %;
…"). The thresholds (:data:`TOLERANCES`):

* travel: |physics_travel − travel| > 2 % of travel;
* bob: |physics_bob − bob| > 10 % of bob and > 0.1 % of the crank radius (a foot sphere's rolling and the
  contacts' give are that small);
* rocks: the body's pitch swings by more than 0.02 rad (1.1°) peak to peak;
* feet fight: two or more feet loaded at once and friction work over 0.2 % of the body's weight × the
  travel per turn (a cost of transport of 0.002 lost in the feet, 2 % of a Strandbeest's own);
* torque: the phase-averaged peak more than 10 % from the forces effect's ``motor_torque_peak`` (when the
  file has it: the model that holds the body still underestimates it).
"""

from __future__ import annotations

import math

#: The thresholds of :func:`verdict` (see the module docstring).
TOLERANCES = {"travel_pct": 2.0, "bob_rel": 0.10, "bob_crank": 1e-3, "pitch_rad": 0.02, "friction_cot": 0.002,
              "torque_rel": 0.10}


def _f(row, name) -> float:
    try:
        x = float(row[name])
    except (KeyError, TypeError, ValueError):
        return math.nan
    return x


def checked(row) -> bool:
    """Whether the frame row holds physics figures (the design was checked and its check ran)."""
    return math.isfinite(_f(row, "physics_travel"))


def comparison(row, operating) -> list[tuple[str, float, float, str]]:
    """[(what, physics value, its counterpart or NaN, unit)] in display units: travel m/turn, bob and pitch
    mm and rad, torques N·m (the counterpart: the forces effect's motor torque when stored)."""
    unit = float(operating.unit)
    return [("travel", _f(row, "physics_travel"), _f(row, "travel") * unit, "m/turn"),
            ("bob", _f(row, "physics_bob") * 1e3, _f(row, "bob") * unit * 1e3, "mm"),
            ("pitch (peak to peak)", _f(row, "physics_pitch"), 0.0, "rad"),
            ("motor torque peak", _f(row, "physics_torque_peak"), _f(row, "motor_torque_peak"), "N·m"),
            ("motor torque rms", _f(row, "physics_torque_rms"), _f(row, "motor_torque_rms"), "N·m")]


def disagreements(row, operating, weight: float | None = None) -> list[str]:
    """What disagrees, one phrase each ([] when everything agrees); ``weight`` (N) for the friction's
    threshold (default the body's weight, [operating] load × gravity)."""
    t = TOLERANCES
    unit = float(operating.unit)
    out = []
    diff = _f(row, "physics_travel_diff")
    pitch = _f(row, "physics_pitch")
    travel_off = math.isfinite(diff) and abs(diff) > t["travel_pct"]
    if math.isfinite(pitch) and pitch > t["pitch_rad"]:
        out.append(f"rocks: pitch {pitch:.2g} rad" + (f", travel {diff:+.1f} %" if travel_off else ""))
    elif travel_off:
        out.append(f"travel {diff:+.1f} %")
    pb, kb = _f(row, "physics_bob"), _f(row, "bob") * unit
    crank = _f(row, "crank") * unit
    if (math.isfinite(pb) and math.isfinite(kb) and abs(pb - kb) > t["bob_rel"] * kb
            and (not math.isfinite(crank) or abs(pb - kb) > t["bob_crank"] * crank)):
        out.append(f"bob {pb * 1e3:.3g} mm against {kb * 1e3:.3g} mm")
    loaded = _f(row, "physics_loaded_feet_max")
    fw = _f(row, "physics_friction_work")
    travel = _f(row, "physics_travel")
    w = weight if weight is not None else float(operating.load) * float(operating.gravity)
    if (math.isfinite(loaded) and loaded >= 2 and math.isfinite(fw) and math.isfinite(travel)
            and fw > t["friction_cot"] * w * abs(travel)):
        out.append(f"feet fight: {int(loaded)} loaded at once, {fw:.3g} J/turn of friction")
    tp, mp = _f(row, "physics_torque_peak"), _f(row, "motor_torque_peak")
    if math.isfinite(tp) and math.isfinite(mp) and mp > 0 and abs(tp - mp) > t["torque_rel"] * mp:
        out.append(f"motor torque peak {tp:.3g} N·m, {100 * (tp - mp) / mp:+.0f} % against the forces model's "
                   f"{mp:.3g} N·m")
    return out


def verdict(row, operating, weight: float | None = None) -> str:
    """"agrees with the kinematic walker" or "disagrees: …" (see :func:`disagreements`)."""
    bad = disagreements(row, operating, weight)
    return "disagrees: " + "; ".join(bad) if bad else "agrees with the kinematic walker"


def show_lines(row, operating, stored: dict | None, variant: int, filename) -> list[str]:
    """What ``explorer show`` prints about the physics check of one design: the settings, each figure
    beside its kinematic counterpart, the verdict; or that it was not checked (or failed, and why)."""
    if stored is None:
        return [f"physics check: not run on this file (`explorer physics {filename} --variant {variant}` checks "
                f"this design in MuJoCo)"]
    mark = (stored.get("checked") or {}).get(str(variant))
    s = stored.get("settings") or {}
    how = (f"MuJoCo {stored.get('mujoco', '?')}, {stored.get('legs', '?')} legs, body {stored.get('body_mass', 0):g} kg, "
           f"pitch {s.get('pitch')}, {s.get('turns')} turns after {s.get('settle', 0):g} settling")
    if mark is None:
        return [f"physics check ({how}): this design was not checked (NaN); `explorer physics {filename} "
                f"--variant {variant}` checks it"]
    if mark != "ok":
        return [f"physics check ({how}): {mark}"]
    lines = [f"physics check ({how}):"]
    rows = [("", "physics", "kinematic", "change")]
    for what, x, ref, unit in comparison(row, operating):
        if what.startswith("motor torque") and not math.isfinite(ref):
            rows.append((f"{what} [{unit}]", f"{x:.4g}", "-", "-"))
            continue
        if what.startswith("motor torque"):
            what = what + " (forces model)"
        change = f"{100 * (x - ref) / abs(ref):+.1f} %" if math.isfinite(ref) and ref != 0 else "-"
        rows.append((f"{what} [{unit}]", f"{x:.4g}", f"{ref:.4g}" if math.isfinite(ref) else "-", change))
    widths = [max(len(r[i]) for r in rows) for i in range(4)]
    for r in rows:
        lines.append("  " + "  ".join(c.ljust(widths[0]) if i == 0 else c.rjust(widths[i]) for i, c in enumerate(r)))
    lines.append(f"  feet loaded at once: at most {int(_f(row, 'physics_loaded_feet_max'))}; friction work "
                 f"{_f(row, 'physics_friction_work'):.3g} J/turn; impact peak {_f(row, 'physics_impact_peak'):.4g} N "
                 f"(the largest normal force on a landing foot; it depends on the contact stiffness)")
    lines.append("  " + verdict(row, operating))
    return lines


def rank_note(full, keys) -> str | None:
    """For ``explorer rank`` by physics metrics: how many of the ranked designs were checked (the others
    are NaN and rank last); None when no key is a physics metric."""
    from ._simulate import PHYSICS_METRICS
    keys = [k for k in keys if k in PHYSICS_METRICS and k in full.columns]
    if not keys:
        return None
    n = int(full[keys[0]].notna().sum())
    return (f"{', '.join(keys)}: {n:,} of the {len(full):,} ranked designs checked by `explorer physics` (the others "
            f"are NaN, not checked, and rank last)")


def report_panel(res, rows_of) -> str:
    """The report's panel of the designs the physics check covered (``res`` an open results file, ``rows_of``
    its ``frame_rows``: the frame rows of some variants, indexed by variant): one row per design, its physics
    figures beside the kinematic ones and the verdict (HTML)."""
    import html

    from ._check import stored_physics
    esc = html.escape
    stored = stored_physics(res) or {}
    op = res.operating
    marks = stored.get("checked") or {}
    s = stored.get("settings") or {}
    if op is None or op.unit is None or not marks:
        return ""
    head = ("<tr><th>variant</th><th class='num'>travel [m/turn]</th><th class='num'>kinematic</th>"
            "<th class='num'>Δ %</th><th class='num'>bob [mm]</th><th class='num'>kinematic</th>"
            "<th class='num'>pitch [rad]</th><th class='num'>feet loaded</th><th class='num'>friction [J/turn]</th>"
            "<th class='num'>torque peak [N·m]</th><th class='num'>forces model</th><th class='num'>torque rms [N·m]</th>"
            "<th class='num'>impact [N]</th><th>verdict</th></tr>")
    body = []
    checked = [(int(k), k) for k in sorted(marks, key=int) if 0 <= int(k) < int(res.n_variants)]
    rows = rows_of([v for v, key in checked if marks[key] == "ok"])  # only the rows shown are read
    for v, key in checked:
        if marks[key] != "ok":
            body.append(f"<tr class='physics' data-variant='{v}'><td>{v}</td>" + "<td class='num'>-</td>" * 12
                        + f"<td>{esc(marks[key])}</td></tr>")
            continue
        row = rows.loc[v]

        def num(x, fmt):
            return format(x, fmt) if math.isfinite(x) else "-"

        unit = float(op.unit)
        cells = [num(_f(row, "physics_travel"), ".4f"), num(_f(row, "travel") * unit, ".4f"),
                 num(_f(row, "physics_travel_diff"), "+.2f"), num(_f(row, "physics_bob") * 1e3, ".3f"),
                 num(_f(row, "bob") * unit * 1e3, ".3f"), num(_f(row, "physics_pitch"), ".3g"),
                 num(_f(row, "physics_loaded_feet_max"), ".0f"), num(_f(row, "physics_friction_work"), ".3g"),
                 num(_f(row, "physics_torque_peak"), ".3f"), num(_f(row, "motor_torque_peak"), ".3f"),
                 num(_f(row, "physics_torque_rms"), ".3f"), num(_f(row, "physics_impact_peak"), ".4g")]
        body.append(f"<tr class='physics' data-variant='{v}'><td>{v}</td>"
                    + "".join(f"<td class='num'>{c}</td>" for c in cells) + f"<td>{esc(verdict(row, op))}</td></tr>")
    how = (f"MuJoCo {stored.get('mujoco', '?')}, {stored.get('legs', '?')} legs, body {stored.get('body_mass', 0):g} kg, "
           f"pitch {s.get('pitch')}, {s.get('turns')} turns after {s.get('settle', 0):g} settling")
    return (f"<div class='panel' id='physics-panel'><h2>Physics check (MuJoCo) of {len(body)} design"
            f"{'s' if len(body) != 1 else ''}</h2><p class='note'>{esc(how)}: each design's walker scene stepped in "
            f"MuJoCo (<code>explorer physics</code>) beside the kinematic walker's figures (forces model: the forces "
            f"effect's motor_torque_peak); the other designs were not checked. The impact, the largest normal force "
            f"on a landing foot, depends on the contact stiffness.</p><table id='physics'>{head}{''.join(body)}"
            f"</table></div>")
