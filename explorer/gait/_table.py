"""The one table of metrics: name, unit, direction, definition and what each needs.

Every other list of metric names (``METRICS``, ``DIRECTIONS``, ``UNITS``, the band metrics, the walker
metrics …) is derived from :data:`TABLE`. Adding a metric means adding one row here and computing it in
the kernel of its group (the registry ``explorer.gait._metrics.GROUPS``: ``leg`` and ``screen`` in
:mod:`explorer.gait._metrics`, ``walker`` in :mod:`explorer.gait._walker`, ``target`` in
:mod:`explorer.gait._path`; ``forces`` in :mod:`explorer.kernels._forces`), which writes its columns by
name; storage, ranking, ``show`` and the plots pick it up from the table.

Groups
------
walker     the walker scene: the leg replicated with crank phase offsets, the body resting on the
           lowest foot (physical metrics; rankings default to these).
leg        single-leg metrics of one foot path with a stance *band* (``y ≤ y_min + band·height``),
           kept for comparison with published figures; those with ``band`` in ``needs`` depend on it.
screen     what the buildability screen reads (:mod:`explorer.gait._screen`).
           walker, leg and screen are not applicable to a foot that is the sliding vertex of a ground
           slider (its path is a stroke along a fixed line: ``FOOT_ON_LINE_GROUPS`` in
           :mod:`explorer.gait._metrics`), as no gait metric applies to a mechanism driven along a path.

slider     a foot that runs on a ground slider (a slider-crank's piston, a shaper's ram): ``quick_return``
           (:mod:`explorer.gait._metrics`); not applicable to any other foot.
target     path synthesis: the foot path against a study's ``[target]`` points (:mod:`explorer.gait._path`).
robustness ``yield``: the share of copies of a design, cut with a manufacturing error on every design
           parameter (a study's ``[robustness]`` table), that assemble over the whole turn and pass the
           buildability screen (:mod:`explorer.study._yield`: it re-solves copies, so the study computes it,
           only when its scene names it).
forces     what it takes to drive and hold the machine, in SI units, at the ``[operating]`` point (the
           forces effect, :mod:`explorer.kernels._forces`, computed with the positions when a study's
           ``[scene] forces = true``); ``pin_force.<joint>`` (N, each joint's peak reaction) follow
           for every joint (see :func:`metric`).
physics    the physics check of a shortlist (``explorer physics``, :mod:`explorer.physics`): each design's
           walker scene as a MuJoCo model, measured over whole turns; SI units; NaN for a design not checked.

``needs`` is a subset of {"velocity", "band", "mechanism", "crank", "walker", "target", "forces",
"robustness", "physics"}: the foot velocities dF/dθ, the stance band, the mechanism and each variant's
lengths, the crank radius, the walker spec, a target path, the forces effect, copies of the design, the
physics check.
Every metric but the forces and robustness groups needs the foot path; the forces group needs the
forces effect, ``yield`` a study's ``[robustness]`` table.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Metric:
    """One metric: ``name``; ``unit`` ("length" = the model units of the link lengths); ``direction``
    "max" (larger is better) or "min"; ``group`` (walker | leg | screen | target | forces | physics …); ``description`` (one line);
    ``needs`` (see the module docstring)."""

    name: str
    unit: str
    direction: str
    group: str
    description: str
    needs: frozenset = frozenset()

    @property
    def better(self) -> str:
        """"higher is better" or "lower is better", as the tables print it."""
        return "higher is better" if self.direction == "max" else "lower is better"


def _m(name, unit, direction, group, description, *needs) -> Metric:
    return Metric(name, unit, direction, group, description, frozenset(needs))


#: Every metric, in storage and display order: walker metrics first, then the single-leg band
#: metrics, then the screen's inputs.
TABLE: tuple[Metric, ...] = (
    # -- the walker scene (body held level on the lowest foot, flat ground, no slip) -------------------
    _m("travel", "length/turn", "max", "walker",
       "how far the body moves per crank turn, |∫ dx_c/dθ dθ| over the contact foot c(θ)", "velocity", "walker"),
    _m("bob", "length", "min", "walker",
       "how much the body rises and falls per crank turn: max − min of the ground g(θ) = min_j y_j(θ)", "walker"),
    _m("body_speed_ripple", "1", "min", "walker",
       "std / mean of the body speed |dx_c/dθ| over the turn", "velocity", "walker"),
    _m("peak_torque", "1 (per W·crank)", "min", "walker",
       "largest |crank torque| carrying the load on the contact foot, per weight × crank radius: quasi-static, the "
       "load alone on massless legs (the forces effect's motor_torque_peak is the dynamic figure)",
       "velocity", "crank", "walker"),
    _m("torque_ripple", "1 (per W·crank)", "min", "walker",
       "max − min of the crank torque over the turn, per weight × crank radius", "velocity", "crank", "walker"),
    _m("clearance", "length", "max", "walker",
       "lowest height above the ground a swinging foot keeps over the middle half of its swing",
       "crank", "walker"),
    _m("slip", "1", "min", "walker",
       "sliding the feet in contact must absorb: ∫ spread of their horizontal speeds dθ / travel",
       "velocity", "crank", "walker"),
    _m("contact_fraction", "fraction of turn", "max", "walker",
       "least fraction of the turn that any one leg's foot is in contact with the ground", "crank", "walker"),
    # -- single-leg band metrics (published figures use these) ------------------------------------------
    _m("width", "length", "max", "leg", "x-range of the whole foot path"),
    _m("height", "length", "max", "leg", "y-range of the whole foot path (step height)"),
    _m("stride", "length", "max", "leg", "x-span of the band stance (y ≤ y_min + band·height)", "band"),
    _m("duty", "fraction of cycle", "max", "leg", "fraction of the cycle in the band stance", "band"),
    _m("flatness", "1 (length/length)", "min", "leg", "std of y over the band stance / stride", "band"),
    _m("stance_rms_line", "length", "min", "leg",
       "RMS perpendicular distance of the band-stance points from their least-squares line y = a + b x", "band"),
    _m("stance_speed", "length/rad", "max", "leg",
       "mean foot speed |dF/dθ| over the band stance, per radian of crank", "band", "velocity"),
    _m("speed_ripple", "1", "min", "leg", "std / mean of the foot speed over the band stance", "band", "velocity"),
    _m("max_speed", "length/rad", "min", "leg",
       "largest foot speed |dF/dθ| over the cycle, per radian of crank", "velocity"),
    # -- what the buildability screen reads -------------------------------------------------------------
    _m("min_transmission_angle", "deg", "max", "screen",
       "smallest transmission angle (deviation from toggle) of the crank-driven four-bar loops", "mechanism"),
    _m("foot_headroom", "length", "max", "screen",
       "how far the foot's highest point stays below the crank axle and every ground pivot", "mechanism", "crank"),
    _m("self_crossings", "count", "min", "screen", "times the foot path crosses itself"),
    # -- a foot on a ground slider ----------------------------------------------------------------------
    _m("quick_return", "1", "max", "slider",
       "crank angle of the foot slider's forward stroke (along its line's direction) / that of its return stroke, "
       "between the two dead centres of its travel (a shaper's cutting / return time)", "mechanism", "crank"),
    # -- path synthesis ---------------------------------------------------------------------------------
    _m("path_error", "length", "min", "target",
       "RMS distance from the [target] points to their matches on the foot path (timed, closest or by arc "
       "length), after the translation / rotation / scale the target lets the match ignore", "velocity", "target"),
    # -- robustness: copies cut with a manufacturing error (explorer.study._yield) -----------------------
    _m("yield", "fraction of copies", "max", "robustness",
       "share of copies cut with ±[robustness] tolerance on every design parameter (common random errors) that "
       "assemble over the whole turn and pass the buildability screen; binomial standard error √(p(1 − p)/copies)",
       "robustness"),
    # -- the forces effect (SI units, at the [operating] point; the walker's whole crankshaft) -----------
    _m("motor_torque_peak", "N·m", "min", "forces",
       "largest |motor torque| over the turn, dynamic: with the links' inertia and weight and the body (the load) "
       "moving with the contact foot ([operating] body = \"moving\") or held still (\"held\"); the walker "
       "metrics' peak_torque is the load-only quasi-static figure", "forces"),
    _m("motor_torque_rms", "N·m", "min", "forces", "root mean square of the motor torque over the turn", "forces"),
    _m("motor_power_peak", "W", "min", "forces", "largest power the motor delivers, max τ·ω", "forces"),
    _m("energy_per_turn", "J", "min", "forces", "positive work the motor does per crank turn, Σ max(τ, 0)·Δθ",
       "forces"),
    _m("flywheel_inertia", "kg·m²", "min", "forces",
       "flywheel that holds the crank speed within ±speed_fluctuation/2: ΔE / (C_s·ω²), ΔE the largest swing of "
       "∫(τ − mean τ)dθ; on the crank", "forces"),
    _m("flywheel_inertia_motor", "kg·m²", "min", "forces",
       "the same flywheel on the motor shaft, flywheel_inertia / N² (N = [operating] gear_ratio, motor turns per "
       "crank turn): at a low crank speed the flywheel belongs on the motor side of the gearbox", "forces"),
    _m("pin_force_max", "N", "min", "forces", "largest joint reaction over every joint, leg and crank angle",
       "forces"),
    _m("shaking_force_peak", "N", "min", "forces",
       "largest resultant force the legs put on the frame (weight and load included)", "forces"),
    _m("machine_mass", "kg", "min", "forces",
       "the whole machine: every leg (links, bodies, crank) and the body ([operating] load)", "forces"),
    _m("cost_of_transport", "1", "min", "forces",
       "energy per turn / (machine_mass·g·travel in metres), the whole machine's (legs and body); "
       "inf for a machine that does not travel", "forces"),
    # -- the physics check of a shortlist (MuJoCo, `explorer physics`; SI units; NaN: not checked) ----------
    _m("physics_travel", "m/turn", "max", "physics",
       "how far the body moves per crank turn, along the kinematic walking direction, in the MuJoCo walker",
       "physics"),
    _m("physics_bob", "m", "min", "physics", "max − min of the body's height over the measured turns", "physics"),
    _m("physics_pitch", "rad", "min", "physics",
       "max − min of the body's pitch over the measured turns (0 when the check holds the pitch)", "physics"),
    _m("physics_loaded_feet_max", "count", "min", "physics",
       "most feet loaded at once (each carrying over 5 % of the machine's weight) at the samples of a turn",
       "physics"),
    _m("physics_friction_work", "J/turn", "min", "physics",
       "work the feet's friction dissipates per turn, Σ|F_x·v_slip|·dt: feet that share the ground and fight",
       "physics"),
    _m("physics_torque_peak", "N·m", "min", "physics",
       "largest |motor torque| of the crank servo, averaged over the measured turns at each crank angle", "physics"),
    _m("physics_torque_rms", "N·m", "min", "physics",
       "root mean square of the phase-averaged motor torque of the crank servo", "physics"),
    _m("physics_impact_peak", "N", "min", "physics",
       "largest normal force on a foot within 10° of crank after it lands (depends on the contact stiffness)",
       "physics"),
    _m("physics_travel_diff", "%", "max", "physics",
       "physics_travel − travel, in % of the kinematic travel (negative: the machine walks less far than the "
       "kinematic walker says)", "physics"),
)
#: Prefix of the per-joint reaction metrics, ``pin_force.<joint>`` (N): each joint's peak reaction.
PIN_FORCE = "pin_force."

BY_NAME: dict[str, Metric] = {m.name: m for m in TABLE}


def metric(name: str) -> Metric | None:
    """The table row of ``name``, ``pin_force.<joint>`` included; None if it names no metric."""
    if name.startswith(PIN_FORCE) and len(name) > len(PIN_FORCE):
        return Metric(name, "N", "min", "forces", f"largest reaction at joint {name[len(PIN_FORCE):]} over the legs "
                      f"and the turn (the force its most heavily loaded member puts on the pin)", frozenset({"forces"}))
    return BY_NAME.get(name)



#: Every metric name, in storage/display order.
METRICS: tuple[str, ...] = tuple(m.name for m in TABLE)
#: Natural ranking direction of each metric: "max" = larger is better, "min" = smaller is better.
DIRECTIONS: dict[str, str] = {m.name: m.direction for m in TABLE}
#: Unit of each metric ("length" = the model units of the link lengths).
UNITS: dict[str, str] = {m.name: m.unit for m in TABLE}
#: One-line help text per metric.
DESCRIPTIONS: dict[str, str] = {m.name: m.description for m in TABLE}
#: Metrics of the walker scene.
WALKER_METRICS: tuple[str, ...] = tuple(m.name for m in TABLE if m.group == "walker")
#: Single-leg metrics of the foot path with a stance band (and the band-free width, height, max_speed).
LEG_METRICS: tuple[str, ...] = tuple(m.name for m in TABLE if m.group == "leg")
#: What the buildability screen reads.
SCREEN_METRICS: tuple[str, ...] = tuple(m.name for m in TABLE if m.group == "screen")
#: Metrics of path synthesis (they need a target path).
TARGET_METRICS: tuple[str, ...] = tuple(m.name for m in TABLE if m.group == "target")
#: Metrics whose value depends on the stance band.
BAND_METRICS: tuple[str, ...] = tuple(m.name for m in TABLE if "band" in m.needs)
#: Metrics of the forces effect (``pin_force.<joint>`` follow them for every joint).
FORCE_METRICS: tuple[str, ...] = tuple(m.name for m in TABLE if m.group == "forces")
#: Metrics of the physics check of a shortlist (``explorer physics``, :mod:`explorer.physics`).
PHYSICS_METRICS: tuple[str, ...] = tuple(m.name for m in TABLE if m.group == "physics")
#: Metrics a study computes by re-solving copies of each design (its ``[robustness]`` table): ``yield``.
ROBUSTNESS_METRICS: tuple[str, ...] = tuple(m.name for m in TABLE if m.group == "robustness")
#: Metrics that need the foot velocities dF/dθ.
VELOCITY_METRICS: tuple[str, ...] = tuple(m.name for m in TABLE if "velocity" in m.needs)
#: Metrics that need the mechanism (and each variant's lengths), not only the foot path.
MECHANISM_METRICS: tuple[str, ...] = tuple(m.name for m in TABLE if "mechanism" in m.needs)
#: Metrics that exist only for a crank-driven mechanism.
CRANK_METRICS: tuple[str, ...] = tuple(m.name for m in TABLE if "crank" in m.needs or "walker" in m.needs)
#: Single-leg metrics of the foot path alone (computed by the foot kernel).
PATH_METRICS: tuple[str, ...] = tuple(m for m in LEG_METRICS if "velocity" not in BY_NAME[m].needs)
#: Single-leg metrics computed by the foot kernel (path and velocity).
FOOT_METRICS: tuple[str, ...] = LEG_METRICS

#: The default ranking (``explorer rank``, ``plot --top``, ``Results.rank()`` with no ``by``): a score
#: in [0, 1] weighting equally how far the walker goes per turn, how smoothly (bob, body speed
#: ripple), how hard the motor works (peak torque) and how high the feet step (clearance; without it
#: the score prefers feet that barely lift, since lifting costs torque). Each metric is min-max
#: normalised over the ranked rows, 1 = best; see :func:`explorer.gait.rank`.
DEFAULT_WEIGHTS: dict[str, float] = {"travel": 1.0, "bob": 1.0, "body_speed_ripple": 1.0, "peak_torque": 1.0,
                                     "clearance": 1.0}
