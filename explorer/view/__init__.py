"""Pictures of linkages and studies: static plots (matplotlib Figures) and animations (MP4 / GIF).

Everything renders headless with matplotlib's Agg canvas; MP4 uses the ffmpeg binary of the
``imageio-ffmpeg`` wheel, so no system ffmpeg (and no display) is needed.

Plots (each returns a :class:`matplotlib.figure.Figure`; save with :func:`save_figure` or
``fig.savefig``):

* ``plot_top(results, top=5)`` — the best buildable variants' foot paths over the nominal (the
  ranking of ``explorer rank``: by default the walker score, or ``by=METRIC``).
* ``plot_scatter(results, "travel", "bob")`` — two metrics, Pareto front, nominal marked.
* ``plot_forces(results, variant=0)`` — motor torque with its mean and flywheel energy, joint reactions.
* ``plot_velocity(cycle_or_mechanism_or_results, variant=None)`` — dx/dθ, dy/dθ: analytic solid,
  central finite differences dashed on top.
* ``plot_sensitivity(results)`` — a one-at-a-time study: change of each metric per link.
* ``plot_front(results)`` — an optimisation (``explorer optimize``): how its Pareto front (or best
  design) moved over the generations.
* ``plot_indices(explorer.analysis.sensitivity(results))`` — global sensitivity indices of a sampled
  study: one panel per output, bars with their intervals.

Report: ``write_report(results, "report.html")`` — one self-contained interactive HTML page (plotly.js
inlined, opens offline): linked parallel coordinates, a metric scatter with the Pareto front, foot paths,
and the screened-out and failed designs by reason (:mod:`explorer.view._report`); ``report_html(results)``
gives the page as a string.

Animation: ``animate(mechanism_or_cycle_or_results, "leg.mp4", cycles=2, frames=120, legs=1)``.

Exports of one design and the build kit are :mod:`explorer.fabrication`'s (``export_svg``, ``build_kit``,
``write_kit``, the ``EXPORTS`` registry, ...); their names are still importable from here for one release.
"""

from ._animate import DEFAULT_FPS, FRAMES_PER_CYCLE, MOVIE_FORMATS, LinkageAnimation, Movie, animate, ffmpeg_exe
from ._describe import describe
from ._draw import FOOT_PATH_COLOR, LegArtists, draw_ground, draw_path, mirror_positions, mirror_velocity
from ._front import plot_front
from ._indices import plot_indices
from ._report import Report, report_html, write_report
from ._plots import (FIGURE_FORMATS, central_differences, new_figure, oat_sensitivity, plot_scatter,
                     plot_forces, plot_sensitivity, plot_top, plot_velocity, save_figure, stance_indices, variant_mechanism)

__all__ = ["DEFAULT_FPS", "FIGURE_FORMATS", "FOOT_PATH_COLOR", "FRAMES_PER_CYCLE", "MOVIE_FORMATS", "LegArtists",
           "LinkageAnimation", "Movie", "animate", "central_differences", "draw_ground", "draw_path", "ffmpeg_exe",
           "mirror_positions", "mirror_velocity", "new_figure", "oat_sensitivity", "plot_indices", "plot_scatter",
           "plot_forces", "plot_sensitivity", "plot_top", "plot_velocity", "save_figure", "stance_indices", "variant_mechanism"]
__all__ += ["plot_front", "describe"]
__all__ += ["Report", "report_html", "write_report"]

from .._moved import moved  # noqa: E402

#: names that moved to explorer.fabrication (issue 40's rooms), importable from here for one release
__getattr__ = moved(__name__, dict.fromkeys(
    ("EXPORTS", "ExportFormat", "ExportJob", "export_format", "export_variant", "register_export",
     "EXPORT_FORMATS", "Sheet", "cut_sheet", "export_csv", "export_dxf", "export_svg", "export_toml",
     "mechanism_toml", "trajectory_frame", "variant_design", "Kit", "KitLeg", "KitPart", "KitPin", "Material",
     "Placement", "build_kit", "design_yield_note", "kit_data", "pin_diameter", "shaft_diameter", "write_kit"),
    "explorer.fabrication"))
