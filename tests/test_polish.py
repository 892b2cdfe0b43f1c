"""The least-squares polish of path synthesis (explorer/synthesis/_polish.py) and ``[optimize] algorithm =
"auto"``: its Jacobian against finite differences of a plain numpy closed-form four-bar written here;
recovery of a hidden four-bar made here from its coupler points, per formulation (timed, untimed with a
free crank angle per point, a closed curve all round the cycle) to 1e-9; the polish generation through
run_optimize (committed rows, --resume exact); bad [optimize] polish / restarts values."""

from __future__ import annotations

import math

import h5py
import numpy as np
import pytest

from explorer import load_mechanism, open_results
from explorer.errors import UserError
from explorer.kernels import simulate_batch
from explorer.store import seal
from explorer.optimize import run_optimize
from explorer.study import load_study
from explorer.synthesis import PathResiduals, batched_lm, distinct_best, polish

S = 72
PARAMS = ("rocker", "A-P", "B-P", "B0.x")
TRUTH = np.array([26.0, 24.0, 21.0, 31.0])
LO, HI = TRUTH * 0.9, TRUTH * 1.1
START = TRUTH * (1.0 + 0.03 * np.array([1.0, -1.0, 1.0, -1.0]))


def coupler(theta, rocker, ap, bp, b0x, *, crank=10.0, coupler_len=30.0):
    """The builtin fourbar's foot P at crank angles theta (radians), plain numpy: crank pin A on the
    circle of radius 10 about the origin, B at |B − A| = 30, |B − B0| = rocker below the line A → B0,
    P at |P − A| = ap, |P − B| = bp on the right of A → B (the builtin's assembly)."""
    theta = np.asarray(theta, dtype=float)
    A = crank * np.stack([np.cos(theta), np.sin(theta)], -1)
    d = np.array([b0x, 0.0]) - A
    dist = np.linalg.norm(d, axis=-1)
    u = d / dist[..., None]
    perp = np.stack([-u[..., 1], u[..., 0]], -1)
    a = (coupler_len ** 2 - rocker ** 2 + dist ** 2) / (2 * dist)
    B = A + a[..., None] * u - np.sqrt(coupler_len ** 2 - a ** 2)[..., None] * perp
    e = (B - A) / coupler_len
    eperp = np.stack([-e[..., 1], e[..., 0]], -1)
    a2 = (ap ** 2 - bp ** 2 + coupler_len ** 2) / (2 * coupler_len)
    return A + a2 * e - math.sqrt(ap ** 2 - a2 ** 2) * eperp


def kernel_simulate(X):
    """One batch solve of designs X (n, 4) in PARAMS order: foot, velocity (n, S, 2), ok (n,)."""
    mech = load_mechanism("fourbar")
    names = list(mech.link_names)
    L = np.broadcast_to(mech.lengths, (len(X), len(names))).copy()
    for j, p in enumerate(PARAMS[:3]):
        L[:, names.index(p)] = X[:, j]
    b = simulate_batch(mech, L, None, S, velocities=True, geometry={"B0.x": X[:, 3].copy()})
    return b.paths["P"], b.velocities["P"], b.status == 0


def samples(k):
    return 2 * np.pi * np.asarray(k) / S


def test_the_kernel_is_the_closed_form():
    """The reference itself: the kernel's foot path of the hidden four-bar is the closed form's."""
    foot, _, ok = kernel_simulate(TRUTH[None])
    assert ok[0]
    assert np.max(np.abs(foot[0] - coupler(samples(np.arange(S)), *TRUTH))) < 1e-9


