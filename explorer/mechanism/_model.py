"""The mechanism data model: a planar linkage as a graph of pin joints and rigid links."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Mapping

import numpy as np

from ..errors import UserError, where


#: Lengths a mechanism may have, model units: beyond them squares of lengths lose every digit of their
#: differences (or overflow), so no solve could be trusted.
LENGTH_RANGE = (1e-9, 1e9)
#: Vertex and link names: they become HDF5 dataset names and frame columns.
NAME_RE = re.compile(r"^[A-Za-z0-9_.+-]{1,64}$")


@dataclass(frozen=True)
class Link:
    """A rigid link of ``length`` (model units) between vertices ``a`` and ``b``."""

    name: str
    a: str
    b: str
    length: float
    mass: float | None = None  # kg, a uniform bar; None: the mechanism's ``link_density`` × length (or massless)


@dataclass(frozen=True)
class Body:
    """A rigid body (a ternary or bigger link) that carries the joints ``joints``.

    ``points[i]`` is joint ``joints[i]``'s position in the body's own frame (model units); only the
    shape matters, not where the frame is. Joints may be collinear (a coupler with its foot on the
    line through its two pins). A body turns and moves but never mirrors.

    For the forces effect: ``mass`` (kg, default 0: massless), ``centroid`` (its centre of mass in the
    body's frame, model units; default: the mean of its joints) and ``inertia`` (kg·m² about the
    centroid; default: the mass shared equally among its joints, m/n·Σ|joint − centroid|²).
    """

    name: str
    joints: tuple[str, ...]
    points: tuple[tuple[float, float], ...]
    mass: float = 0.0
    centroid: tuple[float, float] | None = None
    inertia: float | None = None

    @property
    def span(self) -> float:
        """The largest distance between two of the body's joints, model units."""
        pts = np.asarray(self.points, dtype=np.float64)
        return float(np.max(np.hypot(*(pts[:, None, :] - pts[None, :, :]).transpose(2, 0, 1))))


@dataclass(frozen=True)
class Slider:
    """A prismatic joint: vertex ``vertex`` slides on a line (no friction, no rotation of its own).

    A *ground* line (``line`` None) passes through ``point`` along ``direction`` (model units; only
    the direction of ``direction`` counts). A *slot* is the line through two vertices ``line = (a, b)``
    that one rigid member holds at a fixed distance (a link's ends, or two joints of one body),
    shifted by ``offset`` (model units, to the left of a → b). The equation is one scalar row: the
    vertex's signed perpendicular distance from the line equals ``offset`` (0 for a ground line).

    Design parameters: a ground line's ``NAME.x``, ``NAME.y`` (the point) and ``NAME.dx``,
    ``NAME.dy`` (the direction; not for a slider that a linear actuator drives); a slot's
    ``NAME.offset``.
    """

    name: str
    vertex: str
    point: tuple[float, float] | None = None
    direction: tuple[float, float] | None = None
    line: tuple[str, str] | None = None
    offset: float = 0.0

    @property
    def ground(self) -> bool:
        """True for a line fixed to the ground, False for a slot carried by a moving member."""
        return self.line is None

    def unit(self) -> tuple[float, float]:
        """A ground line's unit direction."""
        dx, dy = self.direction
        n = math.hypot(dx, dy)
        return dx / n, dy / n


@dataclass(frozen=True)
class Gear:
    """A second grounded crank geared to the driving crank (``[[gears]]``: a geared five-bar's).

    Its tip ``tip`` turns about ``center`` at ``radius`` (model units) through the angle
    ``ratio`` × θ + ``phase`` (θ the driving crank's angle; ``ratio`` a nonzero integer, the turns it
    makes per crank turn, negative the other way; ``phase`` in degrees). Design parameters: ``NAME``
    (its radius, a length) and ``NAME.x``, ``NAME.y`` (its centre).
    """

    name: str
    center: tuple[float, float]
    radius: float
    tip: str
    ratio: int
    phase: float = 0.0

    def tip_at(self, theta: float) -> tuple[float, float]:
        """Its tip at crank angle ``theta`` (radians)."""
        psi = self.ratio * theta + math.radians(self.phase)
        return (self.center[0] + self.radius * math.cos(psi), self.center[1] + self.radius * math.sin(psi))


