"""explorer: design-space exploration of planar linkages (Jansen's Strandbeest leg first).

The pipeline, one subpackage each: mechanism → plan → kernels → study → store → gait → view → cli.
"""

from importlib.metadata import PackageNotFoundError, version

from .errors import UserError
from .kernels import STATUS_NAMES, Batch, Cycle, Failure, simulate, simulate_batch
from .mechanism import Crank, Link, Mechanism, PathDriver, builtin_mechanisms, load_mechanism
from .plan import Grashof, grashof, make_plan
from .store import Results, open_results
from .study import RunSummary, Study, load_study, recompute_metrics, run_study, run_study_dask, sample_variants

try:
    __version__ = version("explorer")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

__all__ = ["STATUS_NAMES", "Batch", "Crank", "Cycle", "Failure", "Grashof", "Link", "Mechanism", "PathDriver",
           "UserError", "builtin_mechanisms", "grashof", "load_mechanism", "make_plan", "simulate", "simulate_batch",
           "__version__",
           "Results", "RunSummary", "Study", "load_study", "open_results", "recompute_metrics", "run_study",
           "run_study_dask", "sample_variants"]
