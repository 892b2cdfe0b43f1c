"""Keep Numba's on-disk cache of these kernels consistent with their sources.

Numba checks only the timestamp of the file that defines a cached function, not of the functions it
calls or inlines from other files, so after an upgrade that changes ``_dyads.py`` alone the cached
sweep in ``_sweep.py`` would still run the old step. This guard stamps the cache folder with a hash of
every kernel source and empties it when the hash changes.
"""

import hashlib
from pathlib import Path

_HERE = Path(__file__).parent


def guard_cache() -> None:
    """Delete this package's cached kernels if any kernel source changed since they were written."""
    digest = hashlib.sha1()
    for src in sorted(_HERE.glob("*.py")):
        digest.update(src.read_bytes())
    stamp = digest.hexdigest()
    cache = _HERE / "__pycache__"
    marker = cache / "kernels.stamp"
    try:
        if marker.read_text() == stamp:
            return
    except OSError:
        pass
    try:
        cache.mkdir(exist_ok=True)
        for f in list(cache.glob("*.nbi")) + list(cache.glob("*.nbc")):
            f.unlink(missing_ok=True)
        marker.write_text(stamp)
    except OSError:  # a read-only install: Numba then caches elsewhere, or not at all
        pass
