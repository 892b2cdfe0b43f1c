"""The ``yield`` metric (explorer.study._yield): the share of copies of a design, cut with a
manufacturing error on every design parameter, that assemble over the whole turn and pass the
buildability screen.

The reference is a plain loop over copies written here: the copies' parameters from the documented
common random numbers, Jansen's leg by sequential circle-circle intersections (tests/naive.py), and
the four screen checks computed plainly (sampled transmission angle, headroom, finite-difference foot
speed, brute-force crossings).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from explorer.errors import UserError
from explorer.gait import Screen
from explorer.mechanism import load_mechanism
from explorer.study import design_yield, load_study, robustness_from_dict, run_study
from explorer.testing import study_yield as yield_module

from naive import JANSEN_LINKS, circle_circle, cross, jansen_signs

JANSEN = load_mechanism("jansen")
ORDER = (("3", "1", "2"), ("4", "3", "2"), ("6", "1", "2"), ("5", "4", "6"), ("7", "5", "6"))


def _copies_by_hand(design: dict, tol: float, unit: str, distribution: str, copies: int, seed: int) -> list[dict]:
    """Each copy's parameters, written from the module docstring: draws over every parameter in
    Mechanism.parameters() order; lengths × (1 + t·u), coordinates + t·u·size (unit "%") or every
    parameter + t·u (unit "model")."""
    names = list(JANSEN.parameters())
    rng = np.random.default_rng(seed)
    U = rng.uniform(-1.0, 1.0, (copies, len(names))) if distribution == "uniform" else \
        rng.standard_normal((copies, len(names))) / 3.0
    out = []
    lengths = set(JANSEN.link_names) | {"crank"}
    for j in range(copies):
        c = {}
        for i, p in enumerate(names):
            if unit == "%":
                t = tol / 100.0
                c[p] = design[p] * (1.0 + t * U[j, i]) if p in lengths else design[p] + t * U[j, i] * JANSEN.size
            else:
                c[p] = design[p] + tol * U[j, i]
        out.append(c)
    return out


def _walks_by_hand(c: dict, screen: Screen, signs) -> bool:
    """Does one copy assemble over a full turn (every dyad's circles meet at 1,440 angles) and pass the
    four screen checks? Plain numpy on the closed form."""
    def leg(thetas):
        P = {"1": np.stack([c["crank.x"] + c["crank"] * np.cos(thetas), c["crank.y"] + c["crank"] * np.sin(thetas)], -1),
             "2": np.broadcast_to(np.array([c["2.x"], c["2.y"]]), (len(thetas), 2))}
        L = {pair: c[f"{pair[0]}-{pair[1]}"] for pair in JANSEN_LINKS}

        def length(u, w):
            return L[(u, w)] if (u, w) in L else L[(w, u)]
        least = np.inf
        for v, a, b in ORDER:
            P[v], slack = circle_circle(P[a], P[b], length(a, v), length(b, v), signs[v])
            least = min(least, float(np.nanmin(np.where(np.isfinite(slack), slack, -1.0))))
        return P, least

    _, least = leg(np.linspace(0.0, 2 * np.pi, 1440, endpoint=False))
    if not least > 0.0:
        return False
    th = np.linspace(0.0, 2 * np.pi, 360, endpoint=False)
    P, _ = leg(th)
    foot = P["7"]
    # toggle: the transmission angle at 3 (loop 1-3-2) and 6 (loop 1-6-2), sampled finely
    fine = np.linspace(0.0, 2 * np.pi, 7200, endpoint=False)
    Pf, _ = leg(fine)
    mu_min = np.inf
    for v in ("3", "6"):
        a = Pf["1"] - Pf[v]
        b = Pf["2"] - Pf[v]
        cos = np.sum(a * b, -1) / (np.hypot(*a.T) * np.hypot(*b.T))
        mu = np.degrees(np.arccos(np.clip(cos, -1, 1)))
        mu_min = min(mu_min, float(np.min(np.minimum(mu, 180.0 - mu))))
    if mu_min < screen.min_transmission_angle:
        return False
    # foot above the frame
    headroom = min(c["crank.y"], c["2.y"]) - float(np.max(foot[:, 1]))
    if headroom < screen.min_foot_headroom:
        return False
    # foot whip: central differences of the closed form
    h = 1e-6
    Pp, _ = leg(th + h)
    Pm, _ = leg(th - h)
    speed = np.hypot(*((Pp["7"] - Pm["7"]) / (2 * h)).T)
    if np.max(speed) / c["crank"] > screen.max_foot_speed:
        return False
    # crossing path: proper crossings between non-adjacent segments of the closed polyline
    S = len(foot)
    p, q = foot, np.roll(foot, -1, axis=0)
    crossings = 0
    for i in range(S):
        j = np.arange(i + 2, S)
        if i == 0:
            j = j[j != S - 1]  # the last segment is adjacent to the first
        if not len(j):
            continue
        d1 = cross(q[i] - p[i], p[j] - p[i])
        d2 = cross(q[i] - p[i], q[j] - p[i])
        d3 = cross(q[j] - p[j], p[i] - p[j])
        d4 = cross(q[j] - p[j], q[i] - p[j])
        crossings += int(np.sum((d1 * d2 < 0) & (d3 * d4 < 0)))
    return crossings <= screen.max_self_crossings


def _designs():
    """Three Jansen designs: the nominal and two others, crank centre and pivot 2 moved too."""
    nominal = JANSEN.parameters()
    rng = np.random.default_rng(2)
    out = [dict(nominal)]
    for _ in range(2):
        d = {p: (v * (1 + 0.015 * rng.uniform(-1, 1)) if JANSEN.parameter_kind(p) == "length"
                 else v + 0.3 * rng.uniform(-1, 1)) for p, v in nominal.items()}
        out.append(d)
    return out


def _explorer_yield(designs, rb, screen=None):
    L = np.array([[d[n] for n in JANSEN.link_names] for d in designs])
    r = np.array([d["crank"] for d in designs])
    geo = {p: np.array([d[p] for d in designs]) for p in ("crank.x", "crank.y", "2.x", "2.y")}
    return design_yield(JANSEN, L, r, geo, robustness=rb, steps=360, screen=screen)


@pytest.mark.parametrize("tol,unit,distribution", [(3.0, "%", "uniform"), (1.5, "model", "normal")])
def test_yield_equals_a_plain_loop_over_copies(tol, unit, distribution):
    copies, seed = 40, 11
    rb = robustness_from_dict({"tolerance": tol, "unit": unit, "distribution": distribution, "copies": copies,
                               "seed": seed}, "test", JANSEN)
    designs = _designs()
    got = _explorer_yield(designs, rb)
    screen = Screen()
    signs = jansen_signs()
    want = []
    for d in designs:
        want.append(sum(_walks_by_hand(c, screen, signs) for c in _copies_by_hand(d, tol, unit, distribution,
                                                                                copies, seed)))
    assert got.count.tolist() == want
    assert np.array_equal(got.share, np.array(want) / copies)
    # the outcomes are mixed, and the screen removes copies that assemble: the comparison says something
    assert 0 < sum(want) < copies * len(designs)
    assembles = [sum(_walks_by_hand(c, Screen(5.0, -1e9, 1e9, 10 ** 9), signs)
                     for c in _copies_by_hand(d, tol, unit, distribution, copies, seed)) for d in designs]
    assert sum(assembles) > sum(want)
    p = got.share
    assert np.allclose(got.se, np.sqrt(p * (1 - p) / copies))


def test_common_random_numbers_and_one_call_per_block(monkeypatch):
    """The same design gets the same yield wherever it sits in the batch, and splitting the batch into
    more kernel calls changes nothing (copy j of every design is cut with the same errors)."""
    rb = robustness_from_dict({"tolerance": 3.0, "copies": 32, "seed": 4}, "test", JANSEN)
    d = _designs()
    a = _explorer_yield([d[1], d[0], d[2], d[0]], rb)
    assert a.count[1] == a.count[3]
    monkeypatch.setattr(yield_module, "MAX_ROWS", 40)  # one design per call
    b = _explorer_yield([d[1], d[0], d[2], d[0]], rb)
    assert np.array_equal(a.count, b.count)


def test_a_tolerance_in_mm_is_the_same_cut_in_model_units():
    """0.15 mm on a mechanism drawn in centimetres (unit 0.01 m) is 0.015 model units."""
    from explorer.mechanism import operating_from_dict
    op = operating_from_dict({"unit": 0.01}, "test", "operating")
    mm = robustness_from_dict({"tolerance": 0.15 * 40, "unit": "mm", "copies": 24}, "test", JANSEN, op)
    model = robustness_from_dict({"tolerance": 0.015 * 40, "unit": "model", "copies": 24}, "test", JANSEN)
    d = _designs()[:1]
    assert np.array_equal(_explorer_yield(d, mm).count, _explorer_yield(d, model).count)
    with pytest.raises(UserError, match=r"robustness\.unit.*\[operating\] unit"):
        robustness_from_dict({"tolerance": 0.1, "unit": "mm"}, "f.toml", JANSEN, None)


@pytest.mark.parametrize("table,words", [
    ({}, "robustness.tolerance: missing"),
    ({"tolerance": -1}, "robustness.tolerance: expected"),
    ({"tolerance": 0.5, "unit": "inch"}, "robustness.unit"),
    ({"tolerance": 0.5, "distribution": "cauchy"}, "robustness.distribution"),
    ({"tolerance": 0.5, "copies": 1}, "robustness.copies"),
    ({"tolerance": 0.5, "copies": True}, "robustness.copies"),
    ({"tolerance": 0.5, "parameters": ["9-9"]}, "unknown design parameter"),
    ({"tolerance": 0.5, "spread": 1}, "robustness.spread: unknown key"),
])
def test_bad_robustness_tables_are_one_line_errors_naming_file_and_key(table, words):
    with pytest.raises(UserError) as e:
        robustness_from_dict(table, "my-study.toml", JANSEN)
    msg = str(e.value)
    assert msg.startswith("my-study.toml: ") and words in msg and "\n" not in msg


def _study(tmp_path, **extra):
    d = {"study": {"name": "y", "mechanism": "jansen", "variants": 6, "seed": 1, "steps": 120},
         "perturb": {"spread": 0.01, "parameters": "all"},
         "scene": {"metrics": ["travel", "yield"]},
         "robustness": {"tolerance": 2.0, "copies": 24, "seed": 3},
         "output": {"path": str(tmp_path / "y.h5"), "compression": "none"}}
    for k, v in extra.items():
        if v is None:
            d.pop(k)
        else:
            d[k] = v
    return d


def test_a_study_stores_yield_equal_to_the_designs_yield(tmp_path):
    from explorer.store import open_results
    from explorer.analysis import results_yield
    study = load_study(_study(tmp_path))
    run_study(study, output=tmp_path / "y.h5", progress=False)
    with open_results(tmp_path / "y.h5") as r:
        df = r.frame()
        stored = df["yield"].to_numpy()
        again = results_yield(r, range(len(df)))
        assert r.study["robustness"]["tolerance"] == 2.0
    assert np.array_equal(stored, again.share)
    assert np.all((stored >= 0) & (stored <= 1))
    # a study without [robustness] keeps its fingerprint (no robustness key at all)
    plain = load_study(_study(tmp_path, robustness=None, scene={"metrics": ["travel"]}))
    assert "robustness" not in plain.as_dict()


def test_yield_without_robustness_is_refused(tmp_path):
    with pytest.raises(UserError, match=r"scene\.metrics: 'yield' needs a \[robustness\] table"):
        load_study(_study(tmp_path, robustness=None))


def test_optimize_constraint_on_yield(tmp_path):
    """``constraints = ["yield >= 0.8"]``: the filter grammar reads the keyword-named column, the
    optimiser computes yield, and every feasible design meets the constraint."""
    pytest.importorskip("pymoo")
    from explorer.store import open_results
    from explorer.optimize import feasible_mask, optimization_of, run_optimize
    d = {"study": {"name": "yo", "mechanism": "jansen", "seed": 2, "steps": 90},
         "optimize": {"algorithm": "nsga2", "population": 8, "generations": 2, "objectives": ["travel", "bob"],
                      "constraints": ["yield >= 0.8"], "spread": 0.03, "parameters": ["1-3", "crank"]},
         "scene": {"vertices": ["7"], "velocities": False},
         "robustness": {"tolerance": 2.0, "copies": 16}}
    out = tmp_path / "yo.h5"
    run_optimize(load_study(d), output=out, progress=False)
    with open_results(out) as r:
        df = r.frame()
        feasible = feasible_mask(df, optimization_of(r), r.screen)
    assert "yield" in df.columns and np.isfinite(df["yield"]).all()
    assert (df.loc[feasible, "yield"] >= 0.8).all()
    assert (~feasible & (df["yield"] < 0.8)).any() or (df["yield"] >= 0.8).all()


def test_se_is_binomial():
    rb = robustness_from_dict({"tolerance": 1.0, "copies": 256}, "t", JANSEN)
    res = yield_module.YieldResult(share=np.array([0.95, 1.0, 0.5]), count=np.array([243, 256, 128]), copies=256,
                                   robustness=rb)
    assert res.se[0] == pytest.approx(math.sqrt(0.95 * 0.05 / 256))
    assert res.se[1] == 0.0 and res.se[2] == pytest.approx(0.5 / 16)


# -- the command line: rank --yield, show ------------------------------------------------------------------
@pytest.fixture(scope="module")
def yield_file(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("yield")
    d = _study(tmp)
    d["scene"] = {"metrics": ["travel", "bob", "body_speed_ripple", "peak_torque", "clearance", "yield",
                              "min_transmission_angle", "foot_headroom", "max_speed", "self_crossings"]}
    run_study(load_study(d), output=tmp / "y.h5", progress=False)
    return tmp / "y.h5"


def _cli(capsys, *argv):
    from explorer.cli import main
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_rank_yield_is_each_shown_designs_yield(yield_file, capsys):
    """--yield 3% --copies 20 on the shown rows: each equals design_yield of the design read back from the
    csv's own columns, and yield_se is √(p(1 − p)/20)."""
    import io

    import pandas as pd
    code, out, _ = _cli(capsys, "rank", str(yield_file), "--yield", "3%", "--copies", "20", "--top", "3",
                        "--format", "csv")
    assert code == 0
    df = pd.read_csv(io.StringIO(out))
    assert len(df) == 3
    rb = robustness_from_dict({"tolerance": 3.0, "copies": 20}, "t", JANSEN)
    designs = [{p: float(df[p].iloc[i]) if p in df.columns else JANSEN.parameters()[p] for p in JANSEN.parameters()}
               for i in range(3)]
    want = _explorer_yield(designs, rb)
    assert np.array_equal(df["yield"].to_numpy(), want.share)
    p = df["yield"].to_numpy()
    assert np.allclose(df["yield_se"].to_numpy(), np.sqrt(p * (1 - p) / 20))
    # the table: the study's own [robustness] (24 copies at ±2 %), the reference row included
    code, out, _ = _cli(capsys, "rank", str(yield_file), "--yield", "--top", "2")
    assert code == 0 and "±2 % (uniform) on every design parameter, 24 copies" in out and "yield_se" in out
    assert out.strip().splitlines()[-1].startswith("nominal:")


def test_show_gives_yield_with_its_error_and_warns(yield_file, capsys):
    from explorer.store import open_results
    with open_results(yield_file) as r:
        p = float(r.row(0)["yield"])
    code, out, _ = _cli(capsys, "show", str(yield_file), "--variant", "0")
    assert code == 0
    line = next(s for s in out.splitlines() if s.startswith("yield (will it survive the workshop?)"))
    assert f"{p:.3f} ± {math.sqrt(p * (1 - p) / 24):.3f}" in line
    assert ("warning: only" in out) == (p < 0.95)
    # a tolerance wide enough that few copies walk always warns
    code, out, _ = _cli(capsys, "show", str(yield_file), "--variant", "0", "--yield", "8%", "--copies", "16")
    assert code == 0 and "warning: only" in out and "±8 % (uniform)" in out


@pytest.mark.parametrize("argv,words", [
    (["rank", "{f}", "--yield", "2in"], "--yield: expected a tolerance"),
    (["rank", "{f}", "--copies", "8"], "--copies goes with --yield TOL"),
    (["show", "{f}", "--variant", "0", "--copies", "8"], "--copies goes with --yield TOL"),
    (["rank", "{f}", "--yield", "1mm"], "[operating] unit"),
])
def test_bad_yield_options_exit_2_in_one_line(yield_file, capsys, argv, words):
    code, out, err = _cli(capsys, *[a.format(f=yield_file) for a in argv])
    assert code == 2 and words in err and len(err.strip().splitlines()) == 1


def test_rank_yield_needs_a_tolerance_without_robustness(tmp_path, capsys):
    d = _study(tmp_path, robustness=None, scene={"metrics": ["travel"]})
    run_study(load_study(d), output=tmp_path / "n.h5", progress=False)
    code, _, err = _cli(capsys, "rank", str(tmp_path / "n.h5"), "--by", "travel", "--yield")
    assert code == 2 and "no [robustness] table" in err and "n.h5" in err


def test_report_shows_yield_against_the_reference(yield_file):
    """The report's table of the best designs against the reference carries the stored yield and its change,
    and says what the copies were cut with."""
    import re

    from explorer.store import open_results
    from explorer.view import report_html
    page = report_html(yield_file)
    assert "id='vs-yield'" in page and "±2 % (uniform) on every design parameter, 24 copies" in page
    with open_results(yield_file) as r:
        p0 = float(r.row(0)["yield"])
    ref = re.search(r"<tr class='ref'[^>]*>.*?</tr>", page).group(0)
    cell = re.search(r"data-key='yield' data-value='([^']*)'", ref)
    assert cell is not None and float(cell.group(1)) == p0