@dataclass(frozen=True)
class Crank:
    """The driver: vertex ``tip`` moves on a circle of ``radius`` about ``center``.

    The crank angle θ (radians) is measured counter-clockwise from +x, so the tip sits at
    ``center + radius * (cos θ, sin θ)``.
    """

    center: tuple[float, float]
    radius: float
    tip: str
    mass: float | None = None  # kg, a uniform bar from the centre to the tip; None: link_density × radius (or 0)


@dataclass(frozen=True)
class PathDriver:
    """The driver: vertex ``vertex`` follows a prescribed path over ``duration`` seconds.

    kind "line": from ``points[0]`` to ``points[1]``; "arc": about ``center`` with ``radius`` from
    ``start_angle`` to ``end_angle`` (radians, counter-clockwise positive); "points": a natural cubic
    spline through ``points`` with uniform knots. ``timing`` "linear" moves at constant rate along
    the path parameter; "quintic" is seed 004's rest-to-rest law (zero velocity and acceleration at
    both ends). Velocities of a path-driven mechanism are per second.
    """

    vertex: str
    kind: str
    duration: float
    timing: str = "linear"
    points: tuple[tuple[float, float], ...] = ()
    center: tuple[float, float] = (0.0, 0.0)
    radius: float = 0.0
    start_angle: float = 0.0
    end_angle: float = 0.0
    orientation: Orientation | None = None  # a spherical wrist on ``vertex`` and its orientation path
    slider: str | None = None  # a linear actuator: the ground slider it pushes (kind "line" along it)
    stroke: tuple[float, float] = (0.0, 0.0)  # the actuator's start and end, model units along the slider's line


@dataclass(frozen=True)
class Orientation:
    """A spherical wrist on a path driver's vertex and the orientation path it follows (seed 004, problem 1).

    keyframes : K ≥ 2 rotation matrices, each 9 floats row by row, reached at path fractions k/(K−1) of
        the driver's timing law (so at the driver's start, end and evenly between in path fraction).
    interpolation : one of :data:`INTERPOLATIONS`: "slerp" (the geodesic), "spline" (RotationSpline),
        "matrix" (element-wise, not a rotation in between), "euler" (linear on Euler angles in
        ``euler_seq``), "axis-angle" (linear on the rotation vectors).
    wrist : the wrist's three joint axes in order, an intrinsic Euler sequence (``"ZYZ"``: R = Rz·Ry·Rz).
    branch : 1 or 2, the wrist's joint solution at the start (1: the middle angle in [−90°, 90°] for a
        Tait–Bryan sequence, in [0°, 180°] for a proper one; 2: the other), followed by continuity.
    euler_seq : the "euler" method's sequence ("" = ``wrist``); euler_set : 1 or 2, the first keyframe's
        solution set when it is not given as angles in that sequence.
    euler : per keyframe, (sequence, (a, b, c), degrees) as written in the file (angles in degrees when
        ``degrees`` is true, else radians), or None (a matrix or axis-angle keyframe).
    """

    keyframes: tuple[tuple[float, ...], ...]
    interpolation: str = "slerp"
    wrist: str = "ZYZ"
    branch: int = 1
    euler_seq: str = ""
    euler_set: int = 1
    euler: tuple = ()

    def matrices(self) -> np.ndarray:
        """The keyframes as an array (K, 3, 3)."""
        return np.array(self.keyframes, dtype=np.float64).reshape(-1, 3, 3)

    def euler_radians(self, seq: str) -> list:
        """Per keyframe, its angles (3,) in radians where it was written as Euler angles in ``seq``, else None."""
        return [None if g is None or g[0] != seq else (np.radians(g[1]) if g[2] else np.array(g[1], dtype=np.float64))
                for g in (self.euler or (None,) * len(self.keyframes))]


