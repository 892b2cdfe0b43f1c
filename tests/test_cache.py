"""Numba's cache of explorer's kernels is keyed by the kernels' code: a docstring or comment does not
invalidate it, a code change does, NUMBA_CACHE_DIR is honoured, and every kernel module is covered."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from explorer.testing import KEY, kernel_cache_path, source_key

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
    from explorer.testing import bench_seeds as _seeds
    from explorer.testing import gait_metrics as _metrics, gait_walker as _walker
    from explorer.testing import kernels_batch as _batch
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


@pytest.mark.slow
def test_the_background_warmup_compiles_what_a_study_calls(tmp_path):
    """On an empty cache `explorer run` has a second process compile the metric kernels
    (explorer.gait._warm) while it compiles the solver. That only helps if the warm-up compiles the
    very signatures a study's chunk calls: after the warm-up alone, a fresh process computing a
    chunk's metrics the way the runner does (views of a batch's outputs, int8 status, every metric)
    must load every metric kernel from the cache and compile none."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    warm = subprocess.run([sys.executable, "-m", "explorer.gait._warm"], capture_output=True, text=True, env=env,
                          timeout=300)
    assert warm.returncode == 0, warm.stderr
    code = ("import numpy as np, explorer\n"
            "from explorer.gait import _metrics, _walker, compute_metrics\n"
            "m = explorer.load_mechanism('jansen')\n"
            "b = explorer.simulate_batch(m, np.repeat(m.lengths[None], 3, 0), None, 90, vertices=['7', '6'],\n"
            "                            method='closed')\n"  # positions only: compiles no solver kernel worth waiting for
            "p = b.paths['7']\n"
            "v = np.gradient(p, 2 * np.pi / 90, axis=1)\n"
            "compute_metrics(p, v, b.status, None, mechanism=m, lengths=np.repeat(m.lengths[None], 3, 0),\n"
            "                crank=np.full(3, 15.0))\n"
            "for f in (_metrics._foot_metrics_kernel, _metrics._crossings_kernel, _walker._walker_kernel):\n"
            "    print(f.__name__, sum(f.stats.cache_hits.values()), sum(f.stats.cache_misses.values()))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert out.returncode == 0, out.stderr
    rows = [line.split() for line in out.stdout.strip().splitlines()]
    assert len(rows) == 3
    for name, hits, misses in rows:
        assert int(hits) >= 1 and int(misses) == 0, (name, hits, misses)


def test_metrics_of_no_ok_row_are_nan_without_running_a_kernel():
    """The runner's validation call (and a chunk that failed whole) has no ok row: every metric is
    NaN, and no metric kernel runs, so none is compiled before the solver."""
    import numpy as np

    import explorer
    from explorer.gait import compute_metrics
    m = explorer.load_mechanism("jansen")
    p = np.zeros((2, 36, 2))
    out = compute_metrics(p, p, np.array([1, 3], dtype=np.int8), None, mechanism=m,
                          lengths=np.repeat(m.lengths[None], 2, 0), crank=np.full(2, 15.0))
    assert out and all(np.isnan(v).all() for v in out.values())


_COMPILES = '''
import sys
import numpy as np
from numba.core import event
import explorer
from explorer.kernels import _codegen

compiled = []
class Count(event.Listener):
    def on_start(self, ev):
        compiled.append(str(ev.data.get("dispatcher")))
    def on_end(self, ev):
        pass
with event.install_listener("numba:compile", Count()):
    m = explorer.load_mechanism("fourbar")
    L = np.repeat(m.lengths[None], 3, 0)
    b = explorer.simulate_batch(m, L, None, 36, kernel="generated")
assert (b.status == 0).all()
mod = [n for n in sys.modules if n.startswith("explorer_gen_")]
print(len(compiled), sys.modules[mod[0]].__file__)
'''


@pytest.mark.slow
def test_a_copied_cache_serves_the_generated_kernels_without_compiling(tmp_path):
    """A cache built once in one folder, copied elsewhere (new paths, new file times) serves a later
    run there: no kernel compiles, the per-topology generated module included, although it is
    imported from the copy's own path (Numba's own locators key a cache on the file's absolute path)."""
    import shutil

    first, copy = tmp_path / "built", tmp_path / "elsewhere" / "copied"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(first)}
    out = subprocess.run([sys.executable, "-c", _COMPILES], capture_output=True, text=True, env=env, timeout=600)
    assert out.returncode == 0, out.stderr
    n_first, gen_first = out.stdout.split()
    assert int(n_first) > 0 and gen_first.startswith(str(first))  # it compiled, the generated kernel too
    shutil.copytree(first, copy, copy_function=shutil.copy)  # not copy2: the files' times are new
    shutil.rmtree(first)
    env["NUMBA_CACHE_DIR"] = str(copy)
    out = subprocess.run([sys.executable, "-c", _COMPILES], capture_output=True, text=True, env=env, timeout=600)
    assert out.returncode == 0, out.stderr
    n_copy, gen_copy = out.stdout.split()
    assert gen_copy.startswith(str(copy))
    assert int(n_copy) == 0, f"{n_copy} kernels compiled again from a copied cache"


_AFTER_WARM = r'''
import sys
from pathlib import Path
from numba.core import event
import explorer
from explorer.study import load_study, run_study

compiled = []
class Count(event.Listener):
    def on_start(self, ev):
        compiled.append(str(getattr(ev.data.get("dispatcher"), "py_func", ev.data.get("dispatcher"))))
    def on_end(self, ev):
        pass
with event.install_listener("numba:compile", Count()):
    run_study(load_study(None), output=Path(sys.argv[1]), force=True, progress=False)  # 10,000 x 360: generated
    mech = explorer.load_mechanism("jansen")
    assert explorer.simulate(mech, 360).ok                                      # one design: the general kernel
    b = explorer.simulate_batch(mech, mech.lengths[None].repeat(50, 0), None, 90)  # a small batch: the same
    assert (b.status == 0).all()
print(len(compiled), sorted(set(compiled)))
'''


@pytest.mark.slow
def test_explorer_warm_leaves_nothing_to_compile(tmp_path):
    """``explorer warm`` (the default study) on an empty cache, then a fresh process that runs the default
    study (whose 3.6 million configurations take the generated kernel), solves one design and a small
    batch (the general kernel): nothing compiles there."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    out = subprocess.run([sys.executable, "-m", "explorer.cli", "warm"], capture_output=True, text=True, env=env,
                         timeout=900)
    assert out.returncode == 0, out.stderr
    assert " kernels compiled" in out.stdout and int(out.stdout.split(" kernels compiled")[0].split()[-1]) > 0
    out = subprocess.run([sys.executable, "-c", _AFTER_WARM, str(tmp_path / "r.h5")], capture_output=True, text=True,
                         env=env, timeout=900)
    assert out.returncode == 0, out.stderr
    n, names = out.stdout.split(" ", 1)
    assert int(n) == 0, f"compiled after explorer warm: {names}"
