"""The curve atlas: many designs of one mechanism, each stored with its foot path as a shape that does
not depend on position, rotation or scale, so that "which design draws this curve?" is answered by a
look-up and a short polish instead of a search from scratch.

``explorer atlas build MECHANISM [--designs N]`` (:func:`build_atlas`) samples the mechanism's design
space (:func:`atlas_spec`: which parameters vary, within which bounds), solves the designs with the
batch kernels (``simulate_batch``, 128 crank steps, positions only) and keeps the designs that turn a
full cycle (and pass the buildability screen, for a walking leg), each with its path in the two
normalised forms of :mod:`explorer.synthesis._curves` and its design parameters. :func:`open_atlas` reads
one back; :meth:`Atlas.query` finds the designs whose paths best match target points, each with the
similarity transform that puts it onto them.

What varies (:func:`atlas_spec`)
--------------------------------
The shape of a design's path does not change when the whole design is moved, turned or scaled, so
the atlas fixes that *gauge*: the crank centre and the first ground pivot stay at their nominal
positions (so every design has the nominal's ground line), and each rigid body keeps its first joint
at its nominal position in its own frame and its second joint on its nominal line (y fixed). Every
other design parameter varies: link lengths and the crank radius log-uniformly within a factor
:data:`LENGTH_FACTOR` of the nominal, coordinates uniformly within :data:`COORDINATE_SPREAD` × the
mechanism's size of the nominal. The atlas four-bar (``fourbar``: ``explorer/synthesis/atlas/fourbar.toml``,
the coupler a rigid body) has its own, wider bounds (:data:`FAMILY_BOUNDS`). The designs are a
scrambled Sobol sequence (scipy.stats.qmc, seeded) over those bounds, in order; the atlas keeps the
first N that turn a full cycle.

The families ``fourbar``, ``watt6`` and ``stephenson6`` are the atlases ``explorer synth --mechanism``
names; any other crank-driven mechanism (a built-in or a file, without sliders) gets the general rule.

File (HDF5, ``$EXPLORER_ATLAS_DIR`` or ``$XDG_CACHE_HOME/explorer/atlas`` (``~/.cache/explorer/atlas``),
``<family or mechanism name>.h5``; attributes and datasets below, Blosc LZ4 like the results files)
------------------------------------------------------------------------------------------------------
attrs: ``format`` = "explorer-atlas", ``atlas_version``, ``explorer_version``, ``family``,
``mechanism`` (the TOML text), ``structure`` (:func:`structure_key`), ``parameters``, ``lower``,
``upper``, ``log`` (JSON lists: the varied parameters and their sampling), ``synth_parameters`` (the
varied ones and the gauge, what a synthesis polishes), ``seed``, ``steps``, ``n_curve``, ``sampled``
(designs solved), ``designs`` (kept), ``build_s``, ``build_cpu_s``, ``screen`` (whether the screen
was applied).
datasets: ``params`` (N, p) float64 the varied parameters; ``index`` (N,) int64 each design's position
in the Sobol sequence; ``centre`` (N, 2) and ``scale`` (N,) float64 of its path (model units);
``curve`` and ``timed`` (N, 32, 2) float16 the normalised arc-length and crank-angle curves;
``descriptor`` (N, 16) float32 (:func:`explorer.synthesis._curves.descriptors`).
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..mechanism import Mechanism, builtin_mechanisms, load_mechanism

#: The atlases ``explorer synth --mechanism`` names.
FAMILIES = ("fourbar", "watt6", "stephenson6")
#: Designs an atlas holds by default (the ones ``explorer synth`` builds on first use).
DEFAULT_DESIGNS = 1_000_000
#: Crank steps each atlas design is solved at (a multiple of N_CURVE).
STEPS = 128
#: Layout version of the atlas file; an atlas of another version is refused (rebuild it).
ATLAS_VERSION = 1
#: Default sampling of the general rule: lengths within this factor of the nominal (log-uniform) ...
LENGTH_FACTOR = 2.5
#: ... and coordinates within this share of the mechanism's size of the nominal.
COORDINATE_SPREAD = 0.6
#: The atlas four-bar's bounds (ground link 1 from the crank centre along +x): crank radius, rocker,
#: coupler length and coupler point, wide enough for the literature's long-link answers.
FAMILY_BOUNDS = {"fourbar": {"crank": (0.02, 1.0), "rocker": (0.05, 4.0), "coupler.B.x": (0.05, 4.0),
                             "coupler.P.x": (-2.0, 2.0), "coupler.P.y": (-2.0, 2.0)}}
#: Designs solved per batch while building.
CHUNK = 1 << 15
#: Designs an open or a timed look-up scans by default (the first ones: an even Sobol sample).
SCAN = 200_000


def atlas_dir() -> Path:
    """Where atlases are cached: ``$EXPLORER_ATLAS_DIR``, else ``$XDG_CACHE_HOME/explorer/atlas``
    (``~/.cache/explorer/atlas``)."""
    env = os.environ.get("EXPLORER_ATLAS_DIR")
    if env:
        return Path(env)
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "explorer" / "atlas"


def family_source(name: str) -> str:
    """The mechanism file or built-in of an atlas family, or ``name`` itself (a mechanism)."""
    if name == "fourbar":
        return str(resources.files("explorer.synthesis") / "atlas" / "fourbar.toml")
    return name


def atlas_mechanism(name: str) -> tuple[Mechanism, str]:
    """(mechanism, family or mechanism name) of ``explorer atlas build NAME``: a family of
    :data:`FAMILIES`, a built-in or a mechanism file. UserError for one the atlas cannot take."""
    src = family_source(name)
    mech = load_mechanism(src)
    if mech.crank is None:
        raise UserError(f"{name}: an atlas needs a crank-driven mechanism; {mech.name!r} is driven along a path")
    if mech.sliders:
        raise UserError(f"{name}: an atlas takes pin-jointed mechanisms; {mech.name!r} has sliders")
    label = name if name in FAMILIES else (name if name in builtin_mechanisms() else mech.name)
    return mech, label


def default_path(label: str) -> Path:
    """The cached atlas of a family or mechanism name."""
    safe = "".join(c if c.isalnum() or c in "._-" else "_" for c in label)
    return atlas_dir() / f"{safe}.h5"


@dataclass(frozen=True)
class AtlasSpec:
    """What an atlas samples. parameters : the varied design parameters (``mech.parameters()``
    order); lower, upper : their bounds (model units); log : sampled log-uniformly (lengths);
    gauge : the parameters held to fix position, rotation and scale (the crank centre and the first
    ground pivot); synth : what a synthesis polishes: the varied parameters and the gauge, in
    ``mech.parameters()`` order."""

    parameters: tuple
    lower: tuple
    upper: tuple
    log: tuple
    gauge: tuple
    synth: tuple


def atlas_spec(mech: Mechanism, family: str | None = None) -> AtlasSpec:
    """The design space an atlas of ``mech`` samples (the module docstring's rule)."""
    nominal = mech.parameters()
    gauge = ["crank.x", "crank.y"]
    if mech.fixed:
        first = next(iter(mech.fixed))
        gauge += [f"{first}.x", f"{first}.y"]
    frame = set()
    for b in mech.bodies:
        frame |= {f"{b.name}.{b.joints[0]}.x", f"{b.name}.{b.joints[0]}.y"}
        if len(b.joints) > 1:
            frame.add(f"{b.name}.{b.joints[1]}.y")
    special = FAMILY_BOUNDS.get(family or "", {})
    params, lo, hi, log = [], [], [], []
    for p, v in nominal.items():
        if p in gauge or p in frame:
            continue
        kind = mech.parameter_kind(p)
        if p in special:
            a, b = special[p]
        elif kind == "length":
            a, b = v / LENGTH_FACTOR, v * LENGTH_FACTOR
        else:
            a, b = v - COORDINATE_SPREAD * mech.size, v + COORDINATE_SPREAD * mech.size
        params.append(p)
        lo.append(float(a))
        hi.append(float(b))
        log.append(kind == "length")
    synth = tuple(p for p in nominal if p in set(params) | set(gauge))
    return AtlasSpec(tuple(params), tuple(lo), tuple(hi), tuple(log), tuple(gauge), synth)


def structure_key(mech: Mechanism) -> str:
    """A digest of what an atlas's designs share with another mechanism for its starts to apply:
    the vertices, links, bodies, crank, ground pivots and foot by name (not their values)."""
    d = {"vertices": list(mech.vertices), "links": [[l.name, l.a, l.b] for l in mech.links],
         "bodies": [[b.name, list(b.joints)] for b in mech.bodies], "crank": mech.crank.tip if mech.crank else None,
         "fixed": list(mech.fixed), "foot": mech.foot}
    return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:16]


