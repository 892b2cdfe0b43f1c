"""Issue 28, several objectives and the report of an optimisation: the front's hypervolume per
generation (against an area-by-sorting sweep for two objectives and inclusion-exclusion for three,
written plainly here), what ``explorer optimize`` prints about the best design against the nominal
(every figure checked against the file's rows), and the walking-leg synthesis example."""

from __future__ import annotations

import itertools
import re
import shlex
from pathlib import Path

import numpy as np
import pytest

from explorer import open_results
from explorer.optimize import HYPERVOLUME_REFERENCE, hypervolume_per_generation, run_optimize

from clihelp import ok_cli

STUDY = """\
[study]
name = "front"
mechanism = "jansen"
seed = 5
steps = 72

[operating]
unit = 0.01
rpm = 30
load = 5

[optimize]
algorithm = "nsga2"
population = 12
generations = 4
objectives = ["travel", "bob"]
constraints = ["clearance >= 1"]
spread = 0.05
parameters = ["1-3", "2-6", "1-6", "5-7", "crank", "2.x"]

[scene]
velocities = false
"""


def dominated_by_any(P: np.ndarray) -> np.ndarray:
    """(n,) bool: rows of P (minimised) that another row dominates, by brute force."""
    n = len(P)
    out = np.zeros(n, dtype=bool)
    for i in range(n):
        for j in range(n):
            if j != i and np.all(P[j] <= P[i]) and np.any(P[j] < P[i]):
                out[i] = True
                break
    return out


def plain_normalise(F, feasible, gen):
    """F (minimised) normalised as documented, by brute force: 0 at each objective's best feasible
    value, 1 at its worst on the front as it stood after any generation."""
    ideal = F[feasible].min(axis=0)
    worst = np.full(F.shape[1], -np.inf)
    for g in np.unique(gen):
        pts = F[feasible & (gen <= g)]
        if len(pts):
            worst = np.maximum(worst, pts[~dominated_by_any(pts)].max(axis=0))
    span = np.where(worst > ideal, worst - ideal, 1.0)
    return (F - ideal) / span, ideal, worst


def area_by_sorting(P: np.ndarray, ref: float) -> float:
    """The area dominated by 2-D points P (minimised) up to (ref, ref): sort by the first objective and
    sweep, keeping the lowest second objective seen so far."""
    P = P[(P[:, 0] < ref) & (P[:, 1] < ref)]
    if len(P) == 0:
        return 0.0
    P = P[np.argsort(P[:, 0], kind="stable")]
    area, low = 0.0, ref
    xs = list(P[:, 0]) + [ref]
    for i in range(len(P)):
        low = min(low, P[i, 1])
        area += (xs[i + 1] - xs[i]) * (ref - low)
    return area


def volume_by_inclusion_exclusion(P: np.ndarray, ref: float) -> float:
    """The volume dominated by points P (minimised) up to (ref, …): the union of the boxes
    [p, ref] by inclusion-exclusion over every subset (the intersection of boxes is the box of the
    componentwise max)."""
    total = 0.0
    for k in range(1, len(P) + 1):
        for subset in itertools.combinations(range(len(P)), k):
            corner = P[list(subset)].max(axis=0)
            total += (-1) ** (k + 1) * np.prod(np.maximum(ref - corner, 0.0))
    return total


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    d = tmp_path_factory.mktemp("front")
    study = d / "front.toml"
    study.write_text(STUDY)
    return study, run_optimize(study, output=d / "front.h5", progress=False)


@pytest.mark.slow
def test_hypervolume_of_two_objectives_is_the_area_by_sorting(run):
    _, summary = run
    with open_results(summary) as res:
        df = res.frame()
    feasible = ((df["status"].astype(str) == "ok") & df["travel"].notna() & df["bob"].notna()
                & df["buildable"].astype(bool) & (df["clearance"] >= 1)).to_numpy()
    F = np.column_stack([-df["travel"].to_numpy(float), df["bob"].to_numpy(float)])  # travel is maximised
    gen = df["generation"].to_numpy()
    Fn, ideal, nadir = plain_normalise(F, feasible, gen)
    want = [area_by_sorting(Fn[feasible & (gen <= g)], 1.1) for g in range(4)]
    assert len(summary.hypervolume) == 4
    assert np.allclose(summary.hypervolume, want, rtol=1e-12, atol=1e-15)
    assert want[0] > 0 and all(b >= a for a, b in zip(want, want[1:]))
    # the reference point in the metrics' own units: the nadir + 10 % of the range (travel is negated)
    h = summary.hypervolume_detail
    assert h.reference[0] == pytest.approx(-(nadir[0] + 0.1 * (nadir[0] - ideal[0])), rel=1e-12)
    assert h.reference[1] == pytest.approx(nadir[1] + 0.1 * (nadir[1] - ideal[1]), rel=1e-12)