#: Orientation interpolations (:class:`Orientation`), one home: explorer.wrist interpolates them.
INTERPOLATIONS = ("slerp", "spline", "matrix", "euler", "axis-angle")
#: The 12 Euler sequences (upper case: intrinsic; the lower-case spelling of each is its extrinsic reading).
EULER_SEQUENCES = tuple(a + b + c for a in "XYZ" for b in "XYZ" for c in "XYZ" if a != b and b != c)


def valid_sequence(seq) -> bool:
    """True for an Euler sequence such as "ZYZ", "ZYX" or "xyz" (no axis twice in a row, one case)."""
    return (isinstance(seq, str) and len(seq) == 3 and seq.upper() in EULER_SEQUENCES
            and (seq.isupper() or seq.islower()))


@dataclass(frozen=True)
class Walker:
    """The walker scene of a crank-driven leg: the leg replicated on one crankshaft.

    legs : number of legs L ≥ 1.
    phases : (L,) crank phase offset φ_j of each leg, radians; leg j's foot is the leg's foot at
        crank angle θ + φ_j. Default: evenly spaced, φ_j = 2πj/L.
    mirrored : (L,) bools; a mirrored leg is the mirror image of the leg about the vertical through
        the crank centre, driven backwards (its foot at θ is the mirror image of the foot at
        π − (θ + φ_j)), as ``explorer animate --legs`` draws the odd legs. Default: none.
    drag : horizontal drag D on the body as a fraction of its weight W (≥ 0), for the torque metrics.
    contact : a foot within ``contact`` × crank radius of the ground counts as touching it (for slip,
        contact fraction and clearance; > 0).
    """

    legs: int = 4
    phases: tuple[float, ...] = ()
    mirrored: tuple[bool, ...] = ()
    drag: float = 0.0
    contact: float = 0.01

    def __post_init__(self):
        L = int(self.legs)
        object.__setattr__(self, "legs", L)
        if not self.phases:
            object.__setattr__(self, "phases", tuple(2.0 * math.pi * j / L for j in range(L)))
        if not self.mirrored:
            object.__setattr__(self, "mirrored", (False,) * L)
        object.__setattr__(self, "phases", tuple(float(p) for p in self.phases))
        object.__setattr__(self, "mirrored", tuple(bool(m) for m in self.mirrored))
        if len(self.phases) != L or len(self.mirrored) != L:
            raise ValueError(f"walker: {L} legs need {L} phases and {L} mirrored flags")

    def as_dict(self) -> dict:
        """The TOML shape: phases in degrees."""
        return {"legs": self.legs, "phases": [round(math.degrees(p), 12) for p in self.phases],
                "mirrored": list(self.mirrored), "drag": self.drag, "contact": self.contact}