def _designs(mech: Mechanism, names, X):
    """(lengths (n, n_links), crank (n,), geometry {name: (n,)}) of designs X (n, k) over parameters
    ``names`` (the others at the nominal)."""
    n = len(X)
    lengths = np.broadcast_to(mech.lengths, (n, len(mech.links))).copy()
    crank = np.full(n, float(mech.crank.radius))
    index = {p: i for i, p in enumerate(mech.link_names)}
    geometry = {}
    for j, p in enumerate(names):
        if p == "crank":
            crank = np.ascontiguousarray(X[:, j], dtype=np.float64)
        elif p in index:
            lengths[:, index[p]] = X[:, j]
        else:
            geometry[p] = np.ascontiguousarray(X[:, j], dtype=np.float64)
    return lengths, crank, geometry


def _sample(spec: AtlasSpec, u):
    """Designs (n, k) from unit-cube points u (n, k)."""
    lo, hi = np.array(spec.lower), np.array(spec.upper)
    log = np.array(spec.log)
    X = lo + u * (hi - lo)
    if log.any():
        X[:, log] = lo[log] * (hi[log] / lo[log]) ** u[:, log]
    return X


@dataclass
class BuildSummary:
    """What :func:`build_atlas` did: path, family, designs kept, sampled, seconds (wall and CPU of
    this process), bytes on disk."""

    path: Path
    family: str
    designs: int
    sampled: int
    wall_s: float
    cpu_s: float
    size_bytes: int

    def text(self) -> str:
        return (f"atlas {self.family}: {self.designs:,} designs that turn a full cycle (of {self.sampled:,} sampled, "
                f"{100 * self.designs / max(self.sampled, 1):.1f} %) → {self.path} ({self.size_bytes / 1e6:.1f} MB); "
                f"{self.wall_s:.1f} s wall, {self.cpu_s:.1f} CPU-s")


