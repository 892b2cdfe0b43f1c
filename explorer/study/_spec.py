"""Study files: parsing and validation of every key (the TOML shape is a public contract).

A study file::

    [study]
    name = "jansen-2pct"          # required; letters, digits, '.', '_', '-'
    mechanism = "jansen"          # required; built-in name or path to a mechanism .toml
    variants = 10000              # random methods: number of variants N (variant 0 = nominal);
                                  # oat / grid: levels per parameter; saltelli: base samples N
                                  # (N·(k + 2) + 1 variants; see below)
    seed = 1                      # integer ≥ 0
    steps = 360                   # crank samples per cycle (≥ 3)
    tolerance = 1e-11             # every solved position within tolerance x the longest link (1e-12 … 1e-6)
    method = "block"              # or "dense", or "auto" (the vectorised closed-form pass, Newton where needed)

    [perturb]
    method = "uniform"            # uniform | normal | lhs | sobol | saltelli | oat | grid
    spread = 0.02                 # relative, in [0, 1): ±spread (uniform, lhs, sobol, saltelli, oat, grid), sigma (normal)
    links = "all"                 # or a list of link names such as ["1-3", "2-6"]
    crank = true                  # perturb the crank radius too
    parameters = ["2.x", "2.y"]   # any design parameters by name, or "all" (default: none; see below)

    [scene]
    vertices = ["7"]              # vertices whose paths are stored ("all" allowed); default: the foot
    velocities = true
    accelerations = false
    band = 0.01                   # stance band of the gait metrics, in (0, 1)
    metrics = true                # true (all), false, or a list of metric names
    store = "series"              # or "metrics": a lean study, no series stored (readers re-solve them)

    [walker]                      # the walker scene (metrics travel, bob, …); keys left out come from
    legs = 4                      # the mechanism's own [walker] table, else 4 legs evenly spaced
    phases = [0, 90, 180, 270]    # crank phase offset of each leg, degrees (default: evenly spaced)
    mirrored = true               # odd legs mirrored (or a list of true/false, one per leg)
    drag = 0.0                    # drag on the body as a fraction of its weight (torque metrics)
    contact = 0.01                # feet within contact × crank radius of the ground touch it

    [screen]                      # the buildability screen that rank, plot --top and show apply
    min_transmission_angle = 5.0  # degrees
    min_foot_headroom = 0.0       # model units the foot stays below the crank axle and ground pivots
    max_foot_speed = 6.0          # peak foot speed, crank radii per radian of crank
    max_self_crossings = 0

    [output]
    path = "results/jansen-2pct.h5"   # default results/<name>.h5; relative to the working directory

``[perturb] parameters`` names any design parameters of the mechanism
(:meth:`~explorer.mechanism.Mechanism.parameters`): link lengths by link name (``"2-6"``), the crank
radius ``"crank"`` and centre ``"crank.x"``, ``"crank.y"``, a ground pivot's coordinates
``"2.x"``, ``"2.y"``, a body joint's coordinates in its body's frame ``"coupler.P.x"``; or
``"all"`` for every one of them. What is perturbed is the union of ``links``, ``crank`` and
``parameters``. ``links`` defaults to ``"all"`` and ``crank`` to true only when ``parameters`` is
absent: with ``parameters`` the study perturbs exactly what it lists (plus any ``links`` / ``crank =
true`` written beside it; ``links = []`` is allowed there). Lengths (links, the crank radius) vary
relatively, coordinates by a distance: ±spread × the mechanism's size, its longest link or body span
(see :mod:`explorer.study._sample`).

Only ``study.name`` and ``study.mechanism`` are required; every other key has the default shown
(``variants`` 10000, 11 levels for oat and grid, 1024 base samples for saltelli; ``seed`` 0, ``metrics``
false). Every key is checked: an unknown key, a wrong
type or an out-of-range value raises :class:`~explorer.errors.UserError` with one line naming the
file, the key and what is allowed.

A relative ``mechanism`` path is looked up next to the study file first, then in the working
directory.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path

import numpy as np

from ..errors import UserError, where
from ..gait import SCREEN_KEYS, TARGET_KEYS, VELOCITY_METRICS, Screen, Target, load_target, screen_from_dict
from ..kernels import DEFAULT_TOLERANCE, TOLERANCE_RANGE
from ..mechanism import (BUILD_KEYS, OPERATING_KEYS, Mechanism, Operating, Walker, builtin_mechanisms, load_mechanism,
                         operating_from_dict, parse_toml, walker_body, walker_from_dict)
from ._objectives import OPTIMIZE_KEYS, Optimize, parse_optimize
from ._yield import ROBUSTNESS_KEYS, YIELD, Robustness, robustness_from_dict

PERTURB_METHODS = ("uniform", "normal", "lhs", "sobol", "saltelli", "oat", "grid")
#: Methods whose variants are a sample of the design space (global sensitivity indices apply):
#: every method but the one-at-a-time and full-factorial designs.
SAMPLED_METHODS = ("uniform", "normal", "lhs", "sobol", "saltelli")
SOLVE_METHODS = ("block", "dense", "auto")
#: Largest number of variants a study may ask for (all methods).
MAX_VARIANTS = 1_000_000_000

_SECTIONS = {
    "study": ("name", "mechanism", "variants", "seed", "steps", "tolerance", "method"),
    "perturb": ("method", "spread", "links", "crank", "parameters"),
    "scene": ("vertices", "velocities", "accelerations", "band", "metrics", "forces", "force_joints", "store"),
    "walker": ("legs", "phases", "mirrored", "drag", "contact"),
    "operating": OPERATING_KEYS,
    "screen": SCREEN_KEYS,
    "output": ("path", "compression"),
    "optimize": OPTIMIZE_KEYS,
    "target": TARGET_KEYS,
    "robustness": ROBUSTNESS_KEYS,
    "build": BUILD_KEYS,
}
#: Every section of a study file and the keys it accepts: what the docs' study-file reference is generated from.
STUDY_KEYS = _SECTIONS
#: [output] compression choices: HDF5 filters of the (N, steps, 2) series (see explorer.store._write).
COMPRESSIONS = ("blosc", "zstd", "lzf", "gzip", "none")
#: [scene] store choices: "series" stores every (N, steps, 2) series the scene names; "metrics" (a lean
#: study) stores the designs, statuses and metrics only, and the readers re-solve the series they need.
STORES = ("series", "metrics")
_NAME_RE = re.compile(r"[A-Za-z0-9._-]+")
#: Longest study name: it names the default results file (``results/NAME.h5``, its lock and shards folder).
MAX_NAME = 100


@dataclass(frozen=True)
class Solver:
    """``[study]``'s solver settings: how every design is solved.

    steps : crank samples per cycle (≥ 3). tolerance : the bound on every solved position's error,
    relative to the longest link. method : ``"block"``, ``"dense"`` or ``"auto"``."""

    steps: int = 360
    tolerance: float = DEFAULT_TOLERANCE
    method: str = "block"


@dataclass(frozen=True)
class Perturb:
    """``[perturb]``, resolved: which design parameters vary and how.

    method : one of :data:`PERTURB_METHODS`, or ``"optimize"`` for an optimiser's designs. spread :
    relative spread (± or sigma). links : ``"all"`` or a tuple of the perturbed link names (those named
    in ``parameters`` included). crank : whether the crank radius is perturbed (``parameters`` naming
    "crank" included). parameters : ``[perturb] parameters`` as written: ``"all"``, a tuple of names,
    or ``()`` when absent."""

    method: str = "uniform"
    spread: float = 0.02
    links: object = "all"
    crank: bool = True
    parameters: object = ()


@dataclass(frozen=True)
class Scene:
    """``[scene]``: what each design's solve computes and what is stored.

    vertices : ``"all"`` or a tuple of vertex names whose series are stored. velocities, accelerations :
    whether their series are stored. band : the gait metrics' stance band, in (0, 1). metrics : a bool or
    a tuple of metric names. forces : the forces effect (motor torque, joint reactions, ``/torque``);
    force_joints : the joints whose reactions are stored (``/forces/<joint>``). store : ``"series"`` or
    ``"metrics"`` (a lean study: designs, statuses and metrics, no series)."""

    vertices: object = "all"
    velocities: bool = True
    accelerations: bool = False
    band: float = 0.01
    metrics: object = False
    forces: bool = False
    force_joints: tuple = ()
    store: str = "series"


@dataclass(frozen=True)
class Output:
    """``[output]``: the results file. path : as written (a relative path resolves against the working
    directory when the file is opened). compression : the series' HDF5 filter, one of
    :data:`COMPRESSIONS`."""

    path: str = ""
    compression: str = "blosc"


def _alias(section: str, key: str):
    """A read-only property ``Study.<old name>`` → ``study.<section>.<key>`` (the flat names of before the
    sections, kept for every caller)."""
    def get(self):
        return getattr(getattr(self, section), key)
    return property(get, doc=f"``{section}.{key}`` (the flat name, kept).")


@dataclass(frozen=True)
class Study:
    """A validated study, composed of one typed section per TOML table.

    name, mechanism : as written in ``[study]``; ``mechanism_path`` is the resolved file (None for
        a built-in). variants, seed : ``[study]`` (the number of designs as written and the sampler's seed).
    solver : ``[study]``'s solver settings (:class:`Solver`: steps, tolerance, method).
    perturb : ``[perturb]``, resolved (:class:`Perturb`); :attr:`parameter_names` is the union of its
        links, crank and parameters, in ``mech.parameters()`` order.
    scene : ``[scene]`` (:class:`Scene`); :attr:`lean` for ``store = "metrics"``.
    results_file : ``[output]`` (:class:`Output`: path, compression).
    source : the file the study came from (``builtin:NAME`` or ``<dict>``); text : its TOML text.
    walker : the walker scene (:class:`~explorer.mechanism.Walker`: the study's ``[walker]`` over
        the mechanism's own), None for a path-driven mechanism. screen : the ``[screen]`` thresholds.
    target : the ``[target]`` path (:class:`~explorer.gait.Target`) the ``path_error`` metric compares
        the foot path with, else None.
    operating : the operating point (:class:`~explorer.mechanism.Operating`: the study's ``[operating]``
        over the mechanism's own), None when neither gives one.
    robustness : the ``[robustness]`` table (:class:`~explorer.study.Robustness`: the
        manufacturing error the ``yield`` metric's copies are cut with), None when absent.
    optimize : the ``[optimize]`` table (:class:`~explorer.study.Optimize`) of a study run by
        ``explorer optimize``, else None. Its designs are the optimiser's: ``perturb.method`` is
        ``"optimize"``, ``variants`` is population × generations and the perturbed parameters are the
        searched ones.
    build : the study's ``[build]`` table as written (over the mechanism's, key by key), else None.

    The flat names of before the sections still read (read-only properties): ``steps``, ``tolerance``,
    ``method`` (→ ``solver``); ``perturb_method``, ``spread``, ``links``, ``crank``, ``parameters``
    (→ ``perturb``); ``vertices``, ``velocities``, ``accelerations``, ``band``, ``metrics``, ``forces``,
    ``force_joints``, ``store`` (→ ``scene``); ``output`` (the path) and ``compression`` (→
    ``results_file``). Replace a section with :func:`dataclasses.replace` (``replace(study,
    scene=replace(study.scene, ...))``).
    """

    name: str
    mechanism: str
    variants: int
    seed: int
    solver: Solver
    perturb: Perturb
    scene: Scene
    results_file: Output
    source: str
    text: str
    mechanism_path: str | None = None
    walker: Walker | None = None
    screen: Screen = field(default_factory=Screen)
    optimize: Optimize | None = None
    target: Target | None = None
    operating: Operating | None = None
    robustness: Robustness | None = None
    build: dict | None = None  # the study's [build] table as written (over the mechanism's, key by key)
    _mech: Mechanism | None = field(default=None, repr=False, compare=False)

    steps = _alias("solver", "steps")
    tolerance = _alias("solver", "tolerance")
    method = _alias("solver", "method")
    perturb_method = _alias("perturb", "method")
    spread = _alias("perturb", "spread")
    links = _alias("perturb", "links")
    crank = _alias("perturb", "crank")
    parameters = _alias("perturb", "parameters")
    vertices = _alias("scene", "vertices")
    velocities = _alias("scene", "velocities")
    accelerations = _alias("scene", "accelerations")
    band = _alias("scene", "band")
    metrics = _alias("scene", "metrics")
    forces = _alias("scene", "forces")
    force_joints = _alias("scene", "force_joints")
    store = _alias("scene", "store")
    output = _alias("results_file", "path")
    compression = _alias("results_file", "compression")

    # -- derived -------------------------------------------------------------------------------
    @property
    def mech(self) -> Mechanism:
        """The nominal :class:`~explorer.mechanism.Mechanism`."""
        return self._mech

    @property
    def vertex_names(self) -> tuple[str, ...]:
        """The stored vertices, resolved (``"all"`` → every vertex of the mechanism)."""
        return tuple(self.mech.vertices) if self.vertices == "all" else tuple(self.vertices)

    @property
    def link_names(self) -> tuple[str, ...]:
        """The perturbed links, in ``mech.links`` order (``"all"`` resolved)."""
        chosen = set(self.mech.link_names if self.links == "all" else self.links)
        return tuple(n for n in self.mech.link_names if n in chosen)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Every perturbed design parameter, in ``mech.parameters()`` order: the links (``mech.links``
        order), "crank" (the radius), then the coordinates (:attr:`geometry_names`). This is the column
        order of the study's samples."""
        names = self.mech.parameters()
        if self.parameters == "all":
            return tuple(names)
        chosen = set(self.link_names) | ({"crank"} if self.crank else set()) | set(self.parameters)
        return tuple(n for n in names if n in chosen)

    @property
    def geometry_names(self) -> tuple[str, ...]:
        """The perturbed coordinate parameters (crank centre, ground pivots, body joints), in
        ``mech.parameters()`` order: the columns of ``/variants/geometry``."""
        mech = self.mech
        return tuple(n for n in self.parameter_names if mech.parameter_kind(n) == "coordinate")

    @property
    def lean(self) -> bool:
        """A metrics-only study (``[scene] store = "metrics"``): no series are stored."""
        return self.store == "metrics"

    @property
    def n_series(self) -> int:
        """(N, steps, 2) datasets stored: every scene vertex's path, velocities, accelerations (none
        for a lean study, :attr:`lean`)."""
        if self.lean:
            return 0
        return len(self.vertex_names) * (1 + int(self.velocities) + int(self.accelerations))

    def series_solve(self) -> dict:
        """How the study's series are solved (:func:`series_solve`): what a lean results file records so
        that its readers re-solve the series bit for bit."""
        return series_solve(self)

    @property
    def n_parameters(self) -> int:
        """Number of perturbed parameters k (links, the crank radius, coordinates)."""
        return len(self.parameter_names)

    @property
    def n_variants(self) -> int:
        """Total number of variants N, variant 0 (the nominal) included."""
        return variant_count(self.perturb_method, self.variants, self.n_parameters)

    def as_dict(self) -> dict:
        """The study as a TOML-shaped nested dict, every default filled in (lists for tuples)."""
        def plain(v):
            return list(v) if isinstance(v, tuple) else v
        perturb = {"method": self.perturb_method, "spread": self.spread, "links": plain(self.links),
                   "crank": self.crank}
        if self.parameters:  # only when given: a study without it keeps its fingerprint
            perturb["parameters"] = plain(self.parameters)
        out = {
            "study": {"name": self.name, "mechanism": self.mechanism, "variants": self.variants, "seed": self.seed,
                      "steps": self.steps, "tolerance": self.tolerance, "method": self.method},
            "perturb": perturb,
            "scene": {"vertices": plain(self.vertices), "velocities": self.velocities,
                      "accelerations": self.accelerations, "band": self.band, "metrics": plain(self.metrics)},
            "walker": self.walker.as_dict() if self.walker is not None else {},
            "screen": self.screen.as_dict(),
            "output": {"path": self.output, "compression": self.compression},
        }
        if self.lean:  # only when lean: a study storing its series keeps its fingerprint
            out["scene"]["store"] = self.store
        if self.forces:  # only when on: a study without forces keeps its fingerprint
            out["scene"]["forces"] = True
            out["scene"]["force_joints"] = list(self.force_joints)
        if self.operating is not None:
            out["operating"] = self.operating.as_dict()
        if self.robustness is not None:  # only when given: a study without it keeps its fingerprint
            out["robustness"] = self.robustness.as_dict()
        if self.build:  # only when given: the study's [build] over the mechanism's
            out["build"] = dict(self.build)
        if self.target is not None:  # the points themselves (a CSV's content), so a changed target changes the fingerprint
            t = self.target
            out["target"] = {"points": t.points.tolist(), "match": t.match, "ignore": list(t.ignore)}
            if t.angles is not None:
                out["target"]["angles_deg"] = np.degrees(t.angles).tolist()
            if t.phase != "fixed":  # only when free: a study without it keeps its fingerprint
                out["target"]["phase"] = t.phase
            if t.closed:
                out["target"]["closed"] = True
        if self.optimize is not None:  # the optimiser chooses the designs: no [perturb], no variants
            del out["perturb"]
            del out["study"]["variants"]
            out["optimize"] = self.optimize.as_dict()
        return out

    def fingerprint(self) -> str:
        """JSON of everything that decides the results (the output path and the screen excluded): the
        resolved study, the mechanism file's content (SHA-256) and the explorer version. Equal
        fingerprints, equal results: ``--resume`` refuses to finish a file with another one."""
        d = self.as_dict()
        del d["output"]
        del d["screen"]  # applied when ranking; the stored numbers do not depend on it
        d["mechanism_sha256"] = hashlib.sha256(self.mechanism_text().encode()).hexdigest()
        from .. import __version__
        d["explorer_version"] = __version__
        return json.dumps(d, sort_keys=True)

    def mechanism_text(self) -> str:
        """The TOML text of the study's mechanism file (a built-in's own file for a built-in)."""
        if self.mechanism_path:
            return Path(self.mechanism_path).read_text(encoding="utf-8")
        return (resources.files("explorer.mechanism") / "builtin" / f"{self.mechanism}.toml").read_text(encoding="utf-8")


def _short(value, most: int = 80) -> str:
    """repr of a value a user typed, shortened (a 2 MB name is not printed whole)."""
    text = repr(value)
    return text if len(text) <= most else f"{text[:most - 25]}... ({len(text):,} characters)"


def variant_count(method: str, variants: int, k: int) -> int:
    """Total number of variants N for ``variants`` as written and k perturbed parameters.

    Random methods (uniform, normal, lhs, sobol): N = variants. ``oat``: N = 1 + k·variants (the
    nominal, then each parameter alone at ``variants`` levels). ``grid``: N = 1 + variants**k (the
    nominal, then the full factorial). ``saltelli``: N = 1 + variants·(k + 2) (the nominal, then
    Saltelli's scheme for first-order and total Sobol indices: for each of the ``variants`` base
    points the rows A, AB_1 … AB_k, B).
    """
    if method == "saltelli":
        return 1 + variants * (k + 2)
    if method == "oat":
        return 1 + k * variants
    if method == "grid":
        return 1 + variants ** k
    return variants


# -- reading -----------------------------------------------------------------------------------------
def builtin_studies() -> tuple[str, ...]:
    """Names of the studies shipped with explorer (``default``)."""
    folder = resources.files("explorer.study") / "builtin"
    return tuple(sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml")))


def default_study_text() -> str:
    """The TOML text of the built-in default study (the same file as ``studies/default.toml``)."""
    return (resources.files("explorer.study") / "builtin" / "default.toml").read_text(encoding="utf-8")


def load_study(study=None, *, source: str | None = None) -> Study:
    """Load and validate a study.

    ``study`` is a path to a study ``.toml``, a built-in study name (``"default"``), a parsed dict in
    the TOML shape, an existing :class:`Study` (returned as is), or None for the built-in default.
    Raises :class:`~explorer.errors.UserError` naming the file and key on any invalid input.
    """
    if isinstance(study, Study):
        return study
    base = None
    if study is None:
        study = "default"
    if isinstance(study, dict):
        data, src = study, source or "<dict>"
        text = dumps_toml(study)
    else:
        s = str(study)
        path = Path(s)
        if path.is_file():
            src = source or s
            try:
                text = path.read_text(encoding="utf-8")
            except (OSError, UnicodeDecodeError) as exc:
                raise UserError(f"{s}: cannot read: {exc}") from None
            base = path.parent
        elif s in builtin_studies():
            src = source or f"builtin:{s}"
            text = (resources.files("explorer.study") / "builtin" / f"{s}.toml").read_text(encoding="utf-8")
        else:
            raise UserError(f"{s}: no such study file or built-in study (built-ins: {', '.join(builtin_studies())})")
        data = parse_toml(text, src)
    return study_from_dict(data, src, text=text, base=base)


def study_from_dict(data: dict, source: str = "<dict>", *, text: str | None = None, base: Path | None = None) -> Study:
    """Validate a parsed study (the TOML shape) and build a :class:`Study`."""
    if not isinstance(data, dict):
        raise UserError(f"{source}: expected a table with [study], [perturb], [scene], [output], got {data!r}")
    if "links" in data and "study" not in data:  # [[links]]: a mechanism file, not a study
        raise UserError(f"{source}: this is a mechanism file, not a study: a study runs it with "
                        f"[study] mechanism = {str(source)!r} (or see it: explorer animate --mechanism {source})")
    for sec, value in data.items():
        if sec not in _SECTIONS:
            raise UserError(f"{where(source, sec)}: unknown section (allowed: {', '.join(_SECTIONS)})")
        if not isinstance(value, dict):
            raise UserError(f"{where(source, sec)}: expected a table [{sec}], got {value!r}")
        for key in value:
            if key not in _SECTIONS[sec]:
                raise UserError(f"{where(source, f'{sec}.{key}')}: unknown key (allowed in [{sec}]: "
                                f"{', '.join(_SECTIONS[sec])})")
    st, pe, sc, ou, wa, scr = (data.get(s, {}) for s in ("study", "perturb", "scene", "output", "walker", "screen"))
    v = _Validator(source)

    for k in ("name", "mechanism"):
        if k not in st:
            raise UserError(f"{where(source, 'study.' + k)}: missing required key")
    name = v.string("study.name", st["name"])
    if not _NAME_RE.fullmatch(name) or len(name) > MAX_NAME:
        raise UserError(f"{where(source, 'study.name')}: expected 1 to {MAX_NAME} letters, digits, '.', '_' or '-', "
                        f"got {_short(name)}")
    mech_name = v.string("study.mechanism", st["mechanism"])
    mech, mech_path = _mechanism(source, mech_name, base)
    if "build" in data:  # the study's [build] over the mechanism's, key by key: its link masses and size
        from ..mechanism._build import apply_build, build_from_dict
        mech = apply_build(mech, build_from_dict(data["build"], source, base=mech.build), source)

    opt_table = data.get("optimize")
    if opt_table is not None:
        return _optimize_study(data, source, text, v, name, mech_name, mech, mech_path, st, sc, ou, wa, scr, base)
    pmethod = v.choice("perturb.method", pe.get("method", "uniform"), PERTURB_METHODS)
    if pmethod in ("oat", "grid"):
        variants = v.integer("study.variants", st.get("variants", 11), 2, MAX_VARIANTS,
                             f"levels per parameter for perturb.method = {pmethod!r}")
    elif pmethod == "saltelli":
        variants = v.integer("study.variants", st.get("variants", 1024), 2, MAX_VARIANTS,
                             "base samples N for perturb.method = 'saltelli' (N·(k + 2) + 1 variants; a power of "
                             "two keeps the Sobol sequence balanced)")
    else:
        variants = v.integer("study.variants", st.get("variants", 10000), 1, MAX_VARIANTS)
    seed, steps, tolerance, method = _solver_keys(v, st)

    spread = v.number("perturb.spread", pe.get("spread", 0.02), 0.0, 1.0, "a number in [0, 1)", hi_open=True)
    parameters = _parameters(v, pe, mech)
    # links and crank default to "all" and true only without [perturb] parameters
    links = v.names("perturb.links", pe.get("links", "all" if not parameters else []), mech.link_names, "link",
                    empty_ok=bool(parameters))
    crank = v.boolean("perturb.crank", pe.get("crank", mech.crank is not None and not parameters))
    if crank and mech.crank is None:
        raise UserError(f"{where(source, 'perturb.crank')}: mechanism {mech.name!r} is driven along a path; it has no "
                        f"crank radius to perturb (set crank = false)")
    # resolved: links and crank hold every perturbed link and the crank radius, parameters' included
    if parameters == "all":
        links, crank = "all", mech.crank is not None
    elif parameters:
        if links != "all":
            named = set(links) | set(parameters)
            links = tuple(n for n in mech.link_names if n in named)
        crank = crank or "crank" in parameters
    n_coord = sum(mech.parameter_kind(n) == "coordinate"
                  for n in (mech.parameters() if parameters == "all" else parameters))
    k = (len(mech.links) if links == "all" else len(links)) + int(crank) + n_coord
    if k == 0:
        raise UserError(f"{where(source, 'perturb.links')}: nothing to perturb (give links or parameters, or set "
                        f"crank = true)")
    n_total = variant_count(pmethod, variants, k)
    if n_total > MAX_VARIANTS:
        what = "base samples" if pmethod == "saltelli" else "levels"
        raise UserError(f"{where(source, 'study.variants')}: {pmethod} with {variants} {what} over {k} parameters "
                        f"gives {n_total:,} variants; at most {MAX_VARIANTS:,} are allowed")

    common = _scene_and_output(v, source, name, mech, sc, ou, wa, scr, data.get("target"), base,
                               data.get("operating"), data.get("robustness"))
    return Study(name=name, mechanism=mech_name, variants=variants, seed=seed,
                 solver=Solver(steps=steps, tolerance=float(tolerance), method=method),
                 perturb=Perturb(method=pmethod, spread=float(spread), links=links, crank=crank, parameters=parameters),
                 source=source, text=text if text is not None else dumps_toml(data), mechanism_path=mech_path,
                 _mech=mech, build=data.get("build"), **common)


def _scene_and_output(v: "_Validator", source: str, name: str, mech: Mechanism, sc, ou, wa, scr, ta=None,
                      base: Path | None = None, op=None, rb=None) -> dict:
    """The Study fields of [scene], [walker], [screen], [output], [target], [operating] and [robustness],
    validated (``scene`` and ``results_file`` as their sections)."""
    target = load_target(ta, base, source=source, key="target") if ta is not None else None
    vertices = v.names("scene.vertices", sc.get("vertices", [mech.foot]), mech.vertices, "vertex")
    velocities = v.boolean("scene.velocities", sc.get("velocities", True))
    accelerations = v.boolean("scene.accelerations", sc.get("accelerations", False))
    band = v.number("scene.band", sc.get("band", 0.01), 0.0, 1.0, "a number in (0, 1)", lo_open=True, hi_open=True)
    metrics = _metrics(v, sc.get("metrics", False))

    walker = None
    if mech.crank is not None:
        walker = walker_from_dict(wa, source, "walker", base=mech.walker)
    elif wa:
        raise UserError(f"{where(source, 'walker')}: mechanism {mech.name!r} is driven along a path; a walker needs a crank")
    screen = screen_from_dict(scr, source, "screen")
    forces = v.boolean("scene.forces", sc.get("forces", False))
    force_joints = ()
    if "force_joints" in sc:
        force_joints = v.names("scene.force_joints", sc["force_joints"], mech.vertices, "joint", empty_ok=True)
        force_joints = tuple(mech.vertices) if force_joints == "all" else tuple(force_joints)
        if force_joints and not forces:
            raise UserError(f"{where(source, 'scene.force_joints')}: joint reactions are stored only with "
                            f"[scene] forces = true")
    operating = mech.operating
    if op is not None:
        operating = operating_from_dict(op, source, "operating", base=mech.operating)
        bu = getattr(mech.build, "unit", None)
        if bu is not None and operating.unit is not None and abs(operating.unit / bu - 1.0) > 1e-12:
            raise UserError(f"{where(source, 'operating.unit')}: {operating.unit:g} m per model unit, but the build "
                            f"says unit = {bu:g}: one machine has one size (give it once)")
    if forces:
        if mech.crank is None:
            raise UserError(f"{where(source, 'scene.forces')}: mechanism {mech.name!r} is driven along a path; the "
                            f"forces effect gives a crank's motor torque")
        for k, what in (("unit", "metres per model unit, e.g. 0.01 for a mechanism in centimetres"),
                        ("rpm", "the crank speed in revolutions per minute")):
            if operating is None or getattr(operating, k) is None:
                raise UserError(f"{where(source, 'operating.' + k)}: [scene] forces = true needs it ({what}), in the "
                                f"study's [operating] table or the mechanism's")
        operating = walker_body(mech, operating, source)  # the force model, stored resolved
    elif operating is not None and operating.load and mech.crank is None:
        raise UserError(f"{where(source, 'operating.load')}: a load rides on a walker's contact foot; mechanism "
                        f"{mech.name!r} is driven along a path")
    rail = next((sl for sl in mech.sliders if sl.ground and sl.vertex == mech.foot), None)
    if operating is not None and operating.load and rail is not None:
        raise UserError(f"{where(source, 'operating.load')}: a load rides on a walker's contact foot; the foot "
                        f"{mech.foot!r} of mechanism {mech.name!r} runs on the ground slider {rail.name!r}")

    robustness = robustness_from_dict(rb, source, mech, operating) if rb is not None else None
    if robustness is None and isinstance(metrics, tuple) and YIELD in metrics:
        raise UserError(f"{where(source, 'scene.metrics')}: {YIELD!r} needs a [robustness] table (tolerance = ..., the "
                        f"manufacturing error its copies are cut with, e.g. tolerance = 0.5 and unit = \"%\")")

    out = ou.get("path", f"results/{name}.h5")
    out = v.string("output.path", out)
    compression = v.choice("output.compression", ou.get("compression", "blosc"), COMPRESSIONS)
    store = v.choice("scene.store", sc.get("store", "series"), STORES)

    scene = Scene(vertices=vertices, velocities=velocities, accelerations=accelerations, band=float(band),
                  metrics=metrics, forces=forces, force_joints=force_joints, store=store)
    return dict(scene=scene, results_file=Output(path=out, compression=compression), walker=walker, screen=screen,
                target=target, operating=operating, robustness=robustness)


def _solver_keys(v: "_Validator", st: dict):
    """[study] seed, steps, tolerance and method, validated."""
    seed = v.integer("study.seed", st.get("seed", 0), 0, 2 ** 63 - 1)
    steps = v.integer("study.steps", st.get("steps", 360), 3, 10_000_000)
    lo, hi = TOLERANCE_RANGE
    tolerance = v.number("study.tolerance", st.get("tolerance", DEFAULT_TOLERANCE), lo, hi,
                         f"a number from {lo:g} to {hi:g}: the bound on every solved position's error relative to the "
                         f"longest link (looser saves no time, tighter hits rounding)")
    method = v.choice("study.method", st.get("method", "block"), SOLVE_METHODS)
    return seed, steps, float(tolerance), method


def _optimize_study(data, source, text, v, name, mech_name, mech, mech_path, st, sc, ou, wa, scr, base) -> Study:
    """A study with an [optimize] table: the designs are the optimiser's (see ``_objectives``)."""
    if "perturb" in data:
        raise UserError(f"{where(source, 'perturb')}: a study with [optimize] takes no [perturb] (the optimiser "
                        f"chooses the designs; give the searched parameters in [optimize])")
    if "variants" in st:
        raise UserError(f"{where(source, 'study.variants')}: a study with [optimize] takes no variants (it evaluates "
                        f"[optimize] population x generations designs)")
    seed, steps, tolerance, method = _solver_keys(v, st)
    known = _known_metrics() or ()
    opt = parse_optimize(data["optimize"], source, mech, known, has_target="target" in data)
    common = _scene_and_output(v, source, name, mech, sc, ou, wa, scr, data.get("target"), base,
                               data.get("operating"), data.get("robustness"))
    from ..gait import CHECKS, available_metrics
    from ._objectives import metrics_needed
    why_not = available_metrics(mech)  # the screen reads only the inputs the mechanism has (none: a foot on a slider)
    needed = metrics_needed(opt, tuple(col for check in CHECKS for col in check.inputs if why_not.get(col) is None))
    from ..gait import metric
    forced = [m for m in needed if metric(m) is not None and metric(m).group == "forces"]
    if forced and not common["scene"].forces:
        raise UserError(f"{where(source, 'optimize')}: {', '.join(forced)} come from the forces effect; set "
                        f"[scene] forces = true (with an [operating] table) to search on them")
    needed = tuple(m for m in needed if m not in forced)  # the forces effect computes those with the solve
    if YIELD in needed and common["robustness"] is None:
        raise UserError(f"{where(source, 'optimize')}: {YIELD!r} needs a [robustness] table (tolerance = ..., the "
                        f"manufacturing error its copies are cut with, e.g. tolerance = 0.5 and unit = \"%\")")
    metrics = common["scene"].metrics
    if metrics is not True:  # compute what the search needs on top of what the scene asks for
        metrics = tuple(dict.fromkeys((metrics or ()) + needed))
    common["scene"] = replace(common["scene"], metrics=metrics)
    params = opt.parameters
    links = tuple(n for n in mech.link_names if n in params)
    perturb = Perturb(method="optimize", spread=0.0, links=links, crank="crank" in params, parameters=params)
    return Study(name=name, mechanism=mech_name, variants=opt.evaluations, seed=seed,
                 solver=Solver(steps=steps, tolerance=tolerance, method=method), perturb=perturb, source=source,
                 text=text if text is not None else dumps_toml(data), mechanism_path=mech_path, _mech=mech,
                 optimize=opt, build=data.get("build"), **common)


def _parameters(v: "_Validator", pe: dict, mech: Mechanism):
    """``[perturb] parameters``: ``"all"``, a tuple of design parameter names, or () when absent."""
    if "parameters" not in pe:
        return ()
    value = pe["parameters"]
    known = tuple(mech.parameters())
    if mech.crank is None and isinstance(value, list):
        for n in value:
            if n in ("crank", "crank.x", "crank.y"):
                raise UserError(f"{where(v.source, 'perturb.parameters')}: mechanism {mech.name!r} is driven along a "
                                f"path; it has no crank, so no {n!r} to perturb (known: {', '.join(known)})")
    return v.names("perturb.parameters", value, known, "design parameter")


def _mechanism(source: str, name: str, base: Path | None) -> tuple[Mechanism, str | None]:
    candidates = []
    p = Path(name)
    if base is not None and not p.is_absolute():
        candidates.append(base / p)
    candidates.append(p)
    for c in candidates:
        if c.is_file():
            return load_mechanism(c), str(c)
    if name in builtin_mechanisms():
        return load_mechanism(name), None
    raise UserError(f"{where(source, 'study.mechanism')}: no mechanism file or built-in called {name!r} "
                    f"(built-ins: {', '.join(builtin_mechanisms())}, or a path to a .toml)")


def _metrics(v: "_Validator", value):
    if isinstance(value, bool):
        return value
    if not isinstance(value, list) or not value:
        raise UserError(f"{where(v.source, 'scene.metrics')}: expected true, false or a non-empty list of metric "
                        f"names, got {value!r}")
    known = _known_metrics()
    seen = []
    for m in value:
        if not isinstance(m, str) or not m:
            raise UserError(f"{where(v.source, 'scene.metrics')}: expected metric names (strings), got {m!r}")
        if known is not None and m not in known:
            raise UserError(f"{where(v.source, 'scene.metrics')}: unknown metric {m!r} (allowed: {', '.join(known)})")
        if m in seen:
            raise UserError(f"{where(v.source, 'scene.metrics')}: metric {m!r} is listed twice")
        seen.append(m)
    return tuple(seen)


def _known_metrics():
    """Metric names published by ``explorer.gait`` as ``METRICS``, or None if it is not available."""
    try:
        from .. import gait
    except ImportError:  # the gait module is optional here
        return None
    names = getattr(gait, "METRICS", None)
    return tuple(names) if names else None


class _Validator:
    """Typed checks that raise one-line UserErrors naming ``source: key``."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, key: str, allowed: str, value) -> None:
        raise UserError(f"{where(self.source, key)}: expected {allowed}, got {_short(value)}")

    def string(self, key, value) -> str:
        if not isinstance(value, str) or not value.strip():
            self.fail(key, "a non-empty string", value)
        return value

    def boolean(self, key, value) -> bool:
        if not isinstance(value, bool):
            self.fail(key, "true or false", value)
        return value

    def integer(self, key, value, lo, hi, what: str = "") -> int:
        allowed = f"an integer from {lo:,} to {hi:,}" + (f" ({what})" if what else "")
        if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
            self.fail(key, allowed, value)
        return int(value)

    def number(self, key, value, lo, hi, allowed, lo_open=False, hi_open=False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            self.fail(key, allowed, value)
        below = value <= lo if lo_open else value < lo
        above = value >= hi if hi_open else value > hi
        if below or above:
            self.fail(key, allowed, value)
        return float(value)

    def choice(self, key, value, options) -> str:
        if not isinstance(value, str) or value not in options:
            self.fail(key, "one of " + ", ".join(repr(o) for o in options), value)
        return value

    def names(self, key, value, known, what, empty_ok: bool = False):
        """``"all"`` or a non-empty (or, with ``empty_ok``, empty) list of distinct names from ``known``;
        returns "all" or a tuple."""
        if value == "all":
            return "all"
        if not isinstance(value, list) or not (value or empty_ok):
            self.fail(key, f'"all" or a {"" if empty_ok else "non-empty "}list of {what} names', value)
        seen = []
        for n in value:
            if not isinstance(n, str):
                self.fail(key, f"{what} names as strings (known: {', '.join(known)})", n)
            if n not in known:
                raise UserError(f"{where(self.source, key)}: unknown {what} {n!r} (known: {', '.join(known)})")
            if n in seen:
                raise UserError(f"{where(self.source, key)}: {what} {n!r} is listed twice")
            seen.append(n)
        return tuple(seen)


# -- writing -------------------------------------------------------------------------------------------
# the TOML writer lives beside the loader, in explorer/mechanism/_toml.py


# -- what the scene asks the solver for (the chunk runner and the lean store's re-solve read it) ---------------
def metric_plan(study: Study):
    """(metric names or None for all, needs velocities, needs the foot) of the study's scene: the
    metrics of the foot path (``yield``, which re-solves copies, is ``_chunk.wants_yield``'s)."""
    if study.metrics is False:
        return [], False, False
    names = None if study.metrics is True else [m for m in study.metrics if m != YIELD]
    if names == []:
        return [], False, False
    need_vel = names is None or any(m in VELOCITY_METRICS for m in names)
    return names, need_vel, True


def series_solve(study: Study) -> dict:
    """How ``study``'s designs are solved, as plain JSON-able values: ``steps``, ``tolerance``,
    ``method``, ``vertices`` (the solved vertices: the scene's, plus the foot when metrics are asked
    for), ``velocities`` and ``accelerations`` (solved), ``forces`` and ``force_joints``; and what a
    full study stores of it: ``stored`` (the scene's vertices) and ``groups`` (``paths``, and
    ``velocities`` / ``accelerations`` when the scene asks for them). ``_chunk.design_solver`` solves
    with exactly these arguments, and a lean results file records them (root attribute
    ``series_solve``) so that its readers re-solve any design bit for bit
    (:meth:`explorer.store.Results.path`)."""
    mech = study.mech
    _, metric_vel, want_metrics = metric_plan(study)
    vertices = list(study.vertex_names)
    if want_metrics and mech.foot not in vertices:
        vertices.append(mech.foot)
    from ..store import SERIES  # the stored series, one registry (explorer.store._datasets.SERIES)
    groups = [spec.group for spec in SERIES if spec.member == "vertex" and spec.stored(study)]
    return {"steps": int(study.steps), "tolerance": float(study.tolerance), "method": study.method,
            "vertices": vertices, "velocities": bool(study.velocities or metric_vel),
            "accelerations": bool(study.accelerations), "forces": bool(study.forces),
            "force_joints": list(study.force_joints), "stored": list(study.vertex_names), "groups": groups}


from ..mechanism import dumps_toml  # noqa: E402,F401
