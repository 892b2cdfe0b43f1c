"""The ``yield`` of designs already in a results file: :func:`results_yield` re-solves copies of some of its
variants as its study solved them, cut with the study's own ``[robustness]`` table or a command line's
tolerance (:func:`results_robustness`, :func:`parse_tolerance`). What a copy is, how copies are drawn
and counted, and the ``[robustness]`` table itself are :mod:`explorer.study`'s (``design_yield``,
``Robustness``), since a running study computes ``yield`` as a metric chunk by chunk."""

from __future__ import annotations

import math

import numpy as np

from ..errors import UserError
from ..mechanism import Mechanism, Operating
from ..study import Robustness, YieldResult, design_yield, robustness_from_dict
from ..study import DEFAULT_COPIES, split_parameters


def results_robustness(results, text: str | None = None, copies: int | None = None) -> Robustness:
    """The :class:`Robustness` of an open results file: from a command line's tolerance ``text``
    ("0.5%", "0.1mm", "0.02" model units; ``copies`` per design, default 256), or else the study's own
    ``[robustness]`` table (UserError naming the file if it has none)."""
    mech = results.mechanism
    if text:
        return parse_tolerance(text, results.operating, "--yield", mech, copies or DEFAULT_COPIES)
    table = results.study.get("robustness")
    if not table:
        raise UserError(f"{results.filename}: its study has no [robustness] table; give the tolerance to cut "
                        f"copies with (e.g. --yield 0.5%)")
    return robustness_from_dict(table, f"{results.filename} (its study)", mech, results.operating)


def results_yield(results, variants, robustness: Robustness | None = None) -> YieldResult:
    """The yield of some variants of an open results file (:class:`explorer.store.Results`), re-solved
    as its study solved them (steps, tolerance, method, screen). ``robustness``: None for the study's
    own ``[robustness]`` table (:func:`results_robustness`)."""
    study = results.study
    mech = results.mechanism
    if robustness is None:
        robustness = results_robustness(results)
    variants = [int(v) for v in variants]
    # the rows of these variants alone where the results read them so (an open results file), else the frame
    frame = results.frame_rows(variants) if callable(getattr(results, "frame_rows", None)) else results.frame()
    designs = [results.design(v, frame) for v in variants]
    names = list(mech.parameters())
    X = np.array([[d[p] for p in names] for d in designs], dtype=np.float64).reshape(len(designs), len(names))
    L, r, geo = split_parameters(mech, X)
    st = study.get("study", {})
    return design_yield(mech, L, r, geo, robustness=robustness, steps=results.steps, tolerance=st.get("tolerance"),
                        method=st.get("method", "block"), screen=results.screen)


def parse_tolerance(text: str, operating: Operating | None, source: str, mech: Mechanism, copies: int,
                    distribution: str = "uniform", seed: int = 0) -> Robustness:
    """A command line's tolerance: "0.5%", "0.1mm" or "0.02" (model units) → :class:`Robustness`."""
    s = str(text).strip().replace(" ", "")
    unit = "model"
    for suffix, u in (("%", "%"), ("mm", "mm")):
        if s.endswith(suffix):
            s, unit = s[: -len(suffix)], u
    try:
        value = float(s)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0 and (unit != "%" or value <= 50)):
        raise UserError(f"{source}: expected a tolerance > 0 such as 0.5% (relative, at most 50%), 0.1mm or 0.02 "
                        f"(model units), got {text!r}")
    return robustness_from_dict({"tolerance": value, "unit": unit, "copies": copies, "distribution": distribution,
                                 "seed": seed}, source, mech, operating, key="")
