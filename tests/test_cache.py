"""Numba's cache of explorer's kernels is keyed by the kernels' code: a docstring or comment does not
invalidate it, a code change does, NUMBA_CACHE_DIR is honoured, and every kernel module is covered."""

from __future__ import annotations

import os
import subprocess
import sys

from explorer.kernels._cache import KEY, kernel_cache_path, source_key

CODE = '''"""A kernel module."""
from numba import njit


@njit(cache=True)
def f(x):
    """Twice x."""
    return 2 * x  # doubled
'''


def test_the_key_follows_code_not_docstrings_or_comments():
    base = source_key([("kernels/m.py", CODE)])
    for same in (CODE.replace('"""Twice x."""', '"""Two times x, reworded."""'),
                 CODE.replace("# doubled", "# times two"),
                 CODE.replace('"""A kernel module."""', '"""Reworded."""') + "\n\n# a trailing comment\n"):
        assert source_key([("kernels/m.py", same)]) == base
    for other in (CODE.replace("2 * x", "3 * x"), CODE.replace("def f(x)", "def f(x, y=0)")):
        assert source_key([("kernels/m.py", other)]) != base
    assert source_key([("kernels/m.py", CODE), ("gait/n.py", CODE)]) != base  # another module counts


def test_every_kernel_module_caches_in_the_keyed_folder():
    from explorer.bench import _seeds
    from explorer.gait import _metrics, _walker
    from explorer.kernels import _batch
    for fn in (_walker._walker_kernel, _metrics._crossings_kernel, _batch.fast_batch_jit,
               next(getattr(_seeds, n) for n in dir(_seeds) if hasattr(getattr(_seeds, n), "_cache"))):
        path = kernel_cache_path(fn)
        assert path is not None and KEY in path, (fn, path)


def test_numba_cache_dir_is_honoured(tmp_path):
    code = ("from explorer.kernels._cache import KEY, kernel_cache_path\n"
            "from explorer.gait import _walker\n"
            "print(KEY, kernel_cache_path(_walker._walker_kernel))")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 0, out.stderr
    key, path = out.stdout.split()
    assert path.startswith(str(tmp_path / f"explorer-{key}")), path


def test_nothing_is_cached_inside_the_package(tmp_path):
    """Files pip did not install outlive `pip uninstall`: a cache inside an installed package left an
    `explorer` folder without __init__.py that shadowed the next (editable) install."""
    code = ("import explorer\nfrom explorer.kernels._cache import kernel_cache_path\n"
            "from explorer.gait import _walker\n"
            "print(explorer.__file__, kernel_cache_path(_walker._walker_kernel))")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["XDG_CACHE_HOME"] = str(tmp_path)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 0, out.stderr
    init, path = out.stdout.split()
    assert path.startswith(str(tmp_path / "explorer" / "numba-")), path
    assert not path.startswith(os.path.dirname(init))