def test_hypervolume_of_three_objectives_by_inclusion_exclusion():
    rng = np.random.default_rng(11)
    n = 14
    F = rng.random((n, 3)) * [2.0, 30.0, 0.5] + [1.0, -5.0, 0.0]
    feasible = rng.random(n) > 0.2
    F[~feasible] = 1e30
    gen = np.repeat(np.arange(5), 3)[:n]
    values, ideal, nadir = hypervolume_per_generation(F, feasible, gen)
    Fn, _, _ = plain_normalise(F, feasible, gen)
    for g in range(5):
        pts = Fn[feasible & (gen <= g)]
        assert values[g] == pytest.approx(volume_by_inclusion_exclusion(pts, HYPERVOLUME_REFERENCE), rel=1e-12,
                                          abs=1e-15), g
    assert 0 < values[-1] <= HYPERVOLUME_REFERENCE ** 3
    # no feasible design yet: 0
    v0, _, _ = hypervolume_per_generation(F, np.zeros(n, dtype=bool), gen)
    assert np.all(v0 == 0.0)


def _number(text: str) -> float:
    return float(text.replace("%", "").replace("+", ""))


@pytest.mark.slow
def test_optimize_prints_the_best_design_against_the_nominal(run, capsys, tmp_path):
    study, _ = run
    out = ok_cli(capsys, "optimize", study, "-o", tmp_path / "cli.h5", "--quiet")
    assert out == ""
    out = ok_cli(capsys, "optimize", study, "-o", tmp_path / "cli.h5", "--force")
    block = out[out.index("best design against the nominal"):]
    v = int(re.search(r"variant (\d+)", block).group(1))
    with open_results(tmp_path / "cli.h5") as res:
        df = res.frame()
        nominal = res.nominal
    front_rows = df[df["variant"].isin(run[1].front["variant"])]
    assert v in set(front_rows["variant"])  # the design shown is on the front
    # the balanced design: the best mean of the objectives min-max normalised over the front, plainly
    t, b = front_rows["travel"].to_numpy(float), front_rows["bob"].to_numpy(float)
    score = ((t - t.min()) / np.ptp(t) + (b.max() - b) / np.ptp(b)) / 2
    assert int(front_rows["variant"].to_numpy()[np.argmax(score)]) == v
    row, row0 = df.iloc[v], df.iloc[0]
    # parameters in mm (unit 0.01 m): value, nominal, change, % of the nominal for a length
    for p in ("1-3", "2-6", "1-6", "5-7", "crank"):
        label = p if p == "crank" else f"link {p}"
        line = next(ln.strip() for ln in block.splitlines() if ln.strip().split("  ")[0] == label)
        val, nom, change, pct = line[len(label):].split()[:4]
        assert float(val) == pytest.approx(row[p] * 10.0, abs=5e-5)
        assert float(nom) == pytest.approx(nominal[p] * 10.0, abs=5e-5)
        assert _number(pct) == pytest.approx(100 * (row[p] - nominal[p]) / nominal[p], abs=5e-4)
    # objectives: travel in m/turn (x 0.01), the speed at 30 rpm in m/s, bob in mm (x 10)
    for name, k, unit in (("travel", 0.01, "m/turn"), ("speed", 0.01 * 30 / 60, "m/s"), ("bob", 10.0, "mm")):
        src = "travel" if name == "speed" else name
        line = next(ln for ln in block.splitlines() if ln.strip().startswith(name + " "))
        nom, best, change, pct, _, u = line.split()[1:7]
        assert u == unit
        assert float(nom) == pytest.approx(row0[src] * k, rel=1e-5)
        assert float(best) == pytest.approx(row[src] * k, rel=1e-5)
        assert float(pct) == pytest.approx(100 * (row[src] - row0[src]) / abs(row0[src]), rel=1e-2, abs=1e-9)
    # the command it names runs and shows that variant against the nominal
    cmd = next(ln for ln in block.splitlines() if "explorer show" in ln).split("shown in full by: ")[1]
    args = shlex.split(cmd)
    assert args[:2] == ["explorer", "show"] and args[3:] == ["--variant", str(v), "--vs", "0", "--units", "si"]
    shown = ok_cli(capsys, *args[1:])
    assert f"variant {v} of {len(df)}" in shown



