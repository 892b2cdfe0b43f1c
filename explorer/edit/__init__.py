"""``explorer edit``: design by hand in the browser. Drag a joint of the leg at a crank angle and watch the
foot path, the gait, the screen's margins, the forces and the yield change.

The editor sits at the top of the pipeline, beside ``cli`` and ``view``: a local web app (Flask, the
``edit`` extra) over the library. Every figure it shows is the library's: ``explorer.simulate`` of the
design, ``explorer.gait.compute_metrics`` of its foot path, the buildability screen, the forces effect,
``explorer.study.design_yield``; the page only draws them.

* :class:`EditSession` — the state and every action, as plain Python (JSON in, JSON out).
* :func:`design_data` / :func:`parse_design` — a design as its mechanism file's data, and back through the
  mechanism loader's validation.
* :func:`drag` — what dragging one joint does to the design (the branch kept, or the step refused).
* :func:`solve_design` — what the page shows of one design.
* :func:`make_app`, :class:`Server`, :func:`serve` — the web layer.
"""

from ._design import CRANK_CENTRE, Drag, assemble_at, design_data, drag, parse_design, rotated, set_parameters
from ._solve import live_metrics, screen_margins, solve_design
from ._session import SAVE_FORMATS, EditSession, optimize_study
from ._study import Study, yield_data

__all__ = ["CRANK_CENTRE", "Drag", "EditSession", "SAVE_FORMATS", "Server", "Study", "assemble_at", "design_data",
           "drag", "live_metrics", "make_app", "optimize_study", "parse_design", "rotated", "screen_margins", "serve",
           "set_parameters", "solve_design", "yield_data"]


def __getattr__(name):  # the web layer needs Flask (the edit extra): imported on first use
    if name in ("make_app", "Server", "serve", "DEFAULT_PORT"):
        from . import _app
        return getattr(_app, name)
    raise AttributeError(f"module 'explorer.edit' has no attribute {name!r}")
