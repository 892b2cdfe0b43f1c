"""Optional dependencies: each heavy library serves one verb and is installed with its extra.

=================  ==============  ===============================================
module             extra           needed by
=================  ==============  ===============================================
``plotly``         ``report``      ``explorer report`` (:func:`~explorer.view.write_report`)
``pymoo``          ``optimize``    ``explorer optimize`` (:func:`~explorer.optimize.run_optimize`)
``SALib``          ``sensitivity`` ``explorer sensitivity``, ``perturb.method = "saltelli"``
``ezdxf``          ``cad``         ``explorer export --as dxf``
``imageio_ffmpeg`` ``movie``       ``explorer animate`` to .mp4 (a .gif needs nothing more)
``dask``           ``dask``        ``--workers``, ``client=`` (see :mod:`explorer.study._dask`)
``flask``          ``edit``        ``explorer edit`` (:mod:`explorer.edit`)
``mujoco``         ``physics``     ``explorer physics`` (:func:`~explorer.physics.physics_check`)
=================  ==============  ===============================================

``pip install 'explorer[all]'`` installs all of them. A library is imported where it is used, never at
module level of a shared module, through :func:`require`: a missing one raises :class:`MissingExtra`, a
:class:`~explorer.errors.UserError` (the CLI prints its one line and exits 2) that is also an
``ImportError`` for a Python caller.
"""

from __future__ import annotations

import importlib

from .errors import UserError

#: import name → (extra, distribution name as pip knows it)
EXTRAS = {
    "plotly": ("report", "plotly"),
    "pymoo": ("optimize", "pymoo"),
    "SALib": ("sensitivity", "SALib"),
    "ezdxf": ("cad", "ezdxf"),
    "imageio_ffmpeg": ("movie", "imageio-ffmpeg"),
    "flask": ("edit", "flask"),
    "mujoco": ("physics", "mujoco"),
}


class MissingExtra(UserError, ImportError):
    """An optional dependency is not installed; the message names the extra that installs it."""


def install_hint(extra: str) -> str:
    """``pip install 'explorer[EXTRA]'``."""
    return f"pip install 'explorer[{extra}]'"


def require(module: str, what: str, otherwise: str = ""):
    """Import and return the top-level ``module`` (a key of :data:`EXTRAS`); ``what`` names the verb or
    feature that needs it, e.g. ``"explorer report"``. Raises :class:`MissingExtra` with one line such as
    ``explorer report needs plotly: pip install 'explorer[report]'`` when it is missing (``otherwise``,
    e.g. ``"write a .gif"``, is added as the alternative)."""
    extra, dist = EXTRAS[module]
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        # the package itself is missing, or installed without one of its own dependencies (then say which)
        broken = exc.name not in (None, module) and not str(exc.name).startswith(module + ".")
        why = f" ({' '.join(str(exc).split())})" if broken else ""
        alt = f", or {otherwise}" if otherwise else ""
        raise MissingExtra(f"{what} needs {dist}: {install_hint(extra)}{alt}{why}") from None
