"""Seed 004, problem 1: a tool's orientation from I to R = Rz(45°)·Ry(30°)·Rz(20°) over 10 s, five ways.

``rotations_bench`` reproduces the seed's numbers and measures what each interpolation costs in accuracy
and time (``explorer bench rotations``):

* the seed's R, built from cos/sin as the seed does (its printed R has R₁₂ = −0.8379, a transposed-digit
  typo for −0.8739: the seed's own element-wise interpolation ran on that matrix, whose
  ‖RᵀR − I‖ is 0.066);
* the seed's two "absolute XYZ" Euler sets θ/ψ/φ = 28.02°/11.17°/67.8° and 151.98°/191.17°/247.8°: they
  are R = Rz(φ)·Ry(θ)·Rx(ψ), i.e. scipy's intrinsic ``"ZYX"`` sequence (= extrinsic ``"xyz"``: turns about
  the fixed X, then Y, then Z axes) with angles (φ, θ, ψ); the seed prints them in the order θ (Y), ψ (X),
  φ (Z). The second set is (φ + 180°, 180° − θ, ψ + 180°);
* one row per method: ``slerp`` (the geodesic), ``spline`` (RotationSpline), ``matrix`` (seed (A)),
  ``euler ZYX set 1`` and ``set 2`` (seed (B); the seed says the second set "would also render the same
  rotation matrices" in between: it does not), ``euler XYZ`` (seed (C), relative X-Y-Z), ``axis-angle``
  (seed (D), linear on the rotation vector) and ``seed axang 4-vector`` (the seed's code for (D) taken
  literally: the 4-vector [k, θ] interpolated element-wise from the identity's [0 0 1 0], the axis left
  unnormalised in Rodrigues' formula; the seed's formula also has a typo in element (1,3), not copied);
* per row: the orthonormality defect (max ‖RᵀR − I‖_F and max |det R − 1|), the geodesic deviation (max
  angle to the slerp rotation at the same time), the swept angle against the geodesic's, the angular-speed
  ripple (see :class:`explorer.wrist.WristPath`), and the evaluation time per sample as a ratio to slerp
  measured in the same run.

All angles in the report are degrees; times microseconds.
"""

from __future__ import annotations

import csv
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..wrist import interpolate, orthonormality_defect, project, relative_angle, wrist_path

#: The seed's published figures.
SEED_R_PRINTED = np.array([[0.3336, -0.8379, 0.3536], [0.8173, 0.4550, 0.3536], [-0.4698, 0.1710, 0.8660]])
#: (θ, ψ, φ) degrees, the seed's order: Y, X, Z angles of R = Rz(φ)·Ry(θ)·Rx(ψ).
SEED_SETS = ((28.02, 11.17, 67.8), (151.98, 191.17, 247.8))
#: Times (s) at which the seed draws frames, and their trplot colours.
SEED_TIMES = (0.0, 2.0, 4.0, 6.0, 8.0, 10.0)
SEED_COLOURS = ("r", "g", "b", "m", "c", "k")
DURATION = 10.0

#: Rows: label -> (method, euler sequence, euler set, literal keyframe angles or None).
ROWS = {
    "slerp": ("slerp", None, 1),
    "spline": ("spline", None, 1),
    "matrix": ("matrix", None, 1),
    "euler ZYX set 1": ("euler", "ZYX", 1),
    "euler ZYX set 2": ("euler", "ZYX", 1),  # from (0, 0, 0) to the seed's set 2 as printed (literal angles)
    "euler XYZ": ("euler", "XYZ", 1),
    "axis-angle": ("axis-angle", None, 1),
    "seed axang 4-vector": ("seed-axang", None, 1),
}

COLUMNS = ("row", "defect_frob", "defect_det", "geodesic_dev_deg", "path_deg", "geodesic_deg", "ripple",
           "max_rate_rad_s", "gimbal_locks", "branch_changes", "us_per_sample", "time_vs_slerp", "mid_angles_deg")


def rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def ry(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def seed_rotation() -> np.ndarray:
    """R = Rz(45°)·Ry(30°)·Rz(20°), built from cos and sin as the seed does."""
    d = math.radians
    return rz(d(45)) @ ry(d(30)) @ rz(d(20))


def seed_axang_4vector(R, s) -> np.ndarray:
    """The seed's (D) literally: [kx, ky, kz, θ] linear from the identity's [0, 0, 1, 0] to R's, and the
    matrix from Rodrigues' formula with the (unnormalised) interpolated axis. (S, 3, 3); not rotations."""
    from scipy.spatial.transform import Rotation

    v = Rotation.from_matrix(R).as_rotvec()
    th = float(np.linalg.norm(v))
    end = np.concatenate([v / th, [th]])
    start = np.array([0.0, 0.0, 1.0, 0.0])
    s = np.asarray(s, dtype=np.float64).reshape(-1, 1)
    q = start + s * (end - start)
    k, a = q[:, :3], q[:, 3]
    c, sn, v1 = np.cos(a), np.sin(a), 1.0 - np.cos(a)
    kx, ky, kz = k[:, 0], k[:, 1], k[:, 2]
    return np.stack([np.stack([kx * kx * v1 + c, kx * ky * v1 - kz * sn, kx * kz * v1 + ky * sn], -1),
                     np.stack([kx * ky * v1 + kz * sn, ky * ky * v1 + c, ky * kz * v1 - kx * sn], -1),
                     np.stack([kx * kz * v1 - ky * sn, ky * kz * v1 + kx * sn, kz * kz * v1 + c], -1)], -2)


@dataclass
class RotationsReport:
    """rows: one dict per method (keys COLUMNS, + ``locks``: the gimbal-lock lines); frames: label -> (6, 3, 3)
    matrices at the seed's times (path fractions 0, 0.2, …, 1); wrists: label -> WristPath; facts: the seed's
    checks (name -> value); meta: what was run."""

    rows: list[dict] = field(default_factory=list)
    frames: dict = field(default_factory=dict)
    wrists: dict = field(default_factory=dict)  # label -> explorer.wrist.WristPath (not the seed's 4-vector row)
    facts: dict = field(default_factory=dict)
    meta: dict = field(default_factory=dict)


def _given(label):
    """The seed's set 2 as the seed wrote it (literal angles), for the 'euler ZYX set 2' row."""
    if label != "euler ZYX set 2":
        return None
    th, ps, ph = SEED_SETS[1]
    return [np.zeros(3), np.radians([ph, th, ps])]


def seed_facts() -> dict:
    """The seed's and the issue's numbers, recomputed (degrees where angles)."""
    from scipy.spatial.transform import Rotation

    R = seed_rotation()
    zyx = Rotation.from_matrix(R).as_euler("ZYX", degrees=True)  # (φ, θ, ψ)
    set2 = np.array([zyx[0] + 180.0, 180.0 - zyx[1], zyx[2] + 180.0])
    mid = 0.5 * (np.eye(3) + rz(math.pi / 2))
    s = np.linspace(0.0, 1.0, 20001)
    E = Rotation.from_euler("ZYX", np.outer(s, [90.0, 90.0, 90.0]), degrees=True).as_matrix()
    return {
        "R": R, "R_printed_max_error": float(np.abs(R - SEED_R_PRINTED).max()),
        "R_printed_defect": float(orthonormality_defect(SEED_R_PRINTED)[0]),
        "set1_theta_psi_phi": (zyx[1], zyx[2], zyx[0]), "set2_theta_psi_phi": (set2[1], set2[2], set2[0]),
        "geodesic_deg": math.degrees(float(relative_angle(np.eye(3), R))),
        "matrix_midpoint_det_90deg": float(np.linalg.det(mid)),
        "euler_zyx_0_to_90_sweep_deg": math.degrees(float(relative_angle(E[:-1], E[1:]).sum())),
        "euler_zyx_0_to_90_geodesic_deg": math.degrees(float(relative_angle(np.eye(3), E[-1]))),
    }


def rotations_bench(*, steps: int = 1001, timing: str | None = None, samples: int = 10_000, repeat: int = 5,
                    rows=None, mechanism=None, progress=None) -> RotationsReport:
    """Run the seed's problem: every row's accuracy over ``steps`` samples of the 10 s move (``timing`` law:
    the seed's "linear" (default) or the arm's "quintic"), and its time per sample over ``samples``
    evaluations (best of ``repeat``, slerp timed in the same run). ``rows``: labels of :data:`ROWS` to run
    (default all; slerp always runs, as the time baseline).

    ``mechanism`` (a path-driven :class:`~explorer.mechanism.Mechanism` with a ``[driver] orientation``):
    its keyframes, wrist, branch, duration and timing law (unless ``timing`` is given) instead of the
    seed's, one row per interpolation (its own Euler sequence and keyframe angles for ``euler``); the rows'
    wrist follows each method and its gimbal locks are listed."""
    if steps < 3 or samples < 1 or repeat < 1:
        raise ValueError("steps >= 3, samples >= 1 and repeat >= 1")
    if mechanism is not None:
        o = getattr(mechanism.path, "orientation", None) if mechanism.path is not None else None
        if o is None:
            raise ValueError(f"{mechanism.name}: no [driver] orientation to interpolate (its [driver] table needs "
                             f"orientation keyframes)")
        seq = o.euler_seq or o.wrist
        given = o.euler_radians(seq)
        table = {m: (m, seq, o.euler_set, given if any(g is not None for g in given) else None)
                 for m in ("slerp", "spline", "matrix", "euler", "axis-angle")}
        K, wrist, branch = o.matrices(), o.wrist, o.branch
        duration, law = mechanism.path.duration, timing or mechanism.path.timing
        name = mechanism.name
    else:
        table = {label: (m, q, e, _given(label)) for label, (m, q, e) in ROWS.items()}
        K, wrist, branch, duration, law, name = np.stack([np.eye(3), seed_rotation()]), "ZYX", 1, DURATION, \
            timing or "linear", None
    wanted = list(table) if rows is None else ["slerp"] + [r for r in rows if r != "slerp"]
    unknown = [r for r in wanted if r not in table]
    if unknown:
        raise ValueError(f"unknown rows {', '.join(map(repr, unknown))} (known: {', '.join(table)})")
    report = RotationsReport(facts=seed_facts(), meta={"steps": steps, "timing": law, "samples": samples,
                                                       "repeat": repeat, "duration_s": duration, "mechanism": name,
                                                       "wrist": wrist, "branch": branch, "keyframes": K})

    def evaluate(label, s):
        method, seq, eset, given = table[label]
        if method == "seed-axang":
            return seed_axang_4vector(K[-1], s)
        return interpolate(K, s, method, euler_seq=seq or wrist, euler_set=eset, euler_given=given)

    s_frames = np.array(SEED_TIMES) / SEED_TIMES[-1]
    s_time = np.linspace(0.0, 1.0, samples)
    times = {}
    for label in wanted:
        best = math.inf
        evaluate(label, s_time[:8])  # warm (imports, caches)
        for _ in range(repeat):
            t0 = time.perf_counter()
            evaluate(label, s_time)
            best = min(best, time.perf_counter() - t0)
        times[label] = best / samples * 1e6
    from scipy.spatial.transform import Rotation

    for label in wanted:
        method, seq, eset, given = table[label]
        if progress:
            progress(f"rotations: {label}")
        report.frames[label] = evaluate(label, s_frames)
        locks, max_rate, changes = (), math.nan, 0
        if method == "seed-axang":
            s = np.linspace(0.0, 1.0, steps)
            M = seed_axang_4vector(K[-1], s)
            used = project(M)
            frob, det = orthonormality_defect(M)
            dev = relative_angle(used, interpolate(K, s, "slerp"))
            path = float(relative_angle(used[:-1], used[1:]).sum())
            ds = relative_angle(used[:-1], used[1:]) * (steps - 1)  # swept angle per unit path fraction
            ripple = float((ds.max() - ds.min()) / ds.mean())
            geod = float(relative_angle(K[0], K[-1]))
        else:
            w = wrist_path(K, method, duration=duration, timing_law=law, steps=steps, wrist=wrist, branch=branch,
                           euler_seq=seq, euler_set=eset, euler_given=given)
            frob, det, dev, path, ripple, geod = (w.defect_frob, w.defect_det, w.geodesic_deviation, w.path_angle,
                                                  w.ripple, w.geodesic_angle)
            locks, changes = w.locks, int((np.diff(w.sets) != 0).sum())
            max_rate = float(np.abs(w.rates).max())
            report.wrists[label] = w
        mid = project(report.frames[label][3:4])  # the seed's t = 6 s (s = 0.6)
        report.rows.append({
            "row": label, "defect_frob": float(np.abs(frob).max()), "defect_det": float(np.abs(det).max()),
            "geodesic_dev_deg": math.degrees(float(np.max(dev))), "path_deg": math.degrees(path),
            "geodesic_deg": math.degrees(geod), "ripple": ripple, "max_rate_rad_s": max_rate,
            "gimbal_locks": len(locks), "branch_changes": changes, "us_per_sample": times[label],
            "time_vs_slerp": times[label] / times["slerp"],
            "mid_angles_deg": tuple(np.round(Rotation.from_matrix(mid).as_euler(wrist, degrees=True)[0], 3)),
            "locks": tuple(str(g) for g in locks),
        })
    return report


def format_table(report: RotationsReport) -> str:
    """The facts (the seed's, or the mechanism's keyframes) and the per-method table as text, then every
    gimbal lock a row's wrist meets."""
    f = report.facts
    m = report.meta
    if m.get("mechanism") is None:
        lines = ["seed 004 problem 1: orientation from I to R = Rz(45°)·Ry(30°)·Rz(20°) in 10 s",
                 "R =", *("  " + "  ".join(f"{v:8.4f}" for v in row) for row in f["R"]),
                 f"  the seed prints R12 = -0.8379 (typo for {f['R'][0, 1]:.4f}; its printed matrix has "
                 f"||R^T R - I|| = {f['R_printed_defect']:.3f})",
                 "Euler sets (seed's 'absolute XYZ', R = Rz(phi)·Ry(theta)·Rx(psi), scipy intrinsic 'ZYX'):",
                 "  set 1: theta = {:.2f}°, psi = {:.2f}°, phi = {:.2f}°".format(*f["set1_theta_psi_phi"]),
                 "  set 2: theta = {:.2f}°, psi = {:.2f}°, phi = {:.2f}°".format(*f["set2_theta_psi_phi"]),
                 f"geodesic angle I -> R: {f['geodesic_deg']:.3f}°",
                 f"element-wise midpoint of I and a 90° turn: det = {f['matrix_midpoint_det_90deg']:.4f}",
                 f"Euler Z-Y-X 0 -> 90° on all three: sweeps {f['euler_zyx_0_to_90_sweep_deg']:.2f}° for a "
                 f"{f['euler_zyx_0_to_90_geodesic_deg']:.2f}° geodesic"]
    else:
        from scipy.spatial.transform import Rotation

        K = m["keyframes"]
        lines = [f"mechanism {m['mechanism']}: {len(K)} orientation keyframes over {m['duration_s']:g} s, wrist "
                 f"{m['wrist']} from branch {m['branch']}"]
        for k, M in enumerate(K):
            lines.append(f"  keyframe {k}: {m['wrist']} angles "
                         f"{', '.join(f'{a:.3f}' for a in Rotation.from_matrix(M).as_euler(m['wrist'], degrees=True))}°")
    lines += ["",
              f"{m['steps']} samples, {m['timing']} timing; time per sample over {m['samples']} samples, best of "
              f"{m['repeat']}, ratio to slerp in the same run; wrist {m['wrist']}",
              f"{'method':<20} {'|RtR-I|':>9} {'|det-1|':>9} {'geo dev°':>9} {'swept°':>8} {'geodesic°':>9} "
              f"{'ripple':>7} {'rate rad/s':>10} {'locks':>5} {'µs/sample':>10} {'x slerp':>8}  "
              f"{m['wrist']} angles at s = 0.6 (°)"]
    for r in report.rows:
        rate = "-" if math.isnan(r["max_rate_rad_s"]) else f"{r['max_rate_rad_s']:.3g}"
        lines.append(f"{r['row']:<20} {r['defect_frob']:9.2e} {r['defect_det']:9.2e} {r['geodesic_dev_deg']:9.3f} "
                     f"{r['path_deg']:8.3f} {r['geodesic_deg']:9.3f} {r['ripple']:7.3f} {rate:>10} "
                     f"{r['gimbal_locks']:5d} {r['us_per_sample']:10.3f} {r['time_vs_slerp']:8.2f}  "
                     f"{', '.join(f'{a:.2f}' for a in r['mid_angles_deg'])}")
    for r in report.rows:
        for line in r["locks"]:
            lines.append(f"{r['row']}: {line}")
    return "\n".join(lines)


def write_csv(report: RotationsReport, path) -> Path:
    """The table as CSV (one row per method, COLUMNS)."""
    from .._files import write_replacing

    def write(tmp):
        with Path(tmp).open("w", newline="", encoding="utf-8") as fh:
            w = csv.DictWriter(fh, fieldnames=COLUMNS)
            w.writeheader()
            for r in report.rows:
                w.writerow({**{k: r[k] for k in COLUMNS}, "mid_angles_deg": " ".join(f"{a:g}" for a in r["mid_angles_deg"])})

    return write_replacing(Path(path), write)


def plot(report: RotationsReport, path) -> Path:
    """The interpolated frames as the seed draws them (trplot, view(170, 35)): one 3-D panel per method,
    the frame at t = 0, 2, 4, 6, 8, 10 s in red, green, blue, magenta, cyan, black, each axis an arrow from
    the origin labelled X/Y/Z at its tip. The matrix rows draw the interpolated matrix as it is."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    path = Path(path)
    labels = list(report.frames)
    cols = 4
    rows = (len(labels) + cols - 1) // cols
    fig = Figure(figsize=(4.2 * cols, 4.2 * rows), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    for i, label in enumerate(labels):
        ax = fig.add_subplot(rows, cols, i + 1, projection="3d")
        for M, colour in zip(report.frames[label], SEED_COLOURS):
            for j, name in enumerate("XYZ"):
                v = M[:, j]
                ax.plot([0.0, v[0]], [0.0, v[1]], [0.0, v[2]], color=colour, linewidth=2.0)
                ax.text(1.08 * v[0], 1.08 * v[1], 1.08 * v[2], name, color=colour, fontsize=7)
        ax.set_xlim(-1, 1)
        ax.set_ylim(-1, 1)
        ax.set_zlim(-1, 1)
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
            axis.set_ticks([-1.0, 0.0, 1.0])
        ax.set_xlabel("x")
        ax.set_ylabel("y")
        ax.set_zlabel("z")
        ax.view_init(elev=35, azim=80)  # MATLAB view([170 35]): its azimuth counts from -y, matplotlib's from +x
        ax.set_title(label, fontsize=11)
    fig.suptitle("seed 004: frames at t = 0 (r), 2 (g), 4 (b), 6 (m), 8 (c), 10 s (k)", fontsize=12)

    from .._files import write_replacing

    return write_replacing(path, lambda tmp: fig.savefig(tmp))


#: Columns of :func:`write_wrist_csv` (SI: seconds, radians, radians per second).
WRIST_COLUMNS = ("t_s", "s", "q1_rad", "q2_rad", "q3_rad", "q1_rate_rad_s", "q2_rate_rad_s", "q3_rate_rad_s", "set",
                 "omega_rad_s", "geodesic_deviation_rad", "defect_frob", "defect_det")


def write_wrist_csv(wrist, path) -> Path:
    """One :class:`explorer.wrist.WristPath` as CSV, one row per sample (:data:`WRIST_COLUMNS`); a joint
    rate is ``inf`` at an exact gimbal lock (q1 and q3 split undefined)."""
    from .._files import write_replacing

    cols = np.column_stack([wrist.t, wrist.s, wrist.angles, wrist.rates, wrist.sets, wrist.omega,
                            wrist.geodesic_deviation, wrist.defect_frob, wrist.defect_det])

    def write(tmp):
        with Path(tmp).open("w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow(WRIST_COLUMNS)
            for row in cols:
                w.writerow([repr(float(x)) if i != 8 else int(x) for i, x in enumerate(row)])

    return write_replacing(Path(path), write)
