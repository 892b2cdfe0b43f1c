"""The editor's view of a study: a results file's ranking and a scatter of two metrics, a variant's design
to load, and the yield of the design being edited.

Everything comes from the library: ``Results.rank`` (the ranking ``explorer rank`` prints, screen and
default score included), the results frame, ``explorer.fabrication.variant_design`` (the design ``explorer export
--format toml`` writes, its guess on the branch the study solved) and ``explorer.study.design_yield``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..mechanism import Mechanism

#: Most rows of the ranking the page lists.
RANK_ROWS = 50
#: Most designs drawn in the scatter (the best ranked first, then an even sample of the rest).
SCATTER_MAX = 4000


def _f(x):
    try:
        x = float(x)
    except (TypeError, ValueError):
        return None
    return x if math.isfinite(x) else None


def is_results_file(path) -> bool:
    """True for an HDF5 file (a results file, by its signature), False for anything else."""
    p = Path(path)
    if not p.is_file():
        return False
    try:
        with open(p, "rb") as fh:
            return fh.read(8) == b"\x89HDF\r\n\x1a\n"
    except OSError:
        return False


class Study:
    """An open results file, read-only: its ranking, scatter and variants' designs.

    ``Study(path)`` opens it (UserError with one line if it cannot); :meth:`summary` is what the page
    shows; :meth:`design` is a variant's Mechanism.
    """

    def __init__(self, path):
        from ..study import open_results  # with explorer's re-solver (store only reads files)

        self.path = Path(path)
        if not is_results_file(self.path):
            raise UserError(f"{self.path}: not a results file (an HDF5 file written by explorer run or optimize)")
        self.results = open_results(self.path)
        self.frame = self.results.frame()
        self.steps = int(self.results.steps)

    def close(self) -> None:
        self.results.close()

    @property
    def mechanism(self) -> Mechanism:
        return self.results.mechanism

    @property
    def screen(self):
        return self.results.screen

    def design(self, variant) -> Mechanism:
        """The design of ``variant`` as ``explorer export --as toml`` writes it."""
        from ..fabrication import variant_design

        return variant_design(self.results, variant)

    def summary(self, x: str | None = None, y: str | None = None) -> dict:
        """The page's study panel: the file, its status counts, the ranking (at most :data:`RANK_ROWS` rows:
        variant, rank, score or metric, the default metrics), and a scatter of metrics ``x`` against
        ``y`` (default travel against bob, else the first two stored) over the ok variants, each point
        [variant, x, y, buildable]."""
        res, df = self.results, self.frame
        stored = list(res.metric_names)
        ranking, ranked_by, why = [], None, None
        try:
            ranked = res.rank(top=RANK_ROWS, frame=df)
            ranked_by = "score" if "score" in ranked.columns else None
            show = [c for c in ("travel", "bob", "body_speed_ripple", "peak_torque", "clearance") if c in ranked.columns]
            for _, row in ranked.iterrows():
                ranking.append({"variant": int(row["variant"]), "rank": int(row["rank"]),
                                "score": _f(row["score"]) if "score" in ranked.columns else None,
                                **{m: _f(row[m]) for m in show}})
        except UserError as exc:
            why = str(exc)
        x = x if x in stored else ("travel" if "travel" in stored else (stored[0] if stored else None))
        y = y if y in stored else ("bob" if "bob" in stored else (stored[1] if len(stored) > 1 else None))
        points = []
        if x is not None and y is not None:
            ok = (df["status"].astype(str) == "ok").to_numpy()
            build = df["buildable"].to_numpy(dtype=bool) if "buildable" in df.columns else ok
            xv, yv = df[x].to_numpy(dtype=np.float64), df[y].to_numpy(dtype=np.float64)
            keep = np.flatnonzero(ok & np.isfinite(xv) & np.isfinite(yv))
            if len(keep) > SCATTER_MAX:
                first = {r["variant"] for r in ranking}
                rest = np.array([i for i in keep if int(df["variant"].iloc[i]) not in first])
                pick = rest[np.linspace(0, len(rest) - 1, SCATTER_MAX - len(first)).astype(int)]
                keep = np.array(sorted(set(pick.tolist()) | {i for i in keep if int(df["variant"].iloc[i]) in first}))
            var = df["variant"].to_numpy()
            points = [[int(var[i]), float(xv[i]), float(yv[i]), bool(build[i])] for i in keep]
        from ..gait import DIRECTIONS
        return {"file": str(self.path), "variants": int(res.n_variants), "steps": self.steps,
                "status": {k: int(v) for k, v in res.status_counts().items()}, "metrics": stored,
                "ranking": ranking, "ranked_by": ranked_by or "walker score", "ranking_note": why,
                "scatter": {"x": x, "y": y, "points": points,
                            "directions": {m: DIRECTIONS.get(m) for m in (x, y) if m}}}


def yield_data(mech: Mechanism, tolerance, unit: str = "%", copies: int = 256, steps: int = 360,
               screen=None) -> dict:
    """The yield of ``mech`` (as its own nominal) with every design parameter cut ±``tolerance`` ``unit``
    (``explorer.study.design_yield``; the ``[robustness]`` table's validation): {"yield", "se", "count",
    "copies", "describe", "ms"}."""
    import time

    from ..study import design_yield, robustness_from_dict

    rob = robustness_from_dict({"tolerance": tolerance, "unit": unit, "copies": copies}, "yield", mech,
                               mech.operating)
    t = time.perf_counter()
    crank = np.array([mech.crank.radius]) if mech.crank is not None else None
    got = design_yield(mech, mech.lengths[None, :], crank, None, robustness=rob, steps=steps, screen=screen)
    return {"yield": float(got.share[0]), "se": float(got.se[0]), "count": int(got.count[0]), "copies": got.copies,
            "describe": rob.describe(), "ms": 1e3 * (time.perf_counter() - t)}
