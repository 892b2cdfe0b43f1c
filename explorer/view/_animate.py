"""Animations of a linkage over its crank cycle: MP4 (FFMpegWriter, imageio-ffmpeg's binary) or GIF (Pillow).

The figure is built once: the ground pivots, the crank circle and the foot path of one full cycle are
static; each leg's links, crank, joints, foot and velocity arrow are artists that every frame only
moves (``set_data``, ``set_offsets``, ``set_UVC``) — nothing is cleared or re-created, which is what
made seed 003's animation slow. The layout is computed once and then frozen.

Frame f shows crank angle θ_f = 2π · cycles · f / frames (mod 2π). The cycle is solved once on a grid
of S angles chosen so that every θ_f, every leg's phase and every mirrored angle falls on it exactly
(S ≥ 360, a multiple of the frame step, of the number of legs and of 2).

A walker (``legs = N``) draws N copies with crank phases 2πj/N; the odd ones are mirrored about the
vertical through the crank centre and driven backwards (solved at α = π − β for world crank angle β), so
they share the crankshaft and push the ground the same way: with four legs these are the front pair
and the mirrored hind pair of seed 001's four-legged render.

A design that is not ok is drawn up to its failure angle (the crank sweeps only the part of the turn
that solved), with the failure in the title; one that cannot be assembled at θ = 0 raises UserError.
"""

from __future__ import annotations

import math
import os
import subprocess
import time
from dataclasses import dataclass
from fractions import Fraction
from io import BytesIO
from pathlib import Path

import numpy as np
from matplotlib import rc_context
from matplotlib.animation import FFMpegWriter, PillowWriter
from matplotlib.artist import Artist
from matplotlib.lines import Line2D
from matplotlib.transforms import ScaledTranslation
from PIL import Image

from ..errors import UserError
from ..kernels import Cycle, simulate
from ..mechanism import Mechanism, load_mechanism
from ..store import is_results, variant_mechanism
from ._draw import (ARROW_COLOR, CRANK_COLOR, FOOT_PATH_COLOR, GROUND_COLOR, GUIDE_COLOR, STANCE_COLOR, LegArtists, draw_ground,
                    draw_path, mirror_positions, mirror_velocity)
from .._files import write_replacing
from ._plots import check_output, new_figure

#: Movie formats animate writes, by extension.
MOVIE_FORMATS = {".mp4": "mp4", ".gif": "gif"}
DEFAULT_FPS = 30
#: Frames per crank turn when ``frames`` is not given.
FRAMES_PER_CYCLE = 60
MAX_LEGS = 16
MAX_FRAMES = 20_000


@dataclass(frozen=True)
class Movie:
    """What :func:`animate` wrote: ``path``, ``frames``, ``fps``, ``seconds`` (wall time to render and
    encode) and ``failure`` (the design's failure message, None when its cycle is ok)."""

    path: Path
    frames: int
    fps: float
    seconds: float
    failure: str | None


def foot_vertices(mech, positions: np.ndarray, cx: float) -> list[str]:
    """The feet of a leg: ``mech.foot`` first, then every other moving vertex whose path over the cycle
    is the foot path's mirror image about the crank's vertical axis x = ``cx`` (Strider's foot 8, which
    one crank pin drives as foot 4's mirror image). ``positions``: (S, n_vertices, 2), the solved
    samples. A vertex counts when each of its points lies within the foot path's sampling step (half
    the longest step between samples, plus 1e-9 of the path's size) of a mirrored foot point."""
    foot = mech.vertex_index(mech.foot)
    path = positions[:, foot]
    path = path[np.isfinite(path).all(axis=1)]
    feet = [mech.foot]
    if mech.crank is None or len(path) < 3:
        return feet
    mirrored = mirror_positions(path, cx)
    step = float(np.max(np.hypot(*np.diff(np.vstack([path, path[:1]]), axis=0).T)))
    size = float(np.max(np.ptp(path, axis=0)))
    tol = 0.5 * step + 1e-9 * max(size, 1.0)
    fixed = set(mech.fixed) | {mech.crank.tip}
    for j, v in enumerate(mech.vertices):
        if j == foot or v in fixed:
            continue
        q = positions[:, j]
        q = q[np.isfinite(q).all(axis=1)]
        if len(q) != len(path) or float(np.max(np.ptp(q, axis=0))) < 0.5 * size:
            continue
        d = np.hypot(q[:, None, 0] - mirrored[None, :, 0], q[:, None, 1] - mirrored[None, :, 1]).min(axis=1)
        if float(d.max()) <= tol:
            feet.append(v)
    return feet