def build_atlas(mechanism: str, designs: int = DEFAULT_DESIGNS, *, output=None, seed: int = 0, force: bool = False,
                progress: bool = True, screen: bool | None = None) -> BuildSummary:
    """Build the atlas of ``mechanism`` (a family of :data:`FAMILIES`, a built-in or a mechanism file):
    the first ``designs`` designs of its Sobol sample that turn a full cycle (and pass the screen
    when ``screen``; default: for a mechanism with a ``[walker]`` table, a walking leg), written to
    ``output`` (default :func:`default_path`). The file is written beside and renamed into place, so
    an interrupted build leaves no atlas. UserError for an existing file without ``force``, or a
    mechanism the atlas cannot take."""
    import h5py
    import hdf5plugin

    from .. import __version__
    from ._curves import MAX_STEP_SHARE, N_CURVE, descriptors, normalise
    from ..kernels import simulate_batch
    from ..mechanism import mechanism_toml
    if isinstance(designs, bool) or not isinstance(designs, int) or not 1 <= designs <= 100_000_000:
        raise UserError(f"--designs: expected a whole number from 1 to 100,000,000, got {designs!r}")
    mech, label = atlas_mechanism(mechanism)
    path = Path(output) if output is not None else default_path(label)
    if path.exists() and not force:
        raise UserError(f"{path}: atlas exists; pass --force to build it again")
    spec = atlas_spec(mech, label)
    use_screen = (mech.walker is not None) if screen is None else bool(screen)
    from scipy.stats import qmc
    sampler = qmc.Sobol(d=len(spec.parameters), scramble=True, seed=np.random.default_rng(seed))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".part")
    t0, c0 = time.perf_counter(), time.process_time()
    kept = sampled = 0
    bar = None
    if progress:
        import sys

        from tqdm import tqdm
        if hasattr(sys.stderr, "isatty") and sys.stderr.isatty():
            bar = tqdm(total=designs, unit="design", desc=f"atlas {label}", file=sys.stderr, dynamic_ncols=True,
                       leave=False)
    comp = hdf5plugin.Blosc(cname="lz4", clevel=5, shuffle=hdf5plugin.Blosc.SHUFFLE)
    k = len(spec.parameters)
    try:
        with h5py.File(tmp, "w") as f:
            def ds(name, shape, dtype):
                return f.create_dataset(name, shape=(designs, *shape), dtype=dtype, chunks=(min(designs, 8192), *shape),
                                        **comp)
            d_params, d_index = ds("params", (k,), "f8"), ds("index", (), "i8")
            d_centre, d_scale = ds("centre", (2,), "f8"), ds("scale", (), "f8")
            d_curve, d_timed = ds("curve", (N_CURVE, 2), "f2"), ds("timed", (N_CURVE, 2), "f2")
            d_desc = ds("descriptor", (16,), "f4")
            import warnings
            while kept < designs:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")  # Sobol balance: chunks are powers of two anyway
                    u = sampler.random(CHUNK)
                X = _sample(spec, u)
                lengths, crank, geometry = _designs(mech, spec.parameters, X)
                b = simulate_batch(mech, lengths, crank, STEPS, geometry=geometry or None, velocities=use_screen)
                ok = b.status == 0
                curve, timed, centre, scale, share = normalise(b.paths[mech.foot], N_CURVE)
                ok &= np.isfinite(scale) & (share <= MAX_STEP_SHARE)
                if use_screen:
                    ok &= _screened(mech, b, lengths, crank, geometry)
                idx = np.flatnonzero(ok)[: designs - kept]
                a, z = kept, kept + len(idx)
                if len(idx):
                    d_params[a:z] = X[idx]
                    d_index[a:z] = sampled + idx
                    d_centre[a:z] = centre[idx]
                    d_scale[a:z] = scale[idx]
                    d_curve[a:z] = curve[idx].astype(np.float16)
                    d_timed[a:z] = timed[idx].astype(np.float16)
                    d_desc[a:z] = descriptors(curve[idx])
                kept = z
                sampled += CHUNK if kept < designs else (int(idx[-1]) + 1 if len(idx) else CHUNK)
                if bar is not None:
                    bar.update(len(idx))
                    bar.set_postfix_str(f"{100 * kept / sampled:.0f} % turn", refresh=False)
                if sampled > 200 * designs + 10 * CHUNK:
                    raise UserError(f"{mechanism}: fewer than 1 in 200 sampled designs turn a full cycle "
                                    f"({kept:,} of {sampled:,}); the atlas's bounds do not suit this mechanism")
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            attrs = {"format": "explorer-atlas", "atlas_version": ATLAS_VERSION, "explorer_version": __version__,
                     "family": label, "mechanism": mechanism_toml(mech), "mechanism_name": mech.name,
                     "structure": structure_key(mech), "parameters": json.dumps(spec.parameters),
                     "lower": json.dumps(spec.lower), "upper": json.dumps(spec.upper), "log": json.dumps(spec.log),
                     "gauge": json.dumps(spec.gauge), "synth_parameters": json.dumps(spec.synth), "seed": int(seed),
                     "steps": STEPS, "n_curve": N_CURVE, "sampled": int(sampled), "designs": int(kept),
                     "build_s": float(wall), "build_cpu_s": float(cpu), "screen": bool(use_screen)}
            for key, v in attrs.items():
                f.attrs[key] = v
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    finally:
        if bar is not None:
            bar.close()
    return BuildSummary(path, label, kept, sampled, wall, cpu, path.stat().st_size)


