"""Numba's on-disk cache of explorer's kernels, keyed by the kernels' code.

Numba checks only the source file that defines a cached function, not the files of the functions it
calls or inlines or the globals it freezes in as constants, so after an upgrade that changes
``kinds/dyad.py`` alone (the dyad's arithmetic) the cached sweep in ``_sweep_array.py`` would still run
the old step, and one that renumbers the block kinds would leave every cached kernel comparing against
the old numbers. Instead of deleting cache files, every explorer kernel is
cached in a folder named after a hash of the code of every module that defines or feeds a kernel
(:data:`KERNEL_PACKAGES`: ``explorer/kernels``, ``explorer/kinds``, ``explorer/plan``,
``explorer/gait``, ``explorer/bench``, ``explorer/wrist``, ``explorer/synthesis``): changed code, a new
folder, a fresh compile; a changed docstring or comment leaves the hash alone (it is taken over the syntax tree,
docstrings removed), so it costs at most the recompile of the functions in that one file (Numba's own
check). The folder is ``$NUMBA_CACHE_DIR/explorer-<hash>`` when that variable is set, else the user's
cache folder, ``$XDG_CACHE_HOME/explorer/numba-<hash>`` (``~/.cache/...``), and only if that cannot be
written, ``explorer/__pycache__/numba-<hash>`` in the package. Nothing is written into an installed
package otherwise: files pip did not install would outlive ``pip uninstall`` and leave an
``explorer`` folder without ``__init__.py`` that shadows the next install. Beside the current folder,
the three most recently used folders of other hashes are kept (other installs may share the user's
cache) and older ones removed, best effort.

The modules generated per topology (``explorer.kernels._codegen``, written to ``generated/`` of the
keyed folder) are cached under that same ``generated/`` whatever absolute path they were imported
from: Numba's own locators would key them on the file's path, so a cache built once (by
``explorer warm``, or a first run) and copied to another folder, user or machine would recompile them.
With Numba's content-hash source stamps, a copied folder serves every kernel as it is.

This plugs a locator class into Numba's caching (``numba.core.caching.CacheImpl``); if those
internals are missing (another Numba), the cache falls back to Numba's default locations, guarded by
the old rule: a stamp file, and the cached kernels deleted when the hash changes.
"""

from __future__ import annotations

import ast
import hashlib
import os
import shutil
from pathlib import Path

_PACKAGE = Path(__file__).resolve().parents[1]      # explorer/
#: the module names of the code generated per topology (``_codegen``): explorer_gen_<hash of its source>
GENERATED_PREFIX = "explorer_gen_"
#: Subpackages whose modules define kernels, code the kernels inline, or constants frozen into their
#: machine code (``kinds``: the block kinds' numerics and numbers).
KERNEL_PACKAGES = ("kernels", "kinds", "plan", "gait", "bench", "wrist", "synthesis")


def _strip_docstrings(tree: ast.AST) -> ast.AST:
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(getattr(body[0], "value", None), ast.Constant) \
                    and isinstance(body[0].value.value, str):
                node.body = body[1:] or [ast.Pass()]
    return tree


def source_key(texts) -> str:
    """A hash of the code of the given module sources ((name, text) pairs): docstrings, comments and
    layout do not change it; any change to the code does."""
    digest = hashlib.sha1()
    for name, text in sorted(texts):
        digest.update(name.encode())
        try:
            tree = _strip_docstrings(ast.parse(text))
            digest.update(ast.dump(tree, include_attributes=False).encode())
        except SyntaxError:
            digest.update(text.encode())
    return digest.hexdigest()[:16]


def kernel_sources() -> list[tuple[str, str]]:
    out = []
    for pkg in KERNEL_PACKAGES:
        for src in sorted((_PACKAGE / pkg).glob("*.py")):
            out.append((f"{pkg}/{src.name}", src.read_text(encoding="utf-8")))
    return out


def _user_cache() -> Path:
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "explorer"


def _key() -> str:
    """source_key of the kernel sources, memoised against a hash of their raw bytes (parsing the three
    dozen files costs ~0.3 s; hashing their bytes ~1 ms): the syntax trees are parsed only after a file
    changed."""
    texts = kernel_sources()
    raw = hashlib.sha1("\0".join(f"{n}\0{t}" for n, t in texts).encode()).hexdigest()
    memo = _user_cache() / "kernel-key.txt"
    try:
        seen_raw, seen_key = memo.read_text().split()
        if seen_raw == raw:
            return seen_key
    except (OSError, ValueError):
        pass
    key = source_key(texts)
    try:
        memo.parent.mkdir(parents=True, exist_ok=True)
        memo.write_text(f"{raw} {key}")
    except OSError:
        pass
    return key


