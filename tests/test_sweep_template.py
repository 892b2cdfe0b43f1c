"""The sweep written once (``explorer.kernels._sweep_template``) and its two renderings.

* The committed array form (``_sweep_array.py``) is the template rendered in the array dialect, text
  for text: editing one without re-rendering fails here.
* Every hole of the template is filled by both dialects, every section decided by both; a hole whose
  targets or arguments differ from the table, or an unknown section, is refused.
* The template itself is never run.

That both renderings give the same results bit for bit is tests/test_codegen.py's.
"""

from __future__ import annotations

import ast

import numpy as np
import pytest

import explorer
from explorer.testing import (kernels_codegen as _codegen, kernels_simulate as _simulate, kernels_sweep as _sweep,
                              kernels_sweep_template as _sweep_template)
from explorer.testing import HOLES, SECTIONS, render


def test_committed_array_form_is_the_template_rendered():
    fresh = _sweep.array_module_source()
    committed = _sweep._ARRAY_MODULE.read_text(encoding="utf-8")
    assert committed == fresh, (
        "explorer/kernels/_sweep_array.py differs from the sweep template rendered in the array dialect: "
        "edit _sweep_template.sweep or _sweep.ARRAY, then run "
        "python -c \"from explorer.kernels import _sweep; _sweep.write_array_module()\"")
    assert _sweep._BATCH_MODULE.read_text(encoding="utf-8") == _sweep.batch_module_source(), (
        "explorer/kernels/_batch_array.py differs from the batch template rendered in the array dialect: run "
        "python -c \"from explorer.kernels import _sweep; _sweep.write_array_module()\"")


def test_one_batch_loop():
    """Every sweep kernel's per-design loop is the batch template's: the table-driven ones are its array
    form (with and without forces), a generated one its form around the topology's loop of whole steps
    (shared by every topology; the generated module holds that loop only)."""
    from explorer.testing import kernels_batch as _batch, kernels_batch_array as _batch_array

    for jitted, fn in ((_batch.fast_batch_jit, _batch_array.batch_plain), (_batch.generic_batch_jit, _batch_array.batch_plain),
                       (_batch.fast_forces_jit, _batch_array.batch_forces),
                       (_batch.generic_forces_jit, _batch_array.batch_forces),
                       (_batch.whole_batch_jit, _batch_array.batch_whole_plain),
                       (_batch.whole_forces_jit, _batch_array.batch_whole_forces)):
        assert jitted.py_func.__code__ is fn.__code__
    holes = {m.group("name") for ln in _sweep_template._template_of(_sweep_template.batch)[0]
             if (m := _sweep_template._HOLE.match(ln))}
    assert holes == set(_sweep_template.BATCH_HOLES)
    for forces in (False, True):
        assert set(_sweep.batch_array_dialect(forces)) == holes
        assert set(_sweep.batch_whole_dialect(forces)) == holes
    src = _codegen.source(_hoeken_topology(), True, True, True)
    assert "def kernel(T, P_init, tab, signs," in src and "place_dyad(" in src
    assert "for i in range" not in src and "design_forces" not in src


def test_array_form_is_what_the_kernels_run():
    from explorer.testing import kernels_sweep_array as _sweep_array

    assert _sweep.sweep is _sweep_array.sweep
    for jitted in (_sweep.fast_sweep, _sweep.generic_sweep):
        assert jitted.py_func.__code__ is _sweep_array.sweep.__code__


def _holes_in_template() -> tuple[set, set]:
    lines, _ = _sweep_template._template()
    holes = {m.group("name") for ln in lines if (m := _sweep_template._HOLE.match(ln))}
    sections = {m.group("name") for ln in lines if (m := _sweep_template._SECTION.match(ln))}
    return holes, sections


def _hoeken_topology(want_vel=True):
    mech = explorer.load_mechanism("hoeken")  # a dyad and a body joint
    captured = {}
    real = _simulate.kernel_for

    class Caught(Exception):
        pass

    def spy(topo, *args):
        captured["topo"] = topo
        raise Caught  # the topology is what the tests read: no kernel compiled for it

    _simulate.kernel_for = spy
    try:
        with pytest.raises(Caught):
            explorer.simulate_batch(mech, mech.lengths[None], None, 12, vertices="all", velocities=want_vel,
                                    kernel="generated")
    finally:
        _simulate.kernel_for = real
    return captured["topo"]


def test_both_dialects_fill_every_hole_and_decide_every_section():
    holes, sections = _holes_in_template()
    assert holes == set(HOLES) and sections == set(SECTIONS)
    scalar = _codegen.scalar_dialect(_hoeken_topology(), True)
    for dialect, decided in ((_sweep.ARRAY, _sweep.ARRAY_SECTIONS), (scalar, _codegen.SCALAR_SECTIONS)):
        assert set(dialect) == set(HOLES)
        assert set(decided) == set(SECTIONS)


@pytest.mark.parametrize("want_vel", [True, False])
def test_scalar_form_is_valid_python_without_holes(want_vel):
    src = _codegen.source(_hoeken_topology(want_vel), want_vel)
    tree = ast.parse(src)
    names = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
    assert "hole" not in names and "step" not in names
    assert ("out_vel[" in src) == want_vel
    # the loop of whole steps is kept in the scalar form, dropped in the array form
    assert "iters_before" in src
    assert "iters_before" not in _sweep.array_module_source()


def _rendered_with(monkeypatch, old, new):
    lines, first = _sweep_template._template()
    edited = [ln.replace(old, new) for ln in lines]
    assert edited != lines
    monkeypatch.setattr(_sweep_template, "_template", lambda: (edited, first))
    return render(_sweep.ARRAY, _sweep.ARRAY_SECTIONS)


def test_a_hole_that_changes_meaning_is_refused(monkeypatch):
    with pytest.raises(ValueError, match="does not match"):
        _rendered_with(monkeypatch, "hole.store(sample)", "hole.store(k)")


def test_an_unknown_section_is_refused(monkeypatch):
    with pytest.raises(ValueError, match="unknown section"):
        _rendered_with(monkeypatch, "if hole.whole_steps():", "if hole.fast_steps():")


def test_a_hole_inside_an_expression_is_refused(monkeypatch):
    with pytest.raises(ValueError, match="statement of its own"):
        _rendered_with(monkeypatch, "hole.accept()", "x = 1 + hole.accept()")


def test_the_template_is_never_run():
    with pytest.raises(RuntimeError, match="rendered"):
        _sweep_template.sweep(None, None, None, None, np.zeros((1, 2)), np.zeros(2, dtype=np.int64),
                              np.zeros((0, 1, 2)), None, 0.0, 0.0, 1.0, 1.0, 1e-9, None, None, None)


def test_the_hole_marker_answers_introspection_as_an_ordinary_object():
    assert not hasattr(_sweep_template.hole, "__wrapped__")


def test_kernel_cache_key_covers_the_plan():
    """The block kinds (``kinds``) are code and constants frozen into the kernels' machine code (and into
    the generated sources): a change there must key a fresh cache folder."""
    from explorer.testing import kernel_sources

    names = {name for name, _ in kernel_sources()}
    for module in ("plan/_kinds.py", "kinds/__init__.py", "kinds/dyad.py", "kernels/_sweep_template.py",
                   "kernels/_sweep_array.py", "kernels/_kinds_array.py"):
        assert module in names
