"""explorer: design-space exploration of planar linkages (Jansen's Strandbeest leg first).

The pipeline, one subpackage each: mechanism → plan → kernels → wrist → gait → store → study → analysis →
synthesis → optimize → fabrication → view → cli.

The public names below are imported on first use (PEP 562), so that ``import explorer`` and
``explorer --help`` stay light: Numba, h5py and the kernels load only when something needs them.
"""

from . import _early  # noqa: F401  (first: the command catches SIGINT/SIGTERM from here on)

from importlib import import_module  # noqa: E402

from .errors import UserError  # noqa: E402


def _version() -> str:
    """The installed distribution's version (``importlib.metadata``, imported on first use: ~20 ms)."""
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version("explorer")
    except PackageNotFoundError:  # running from a source tree without installation
        return "0.0.0+unknown"

#: public name -> the subpackage that defines it
_LAZY = {
    **dict.fromkeys(("STATUS_NAMES", "Batch", "Cycle", "Failure", "simulate", "simulate_batch"), "kernels"),
    **dict.fromkeys(("Crank", "Link", "Mechanism", "PathDriver", "builtin_mechanisms", "load_mechanism"), "mechanism"),
    **dict.fromkeys(("Grashof", "grashof", "make_plan"), "plan"),
    "Results": "store",
    **dict.fromkeys(("RunSummary", "open_results", "Study", "load_study", "run_study", "run_study_dask", "sample_variants"), "study"),
    "run_optimize": "optimize",
    **dict.fromkeys(("recompute_metrics", "sensitivity", "tolerance", "tolerance_summary"), "analysis"),
}


#: the subpackages, reachable as attributes (``explorer.gait``) like any imported submodule
_SUBPACKAGES = ("analysis", "bench", "cli", "edit", "fabrication", "gait", "kernels", "mechanism", "optimize", "plan", "store",
                "study", "synthesis", "view", "wrist")


def __getattr__(name: str):
    if name == "__version__":
        value = globals()["__version__"] = _version()
        return value
    if name in _LAZY:
        value = getattr(import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value  # once imported, a plain attribute
        return value
    if name in _SUBPACKAGES:
        return import_module(f".{name}", __name__)
    raise AttributeError(f"module 'explorer' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))


__all__ = ["STATUS_NAMES", "Batch", "Crank", "Cycle", "Failure", "Grashof", "Link", "Mechanism", "PathDriver",
           "UserError", "builtin_mechanisms", "grashof", "load_mechanism", "make_plan", "simulate", "simulate_batch",
           "__version__",
           "Results", "RunSummary", "Study", "load_study", "open_results", "recompute_metrics", "run_optimize", "run_study",
           "run_study_dask", "sample_variants", "sensitivity", "tolerance", "tolerance_summary"]