@dataclass(frozen=True)
class Operating:
    """How a built machine runs, for the forces effect (``[operating]`` in a study or a mechanism file).

    unit : metres per model unit (0.01 for Jansen's numbers in centimetres); None if not given.
    rpm : the crank's constant speed, revolutions per minute (> 0); None if not given.
    gravity : m/s², acting along −y (0 turns it off; default 9.81).
    load : kg, the mass of the walker's body: frame, motor, battery, everything but the legs (default 0).
        It rides on the contact foot (the walker scene's lowest foot, with its drag).
    speed_fluctuation : the crank speed's allowed total fluctuation C_s = (ω_max − ω_min)/ω_mean that
        sizes the flywheel (default 0.05, i.e. ±2.5 %).
    body : the force model, :data:`BODY_MODELS`: "moving" (the body moves with the planted contact
        foot and the ground carries the whole machine through it) or "held" (the frame is held still
        in space, the legs hang from it and the ground carries the load alone); None when not given:
        the forces effect then takes "moving", or "held" for a foot that runs on a ground slider.
    gear_ratio : N, the motor turns N times for one crank turn (default 1); the flywheel on the motor
        shaft needs I/N² of the crank-side inertia.
    """

    unit: float | None = None
    rpm: float | None = None
    gravity: float = 9.81
    load: float = 0.0
    speed_fluctuation: float = 0.05
    body: str | None = None
    gear_ratio: float = 1.0

    @property
    def omega(self) -> float:
        """The crank speed, rad/s."""
        return float(self.rpm) * 2.0 * math.pi / 60.0

    def as_dict(self) -> dict:
        """The TOML shape (keys not given are left out)."""
        return {k: v for k, v in (("unit", self.unit), ("rpm", self.rpm), ("gravity", self.gravity),
                                  ("load", self.load), ("speed_fluctuation", self.speed_fluctuation),
                                  ("body", self.body), ("gear_ratio", self.gear_ratio)) if v is not None}


#: The walker's force models (``[operating] body``), the default first.
BODY_MODELS = ("moving", "held")


def _frozen(d: Mapping[str, tuple[float, float]]) -> Mapping[str, tuple[float, float]]:
    return MappingProxyType({k: (float(v[0]), float(v[1])) for k, v in d.items()})