def _screened(mech, batch, lengths, crank, geometry) -> np.ndarray:
    """(n,) the designs of a walking leg's batch that pass the default buildability screen."""
    import pandas as pd

    from ..gait import SCREEN_METRICS, available_metrics, compute_metrics, screen_columns
    why = available_metrics(mech)
    names = [m for m in SCREEN_METRICS if why.get(m) is None]
    met = compute_metrics(batch.paths[mech.foot], batch.velocities.get(mech.foot), batch.status, names,
                          mechanism=mech, lengths=lengths, crank=crank, geometry=geometry or None)
    df = pd.DataFrame({"status": np.where(batch.status == 0, "ok", "failed"), "crank": crank, **met})
    cols = screen_columns(df)
    return np.ones(len(df), bool) if cols is None else cols[0]


# -- reading an atlas ------------------------------------------------------------------------------------
@dataclass
class Candidate:
    """One atlas design matched to a target. row : its row in the atlas; err : the shape residual
    (share of the target's spread, the scan's); A, B : the similarity p ↦ A·p + B (complex; model
    units) that moves it onto the target; params : its design parameters after that move, by name
    (every one of :attr:`AtlasSpec.synth`); phase : the free phase ψ of a phase-free timed target
    (radians, in the design's own frame before the move) or None."""

    row: int
    err: float
    A: complex
    B: complex
    params: dict
    phase: float | None = None
    arc_start: float | None = None
    arc_direction: int = 1
    arc_span: float = 1.0

    def arc_positions(self, fractions) -> np.ndarray | None:
        """Where the target points (their shares ``fractions`` (M,) of the way along the target,
        :func:`explorer.synthesis._curves.arc_fractions`) fall on this design's path, as shares of its length
        from the atlas curve's start (the design's θ = 0 point before the move, θ = arg A after it):
        the look-up's alignment, in order along the path; None for a timed look-up."""
        if self.arc_start is None:
            return None
        return self.arc_start + self.arc_direction * self.arc_span * np.asarray(fractions, dtype=np.float64)


