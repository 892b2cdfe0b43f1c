"""How precisely must the parts be cut? The largest manufacturing spread at which a target share of
legs still walks, found by bisection on the spread with small studies (what ``explorer tolerance``
runs).

Each evaluation is a uniform study of ``variants`` variants (variant 0, the nominal, plus
``variants − 1`` designs with every chosen parameter within ±spread: lengths relatively, coordinates
by spread × the mechanism's size, as ``[perturb]`` does), run by :func:`~explorer.study.run_study`
into a temporary file, and the share of the sampled designs that meet the criterion. The chosen
parameters are by default every design parameter (links, crank radius and centre, ground pivots,
body points: a workshop cuts the holes in the bodies and the frame with the same error as the links);
``"links"`` keeps the links and the crank radius only, as a default ``[perturb]`` study does.
The criterion:

* ``assembles`` (default): solved over a full crank turn (status ok);
* ``buildable``: that, and passing the buildability screen (the study computes the four metrics the
  screen reads).

Every evaluation uses the same seed, so the spreads are compared on common random numbers: the same
draws u in [−1, 1]^k scaled by each spread (a design moves along a fixed ray from the nominal as the
spread grows), and the share is (nearly) monotone in the spread. The search starts at ``spread``;
while the share meets the target it doubles the spread (up to :data:`MAX_SPREAD`), while it does not
it halves it, then it bisects geometrically (√(lo·hi)) between the largest spread that met the target
and the smallest that did not until ``hi / lo ≤ 1 + rtol``.

Accuracy: the answer ``lo`` is bracketed by [lo, hi] in the spread (hi/lo ≤ 1 + rtol, 5 % by
default) for *this* sample; the share measured at lo has the binomial standard error
√(p(1 − p)/n) with n = variants − 1 (at 1,000 variants and p = 0.99: ±0.0031), which the slope of
the share across the bracket turns into a standard error of the spread (``spread_se``). The spread
where the true share crosses the target is lo to within about the bracket's width plus two of those;
more variants narrow the statistical part as 1/√n.
"""

from __future__ import annotations

import math
import os
import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..gait import SCREEN_INPUTS as _SCREEN_INPUTS

#: The search never goes beyond ±50 % (lengths from half to one and a half times the nominal).
MAX_SPREAD = 0.5
#: ... nor below this (a spread that small is machining noise).
MIN_SPREAD = 1e-6
CRITERIA = ("assembles", "buildable")
#: The ``parameters`` choices by word: every design parameter (the default), or the links and the crank radius.
PARAMETER_SETS = ("all", "links")
#: How the table says what each of them cuts.
PARAMETER_WORDS = {"all": "every design parameter (links, crank, pivots, body points)",
                   "links": "the links and the crank radius"}
#: The metrics the buildability screen reads (computed for ``criterion = "buildable"``): its checks' own
#: inputs (``explorer.gait.CHECKS``), so a new check needs no edit here.
SCREEN_INPUTS = list(_SCREEN_INPUTS)


@dataclass
class ToleranceResult:
    """What :func:`tolerance` found.

    spread : the answer, the largest spread evaluated whose share met the target (NaN if none);
    bracket : (lo, hi), the answer and the smallest spread evaluated that missed the target (hi is NaN
    when even :data:`MAX_SPREAD` meets it); share, se, count, n : at the answer (share ± its binomial
    standard error, count of n sampled designs meeting the criterion); spread_se : that standard error
    carried over to the spread by the share's slope across the bracket, se / ((share(lo) − share(hi)) /
    (hi − lo)) (NaN without a bracket or a slope); evaluations : every study run,
    in order, as dicts (spread, share, se, count, n, meets); and the inputs (mechanism, target,
    criterion, variants, parameters, seed, steps, rtol).
    """

    mechanism: str
    target: float
    criterion: str
    variants: int
    parameters: tuple
    seed: int
    steps: int
    rtol: float
    spread: float = math.nan
    bracket: tuple = (math.nan, math.nan)
    share: float = math.nan
    se: float = math.nan
    spread_se: float = math.nan
    count: int = 0
    n: int = 0
    evaluations: list = field(default_factory=list)

    def as_dict(self) -> dict:
        d = asdict(self)
        d["parameters"] = list(self.parameters)
        d["bracket"] = list(self.bracket)
        return d


