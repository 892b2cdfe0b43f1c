"""Physical units for the figures of a results file (``--units si`` of ``show``, ``rank`` and ``report``).

The one home of the conversion. It is driven by the ``unit`` strings of the metric table
(:data:`explorer.gait.TABLE`), never by lists of metric names, and by the study's ``[operating]`` table
(:class:`explorer.mechanism.Operating`: ``unit`` metres per model unit, ``rpm``, ``load`` kg, ``gravity``
m/s²):

=====================  ==========  ==================================================================
model unit             SI unit     factor
=====================  ==========  ==================================================================
``length``             mm          × unit × 1000 (metrics, and design parameters of kind length or
                                   coordinate: link lengths, crank radius, pivots, body points)
``length/rad``         mm/rad      × unit × 1000
``length/turn``        m/turn      × unit (the walker's travel per crank turn)
``1 (per W·crank)``    N·m         × load·gravity × crank radius·unit, the crank radius of THAT variant
                                   (needs ``load`` > 0 and ``gravity`` > 0)
=====================  ==========  ==================================================================

Every other unit (ratios, degrees, counts, fractions, and the forces group, already in N, N·m, W, J,
kg·m²) is left as it is. With ``rpm``, a derived column ``speed`` (m/s) follows travel: the walking
speed at the stated crank speed, travel per turn [m] × rpm / 60.

The comparison with a reference design that ``show``, ``rank --change`` and the report print lives here
too (:func:`change_pct`, :func:`verdict`), so that the command line and the report word it alike.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import UserError
from ._table import metric

#: The units the command line offers: "model" (the file's own) and "si".
UNIT_SYSTEMS = ("model", "si")

#: The derived walking speed column (m/s) that ``--units si`` adds after travel, when the study gives rpm.
SPEED = "speed"

#: model unit string → (SI unit, what scales it): "mm" × unit·1000, "m" × unit, "torque" × load·g·crank·unit.
CONVERSIONS: dict[str, tuple[str, str]] = {
    "length": ("mm", "mm"),
    "length/rad": ("mm/rad", "mm"),
    "length/turn": ("m/turn", "m"),
    "1 (per W·crank)": ("N·m", "torque"),
}
#: What a design parameter's kind (``Mechanism.parameter_kind``) converts like.
PARAMETER_UNITS = {"length": "length", "coordinate": "length"}


def si_label(name: str, unit: str) -> str:
    """A column name that carries its unit, ``bob[mm]`` (no space: table columns split on spaces)."""
    return f"{name}[{unit}]"


def si_operating(table, source: str):
    """The :class:`~explorer.mechanism.Operating` of a results file's ``[operating]`` table (a dict, or
    an Operating, or None) for ``--units si``; a :class:`UserError` naming ``source`` and the key to add
    when it gives no ``unit`` (metres per model unit)."""
    from ..mechanism import Operating, operating_from_dict

    op = table if isinstance(table, Operating) or table is None else operating_from_dict(table, str(source))
    if op is None or op.unit is None:
        raise UserError(f"{source}: --units si needs the study's metres per model unit: add `unit = ...` to its "
                        f"[operating] table ([operating] unit = 0.01 for a mechanism in centimetres), or use "
                        f"--units model")
    return op


@dataclass
class SI:
    """What :func:`to_si` gives.

    frame : a copy of the input with the converted columns in SI (same column names) and, with rpm and
        travel, a ``speed`` column (m/s) right after travel.
    units : {column: the unit it is now in} for every named column (and ``speed``): an SI unit where it
        was converted, the table's own unit string where not.
    converted : the columns whose values changed (``speed`` included).
    notes : one line per thing left undone (torque without a load, speed without rpm).
    operating : the :class:`~explorer.mechanism.Operating` used; names, parameters, crank_column : the
    arguments of :func:`to_si` (:meth:`apply` converts another frame with them).
    """

    frame: object
    units: dict
    converted: list
    notes: list
    operating: object = None
    names: tuple = ()
    parameters: dict | None = None
    crank_column: object = "crank"

    def labels(self) -> dict:
        """{column: ``name[unit]``} for the converted columns, for a csv / json header."""
        return {c: si_label(c, self.units[c]) for c in self.converted}

    def apply(self, frame) -> "SI":
        """The same conversion of another frame in model units (rows of the same results: a ranking)."""
        return to_si(frame, self.names, self.operating, self.crank_column, self.parameters)


def _scale(kind: str, op, crank):
    """Multiplier of a conversion kind ("mm", "m", "torque"); ``crank`` is the crank radius in model
    units (a number or an array, one per row). None when the operating point lacks what it needs."""
    if kind == "mm":
        return op.unit * 1000.0
    if kind == "m":
        return op.unit
    weight = float(op.load or 0.0) * float(op.gravity or 0.0)  # N
    if weight <= 0 or crank is None:
        return None
    return weight * crank * op.unit  # N × m


def to_si(frame, names, operating, crank_column="crank", parameters=None) -> SI:
    """Convert the columns ``names`` of ``frame`` (a DataFrame in model units) to SI units.

    names : metric names (their unit from :func:`explorer.gait.metric`); columns not in ``frame`` are
        skipped. parameters : {design parameter: kind} (``Mechanism.parameter_kind``) of the design
        parameter columns to convert (kind length / coordinate → mm). operating : an
        :class:`~explorer.mechanism.Operating` with ``unit`` (see :func:`si_operating`).
    crank_column : the column of each row's crank radius (model units), or a number for every row;
        the torque metrics (per weight × crank radius) become N·m with it.
    """
    import numpy as np

    out = frame.copy()
    units: dict = {}
    converted: list = []
    missing_load: list = []
    if isinstance(crank_column, str):
        crank = frame[crank_column].to_numpy(dtype=np.float64) if crank_column in frame.columns else None
    else:
        crank = None if crank_column is None else float(crank_column)
    todo = [(c, metric(c).unit if metric(c) is not None else None) for c in names]
    todo += [(p, PARAMETER_UNITS.get(kind)) for p, kind in (parameters or {}).items()]
    for col, unit in todo:
        if col not in frame.columns:
            continue
        units[col] = unit or ""
        if unit not in CONVERSIONS:
            continue
        si, kind = CONVERSIONS[unit]
        k = _scale(kind, operating, crank)
        if k is None:
            missing_load.append(col)
            continue
        out[col] = frame[col].to_numpy(dtype=np.float64) * k
        units[col] = si
        converted.append(col)
    notes = []
    if missing_load:
        why = ("gives no load (the body's mass in kg: add `load = ...`)" if not operating.load
               else "gives no gravity" if not operating.gravity else "has no crank radius")
        notes.append(f"{', '.join(missing_load)} stay per weight × crank radius (model units): the study's "
                     f"[operating] table {why}")
    if "travel" in units and units["travel"] == "m/turn":
        if operating.rpm:
            speed = out["travel"].to_numpy(dtype=np.float64) * float(operating.rpm) / 60.0  # m/turn × turn/s
            out.insert(list(out.columns).index("travel") + 1, SPEED, speed)
            units[SPEED] = "m/s"
            converted.append(SPEED)
        else:
            notes.append("no walking speed: the study's [operating] table gives no rpm (add `rpm = ...`)")
    return SI(out, units, converted, notes, operating, tuple(names), dict(parameters or {}), crank_column)


def operating_line(operating) -> str:
    """One line that states the operating point the SI figures use."""
    parts = [f"unit {operating.unit:g} m per model unit"]
    if operating.rpm:
        parts.append(f"{operating.rpm:g} rpm")
    if operating.load:
        parts.append(f"load {operating.load:g} kg × g {operating.gravity:g} m/s² = {operating.load * operating.gravity:.4g} N")
    return "SI units at the study's [operating] point: " + ", ".join(parts)



def results_si(res, frame, units: str = "si") -> SI | None:
    """:func:`to_si` of ``frame`` (a frame of the open results ``res``, model units) when ``units`` is
    "si": every stored metric and every design parameter column of kind length or coordinate, at the
    study's ``[operating]`` point; None for "model". UserError naming the file when ``units`` is
    neither, or the study gives no ``[operating] unit``."""
    if units not in UNIT_SYSTEMS:
        raise UserError(f"{res.filename}: units: expected one of {', '.join(UNIT_SYSTEMS)}, got {units!r}")
    if units != "si":
        return None
    op = si_operating(res.operating, res.filename)
    mech = res.mechanism
    params = {p: mech.parameter_kind(p) for p in mech.parameters() if p in frame.columns}
    return to_si(frame, list(res.metric_names), op, parameters=params)


# -- against a reference design ---------------------------------------------------------------------------
def change_pct(x, ref) -> float:
    """The change of ``x`` against ``ref`` in % of ``|ref|``: 100·(x − ref)/|ref| (NaN where ref is 0 or
    either is not finite)."""
    x, ref = float(x), float(ref)
    if not (math.isfinite(x) and math.isfinite(ref)) or ref == 0:
        return math.nan
    return 100.0 * (x - ref) / abs(ref)


def verdict(row, ref_row, ref_label: str, names, units: dict | None = None) -> str:
    """One plain line: in which of ``names`` the variant (``row``) is better and worse than the
    reference (``ref_row``, called ``ref_label``), each with both values (followed by their unit where
    ``units`` names one, e.g. ``--units si``'s) and the change in %, by each metric's direction."""
    good, bad = [], []
    for m in names:
        x, r = float(row[m]), float(ref_row[m])
        if not (math.isfinite(x) and math.isfinite(r)) or x == r:
            continue
        pct = f" ({change_pct(x, r):+.0f} %)" if r != 0 else ""
        unit = f" {units[m]}" if units and units.get(m) else ""
        text = f"{m} {x:.4g} vs {r:.4g}{unit}{pct}"
        info = metric("travel" if m == SPEED else m)
        (good if (x > r) == (info is not None and info.direction == "max") else bad).append(text)
    if not good and not bad:
        return f"verdict: the same as the {ref_label} in {', '.join(names)}"
    return (f"verdict against the {ref_label}: better in " + ("; ".join(good) or "none")
            + "; worse in " + ("; ".join(bad) or "none"))