class Atlas:
    """An atlas read into memory (:func:`open_atlas`). mech : its mechanism; family; spec :
    :class:`AtlasSpec`; params (N, p), centre (N, 2), scale (N,), descriptor (N, 16); ``curve`` and
    ``timed`` (N, 32, 2) float16, read on first use; path; attrs (the file's attributes)."""

    def __init__(self, path: Path, attrs: dict, data: dict, mech: Mechanism):
        self.path = path
        self.attrs = attrs
        self.mech = mech
        self.family = attrs["family"]
        self.spec = AtlasSpec(tuple(json.loads(attrs["parameters"])), tuple(json.loads(attrs["lower"])),
                              tuple(json.loads(attrs["upper"])), tuple(json.loads(attrs["log"])),
                              tuple(json.loads(attrs["gauge"])), tuple(json.loads(attrs["synth_parameters"])))
        self.params = data["params"]
        self.centre = data["centre"]
        self.scale = data["scale"]
        self.descriptor = data["descriptor"]
        self._curve = None
        self._timed = None
        self._tree = None

    def __len__(self) -> int:
        return len(self.params)

    def _read(self, name):
        import h5py
        import hdf5plugin  # noqa: F401 (the Blosc filter)
        with h5py.File(self.path, "r") as f:
            return f[name][...]

    @property
    def curve(self) -> np.ndarray:
        if self._curve is None:
            self._curve = self._read("curve")
        return self._curve

    @property
    def timed(self) -> np.ndarray:
        if self._timed is None:
            self._timed = self._read("timed")
        return self._timed

    @property
    def tree(self):
        """The nearest-neighbour index of the descriptors (scipy.spatial.cKDTree), built on first use."""
        if self._tree is None:
            from scipy.spatial import cKDTree
            self._tree = cKDTree(self.descriptor, leafsize=32, balanced_tree=False, compact_nodes=False)
        return self._tree

    def design(self, row: int) -> dict:
        """Every design parameter of atlas row ``row`` (its own frame), by name."""
        out = dict(self.mech.parameters())
        out.update(zip(self.spec.parameters, (float(v) for v in self.params[row])))
        return out

    def moved(self, row: int, A: complex, B: complex) -> dict:
        """The parameters of :attr:`AtlasSpec.synth` of atlas row ``row`` after the similarity p ↦ A·p + B
        (complex): lengths and body coordinates scaled by |A|, the crank centre and ground pivots moved."""
        return move_parameters(self.mech, self.design(row), A, B, self.spec.synth)

    def query(self, points, angles=None, *, closed: bool, free_phase: bool = False, k: int = 16,
              neighbours: int = 512, scan: int | None = None) -> list:
        """The ``k`` atlas designs whose paths best match target ``points`` (M, 2), best first, as
        :class:`Candidate` s.

        Untimed (``angles`` None) and ``closed``: the ``neighbours`` nearest descriptors of the target
        (both ways round) from the index, then :func:`~explorer.synthesis._curves.align_closed` on them.
        Untimed and open: :func:`~explorer.synthesis._curves.align_open` over the first ``scan`` designs
        (default :data:`SCAN`; the atlas is a Sobol sequence, so its first rows are an even sample).
        Timed (``angles`` (M,) radians, explorer's crank angle in the target's frame):
        :func:`~explorer.synthesis._curves.align_timed` over the first ``scan`` designs, the phase fixed
        (rotating a design delays its crank by the same angle) or free."""
        from ._curves import N_CURVE, align_closed, align_open, align_timed, descriptors, resample_target
        P = np.asarray(points, dtype=np.float64)
        n_scan = min(SCAN, len(self)) if scan is None else max(1, min(int(scan), len(self)))
        out = []
        if angles is None and closed:
            q, c, r = resample_target(P, N_CURVE, closed=True)
            qn = (q - c) / r
            d = descriptors(qn[None])[0]
            from ._curves import reverse_descriptor
            nb = min(neighbours, len(self))
            rows = np.unique(np.concatenate([np.atleast_1d(self.tree.query(d, k=nb)[1]),
                                             np.atleast_1d(self.tree.query(reverse_descriptor(d), k=nb)[1])]))
            rows = rows[rows < len(self)]
            err, shift, direction, a = align_closed(self.curve[rows].astype(np.float32), np.arange(len(rows)), qn)
            for i in np.argsort(err, kind="stable")[:k]:
                row = int(rows[i])
                A = r * complex(a[i, 0], a[i, 1]) / self.scale[row]
                B = complex(*c) - A * complex(*self.centre[row])
                out.append(Candidate(row, float(err[i]), A, B, self.moved(row, A, B), None, float(shift[i]) / N_CURVE,
                                     int(direction[i]), 1.0))
            return out
        err = np.empty(n_scan)
        fits = []
        if angles is None:
            from ._curves import OPEN_POINTS
            q, c, r = resample_target(P, OPEN_POINTS, closed=False)
            for a0 in range(0, n_scan, 65536):
                a1 = min(a0 + 65536, n_scan)
                e, st, di, fr, a, t = align_open(self.curve[a0:a1].astype(np.float32), np.arange(a1 - a0), q)
                err[a0:a1] = e
                fits.append((a, t, np.column_stack([st / N_CURVE, di, fr])))
        else:
            th = np.asarray(angles, dtype=np.float64)
            for a0 in range(0, n_scan, 65536):
                a1 = min(a0 + 65536, n_scan)
                e, ph, a, t = align_timed(self.timed[a0:a1].astype(np.float32), np.arange(a1 - a0), P, th,
                                          free_phase=free_phase)
                err[a0:a1] = e
                fits.append((a, t, ph))
        a_all = np.concatenate([f[0] for f in fits])
        t_all = np.concatenate([f[1] for f in fits])
        extra = np.concatenate([f[2] for f in fits])
        best = np.argpartition(err, min(k, n_scan - 1))[:k] if n_scan > k else np.arange(n_scan)
        for row in best[np.argsort(err[best], kind="stable")]:
            row = int(row)
            A = complex(a_all[row, 0], a_all[row, 1]) / self.scale[row]
            B = complex(*t_all[row]) - A * complex(*self.centre[row])
            if angles is None:
                st, di, fr = extra[row]
                out.append(Candidate(row, float(err[row]), A, B, self.moved(row, A, B), None, float(st), int(di),
                                     float(fr)))
            else:
                out.append(Candidate(row, float(err[row]), A, B, self.moved(row, A, B),
                                     float(extra[row]) if free_phase else None))
        return out