def ffmpeg_exe() -> str:
    """The ffmpeg binary shipped in the ``imageio-ffmpeg`` wheel (no system ffmpeg needed)."""
    from .._extras import require
    imageio_ffmpeg = require("imageio_ffmpeg", "an MP4 movie (explorer animate)", otherwise="write a .gif")
    try:
        return imageio_ffmpeg.get_ffmpeg_exe()
    except RuntimeError as exc:
        raise UserError(f"MP4 output: imageio-ffmpeg has no ffmpeg binary for this platform: {exc}") from None


# -- validation ---------------------------------------------------------------------------------------
def _positive_int(name, value, hi=None) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise UserError(f"{name}: expected a whole number >= 1, got {value!r}")
    if hi is not None and value > hi:
        raise UserError(f"{name}: expected at most {hi}, got {value!r}")
    return int(value)


def _positive(name, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value) or value <= 0:
        raise UserError(f"{name}: expected a number > 0, got {value!r}")
    return float(value)


def _positive_or_zero(name, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not math.isfinite(value) or value < 0:
        raise UserError(f"{name}: expected a number >= 0, got {value!r}")
    return float(value)


def _grid(cycles: float, frames: int, legs: int) -> tuple[int, bool]:
    """Steps S of the solve grid and whether every frame angle falls on it exactly."""
    turn = Fraction(cycles).limit_denominator(1000) / frames  # crank turns per frame
    base = math.lcm(turn.denominator, legs, 2)
    if base > 7200:
        return 720, False
    return base * max(1, math.ceil(360 / base)), True


class _GifWriter(PillowWriter):
    """PillowWriter that maps every frame onto one palette (made from the first frame, no dithering;
    "max coverage" keeps the flat colours, white included, exact).

    Pillow would otherwise build an adaptive palette per frame when saving, which costs more than the
    drawing; one shared palette also keeps the colours steady from frame to frame.
    """

    def setup(self, fig, outfile, dpi=None):
        super().setup(fig, outfile, dpi=dpi)
        self._palette = None
        self._images = []

    def grab_frame(self, **savefig_kwargs):
        buf = BytesIO()
        self.fig.savefig(buf, **{**savefig_kwargs, "format": "rgba", "dpi": self.dpi})
        im = Image.frombuffer("RGBA", self.frame_size, buf.getbuffer(), "raw", "RGBA", 0, 1).convert("RGB")
        if self._palette is None:
            self._palette = im.quantize(colors=255, method=Image.Quantize.MAXCOVERAGE, dither=Image.Dither.NONE)
        self._images.append(im.quantize(palette=self._palette, dither=Image.Dither.NONE))

    def finish(self):
        self._images[0].save(self.outfile, save_all=True, append_images=self._images[1:],
                             duration=int(round(1000 / self.fps)), loop=0)


# -- the animation ------------------------------------------------------------------------------------
class _Background(Artist):
    """The static parts, rendered once and copied back into the canvas buffer each frame (Agg's
    ``restore_region``: a plain memory copy, no compositing or resampling as ``figimage`` would do)."""

    def __init__(self, region, size: tuple[int, int]):
        super().__init__()
        self.region, self.size = region, size
        self.set_zorder(-100)

    def draw(self, renderer):
        if not self.get_visible():
            return
        if (int(renderer.width), int(renderer.height)) != self.size:  # another size (a save at another dpi)
            return
        renderer.restore_region(self.region)


class LinkageAnimation:
    """A linkage figure whose artists are created once; :meth:`draw_frame` moves them to frame ``i``.

    ``source`` is a Mechanism (or a built-in name / mechanism file), a Cycle, or results with
    ``variant`` (default 0). Attributes: ``fig``, ``ax``, ``n_frames``, ``cycle`` (the solved cycle),
    ``failure`` (message or None), ``foot_paths`` (the drawn foot path overlays, world coordinates).
    """

    def __init__(self, source, *, cycles: float = 2, frames: int | None = None, legs: int = 1, fps: float = DEFAULT_FPS,
                 variant: int | None = None, steps: int | None = None, dpi: float = 100, figsize=None,
                 arrow_scale: float | None = None, walker=None):
        self.cycles = _positive("cycles", cycles)
        self.walker = _resolve_walker(source, walker)
        self.legs = self.walker.legs if self.walker is not None else _positive_int("legs", legs, MAX_LEGS)
        self.fps = _positive("fps", fps)
        dpi = _positive("dpi", dpi)
        if frames is None:
            frames = max(1, round(FRAMES_PER_CYCLE * self.cycles))
        self.n_frames = _positive_int("frames", frames, MAX_FRAMES)
        label = ""
        if isinstance(source, (str, os.PathLike)) and not is_results(source):
            source = load_mechanism(source)
        if is_results(source):
            v = 0 if variant is None else variant
            source = variant_mechanism(source, v)
            label = f" variant {int(v)}"
        elif variant is not None:
            raise UserError("variant: only results files have variants (pass results, or omit variant)")
        if isinstance(source, Mechanism):
            S, self._exact = _grid(self.cycles, self.n_frames, self.legs)
            if steps is not None:
                S, self._exact = _positive_int("steps", steps), False
            cyc = simulate(source, S, velocities=True)
        elif isinstance(source, Cycle):
            cyc, self._exact = source, False
        else:
            raise UserError(f"animate: expected a Mechanism, a Cycle or results, got {type(source).__name__}")
        self.cycle = cyc
        self.mech = mech = cyc.mechanism
        if mech.crank is None and self.legs > 1:
            raise UserError(f"legs: mechanism {mech.name!r} is driven along a path; a walker of several legs needs a "
                            f"crank (draw it with legs = 1)")
        self.title_base = f"{mech.name}{label}"
        self.S = S = len(cyc.theta)
        P = cyc.positions
        finite = np.isfinite(P).all(axis=(1, 2))
        self.n_valid = int(np.argmin(finite)) if not finite.all() else S
        self.failure = cyc.failure.message if cyc.failure is not None else None
        if self.n_valid == 0:
            raise UserError(f"{self.title_base}: nothing to animate: {self.failure or 'no configuration solved'}")
        foot = mech.vertex_index(mech.foot)
        if cyc.velocities is not None:
            self._vel = cyc.velocities[:, foot]
        else:  # central differences of the positions (a Cycle solved without velocities)
            from ._plots import central_differences
            self._vel = central_differences(cyc.theta, P[:, foot], cyclic=self.n_valid == S)
        if self.walker is not None:  # the walker the metrics describe: its phases (to the nearest sample) and mirrors
            self._mirrored = list(self.walker.mirrored)
            self._offset = [round(p * S / (2.0 * math.pi)) % S for p in self.walker.phases]
        else:
            self._mirrored = [self.legs > 1 and j % 2 == 1 for j in range(self.legs)]
            self._offset = [round(j * S / self.legs) for j in range(self.legs)]
        self._build(dpi, figsize, arrow_scale)

    # -- frame → sample indices ----------------------------------------------------------------------
    def frame_index(self, i: int) -> int:
        """Index into the cycle of the first leg's configuration at frame ``i``."""
        turns = self.cycles * i / self.n_frames
        frac = turns - math.floor(turns)
        if self.n_valid < self.S:  # sweep only the part of the turn that solved
            return min(int(frac * self.n_valid), self.n_valid - 1)
        if self._exact:
            t = Fraction(self.cycles).limit_denominator(1000) * i / self.n_frames
            return int((t - math.floor(t)) * self.S) % self.S
        return int(round(frac * self.S)) % self.S

    def leg_index(self, j: int, k: int) -> int:
        """Cycle index for leg ``j`` when the first leg is at index ``k`` (phase, then mirror)."""
        kk = k + self._offset[j]
        if self._mirrored[j]:
            kk = round(self.S / 2) - kk
        return kk % self.S

    def frame_theta(self, i: int) -> float:
        """World crank angle (rad, in [0, 2π)) of the first leg at frame ``i``."""
        return float(self.cycle.theta[self.frame_index(i)])

    # -- building the figure -------------------------------------------------------------------------
    def _build(self, dpi, figsize, arrow_scale):
        mech, cyc = self.mech, self.cycle
        cx = mech.crank.center[0] if mech.crank is not None else 0.0
        foot = mech.vertex_index(mech.foot)
        valid = cyc.positions[: self.n_valid]
        path = valid[:, foot]
        closed = self.n_valid == self.S
        # every foot of the leg: the named foot, and any vertex that walks its mirror image (Strider's
        # second foot); a walker's mirrored legs add the mirror image of a single foot's path
        self.feet = foot_vertices(mech, valid, cx)
        paths = [valid[:, mech.vertex_index(v)] for v in self.feet]
        if any(self._mirrored) and len(self.feet) == 1:
            paths.append(mirror_positions(path, cx))
        self.foot_paths = paths
        # extent: every vertex of every drawn orientation, the pivots and the crank circle
        pts = [valid.reshape(-1, 2)]
        fixed = np.array(list(mech.fixed.values()), dtype=np.float64).reshape(-1, 2)
        pts.append(fixed)
        if mech.crank is not None:
            r = mech.crank.radius
            c = np.array(mech.crank.center)
            pts.append(np.array([c + (r, r), c - (r, r)]))
        allp = np.vstack(pts)
        if any(self._mirrored):
            allp = np.vstack([allp, mirror_positions(allp, cx)])
        lo, hi = np.nanmin(allp, axis=0), np.nanmax(allp, axis=0)
        span = np.maximum(hi - lo, 1e-9)
        lo, hi = lo - 0.07 * span, hi + 0.07 * span
        span = hi - lo
        if figsize is None:
            w = 7.2
            h = min(max(w * span[1] / span[0] + 1.0, 4.0), 9.0)
            figsize = (w, h)
        # even pixel sizes, so H.264 with yuv420p takes the frame as it is
        wpx = 2 * max(16, round(figsize[0] * dpi / 2))
        hpx = 2 * max(16, round(figsize[1] * dpi / 2))
        self.dpi = dpi
        self.fig = fig = new_figure((wpx / dpi, hpx / dpi), dpi)
        self.ax = ax = fig.add_subplot()
        ax.set_aspect("equal", adjustable="box")
        width = np.nanmax(path[:, 0]) - np.nanmin(path[:, 0])
        ref = max(width, 0.15 * max(span))
        ax.set_xlabel("x [model units]")
        ax.set_ylabel("y [model units]")
        ax.grid(True, lw=0.4, alpha=0.4)
        # static: foot path(s), ground line, pivots, crank circle
        for n, p in enumerate(paths):
            draw_path(ax, p, closed=closed, label="foot path (one cycle)" if n == 0 else None)
        ymin = min(np.nanmin(p[:, 1]) for p in paths)
        # the ground: under the lowest foot point, shifted down by the path's half width so that the
        # stance stays visible on top of it
        # (none under a foot that runs on a ground slider: a piston or a ram does not stand on the ground)
        if not any(sl.ground and sl.vertex == mech.foot for sl in mech.sliders):
            ground = ax.axhline(ymin, color=STANCE_COLOR, lw=1.0, alpha=0.6, zorder=1)
            ground.set_transform(ground.get_transform() + ScaledTranslation(0.0, -1.6 / 72, fig.dpi_scale_trans))
        draw_ground(ax, mech, mirrored=False, positions=valid)
        if any(self._mirrored):
            draw_ground(ax, mech, mirrored=True, crank_circle=False, label=None, positions=valid)
        # moving: one LegArtists per leg, the first in front
        if arrow_scale is None:
            # the fastest foot speed draws 0.3 × the path's width (the 95th percentile: a rate blowing
            # up next to a failure must not shrink every other arrow to nothing)
            speed = np.hypot(self._vel[: self.n_valid, 0], self._vel[: self.n_valid, 1])
            speed = speed[np.isfinite(speed)]
            vref = float(np.percentile(speed, 95)) if speed.size else 0.0
            arrow_scale = 0.3 * ref / vref if vref > 0 else 0.0
        self.arrow_scale = _positive_or_zero("arrow_scale", arrow_scale)
        max_arrow = 0.5 * ref
        self.legs_artists = []
        for j in range(self.legs):
            front = j == 0
            self.legs_artists.append(LegArtists(ax, mech, arrow_scale=self.arrow_scale, alpha=1.0 if front else 0.45,
                                                zorder=10.0 if front else 6.0 - 0.1 * j, max_arrow=max_arrow))
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        handles = [Line2D([], [], color=FOOT_PATH_COLOR, lw=2),
                   Line2D([], [], color=ARROW_COLOR, lw=2, marker=">", ms=6),
                   Line2D([], [], color=CRANK_COLOR, lw=4),
                   Line2D([], [], color=GROUND_COLOR, ls="none", marker="^", ms=8)]
        crank = mech.crank is not None
        labels = [("foot path (one cycle)" if len(self.feet) == 1 else f"paths of feet {', '.join(self.feet)} "
                   f"(one cycle)") if crank else "tip path",
                  f"foot velocity dF/dθ (× {self.arrow_scale:.2g} rad)" if crank else
                  f"tip velocity (× {self.arrow_scale:.2g} s)", "crank" if crank else "(driven along its path)",
                  "ground pivots"]
        if any(sl.ground for sl in mech.sliders):
            handles.append(Line2D([], [], color=GUIDE_COLOR, lw=1.6, ls="--"))
            labels.append("slider guide")
        fig.legend(handles, labels, loc="outside lower center", ncols=4 if len(labels) <= 4 else 3, fontsize="small",
                   frameon=False)
        # The title is static (drawn into the background once); only the short clock text to its right
        # changes per frame. A fixed title position (y given): matplotlib would otherwise move it past
        # the hidden axes.
        if self.walker is not None:
            n_mirror = sum(self._mirrored)
            legs = f" · walker of {self.legs} legs" + (f" ({n_mirror} mirrored)" if n_mirror else "")
        else:
            legs = f" · {self.legs} legs (odd ones mirrored)" if self.legs > 1 else ""
        what = "crank turn" if mech.crank is not None else "pass along the path"
        rest = f"{legs} · {self.cycles:g} {what}{'s' if self.cycles != 1 else ''}"
        # above the name, so the clock on the name's line never overlaps it
        failure = f"not ok: {self.failure}; drawn up to it\n" if self.failure else ""
        self.title = ax.set_title(f"{failure}{self.title_base}{rest}", fontsize="medium", loc="left", y=1.0,
                                  pad=8)
        self.clock = ax.text(1.0, 1.0, " ", ha="right", va="baseline", fontsize="medium", family="monospace",
                             transform=ax.transAxes + ScaledTranslation(0.0, 8 / 72, fig.dpi_scale_trans))
        self.draw_frame(0)
        fig.canvas.draw()  # lay out once (constrained), with every part in place
        if _too_close(self.title, self.clock):
            # a long title (a walker's, a long name) would run into the clock: the name on a line of its
            # own, the clock beside the shorter rest (the clock's width is the same every frame)
            self.title.set_text(f"{failure}{self.title_base}\n{rest.removeprefix(' · ')}")
            fig.canvas.draw()
        fig.set_layout_engine(None)  # then freeze the layout: no re-layout per frame
        self._cache_background()

    def _cache_background(self) -> None:
        """Render the static parts once; afterwards a frame copies them back, then draws only the
        moving artists and the title (the static artists are hidden, not removed: transforms stay)."""
        fig, ax = self.fig, self.ax
        moving = {a for art in self.legs_artists for a in art.artists}
        moving.add(self.clock)
        saved_clock = self.clock.get_text()
        self.clock.set_text("")
        hidden = [a for art in self.legs_artists for a in art.artists if a.get_visible()]
        for a in hidden:
            a.set_visible(False)
        fig.canvas.draw()
        region = fig.canvas.copy_from_bbox(fig.bbox)
        size = fig.canvas.get_width_height()
        for a in hidden:
            a.set_visible(True)
        self.clock.set_text(saved_clock)
        self._static = [a for a in ax.get_children() if a not in moving and a.get_visible()] + list(fig.legends)
        self._static += [t for t in fig.texts if t.get_visible()]
        for a in self._static:
            a.set_visible(False)
        self.background = fig.add_artist(_Background(region, size))

    def draw_frame(self, i: int) -> None:
        """Move every leg to frame ``i`` and update the clock text (no artist is created)."""
        k = self.frame_index(i)
        P, V = self.cycle.positions, self._vel
        cx = self.mech.crank.center[0] if self.mech.crank is not None else 0.0
        for j, art in enumerate(self.legs_artists):
            kk = self.leg_index(j, k)
            if self._mirrored[j]:
                art.update(mirror_positions(P[kk], cx), mirror_velocity(V[kk]))
            else:
                art.update(P[kk], V[kk])
        if self.mech.crank is None:  # a path driver's parameter is its own time, in seconds
            self.clock.set_text(f"path t = {float(self.cycle.theta[k]):5.2f} s")
        else:
            deg = math.degrees(float(self.cycle.theta[k]))
            self.clock.set_text(f"θ = {deg:5.1f}°  t = {i / self.fps:5.2f} s")

    def data_to_pixels(self, xy: np.ndarray) -> np.ndarray:
        """Pixel (column, row) positions, row 0 at the top, of data points (n, 2) in a rendered frame."""
        disp = self.ax.transData.transform(np.asarray(xy, dtype=np.float64))
        h = self.fig.canvas.get_width_height()[1]
        return np.column_stack([disp[:, 0], h - disp[:, 1]])

    def write(self, out_path, progress=None) -> Movie:
        """Render every frame to ``out_path`` (.mp4 or .gif); returns a :class:`Movie`."""
        p = check_output(out_path, MOVIE_FORMATS)
        fmt = MOVIE_FORMATS[p.suffix.lower()]
        t0 = time.perf_counter()
        rc = {}
        if fmt == "gif":
            writer = _GifWriter(fps=self.fps)
        else:
            rc = {"animation.ffmpeg_path": ffmpeg_exe()}
            # yuv420p: browsers play it; veryfast: half the encoding time of the default preset for
            # the same file size on these flat-coloured frames (measured)
            writer = FFMpegWriter(fps=self.fps, codec="h264",
                                  extra_args=["-pix_fmt", "yuv420p", "-preset", "veryfast"])
        def render(tmp):
            # ffmpeg and Pillow write to a temporary file (same extension) renamed into place: a link at
            # the path is replaced, never followed, and a failure leaves nothing there
            try:
                with rc_context(rc), writer.saving(self.fig, str(tmp), dpi=self.dpi):
                    for i in range(self.n_frames):
                        self.draw_frame(i)
                        writer.grab_frame()
                        if progress is not None:
                            progress(i + 1, self.n_frames)
            except (subprocess.CalledProcessError, BrokenPipeError, OSError) as exc:
                msg = getattr(exc, "strerror", None) or (str(exc).splitlines() or [type(exc).__name__])[0]
                raise UserError(f"{p}: cannot write the {fmt.upper()}: {msg}") from None

        write_replacing(p, render)
        return Movie(p, self.n_frames, self.fps, time.perf_counter() - t0, self.failure)


def _too_close(title, clock) -> bool:
    """Whether the title's text comes within one em of the clock's (both drawn; sizes in pixels)."""
    r = title.figure.canvas.get_renderer()
    em = title.get_fontsize() * title.figure.dpi / 72
    return title.get_window_extent(r).padded(em).overlaps(clock.get_window_extent(r))


def _resolve_walker(source, walker):
    """None, a Walker as given, or (walker=True) the source's own: a results file's study [walker], else the
    mechanism's [walker] table, else four evenly spaced legs."""
    if walker is None or walker is False:
        return None
    from ..mechanism import Walker, walker_from_dict
    if isinstance(walker, Walker):
        return walker
    if is_results(source):
        mech = source.mechanism
        spec = (getattr(source, "study", {}) or {}).get("walker") or {}
        if mech.crank is None:
            raise UserError(f"walker: mechanism {mech.name!r} is driven along a path; a walker needs a crank")
        return walker_from_dict(spec, f"{getattr(source, 'filename', 'results')} (study)", "walker", base=mech.walker)
    mech = source if isinstance(source, Mechanism) else source.mechanism if isinstance(source, Cycle) \
        else load_mechanism(source)
    if mech.crank is None:
        raise UserError(f"walker: mechanism {mech.name!r} is driven along a path; a walker needs a crank")
    return mech.walker if mech.walker is not None else Walker()


def animate(source, out_path, cycles: float = 2, frames: int | None = None, legs: int = 1, fps: float = DEFAULT_FPS, *,
            variant: int | None = None, steps: int | None = None, dpi: float = 100, figsize=None,
            arrow_scale: float | None = None, progress=None, walker=None) -> Movie:
    """Animate a linkage over ``cycles`` crank turns into ``out_path`` (.mp4 or .gif).

    source : a Mechanism, a built-in mechanism name or mechanism file, a Cycle, or results (with
        ``variant``, default 0 = the nominal).
    frames : total frames (default 60 per crank turn); fps : frames per second of the movie.
    legs : 1 for one leg; N for a walker of N legs with crank phases 2πj/N, odd legs mirrored.
    walker : a :class:`explorer.mechanism.Walker`, or True for the one the metrics describe (the
        results' study ``[walker]``, else the mechanism's): its legs, phases (to the nearest sample of
        the animation's grid) and mirrored legs; overrides ``legs``.
    arrow_scale : data units of arrow per (model unit/rad) of foot speed (default: the fastest foot
        speed draws an arrow 0.3 × the path's width); 0 hides the arrows.

    Draws the links, joints, crank and ground pivots over the foot path of one full cycle, with the
    foot's velocity arrow tangent to that path. MP4 is H.264 yuv420p through matplotlib's
    FFMpegWriter with imageio-ffmpeg's binary; GIF through PillowWriter. A design that is not ok is
    drawn up to its failure angle with the failure in the title; one that cannot even be assembled
    raises UserError. Returns a :class:`Movie` (path, frames, fps, seconds, failure).
    """
    p = check_output(out_path, MOVIE_FORMATS)  # fail before solving anything
    if MOVIE_FORMATS[p.suffix.lower()] != "gif":
        ffmpeg_exe()  # an .mp4 without the movie extra, too
    anim = LinkageAnimation(source, cycles=cycles, frames=frames, legs=legs, fps=fps, variant=variant, steps=steps,
                            dpi=dpi, figsize=figsize, arrow_scale=arrow_scale, walker=walker)
    return anim.write(out_path, progress=progress)
