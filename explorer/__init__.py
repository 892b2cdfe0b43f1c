"""explorer: design-space exploration of planar linkages (Jansen's Strandbeest leg first).

The pipeline, one subpackage each: mechanism → plan → kernels → study → store → gait → view → cli.
"""

from importlib.metadata import PackageNotFoundError, version

from .errors import UserError
from .kernels import STATUS_NAMES, Batch, Cycle, Failure, simulate, simulate_batch
from .mechanism import Crank, Link, Mechanism, builtin_mechanisms, load_mechanism
from .plan import make_plan

try:
    __version__ = version("explorer")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

__all__ = ["STATUS_NAMES", "Batch", "Crank", "Cycle", "Failure", "Link", "Mechanism", "UserError", "builtin_mechanisms",
           "load_mechanism", "make_plan", "simulate", "simulate_batch", "__version__"]