def _study(mech_ref: str, spread: float, variants: int, parameters, seed: int, steps: int, criterion: str) -> dict:
    perturb = {"method": "uniform", "spread": float(spread)}
    if parameters is None or parameters == "all":
        perturb["parameters"] = "all"
    elif parameters != "links":  # "links": a default [perturb] study's links and crank radius
        perturb["parameters"] = list(parameters)
    return {"study": {"name": "tolerance", "mechanism": mech_ref, "variants": int(variants), "seed": int(seed),
                      "steps": int(steps)},
            "perturb": perturb,
            "scene": {"velocities": criterion == "buildable",
                      "metrics": SCREEN_INPUTS if criterion == "buildable" else False},
            "output": {"compression": "none"}}


def share_at(mechanism, spread: float, *, variants: int = 1000, parameters=None, seed: int = 1, steps: int = 360,
             criterion: str = "assembles", folder=None) -> dict:
    """One evaluation: run the uniform study at ``spread`` into a temporary file and count. Returns
    {spread, share, se, count, n, nominal_ok, meets: None, perturbed} (n = variants − 1: the nominal is no
    sample). ``parameters`` as for :func:`tolerance`."""
    from ..study import open_results  # with explorer's re-solver (store only reads files)
    from ..study import run_study
    from ..study import load_study
    mech_ref = _mechanism_ref(mechanism)
    # the study's own errors name the mechanism the user gave, not an anonymous <dict>
    study = load_study(_study(mech_ref, spread, variants, parameters, seed, steps, criterion),
                       source=f"{mechanism} (tolerance study)")
    with tempfile.TemporaryDirectory(prefix="explorer-tolerance-", dir=folder) as tmp:
        out = Path(tmp) / "tolerance.h5"
        run_study(study, output=out, progress=False)
        with open_results(out) as r:
            df = r.frame()
            perturbed = r.perturbed
    if criterion == "buildable":
        good = df["buildable"].to_numpy(dtype=bool) if "buildable" in df.columns else np.zeros(len(df), dtype=bool)
    else:
        good = (df["status"].astype(str) == "ok").to_numpy()
    n = len(df) - 1
    count = int(good[1:].sum())
    p = count / n
    return {"spread": float(spread), "share": p, "se": math.sqrt(p * (1.0 - p) / n), "count": count, "n": n,
            "nominal_ok": bool(good[0]), "perturbed": tuple(perturbed)}


def _mechanism_ref(mechanism) -> str:
    """A built-in name, or an absolute path to a mechanism file (the study dict has no folder of its own)."""
    from ..mechanism import builtin_mechanisms
    s = os.fspath(mechanism) if not isinstance(mechanism, str) else mechanism
    p = Path(s)
    if p.is_file():
        return str(p.resolve())
    if s in builtin_mechanisms():
        return s
    raise UserError(f"{s}: no mechanism file or built-in called that (built-ins: {', '.join(builtin_mechanisms())}, "
                    f"or a path to a .toml)")


def _check_nominal(mechanism, mech_ref: str, parameters) -> None:
    """Before any study: the named parameters exist and the nominal design assembles (UserError naming
    the mechanism as given)."""
    from ..kernels import assemble
    from ..mechanism import load_mechanism
    mech = load_mechanism(mech_ref)
    if parameters not in PARAMETER_SETS:
        known = mech.parameters()
        for name in parameters:
            if name not in known:
                raise UserError(f"{mechanism}: --parameters: unknown design parameter {name!r} (known: "
                                f"{', '.join(known)}; or all, links)")
    _, fail = assemble(mech)
    if fail is not None:
        raise UserError(f"{mechanism}: the nominal design cannot be assembled at θ = 0: {fail.message}: no "
                        f"tolerance makes its legs walk")


