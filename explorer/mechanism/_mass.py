"""The mass rule of a build, in one place: what each link and the crank weigh.

A link (or the crank) with a ``mass`` of its own weighs that; otherwise the mechanism's
``[mass] link_density`` (kg per metre) times its length (model units) times ``unit`` (metres per
model unit); with neither it is massless. The forces effect and ``explorer describe`` both read it
from here.
"""

from __future__ import annotations

import numpy as np


def effective_mass(mech, given, length, unit):
    """One member's mass, kg: ``given`` if not None, else link_density × length × unit; None when that
    needs a ``unit`` that is not known (``unit`` None with a density), 0.0 with no density."""
    if given is not None:
        return float(given)
    if mech.link_density is None:
        return 0.0
    if unit is None:
        return None
    return float(mech.link_density) * float(length) * float(unit)


def link_masses(mech, lengths, unit: float) -> np.ndarray:
    """(N, n_links) kg: each link's mass for N variants of link lengths ``lengths`` (N, n_links), model
    units, at ``unit`` metres per model unit."""
    lengths = np.asarray(lengths, dtype=np.float64)
    density = mech.link_density or 0.0
    out = np.empty(lengths.shape)
    for e, lk in enumerate(mech.links):
        out[:, e] = lk.mass if lk.mass is not None else density * lengths[:, e] * unit
    return out


def crank_masses(mech, radii, unit: float) -> np.ndarray:
    """(N,) kg: the crank's mass (a uniform bar from its centre to its tip) for N crank radii."""
    radii = np.asarray(radii, dtype=np.float64)
    cm = mech.crank.mass
    return np.full(radii.shape[0], cm) if cm is not None else (mech.link_density or 0.0) * radii * unit