def move_parameters(mech: Mechanism, params: dict, A: complex, B: complex, names) -> dict:
    """Design parameters ``names`` of design ``params`` (every parameter by name) after the similarity
    p ↦ A·p + B of the whole design (complex; |A| the scale, arg A the rotation): lengths and body-frame
    coordinates × |A|, the crank centre and the ground pivots moved."""
    s = abs(A)
    out = {}
    points = ["crank"] + list(mech.fixed)
    moved = {}
    for v in points:
        x, y = params[f"{v}.x"], params[f"{v}.y"]
        z = A * complex(x, y) + B
        moved[f"{v}.x"], moved[f"{v}.y"] = z.real, z.imag
    for p in names:
        if p in moved:
            out[p] = float(moved[p])
        else:
            out[p] = float(params[p]) * s
    return out


#: Atlases read in this process, by (path, size, modification time): a second look-up reuses the read
#: arrays and the index.
_OPEN: dict = {}


def open_atlas(path, *, family: str | None = None) -> Atlas:
    """Read the atlas at ``path`` (once per process: the same file again is the same :class:`Atlas`,
    its index built once). UserError (one line) for a file that is not an atlas, one of another atlas
    layout or explorer version, or, with ``family``, of another family."""
    path = Path(path)
    try:
        st = path.stat()
        key = (str(path.resolve()), st.st_size, st.st_mtime_ns)
    except OSError:
        key = None
    at = _OPEN.get(key) if key is not None else None
    if at is None:
        at = _read_atlas(path)
        if key is not None:
            _OPEN.clear()  # one atlas at a time in memory (a family's is ~0.5 GB with its index)
            _OPEN[key] = at
    if family is not None and at.attrs.get("family") != family:
        raise UserError(f"{path}: an atlas of {at.attrs.get('family')!r}, not of {family!r}")
    return at