@dataclass(frozen=True)
class Mechanism:
    """A crank-driven planar linkage (the vertex formulation of seed 000).

    Attributes
    ----------
    name, description : str
    vertices : tuple[str, ...]
        Every vertex name, in a fixed order: the crank tip, the fixed vertices, then the guessed
        ones, each group in file order. Position arrays index vertices in this order.
    links : tuple[Link, ...]
        Rigid links in file order; ``lengths`` arrays follow this order.
    crank : Crank or None
        The crank, for crank-driven mechanisms (the usual case); None when ``path`` drives it.
    fixed : Mapping[str, (x, y)]
        Ground pivots.
    guess : Mapping[str, (x, y)]
        Rough positions at θ = 0 for every other vertex; they choose the assembly (branch).
    foot : str
        The vertex whose path is the gait.
    source : str
        Where the mechanism came from (a file path or ``builtin:NAME``), used in error messages.
    path : PathDriver or None
        A prescribed path driving one vertex, instead of a crank.
    walker : Walker or None
        The file's ``[walker]`` table: the default walker scene of this leg (None: the generic
        default, :class:`Walker`).
    bodies : tuple[Body, ...]
        Rigid bodies with two or more joints (file order).
    link_density : float or None
        ``[mass] link_density``: kg per metre of link length, the mass of every link (and the crank)
        that gives none of its own (None: such links are massless).
    operating : Operating or None
        The file's ``[operating]`` table: the default operating point for the forces effect.
    sliders : tuple[Slider, ...]
        Prismatic joints (file order): a vertex on a ground line or in a slot of a moving member.
    gears : tuple[Gear, ...]
        Grounded cranks geared to the driving crank (file order); each tip is a vertex (in ``guess``,
        at its exact place at θ = 0).
    build : Build or None
        The file's ``[build]`` table (:mod:`explorer.mechanism._build`): the sheet, part width, pin and
        shaft materials and size the design is built with (the link masses come from it).

    Design parameters
    -----------------
    Every number a designer may vary has a name (:meth:`parameters`): each link's length by its
    name (``"2-6"``); for a crank, its radius ``"crank"`` and centre ``"crank.x"``, ``"crank.y"``;
    each ground pivot's coordinates ``"2.x"``, ``"2.y"``; each body joint's coordinates in its
    body's frame ``"coupler.P.x"``, ``"coupler.P.y"``; each ground slider's line ``"piston.x"``,
    ``"piston.y"``, ``"piston.dx"``, ``"piston.dy"`` (its point and direction), each slot's
    ``"block.offset"`` and each geared crank's radius ``"gear"`` and centre ``"gear.x"``, ``"gear.y"``.
    """

    name: str
    description: str
    vertices: tuple[str, ...]
    links: tuple[Link, ...]
    crank: Crank | None
    fixed: Mapping[str, tuple[float, float]]
    guess: Mapping[str, tuple[float, float]]
    foot: str
    source: str = "<memory>"
    path: PathDriver | None = None
    walker: Walker | None = None
    bodies: tuple[Body, ...] = ()
    link_density: float | None = None
    operating: Operating | None = None
    sliders: tuple[Slider, ...] = ()
    gears: tuple[Gear, ...] = ()
    build: object = None  # a Build (explorer.mechanism._build), or None
    _index: Mapping[str, int] = field(init=False, repr=False, compare=False)
    #: the parameter table (names → nominal, names → kind, link names), built once per mechanism on first
    #: use: a study asks for a parameter's kind per parameter, which rebuilt the table each time
    #: (quadratic in the mechanism: 2,999 vertices spent ~60 CPU-s there)
    _table: list = field(init=False, repr=False, compare=False, default_factory=list)

    def __post_init__(self):
        object.__setattr__(self, "fixed", _frozen(self.fixed))
        object.__setattr__(self, "guess", _frozen(self.guess))
        object.__setattr__(self, "_index", MappingProxyType({v: i for i, v in enumerate(self.vertices)}))
        object.__setattr__(self, "_table", [])

    def _parameter_table(self) -> tuple:
        """(items, {name: nominal}, {name: kind}, link names, {link name: index}), built once (the mechanism
        is frozen)."""
        if not self._table:
            items = self._parameter_items()
            names = tuple(l.name for l in self.links)
            links = set(names)
            gears = {g.name for g in self.gears}
            kinds = {n: "length" if n == "crank" or n in links or n in gears else "coordinate" for n, _ in items}
            index = {}
            for i, n in enumerate(names):
                index.setdefault(n, i)  # the first of a repeated name, as a scan finds it
            self._table.append((tuple(items), dict(items), MappingProxyType(kinds), names, index))
        return self._table[0]

    # -- lookups ---------------------------------------------------------------------------
    def vertex_index(self, name: str) -> int:
        """Index of vertex ``name`` in :attr:`vertices` (UserError if unknown)."""
        try:
            return self._index[str(name)]
        except KeyError:
            raise UserError(
                f"{where(self.source, 'vertices')}: unknown vertex {name!r} "
                f"(known: {', '.join(self.vertices)})"
            ) from None

    def link_index(self, name: str) -> int:
        """Index of the link called ``name`` in :attr:`links` (UserError if unknown)."""
        i = self._parameter_table()[4].get(name) if isinstance(name, str) else None
        if i is not None:
            return i
        raise UserError(
            f"{where(self.source, 'links')}: unknown link {name!r} "
            f"(known: {', '.join(l.name for l in self.links)})"
        )

    @property
    def driven(self) -> str:
        """Name of the driven vertex (the crank tip, or the vertex on the prescribed path)."""
        return self.crank.tip if self.crank is not None else self.path.vertex

    @property
    def link_names(self) -> tuple[str, ...]:
        return self._parameter_table()[3]

    @property
    def size(self) -> float:
        """The longest link or body span, model units: the scale of tolerances and coordinate spreads."""
        spans = [l.length for l in self.links] + [b.span for b in self.bodies]
        return float(max(spans))

    def parameters(self) -> dict[str, float]:
        """Every design parameter's nominal value by name, in a fixed order: link lengths
        (:attr:`links` order), the crank radius and centre, the ground pivots' coordinates, then the
        body joints' coordinates (body, then joint order). Lengths are model units, coordinates too.
        A new dict each call (the table itself is built once per mechanism)."""
        return dict(self._parameter_table()[1])

    def parameter_items(self) -> list[tuple[str, float]]:
        """(name, nominal) of every design parameter, in :meth:`parameters` order (as a list, so a
        loader can tell two parameters that would share a name)."""
        return list(self._parameter_table()[0])

    def _parameter_items(self) -> list[tuple[str, float]]:
        out = [(l.name, float(l.length)) for l in self.links]
        if self.crank is not None:
            out += [("crank", float(self.crank.radius)), ("crank.x", float(self.crank.center[0])),
                    ("crank.y", float(self.crank.center[1]))]
        for v, (x, y) in self.fixed.items():
            out += [(f"{v}.x", float(x)), (f"{v}.y", float(y))]
        for b in self.bodies:
            for j, (x, y) in zip(b.joints, b.points):
                out += [(f"{b.name}.{j}.x", float(x)), (f"{b.name}.{j}.y", float(y))]
        actuated = self.path.slider if self.path is not None else None
        for s in self.sliders:
            if s.ground:
                out += [(f"{s.name}.x", float(s.point[0])), (f"{s.name}.y", float(s.point[1]))]
                if s.name != actuated:
                    out += [(f"{s.name}.dx", float(s.direction[0])), (f"{s.name}.dy", float(s.direction[1]))]
            else:
                out.append((f"{s.name}.offset", float(s.offset)))
        for g in self.gears:
            out += [(g.name, float(g.radius)), (f"{g.name}.x", float(g.center[0])), (f"{g.name}.y", float(g.center[1]))]
        return out

    def parameter_kind(self, name: str) -> str:
        """``"length"`` (a link length or the crank radius: positive, varied relatively) or
        ``"coordinate"`` (a crank centre, ground pivot or body joint coordinate: varied by a
        distance). UserError naming the known parameters if ``name`` is not one."""
        kinds = self._parameter_table()[2]
        kind = kinds.get(name) if isinstance(name, str) else None
        if kind is None:
            known = ", ".join(kinds)
            raise UserError(f"{where(self.source, 'parameters')}: unknown design parameter {name!r} (known: {known})")
        return kind

    def parameter_kinds(self) -> Mapping[str, str]:
        """{parameter name: :meth:`parameter_kind`} of every design parameter, in :meth:`parameters` order
        (read only; built once per mechanism)."""
        return self._parameter_table()[2]

    def with_parameters(self, values: Mapping[str, float]) -> "Mechanism":
        """A variant with some design parameters (by name, see :meth:`parameters`) replaced."""
        values = {str(k): float(v) for k, v in values.items()}
        for k in values:
            self.parameter_kind(k)  # raises on an unknown name
        lengths = {k: v for k, v in values.items() if k in self.link_names}
        out = self.with_lengths(lengths, values.get("crank"))
        changes = {}
        if out.crank is not None and ("crank.x" in values or "crank.y" in values):
            cx, cy = out.crank.center
            changes["crank"] = replace(out.crank, center=(values.get("crank.x", cx), values.get("crank.y", cy)))
        if any(f"{v}.{a}" in values for v in self.fixed for a in "xy"):
            changes["fixed"] = {v: (values.get(f"{v}.x", x), values.get(f"{v}.y", y)) for v, (x, y) in self.fixed.items()}
        if self.sliders and any(k.split(".", 1)[0] in {s.name for s in self.sliders} for k in values):
            sl = []
            for s in self.sliders:
                if s.ground:
                    g = lambda a, d: values.get(f"{s.name}.{a}", d)  # noqa: E731
                    sl.append(replace(s, point=(g("x", s.point[0]), g("y", s.point[1])),
                                      direction=(g("dx", s.direction[0]), g("dy", s.direction[1]))))
                else:
                    sl.append(replace(s, offset=values.get(f"{s.name}.offset", s.offset)))
            changes["sliders"] = tuple(sl)
            if self.path is not None and self.path.slider is not None:
                changes["path"] = actuator_path(self.path, next(s for s in sl if s.name == self.path.slider))
        if self.gears and any(k.split(".", 1)[0] in {g.name for g in self.gears} for k in values):
            gears = tuple(replace(g, radius=values.get(g.name, g.radius),
                                  center=(values.get(f"{g.name}.x", g.center[0]), values.get(f"{g.name}.y", g.center[1])))
                          for g in self.gears)
            changes["gears"] = gears
            changes["guess"] = {**self.guess, **{g.tip: g.tip_at(0.0) for g in gears}}
        if self.bodies and any(k.count(".") == 2 for k in values):
            changes["bodies"] = tuple(
                replace(b, points=tuple((values.get(f"{b.name}.{j}.x", x), values.get(f"{b.name}.{j}.y", y))
                                        for j, (x, y) in zip(b.joints, b.points)))
                for b in self.bodies)
        return replace(out, **changes) if changes else out

    @property
    def lengths(self) -> np.ndarray:
        """Link lengths, shape (n_links,), in :attr:`links` order."""
        return np.array([l.length for l in self.links], dtype=np.float64)

    # -- variants --------------------------------------------------------------------------
    def with_lengths(self, lengths: Mapping[str, float] | None = None, crank: float | None = None) -> "Mechanism":
        """A variant with some link lengths (by link name) and/or the crank radius replaced.

        The mechanism it is called on is left untouched.
        """
        lengths = dict(lengths or {})
        names = set(self.link_names)
        for k, v in lengths.items():
            if k not in names:
                self.link_index(k)  # raises the UserError naming the link
            _check_length(self.source, f"links.{k}.length", v)
        links = tuple(replace(l, length=float(lengths[l.name])) if l.name in lengths else l for l in self.links)
        new_crank = self.crank
        if crank is not None:
            if self.crank is None:
                raise UserError(f"{where(self.source, 'crank')}: this mechanism is driven by a path, not a crank")
            _check_length(self.source, "crank.radius", crank)
            new_crank = replace(self.crank, radius=float(crank))
        return replace(self, links=links, crank=new_crank)