@pytest.mark.slow
def test_best_design_when_the_nominal_lies_outside_the_bounds(tmp_path, capsys):
    """The file does not hold the nominal: the parameters are compared with it, the objectives are not,
    and the show command has no --vs 0."""
    text = STUDY.replace('parameters = ["1-3", "2-6", "1-6", "5-7", "crank", "2.x"]',
                         'parameters = ["1-3"]\n\n[optimize.bounds]\n"1-3" = [50.5, 51.5]')
    text = text.replace("population = 12\ngenerations = 4", "population = 4\ngenerations = 1")
    study = tmp_path / "outside.toml"
    study.write_text(text.replace("[operating]\nunit = 0.01\nrpm = 30\nload = 5\n", ""))
    out = ok_cli(capsys, "optimize", study, "-o", tmp_path / "o.h5")
    block = out[out.index("best design against the nominal"):]
    with open_results(tmp_path / "o.h5") as res:
        df = res.frame()
    v = int(re.search(r"variant (\d+)", block).group(1))
    assert df.loc[0, "1-3"] != 50.0 and 50.5 <= df.loc[v, "1-3"] <= 51.5
    line = next(ln.strip() for ln in block.splitlines() if ln.strip().startswith("link 1-3"))
    val, nom, change, pct = line[len("link 1-3"):].split()[:4]
    assert float(val) == pytest.approx(df.loc[v, "1-3"], abs=5e-5) and float(nom) == 50.0
    assert _number(pct) == pytest.approx(100 * (df.loc[v, "1-3"] - 50.0) / 50.0, abs=5e-4)
    assert "outside the [optimize] bounds" in block and "link 2-6" not in block  # only the searched ones
    assert block.rstrip().endswith(f"explorer show {tmp_path / 'o.h5'} --variant {v}")


# -- the walking-leg synthesis example ------------------------------------------------------------------
EXAMPLE = Path(__file__).resolve().parents[1] / "studies" / "jansen-stance.toml"


def arc_match_error(path: np.ndarray, q: np.ndarray) -> float:
    """The RMS distance from target points q (M, 2) to a closed polyline ``path`` (K, 2, samples in the
    direction of motion), matched by arc length as the "arc" match is documented: a_0 and a_e the path
    points closest to q_0 and q_{M-1} (here: the nearest samples of a dense path), q_i compared with the
    point f_i Λ forward of a_0, f_i the target's cumulative chord length share, Λ the arc from a_0 to a_e."""
    K = len(path)
    seg = np.linalg.norm(np.roll(path, -1, axis=0) - path, axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])  # arc length at each sample, closed
    total = s[-1]
    i0 = int(np.argmin(np.linalg.norm(path - q[0], axis=1)))
    ie = int(np.argmin(np.linalg.norm(path - q[-1], axis=1)))
    lam = (s[ie] - s[i0]) % total or total
    chords = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    f = chords / chords[-1]
    target_s = (s[i0] + f * lam) % total
    closed = np.vstack([path, path[:1]])
    x = np.interp(target_s, s, closed[:, 0])
    y = np.interp(target_s, s, closed[:, 1])
    assert K > 1000
    return float(np.sqrt(np.mean((x - q[:, 0]) ** 2 + (y - q[:, 1]) ** 2)))


