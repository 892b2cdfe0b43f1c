"""What an optimisation searches: the ``[optimize]`` table of a study file, part of the study it
belongs to. How evaluated designs are scored against it (objectives, constraint violations,
feasibility) is :mod:`explorer.optimize`'s (``objective_matrix``).

A study file with an ``[optimize]`` table is run by ``explorer optimize`` (:mod:`explorer.optimize`)::

    [optimize]
    algorithm = "auto"            # auto (default) | nsga2 | nsga3 (several objectives) | de | ga | cmaes (one)
    population = 40               # designs per generation
    generations = 25              # or: evaluations = 1000 (rounded up to whole generations)
    objectives = ["travel", "bob", "peak_torque"]   # metric names; each metric's direction (max or min)
                                  # comes from the one table of metrics (`explorer metrics --list`)
    constraints = ["clearance >= 1", "`1-3` < 16"]  # the --where filter language, over metrics and
                                  # parameters; a design satisfies every one
    screen = true                 # designs failing the buildability screen are infeasible (default true)
    spread = 0.1                  # bounds of parameters given by name only (below)
    parameters = ["1-3", "2-6", "crank.x"]          # the design parameters searched, ±spread around
                                  # the nominal (lengths relatively, coordinates × the mechanism's size)

    [optimize.bounds]             # or explicit bounds, model units; these override the spread
    "1-3" = [13.0, 17.0]

One objective (``algorithm = "auto"``, or any single-objective algorithm with ``polish = true``):
``auto`` runs pymoo's DE for the generations, then, when the objective is ``path_error``, *polishes*
(the path polish: bounded least squares on the path residuals, the untimed formulation with one free
crank angle per target point for ``closest`` matching) the best design and the ``restarts`` next best
distinct designs of the run, and commits the polished designs as one more generation (number
``generations``, rows ``generations·P …``). ``auto`` with several objectives is ``nsga2``::

    polish = true                 # default: true for auto with objective path_error, else false
                                  # several objectives: polish the final front instead (below)
    restarts = 4                  # polish starts beyond the best (0 … population − 1; default 4)
    polish_starts = 64            # designs advanced together by the batched Levenberg–Marquardt first
                                  # (0 … 100,000; default 64; 0: none)
    rounds = 8                    # restart rounds (one objective): each round the search's generations from
                                  # a fresh seed, then the polish generation (default 1)
    seconds = 60                  # a round begins only while the run has taken less than this (default: no limit)
    repeat = 3                    # rounds stop once this many have reached the best value (0: never; default 3)
    atlas = "auto"                # polish starts from the curve atlas of the mechanism when one is cached
                                  # ("auto", default), from this atlas file, or none (false)

With ``polish_starts`` = K > 0 the polish first advances the K best distinct feasible designs of the
run together by a batched bounded Levenberg–Marquardt (``batched_lm``: one batch solve of
K·(1 + k) designs per iteration), then finishes the best ``1 + restarts`` distinct answers with the
least squares. With constraints or the screen, each polished design is committed beside points on the
way back to the design it started from (half, a quarter, … of the step, as the generation's rows
allow), so the best *feasible* design the polish reached is kept.

Several objectives with ``polish = true`` (the front polish of :mod:`explorer.optimize`): after the generations, each design of
the final front (at most P of them) is polished by SLSQP on the equal-weight sum of its normalised
objectives, no objective allowed to get worse, and the designs it improves (each dominating the
design it started from) are committed as the same extra generation. ``restarts`` does not apply.

The seed is ``[study] seed``. ``[perturb]`` does not apply (the optimiser chooses the designs) and is
refused beside ``[optimize]``.

Feasibility. A design is *feasible* when it solved over the whole cycle (status ok), every objective
is a number, it passes the buildability screen (unless ``screen = false``) and every constraint holds.
Infeasible designs are handed to the algorithm with a positive constraint violation and never
appear on a front (pymoo's constraint domination ranks any feasible design above any infeasible one).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import UserError, where
from ..mechanism import Mechanism

#: Algorithms ``[optimize] algorithm`` accepts (pymoo's implementations).
ALGORITHMS = ("auto", "nsga2", "nsga3", "de", "ga", "cmaes")
#: Algorithms that take exactly one objective.
SINGLE_OBJECTIVE = ("de", "ga", "cmaes")
#: Keys of the ``[optimize]`` table.
OPTIMIZE_KEYS = ("algorithm", "population", "generations", "evaluations", "objectives", "constraints", "screen",
                 "spread", "parameters", "bounds", "polish", "restarts", "polish_starts", "rounds", "seconds", "repeat",
                 "atlas")
#: Restart rounds by default (each: the search's generations, then the polish generation).
ROUNDS = 1
#: Rounds stop once the best value has been reached by this many rounds (0: never), by default.
REPEAT = 3
#: Polish starts beyond the best, by default.
RESTARTS = 4
#: Designs the batched Levenberg–Marquardt of the polish advances together, by default.
POLISH_STARTS = 64
#: Most evaluations one optimisation may ask for (rows of its results file).
MAX_EVALUATIONS = 10_000_000


@dataclass(frozen=True)
class Optimize:
    """A validated ``[optimize]`` table (see the module docstring).

    parameters : the searched design parameters, in ``mech.parameters()`` order; lower, upper : their
    bounds (model units); objectives : metric names; directions : "max" or "min" per objective;
    constraints : filter expressions; algorithm, population, generations; screen : whether the
    buildability screen decides feasibility; spread : as written (bounds of parameters without
    explicit ones).
    """

    parameters: tuple
    lower: tuple
    upper: tuple
    objectives: tuple
    directions: tuple
    constraints: tuple
    algorithm: str
    population: int
    generations: int
    screen: bool = True
    spread: float = 0.1
    polish: bool = False
    restarts: int = RESTARTS
    polish_starts: int = 0
    rounds: int = ROUNDS
    seconds: float | None = None
    repeat: int = REPEAT
    atlas: object = "auto"

    @property
    def per_round(self) -> int:
        """Generations of one round: the algorithm's, and the polished designs' one."""
        return self.generations + int(self.polish)

    @property
    def chunks(self) -> int:
        """Generations in the results file: every round's (:attr:`per_round` each)."""
        return self.rounds * self.per_round

    @property
    def evaluations(self) -> int:
        """Rows of the results file: population × (generations, plus one with ``polish``)."""
        return self.population * self.chunks

    @property
    def search(self) -> str:
        """The pymoo algorithm that runs the generations (``auto``: de for one objective, else nsga2)."""
        if self.algorithm != "auto":
            return self.algorithm
        return "de" if len(self.objectives) == 1 else "nsga2"

    def as_dict(self) -> dict:
        return {"algorithm": self.algorithm, "population": self.population, "generations": self.generations,
                "objectives": list(self.objectives), "constraints": list(self.constraints), "screen": self.screen,
                "spread": self.spread, "parameters": list(self.parameters),
                "bounds": {p: [lo, hi] for p, lo, hi in zip(self.parameters, self.lower, self.upper)},
                "polish": self.polish, "restarts": self.restarts, "polish_starts": self.polish_starts,
                **self._rounds_dict()}

    def _rounds_dict(self) -> dict:
        """The restart keys, only where they differ from the defaults (a study without them keeps its
        fingerprint)."""
        out = {}
        if self.rounds != ROUNDS:
            out["rounds"] = self.rounds
        if self.seconds is not None:
            out["seconds"] = self.seconds
        if self.repeat != REPEAT:
            out["repeat"] = self.repeat
        if self.atlas != "auto":
            out["atlas"] = self.atlas
        return out