def actuator_path(driver: PathDriver, slider: Slider) -> PathDriver:
    """A linear actuator's path: ``driver`` (kind "line") from ``point + stroke[0]·n`` to
    ``point + stroke[1]·n`` along ``slider``'s ground line (n its unit direction)."""
    (px, py), (nx, ny) = slider.point, slider.unit()
    s0, s1 = driver.stroke
    return replace(driver, kind="line", points=((px + s0 * nx, py + s0 * ny), (px + s1 * nx, py + s1 * ny)))


def _check_length(source: str, key: str, value) -> float:
    """Return ``value`` as a float, or raise UserError unless it is finite and > 0."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise UserError(f"{where(source, key)}: expected a number, got {_short(value)}")
    try:
        v = float(value)
    except OverflowError:
        v = math.inf
    lo, hi = LENGTH_RANGE
    if not math.isfinite(v) or not lo <= v <= hi:
        raise UserError(f"{where(source, key)}: a length must be finite and > 0, from {lo:g} to {hi:g} model units, "
                        f"got {_short(value)}")
    return v


def _short(value) -> str:
    """repr of a value, shortened (a 400-digit integer is not printed whole)."""
    text = repr(value) if not isinstance(value, int) or value.bit_length() < 200 else f"an integer of {len(str(value))} digits"
    return text if len(text) <= 60 else text[:57] + "..."


def bounded_number(source: str, key: str, v, lo: float, lo_ok: bool, hi: float, what: str) -> float:
    """A number of a table: finite, above ``lo`` (or equal to it where ``lo_ok``), at most ``hi``; else a one-line
    UserError naming the file, the key and the value."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise UserError(f"{where(source, key)}: expected {what}, got {_short(v)}")
    f = float(v) if abs(v) < 1e300 else math.inf
    if not (math.isfinite(f) and (f > lo or (lo_ok and f == lo)) and f <= hi):
        raise UserError(f"{where(source, key)}: expected {what} (at most {hi:g}), got {_short(v)}")
    return f
