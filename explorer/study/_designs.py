"""An optimiser's designs: the searched parameters X (n, k) ↔ the (lengths, crank, geometry) the chunk
runner solves. Shared by :mod:`explorer.optimize` (each generation) and :mod:`._cluster` (warming a worker's
kernels on the nominal design), so neither reaches into the other."""

from __future__ import annotations

import numpy as np

from ._spec import Study


def designs_from_x(study: Study, X: np.ndarray):
    """(lengths (n, n_links), crank (n,), geometry (n, g)) of designs X (n, k), one column per
    ``study.optimize.parameters`` (values in model units, set exactly: the file stores X bitwise)."""
    mech = study.mech
    names = study.optimize.parameters
    n = X.shape[0]
    lengths = np.broadcast_to(mech.lengths, (n, len(mech.links))).copy()
    crank = np.full(n, float(mech.crank.radius) if mech.crank is not None else np.nan)
    nominal = mech.parameters()
    geo = study.geometry_names
    geometry = np.empty((n, len(geo)))
    for c, name in enumerate(geo):
        geometry[:, c] = nominal[name]
    index = {p: i for i, p in enumerate(mech.link_names)}
    for j, p in enumerate(names):
        if p == "crank":
            crank[:] = X[:, j]
        elif p in index:
            lengths[:, index[p]] = X[:, j]
        else:
            geometry[:, geo.index(p)] = X[:, j]
    return lengths, crank, geometry


def stored_x(df, study: Study) -> np.ndarray:
    """The designs (n, k) of a results frame's rows, one column per searched parameter."""
    return np.column_stack([df[p].to_numpy(dtype=np.float64) for p in study.optimize.parameters])


def nominal_x(study: Study) -> np.ndarray:
    """The nominal design's parameters (k,), clipped into the bounds."""
    nominal = study.mech.parameters()
    opt = study.optimize
    x = np.array([nominal[p] for p in opt.parameters])
    return np.clip(x, opt.lower, opt.upper)