@pytest.mark.parametrize("form", ["timed", "untimed"])
def test_jacobian_matches_finite_differences_of_the_closed_form(form):
    k = np.array([0, 7, 15, 26, 40, 51, 63])
    th = samples(k)
    target = coupler(th, *TRUTH) + 0.3  # any target: the Jacobian does not depend on it
    x = START.copy()
    if form == "timed":
        res = PathResiduals(kernel_simulate, target, match="timed", angles=th)
        z = x
    else:
        res = PathResiduals(kernel_simulate, target, match="closest")
        z = np.concatenate([x, th])  # free angles at samples: the kernel's tangent there is its velocity
    step = 1e-6 * np.abs(x)
    J = res.jacobian(z, 4, step, HI)
    assert J.shape == (2 * len(k), len(z))

    def closed(zz):
        return (coupler(th if form == "timed" else zz[4:], *zz[:4]) - target).ravel()

    ref = np.zeros_like(J)
    for j in range(len(z)):
        h = 1e-6 * max(abs(z[j]), 1.0)
        dz = np.zeros(len(z))
        dz[j] = h
        ref[:, j] = (closed(z + dz) - closed(z - dz)) / (2 * h)
    assert np.max(np.abs(J - ref)) <= 1e-5 * np.max(np.abs(ref))