def _read_atlas(path: Path) -> Atlas:
    import h5py
    import hdf5plugin  # noqa: F401

    from .. import __version__
    from ..mechanism import mechanism_from_dict, parse_toml
    path = Path(path)
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise UserError(f"{path}: cannot read the atlas: {exc}") from None
    with f:
        attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
        if attrs.get("format") != "explorer-atlas":
            raise UserError(f"{path}: not an explorer atlas (no format = 'explorer-atlas' attribute)")
        if int(attrs.get("atlas_version", -1)) != ATLAS_VERSION:
            raise UserError(f"{path}: atlas layout version {attrs.get('atlas_version')!r}, this explorer reads "
                            f"{ATLAS_VERSION}; build it again (explorer atlas build {attrs.get('family')} --force)")
        if attrs.get("explorer_version") != __version__:
            raise UserError(f"{path}: atlas built by explorer {attrs.get('explorer_version')!r}, this is {__version__}; "
                            f"build it again (explorer atlas build {attrs.get('family')} --force)")
        data = {k: f[k][...] for k in ("params", "centre", "scale", "descriptor")}
    mech = mechanism_from_dict(parse_toml(attrs["mechanism"], str(path)), f"{path}:mechanism")
    return Atlas(path, attrs, data, mech)


def find_atlas(mech: Mechanism) -> Path | None:
    """A cached atlas (:func:`atlas_dir`) whose mechanism has ``mech``'s structure
    (:func:`structure_key`) and whose design parameters ``mech`` has, or None."""
    d = atlas_dir()
    if not d.is_dir():
        return None
    key = structure_key(mech)
    import h5py
    for p in sorted(d.glob("*.h5")):
        try:
            with h5py.File(p, "r") as f:
                if f.attrs.get("structure") == key and f.attrs.get("format") == "explorer-atlas":
                    return p
        except OSError:
            continue
    return None


def same_branch(atlas_mech: Mechanism, mech: Mechanism, steps: int = 36) -> bool:
    """Whether ``mech`` (same structure) is the atlas mechanism's assembly: its nominal design, solved
    as itself and as the atlas mechanism with its parameters, draws the same foot path."""
    from ..kernels import simulate
    try:
        a = simulate(mech, steps)
        b = simulate(atlas_mech.with_parameters(mech.parameters()), steps)
    except UserError:
        return False
    if not (a.ok and b.ok):
        return False
    pa, pb = a.path(mech.foot), b.path(mech.foot)
    return bool(np.max(np.abs(pa - pb)) <= 1e-9 * mech.size)


def atlas_info(path) -> dict:
    """The attributes of an atlas file and its size in bytes (``explorer atlas info``)."""
    import h5py
    with h5py.File(path, "r") as f:
        attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
    attrs["size_bytes"] = Path(path).stat().st_size
    return attrs


#: Two starts are distinct when a varied parameter differs by more than this share of its range.
DISTINCT = 0.02


def diverse(atlas, cands, n: int, distinct: float = DISTINCT) -> list:
    """At most n of the candidates (best first), each more than ``distinct`` from those chosen before it
    in the atlas's unit box (the largest difference of a varied parameter as a share of its range,
    lengths on a log scale): nearly the same curve is drawn by designs in different basins of the
    polish, and starts from one basin all end at its minimum."""
    spec = atlas.spec
    lo, hi, log = np.array(spec.lower), np.array(spec.upper), np.array(spec.log)

    def unit(row):
        x = atlas.params[row].astype(np.float64)
        u = (x - lo) / (hi - lo)
        u[log] = np.log(x[log] / lo[log]) / np.log(hi[log] / lo[log])
        return u

    chosen, units = [], []
    for c in cands:
        u = unit(c.row)
        if all(np.max(np.abs(u - v)) > distinct for v in units):
            chosen.append(c)
            units.append(u)
            if len(chosen) >= n:
                break
    return chosen