def tolerance(mechanism, target: float = 0.99, spread: float = 0.01, *, variants: int = 1000, parameters=None,
              seed: int = 1, steps: int = 360, criterion: str = "assembles", rtol: float = 0.05,
              max_runs: int = 24, progress=None) -> ToleranceResult:
    """The largest uniform spread ±s of the chosen parameters at which at least ``target`` of the
    sampled legs meet ``criterion``, by bisection on s (see the module docstring).

    mechanism : built-in name or mechanism .toml. target : share in (0, 1). spread : where the search
        starts, in (0, 0.5]. variants : per study (≥ 20; variant 0 is the nominal). parameters : None or
        ``"all"`` (every design parameter: links, crank radius and centre, ground pivots, body points),
        ``"links"`` (every link and the crank radius, as a default ``[perturb]`` study), or names as in
        ``[perturb] parameters``. seed, steps : of each study. criterion : "assembles" or "buildable". rtol : stop
        when hi/lo ≤ 1 + rtol. max_runs : at most this many studies. progress : called with each
        evaluation dict as it comes.
    """
    if isinstance(target, bool) or not isinstance(target, (int, float)) or not 0.0 < target < 1.0:
        raise UserError(f"--target: expected a share in (0, 1) such as 0.99, got {target!r}")
    if isinstance(spread, bool) or not isinstance(spread, (int, float)) or not MIN_SPREAD <= spread <= MAX_SPREAD:
        raise UserError(f"--spread: expected a relative spread from {MIN_SPREAD:g} to {MAX_SPREAD:g} such as 0.005 "
                        f"(±0.5 %), got {spread!r}")
    if isinstance(variants, bool) or not isinstance(variants, int) or not 20 <= variants <= 10_000_000:
        raise UserError(f"--variants: expected a whole number from 20 to 10,000,000, got {variants!r}")
    if criterion not in CRITERIA:
        raise UserError(f"--criterion: expected one of {', '.join(CRITERIA)}, got {criterion!r}")
    if isinstance(rtol, bool) or not isinstance(rtol, (int, float)) or not 0.0 < rtol <= 1.0:
        raise UserError(f"--rtol: expected a number in (0, 1], got {rtol!r}")
    if isinstance(max_runs, bool) or not isinstance(max_runs, int) or max_runs < 2:
        raise UserError(f"max_runs: expected a whole number >= 2, got {max_runs!r}")
    if parameters is None:
        parameters = "all"
    if parameters not in PARAMETER_SETS:
        parameters = [parameters] if isinstance(parameters, str) else list(parameters)
    mech_ref = _mechanism_ref(mechanism)
    _check_nominal(mechanism, mech_ref, parameters)
    res = ToleranceResult(mechanism=str(mechanism), target=float(target), criterion=criterion, variants=variants,
                          parameters=(), seed=int(seed), steps=int(steps), rtol=float(rtol))
    best = None

    def evaluate(s):
        nonlocal best
        e = share_at(mech_ref, s, variants=variants, parameters=parameters, seed=seed, steps=steps, criterion=criterion)
        if not e["nominal_ok"]:
            what = "assemble over a full turn" if criterion == "assembles" else "pass the buildability screen"
            raise UserError(f"{mechanism}: the nominal design itself does not {what}: no tolerance makes its legs walk")
        res.parameters = e.pop("perturbed")
        e.pop("nominal_ok")
        e["meets"] = bool(e["share"] >= target)
        res.evaluations.append(e)
        if e["meets"] and (best is None or s > best["spread"]):
            best = e
        if progress is not None:
            progress(dict(e))
        return e["meets"]

    lo, hi = math.nan, math.nan
    s = float(spread)
    if evaluate(s):
        lo = s
        while len(res.evaluations) < max_runs and s < MAX_SPREAD:
            s = min(2.0 * s, MAX_SPREAD)
            if evaluate(s):
                lo = s
            else:
                hi = s
                break
    else:
        hi = s
        while len(res.evaluations) < max_runs:
            s = s / 2.0
            if s < MIN_SPREAD:
                raise UserError(f"{mechanism}: even ±{100 * MIN_SPREAD:g} % leaves fewer than {100 * target:g} % of "
                                f"the legs that {criterion}: the nominal sits on the edge")
            if evaluate(s):
                lo = s
                break
            hi = s
    while (math.isfinite(lo) and math.isfinite(hi) and hi / lo > 1.0 + rtol
           and len(res.evaluations) < max_runs):
        mid = math.sqrt(lo * hi)
        if evaluate(mid):
            lo = mid
        else:
            hi = mid
    res.bracket = (lo, hi)
    res.spread = lo
    if best is not None and math.isfinite(lo):
        at = next(e for e in res.evaluations if e["spread"] == lo)
        res.share, res.se, res.count, res.n = at["share"], at["se"], at["count"], at["n"]
        if math.isfinite(hi):
            above = next(e for e in res.evaluations if e["spread"] == hi)
            slope = (at["share"] - above["share"]) / (hi - lo)
            res.spread_se = res.se / slope if slope > 0 else math.nan
    return res