CASES = {
    # timed: twelve points at their crank angles (every 30°)
    "timed": dict(k=np.arange(0, S, 6), match="timed"),
    # untimed (the literature's formulation): eight points of an open stretch, each angle a free variable
    "untimed": dict(k=np.array([2, 5, 9, 14, 20, 27, 33, 40]), match="closest"),
    # a closed curve: eighteen points all round the cycle (20° steps), untimed
    "closed": dict(k=np.arange(0, S, 4), match="closest"),
    # the same closed curve, timed
    "closed-timed": dict(k=np.arange(0, S, 4), match="timed"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_polish_recovers_a_hidden_fourbar(case):
    """Targets are the closed form's points of the hidden four-bar; from a start 3 % off in every
    parameter the polish recovers the parameters to 1e-9 and drives the sum of squares below 1e-18."""
    c = CASES[case]
    th = samples(c["k"])
    target = coupler(th, *TRUTH)
    res = PathResiduals(kernel_simulate, target, match=c["match"], angles=th if c["match"] == "timed" else None)
    r = polish(res, START, LO, HI)
    assert r.start_cost > 1e-2
    assert r.cost < 1e-18
    assert np.max(np.abs(r.x - TRUTH)) < 1e-9, r.x - TRUTH
    if c["match"] == "closest":  # the free angles land on the hidden design's
        dth = np.angle(np.exp(1j * (r.theta - th)))
        assert np.max(np.abs(dth)) < 1e-8
    assert r.evaluations > 0 and r.iterations > 0


def test_polish_of_a_failing_start_returns_it():
    bad = np.array([60.0, 24.0, 21.0, 31.0])  # the rocker cannot reach: no full cycle
    res = PathResiduals(kernel_simulate, coupler(samples([0, 10]), *TRUTH), match="closest")
    r = polish(res, bad, LO, np.maximum(HI, bad))
    assert r.cost == math.inf and np.array_equal(r.x, bad)


def test_distinct_best_picks_best_first_and_spreads():
    X = np.array([[0.0], [0.01], [0.5], [0.2], [0.9]])
    f = np.array([1.0, 0.5, 3.0, np.nan, 2.0])
    # best 0.5 (row 1), row 0 is within 5 % of row 1, then row 4 (2.0), then row 2 (3.0); NaN never
    assert distinct_best(X, f, [0.0], [1.0], 5) == [1, 4, 2]
    assert distinct_best(X, f, [0.0], [1.0], 2) == [1, 4]


def study_dict(match, generations=4, **opt):
    th = samples(np.arange(0, S, 6))
    target = {"points": coupler(th, *TRUTH).tolist()}
    if match == "timed":
        target["angles_deg"] = np.degrees(th).tolist()
    else:
        target["match"] = match
    return {"study": {"name": "polish", "mechanism": "fourbar", "seed": 2, "steps": S},
            "target": target,
            "optimize": {"population": 8, "generations": generations, "objectives": ["path_error"], "screen": False,
                         "bounds": {p: [lo, hi] for p, lo, hi in zip(PARAMS, LO.tolist(), HI.tolist())}, **opt},
            "scene": {"vertices": ["P"], "metrics": ["path_error"]}}


@pytest.mark.slow
def test_auto_polishes_into_a_committed_generation_and_resumes_exactly(tmp_path):
    """auto = DE, then the polish of the best distinct designs committed as generation G: the best row
    is a polished one, at the hidden design to 1e-9, its stored path_error recomputed plainly here; a
    file whose polish generation is undone resumes to the same bytes."""
    study = study_dict("closest")
    s = run_optimize(study, output=tmp_path / "a.h5", progress=False)
    # the batched LM (default polish_starts) takes every start to the hidden design: one distinct answer
    n = s.polished["starts"]
    assert s.polished is not None and 1 <= n <= 5
    best = s.front.iloc[0]
    assert int(best["generation"]) == 4
    assert best["path_error"] < 1e-9
    assert np.max(np.abs(best[list(PARAMS)].to_numpy(dtype=float) - TRUTH)) < 1e-9
    with open_results(s) as r:
        df = r.frame()
        P = r.file["paths/P"][int(best["variant"])]
    assert (df["generation"] == 4).sum() == 8 and (df[df["generation"] == 4]["status"].astype(str) == "ok").sum() == n
    th = samples(np.arange(0, S, 6))
    q = coupler(th, *TRUTH)
    d = np.min(np.linalg.norm(P[None, :, :] - q[:, None, :], axis=2), axis=1)  # samples only: an upper bound
    assert best["path_error"] <= np.sqrt(np.mean(d ** 2)) + 1e-12
    assert f"polish: {n} start" in s.text()

    # undo the polish generation; --resume solves it again from the file's rows: the same bytes
    b = tmp_path / "b.h5"
    b.write_bytes((tmp_path / "a.h5").read_bytes())
    with h5py.File(b, "r+") as f:
        done = f["chunks/done"][...]
        done[4] = False
        f["chunks/done"][...] = done
    seal(b)
    s2 = run_optimize(study, output=b, resume=True, progress=False)
    assert s2.polished["solved"] is not None and s2.polished["best_after"] == s.polished["best_after"]
    with h5py.File(tmp_path / "a.h5", "r") as fa, h5py.File(b, "r") as fb:
        for n in ("variants/lengths", "variants/generation", "metrics/path_error", "status", "paths/P"):
            assert fa[n][...].tobytes() == fb[n][...].tobytes(), n


def test_polish_without_the_batched_lm_polishes_one_plus_restarts_starts(tmp_path):
    s = run_optimize(study_dict("timed", generations=2, polish_starts=0), output=tmp_path / "d.h5", progress=False)
    assert s.polished["starts"] == 5 and s.polished["best_after"] < 1e-9


def test_polish_stays_inside_a_constraint_the_least_squares_answer_breaks(tmp_path):
    """A constraint the unconstrained answer breaks (path_error >= 0.05; the least squares alone reaches
    ~0): the polish inside the constraints (augmented Lagrangian, then the feasible point nearest its
    answer) ends on the constraint's boundary, the best feasible design is a committed polished row, and
    the stopping rule names the constraint that holds it."""
    study = study_dict("timed", generations=2, constraints=["path_error >= 0.05"])
    s = run_optimize(study, output=tmp_path / "e.h5", progress=False)
    with open_results(s) as r:
        df = r.frame()
    pol = df[(df["generation"] == 2) & (df["status"].astype(str) == "ok")]
    pe = pol["path_error"].to_numpy(dtype=float)
    assert s.polished["best_before"] > 0.1
    assert 0.05 <= s.polished["best_after"] <= 0.05 * (1 + 1e-6)
    assert s.polished["best_after"] == pe[pe >= 0.05].min()
    assert s.polished["held"]["constraints"] == ["path_error >= 0.05"] and not s.polished["held"]["exact"]
    assert "held by the constraint `path_error >= 0.05`" in s.text()


def test_timed_study_with_polish_off_has_no_polish_generation(tmp_path):
    s = run_optimize(study_dict("timed", generations=2, polish=False), output=tmp_path / "c.h5", progress=False)
    assert s.polished is None
    with open_results(s) as r:
        assert int(r.frame()["generation"].max()) == 1


@pytest.mark.parametrize("edit, key, value", [
    ({"polish": "yes"}, "optimize.polish", "'yes'"),
    ({"restarts": -1}, "optimize.restarts", "-1"),
    ({"restarts": 8}, "optimize.restarts", "8"),  # at most population - 1
    ({"restarts": 1.5}, "optimize.restarts", "1.5"),
    ({"polish_starts": -3}, "optimize.polish_starts", "-3"),
    ({"polish_starts": "many"}, "optimize.polish_starts", "'many'"),
    ({"polish": True, "algorithm": "nsga2"}, "optimize.polish", "nsga2"),
    ({"algorithm": "simplex"}, "optimize.algorithm", "'simplex'"),
])
def test_bad_polish_keys_are_one_line_errors(tmp_path, edit, key, value):
    from explorer.study import dumps_toml
    p = tmp_path / "bad.toml"
    p.write_text(dumps_toml(study_dict("timed", **edit)))
    with pytest.raises(UserError) as e:
        load_study(p)
    msg = str(e.value)
    assert "\n" not in msg and str(p) in msg and key in msg and value in msg


def test_polish_needs_the_path_error_objective(tmp_path):
    from explorer.study import dumps_toml
    d = study_dict("timed", polish=True)
    d["optimize"]["objectives"] = ["travel"]
    d["scene"]["metrics"] = ["travel"]
    p = tmp_path / "travel.toml"
    p.write_text(dumps_toml(d))
    with pytest.raises(UserError, match=r"optimize\.polish.*path_error"):
        load_study(p)


def test_auto_defaults():
    """auto is the default; polish defaults on for path_error, restarts to 4 (at most population - 1)."""
    s = load_study(study_dict("timed"))
    opt = s.optimize
    assert opt.algorithm == "auto" and opt.search == "de" and opt.polish and opt.restarts == 4
    assert s.n_variants == 8 * 5  # four generations and the polish generation
    d = study_dict("timed")
    d["optimize"]["population"] = 4
    assert load_study(d).optimize.restarts == 3


# --- the batched bounded Levenberg–Marquardt (batched_lm) ----------------------------------------

def numpy_simulate(X):
    """A plain numpy batch solve (no kernel): the closed form's foot at the S samples of designs X (n, 4)
    in PARAMS order, no velocity (straight segments between samples), ok where the closed form is real."""
    th = samples(np.arange(S))
    with np.errstate(invalid="ignore"):
        foot = np.stack([coupler(th, *x) for x in X])
    return foot, None, np.all(np.isfinite(foot), axis=(1, 2))


SIGNS = np.array([[1, -1, 1, -1], [-1, -1, 1, 1], [1, 1, -1, -1], [-1, 1, 1, -1], [1, 1, 1, 1], [-1, -1, -1, -1]])


@pytest.mark.parametrize("case, simulate", [("timed", "numpy"), ("timed", "kernel"), ("closed", "kernel")])
def test_batched_lm_recovers_a_hidden_fourbar_from_several_starts(case, simulate):
    """Six starts 3–5 % off in every parameter, advanced together: each reaches the hidden four-bar to
    1e-9 in the parameters (sum of squares < 1e-18), inside the bounds; the untimed case's free angles
    land on the hidden design's. With numpy's closed form (straight segments: its points at the samples
    are exact) and with the kernel (the untimed case: its free angles need the kernel's smooth path)."""
    c = CASES[case]
    th = samples(c["k"])
    res = PathResiduals(numpy_simulate if simulate == "numpy" else kernel_simulate, coupler(th, *TRUTH),
                        match=c["match"], angles=th if c["match"] == "timed" else None)
    starts = TRUTH * (1.0 + np.array([0.03, 0.05, 0.04, 0.03, 0.05, 0.04])[:, None] * SIGNS)
    r = batched_lm(res, starts, LO, HI, iterations=100)
    assert np.all(r.start_cost > 1e-2)
    assert np.all(r.cost < 1e-18), r.cost
    assert np.max(np.abs(r.X - TRUTH)) < 1e-9, r.X - TRUTH
    assert np.all((r.X >= LO) & (r.X <= HI))
    assert r.calls <= 100 + 2 and r.evaluations <= r.calls * len(starts) * (1 + 2 * 4)  # central differences
    if c["match"] == "closest":
        assert np.max(np.abs(np.angle(np.exp(1j * (r.theta - th[None]))))) < 1e-8


def test_batched_lm_holds_the_bounds_and_agrees_with_scipy_where_one_binds():
    """The hidden rocker length lies above the box: every start ends on that bound (never past it), at
    the answer scipy's bounded least_squares reaches on the same numpy residuals."""
    from scipy.optimize import least_squares
    th = samples(np.arange(0, S, 6))
    target = coupler(th, *TRUTH)
    hi = HI.copy()
    hi[0] = TRUTH[0] - 0.5
    res = PathResiduals(numpy_simulate, target, match="timed", angles=th)
    starts = np.minimum(TRUTH * (1.0 + 0.03 * SIGNS[:4]), hi)
    r = batched_lm(res, starts, LO, hi, iterations=200)

    def fun(x):
        return (coupler(th, *x) - target).ravel()

    ref = least_squares(fun, starts[0], bounds=(LO, hi), method="trf", xtol=1e-15, ftol=1e-15, gtol=1e-15)
    assert np.all((r.X >= LO) & (r.X <= hi))
    assert np.all(r.X[:, 0] == hi[0])
    assert np.max(np.abs(r.X - ref.x)) < 1e-7, r.X - ref.x
    assert np.allclose(r.cost, np.sum(ref.fun ** 2), rtol=1e-9)


def test_batched_lm_agrees_with_scipy_on_a_convex_problem():
    """Residuals linear in the parameters (an ellipse's points x0 + a cos θ, y0 + b sin θ against
    scattered points; two bounds bind): one minimum, which every start and scipy's least_squares reach
    to 1e-9."""
    from scipy.optimize import least_squares
    th_s = samples(np.arange(S))

    def simulate(X):
        foot = np.stack([X[:, 0, None] + X[:, 1, None] * np.cos(th_s), X[:, 2, None] + X[:, 3, None] * np.sin(th_s)], -1)
        return foot, None, np.ones(len(X), bool)

    rng = np.random.default_rng(3)
    k = np.arange(0, S, 3)
    target = np.stack([1.0 + 3.0 * np.cos(th_s[k]), 2.0 + 1.5 * np.sin(th_s[k])], -1) + 0.1 * rng.standard_normal((len(k), 2))
    lo, hi = np.array([-5.0, 0.5, 2.2, 0.5]), np.array([5.0, 2.5, 5.0, 4.0])
    res = PathResiduals(simulate, target, match="timed", angles=th_s[k])
    starts = lo + rng.random((5, 4)) * (hi - lo)
    r = batched_lm(res, starts, lo, hi)

    def fun(x):
        return np.stack([x[0] + x[1] * np.cos(th_s[k]), x[2] + x[3] * np.sin(th_s[k])], -1).ravel() - target.ravel()

    ref = least_squares(fun, starts[0], bounds=(lo, hi), method="trf", xtol=1e-15, ftol=1e-15, gtol=1e-15)
    assert ref.x[1] == pytest.approx(2.5) and ref.x[2] == pytest.approx(2.2)  # both bounds bind
    assert np.max(np.abs(r.X - ref.x)) < 1e-9, r.X - ref.x
    assert np.all((r.X >= lo) & (r.X <= hi))


def test_batched_lm_keeps_a_failing_start_and_refuses_bad_arguments():
    bad = np.array([60.0, 24.0, 21.0, 31.0])  # the rocker cannot reach: no full cycle
    th = samples(np.arange(0, S, 6))
    res = PathResiduals(numpy_simulate, coupler(th, *TRUTH), match="timed", angles=th)
    r = batched_lm(res, np.vstack([bad, START]), LO, np.maximum(HI, bad))
    assert r.cost[0] == math.inf and np.array_equal(r.X[0], bad) and r.cost[1] < 1e-18
    with pytest.raises(ValueError):
        batched_lm(res, START[None], LO, HI, iterations=0)