KEY = _key()


def cache_bases() -> list[Path]:
    """Where the keyed cache folder may live, in order of preference."""
    from numba.core import config
    if config.CACHE_DIR:
        return [Path(config.CACHE_DIR) / f"explorer-{KEY}"]
    return [_user_cache() / f"numba-{KEY}", _PACKAGE / "__pycache__" / f"numba-{KEY}"]


#: Folders of other code hashes kept beside the current one (other installs may share the cache).
KEEP_OTHER_KEYS = 3


def _remove_other_keys(base: Path) -> None:
    prefix = base.name.rsplit("-", 1)[0] + "-"
    try:
        others = [p for p in base.parent.glob(prefix + "*") if p != base and p.is_dir()]
        others.sort(key=lambda p: p.stat().st_mtime, reverse=True)
        for old in others[KEEP_OTHER_KEYS:]:
            shutil.rmtree(old, ignore_errors=True)
    except OSError:
        pass


def _install() -> bool:
    try:
        from numba.core.caching import CacheImpl, _CacheLocator, _SourceFileBackedLocatorMixin
    except ImportError:
        return False

    class ExplorerLocator(_SourceFileBackedLocatorMixin, _CacheLocator):
        """explorer's kernels: the cache folder keyed by the kernels' code (see the module docstring)."""

        def __init__(self, py_func, py_file, base: Path, rel: Path):
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            self._cache_path = str(base / rel)

        def get_cache_path(self):
            return self._cache_path

        @classmethod
        def from_function(cls, py_func, py_file):
            if str(getattr(py_func, "__module__", "")).startswith(GENERATED_PREFIX):
                # a module generated per topology (``_codegen``): cached under generated/ of the keyed
                # folder whatever path it was imported from, so a copied cache serves it (Numba's own
                # locators key on the file's absolute path; the source stamp is its content's hash)
                rel = Path("generated")
            else:
                try:
                    rel = Path(py_file).resolve().parent.relative_to(_PACKAGE)
                except (ValueError, OSError):
                    return None  # not one of explorer's modules: Numba's own locators decide
            for base in cache_bases():
                self = cls(py_func, py_file, base, rel)
                try:
                    self.ensure_cache_path()
                except OSError:
                    continue
                if base not in _CLEANED:
                    _CLEANED.add(base)
                    _remove_other_keys(base)
                return self
            return None

    if not isinstance(getattr(CacheImpl, "_locator_classes", None), list):
        return False
    if not any(getattr(c, "__name__", "") == "ExplorerLocator" for c in CacheImpl._locator_classes):
        CacheImpl._locator_classes.insert(0, ExplorerLocator)
    return True


_CLEANED: set = set()


def _legacy_guard() -> None:
    """Numba without the locator hook: delete this package's cached kernels when the code hash changes."""
    cache = _PACKAGE / "kernels" / "__pycache__"
    marker = cache / "kernels.stamp"
    try:
        if marker.read_text() == KEY:
            return
    except OSError:
        pass
    try:
        cache.mkdir(exist_ok=True)
        for f in list(cache.glob("*.nbi")) + list(cache.glob("*.nbc")):
            f.unlink(missing_ok=True)
        marker.write_text(KEY)
    except OSError:  # a read-only install: Numba then caches elsewhere, or not at all
        pass


def guard_cache() -> None:
    """Send explorer's kernels to the cache folder keyed by their code (before any is compiled or loaded)."""
    if not _install():
        _legacy_guard()


def kernel_cache_path(dispatcher) -> str | None:
    """Where Numba caches ``dispatcher`` (an ``njit(cache=True)`` function): for tests and for users."""
    cache = getattr(dispatcher, "_cache", None)
    impl = getattr(cache, "_impl", None)
    locator = getattr(impl, "_locator", None)
    return locator.get_cache_path() if locator is not None else None


def is_cached(dispatcher) -> bool:
    """True if Numba's on-disk cache holds an index for ``dispatcher`` (some signature of it is cached;
    False where that cannot be told)."""
    try:
        return os.path.exists(dispatcher._cache._cache_file._index_path)
    except AttributeError:  # Numba's private layout changed: say not cached, which only costs time
        return False
