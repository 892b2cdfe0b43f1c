"""``python -m explorer.cli``: the same as the ``explorer`` command."""

import sys

from . import main

sys.exit(main())