def parse_optimize(table: dict, source: str, mech: Mechanism, known_metrics, has_target: bool) -> Optimize:
    """Validate an ``[optimize]`` table against the mechanism ``mech``. ``known_metrics``: every metric
    name; ``has_target``: whether the study gives a ``[target]`` path (needed by ``path_error``)."""
    def key(k):
        return where(source, f"optimize.{k}")

    for k in table:
        if k not in OPTIMIZE_KEYS:
            raise UserError(f"{key(k)}: unknown key (allowed in [optimize]: {', '.join(OPTIMIZE_KEYS)})")
    algorithm = table.get("algorithm", "auto")
    if algorithm not in ALGORITHMS:
        raise UserError(f"{key('algorithm')}: expected one of {', '.join(ALGORITHMS)}, got {algorithm!r}")
    population = _integer(table.get("population", 40), key("population"), 4, 100_000)
    if "generations" in table and "evaluations" in table:
        raise UserError(f"{key('evaluations')}: give generations or evaluations, not both")
    if "evaluations" in table:
        evals = _integer(table["evaluations"], key("evaluations"), population, MAX_EVALUATIONS)
        generations = -(-evals // population)
    else:
        generations = _integer(table.get("generations", 25), key("generations"), 1, MAX_EVALUATIONS)
    if population * generations > MAX_EVALUATIONS:
        raise UserError(f"{key('generations')}: {population} x {generations} = {population * generations:,} "
                        f"evaluations; at most {MAX_EVALUATIONS:,}")

    objectives = table.get("objectives")
    if isinstance(objectives, str):
        objectives = [objectives]
    if not isinstance(objectives, list) or not objectives or not all(isinstance(o, str) for o in objectives):
        raise UserError(f"{key('objectives')}: expected a non-empty list of metric names, got {objectives!r}")
    from ..gait import DIRECTIONS
    for o in objectives:
        if o not in known_metrics:
            raise UserError(f"{key('objectives')}: unknown metric {o!r} (known: {', '.join(known_metrics)})")
        if objectives.count(o) > 1:
            raise UserError(f"{key('objectives')}: {o!r} is listed twice")
    if "path_error" in objectives and not has_target:
        raise UserError(f"{key('objectives')}: 'path_error' needs a [target] table (the path to match)")
    if algorithm in SINGLE_OBJECTIVE and len(objectives) != 1:
        raise UserError(f"{key('objectives')}: algorithm {algorithm!r} takes one objective, got {len(objectives)} "
                        f"({', '.join(objectives)}); use nsga2 or nsga3 for several")
    directions = tuple(DIRECTIONS[o] for o in objectives)
    polish = table.get("polish", algorithm == "auto" and objectives == ["path_error"])
    if not isinstance(polish, bool):
        raise UserError(f"{key('polish')}: expected true or false, got {polish!r}")
    if polish and len(objectives) == 1 and objectives != ["path_error"]:
        raise UserError(f"{key('polish')}: polish = true needs the one objective 'path_error' (it is least squares "
                        f"on the path residuals) or several objectives (the front's polish), got {objectives[0]!r}")
    if polish and len(objectives) == 1 and algorithm not in SINGLE_OBJECTIVE + ("auto",):
        raise UserError(f"{key('polish')}: polish = true runs after a single-objective search (auto, de, ga or "
                        f"cmaes), not {algorithm!r}")
    restarts = _integer(table.get("restarts", min(RESTARTS, population - 1)), key("restarts"), 0, population - 1)
    polish_starts = _integer(table.get("polish_starts", POLISH_STARTS), key("polish_starts"), 0, 100_000)
    rounds = _integer(table.get("rounds", ROUNDS), key("rounds"), 1, 100_000)
    if rounds > 1 and len(objectives) > 1:
        raise UserError(f"{key('rounds')}: restart rounds apply to one objective; got {len(objectives)} objectives")
    if population * generations * rounds > MAX_EVALUATIONS:
        raise UserError(f"{key('rounds')}: {population} x {generations} x {rounds} rounds = "
                        f"{population * generations * rounds:,} evaluations; at most {MAX_EVALUATIONS:,}")
    seconds = table.get("seconds")
    if seconds is not None and (isinstance(seconds, bool) or not isinstance(seconds, (int, float))
                                or not 0 < seconds <= 1e7 or not math.isfinite(seconds)):
        raise UserError(f"{key('seconds')}: expected a number of seconds in (0, 1e7], got {seconds!r}")
    repeat = _integer(table.get("repeat", REPEAT), key("repeat"), 0, 100_000)
    atlas = table.get("atlas", "auto")
    if atlas is True:
        atlas = "auto"
    if not (atlas is False or (isinstance(atlas, str) and atlas.strip())):
        raise UserError(f"{key('atlas')}: expected \"auto\", false or an atlas file, got {atlas!r}")

    constraints = table.get("constraints", [])
    if isinstance(constraints, str):
        constraints = [constraints]
    if not isinstance(constraints, list) or not all(isinstance(c, str) and c.strip() for c in constraints):
        raise UserError(f"{key('constraints')}: expected a list of filter expressions, got {constraints!r}")
    from ..gait import FilterError, parse_filter
    for c in constraints:
        try:
            parse_filter(c)
        except FilterError as exc:
            raise UserError(f"{key('constraints')}: {exc}") from None

    screen = table.get("screen", True)
    if not isinstance(screen, bool):
        raise UserError(f"{key('screen')}: expected true or false, got {screen!r}")
    spread = table.get("spread", 0.1)
    if isinstance(spread, bool) or not isinstance(spread, (int, float)) or not 0.0 < spread < 1.0:
        raise UserError(f"{key('spread')}: expected a number in (0, 1), got {spread!r}")

    known = tuple(mech.parameters())
    named = table.get("parameters", [])
    if not isinstance(named, list) or not all(isinstance(p, str) for p in named):
        raise UserError(f"{key('parameters')}: expected a list of design parameter names, got {named!r}")
    bounds = table.get("bounds", {})
    if not isinstance(bounds, dict):
        raise UserError(f"{key('bounds')}: expected a table name = [low, high], got {bounds!r}")
    for p in list(named) + list(bounds):
        if p not in known:
            k = "parameters" if p in named else f"bounds.{p}"
            raise UserError(f"{key(k)}: unknown design parameter {p!r} (known: {', '.join(known)})")
        if named.count(p) > 1:
            raise UserError(f"{key('parameters')}: {p!r} is listed twice")
    chosen = set(named) | set(bounds)
    if not chosen:
        raise UserError(f"{key('parameters')}: no design parameter to search (give parameters or [optimize.bounds])")
    nominal = mech.parameters()
    params, lower, upper = [], [], []
    for p in known:
        if p not in chosen:
            continue
        if p in bounds:
            b = bounds[p]
            if (not isinstance(b, list) or len(b) != 2
                    or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in b)):
                raise UserError(f"{key('bounds.' + p)}: expected [low, high] numbers, got {b!r}")
            lo, hi = float(b[0]), float(b[1])
            if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
                raise UserError(f"{key('bounds.' + p)}: expected finite low < high, got {b!r}")
            if mech.parameter_kind(p) == "length" and lo <= 0.0:
                raise UserError(f"{key('bounds.' + p)}: a length's bounds must be positive, got {b!r}")
        elif mech.parameter_kind(p) == "length":
            lo, hi = nominal[p] * (1.0 - spread), nominal[p] * (1.0 + spread)
        else:
            lo, hi = nominal[p] - spread * mech.size, nominal[p] + spread * mech.size
        params.append(p)
        lower.append(lo)
        upper.append(hi)
    return Optimize(parameters=tuple(params), lower=tuple(lower), upper=tuple(upper), objectives=tuple(objectives),
                    directions=directions, constraints=tuple(constraints), algorithm=algorithm, population=population,
                    generations=generations, screen=screen, spread=float(spread), polish=polish, restarts=restarts,
                    polish_starts=polish_starts, rounds=rounds, seconds=None if seconds is None else float(seconds),
                    repeat=repeat, atlas=atlas)