@pytest.mark.slow
def test_walking_leg_synthesis_example_follows_the_drawn_stance(tmp_path, capsys):
    from naive import JANSEN_CRANK, JANSEN_LENGTHS, jansen_closed_form
    import pandas as pd
    q = pd.read_csv(EXAMPLE.parent / "jansen-stance.csv")[["x", "y"]].to_numpy(float)
    theta = np.linspace(0.0, 2 * np.pi, 20000, endpoint=False)  # the foot (vertex 7) moves with θ

    def error(lengths, crank):
        pos, ok, _ = jansen_closed_form(lengths, crank, theta)
        assert ok.all()
        return arc_match_error(pos[:, 6], q)

    nominal_error = error(JANSEN_LENGTHS, JANSEN_CRANK)
    assert nominal_error > 2.0  # the stance is drawn 2.2 units below Jansen's foot path
    out = ok_cli(capsys, "optimize", EXAMPLE, "-o", tmp_path / "stance.h5")
    assert "best design against the nominal" in out and "path_error" in out
    with open_results(tmp_path / "stance.h5") as res:
        df = res.frame()
    assert df.loc[0, "path_error"] == pytest.approx(nominal_error, rel=2e-3)  # variant 0 is Jansen's leg
    ok = df[(df["status"].astype(str) == "ok") & (df["screen"] == "pass") & (df["clearance"] >= 1)
            & (df["bob"] <= 1)]
    best = ok.loc[ok["path_error"].idxmin()]
    links = ["1-3", "3-4", "2-3", "2-4", "4-5", "2-6", "1-6", "5-6", "5-7", "6-7"]
    best_error = error(best[links].to_numpy(float), float(best["crank"]))
    # the stored error of the best leg is the plain one of its closed-form foot path
    assert best["path_error"] == pytest.approx(best_error, rel=2e-3, abs=1e-3)
    # the search reduces the error by at least 90 % against Jansen's leg, each figure computed here
    assert best_error <= 0.1 * nominal_error, (best_error, nominal_error)
    # the printed best design is that one, and it passes the screen and the walker constraints
    assert f"variant {int(best['variant'])}, the best feasible design" in out
    row = df.iloc[int(best["variant"])]
    assert row["screen"] == "pass" and bool(row["buildable"]) and row["clearance"] >= 1 and row["bob"] <= 1


# -- the front's polish (several objectives, [optimize] polish = true) -----------------------------------
@pytest.mark.slow
def test_front_polish_dominates_its_starts_and_resumes_exactly(tmp_path, monkeypatch):
    import pandas as pd
    study = tmp_path / "polish.toml"
    study.write_text(STUDY.replace("population = 12\ngenerations = 4", "population = 10\ngenerations = 3\n"
                                                                      "polish = true"))
    s = run_optimize(study, output=tmp_path / "a.h5", progress=False)
    with open_results(s) as res:
        df = res.frame()
    assert len(df) == 40 and (df["generation"].to_numpy() == np.arange(40) // 10).all()
    feasible = ((df["status"].astype(str) == "ok") & df["travel"].notna() & df["bob"].notna()
                & df["buildable"].astype(bool) & (df["clearance"] >= 1)).to_numpy()
    gen = df["generation"].to_numpy()
    # the starts: the feasible non-dominated designs of generations 0-2, by brute force
    search = feasible & (gen < 3)
    F = np.column_stack([-df["travel"].to_numpy(float), df["bob"].to_numpy(float)])
    front = set(df["variant"].to_numpy()[search][~dominated_by_any(F[search])])
    p = s.polished
    assert p["front"] == len(front) and set(p["from"]) <= front
    polished = df[(gen == 3) & (df["status"].astype(str) != "not-run")]
    assert len(polished) == p["improved"] == len(p["from"]) > 0
    for (_, row), v in zip(polished.iterrows(), p["from"]):
        start = df.iloc[v]
        assert feasible[int(row["variant"])]
        # each polished design dominates the front design it started from
        assert row["travel"] >= start["travel"] and row["bob"] <= start["bob"]
        assert row["travel"] > start["travel"] or row["bob"] < start["bob"]
    assert s.hypervolume[3] > s.hypervolume[2]
    # stopped during the polish (the search committed), --resume polishes again to the same rows
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt
    from explorer.testing import optimize_front_polish
    monkeypatch.setattr(optimize_front_polish, "polish_front", interrupted)
    with pytest.raises(KeyboardInterrupt, match="3 of 4 generations committed"):
        run_optimize(study, output=tmp_path / "b.h5", progress=False)
    monkeypatch.undo()
    s2 = run_optimize(study, output=tmp_path / "b.h5", resume=True, progress=False)
    assert s2.polished["improved"] == p["improved"]
    with open_results(s2) as res:
        pd.testing.assert_frame_equal(res.frame(), df)