def _integer(value, key: str, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise UserError(f"{key}: expected a whole number from {lo:,} to {hi:,}, got {value!r}")
    return int(value)


def metrics_needed(opt: Optimize, screen_metrics) -> tuple:
    """The metrics an optimisation must compute: its objectives, the metrics its constraints name, and
    (with ``screen``) the metrics among ``screen_metrics``, the columns the buildability screen reads."""
    from ..gait import METRICS, filter_columns
    names = list(opt.objectives)
    for c in opt.constraints:
        names += [n for n in filter_columns(c) if n in METRICS]
    if opt.screen:
        names += [n for n in screen_metrics if n in METRICS]
    out = []
    for n in names:
        if n not in out:
            out.append(n)
    return tuple(out)


def optimize_from_dict(d: dict, mech: Mechanism) -> Optimize:
    """Rebuild an :class:`Optimize` from its :meth:`Optimize.as_dict` (as stored in a results file)."""
    params = tuple(d["parameters"])
    from ..gait import DIRECTIONS
    return Optimize(parameters=params, lower=tuple(float(d["bounds"][p][0]) for p in params),
                    upper=tuple(float(d["bounds"][p][1]) for p in params), objectives=tuple(d["objectives"]),
                    directions=tuple(DIRECTIONS[o] for o in d["objectives"]), constraints=tuple(d["constraints"]),
                    algorithm=d["algorithm"], population=int(d["population"]), generations=int(d["generations"]),
                    screen=bool(d["screen"]), spread=float(d["spread"]), polish=bool(d.get("polish", False)),
                    restarts=int(d.get("restarts", RESTARTS)), polish_starts=int(d.get("polish_starts", 0)),
                    rounds=int(d.get("rounds", ROUNDS)), seconds=d.get("seconds"), repeat=int(d.get("repeat", REPEAT)),
                    atlas=d.get("atlas", "auto"))
