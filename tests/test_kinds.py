"""The block kinds as units (``explorer.kinds``): the registry, the rendered table-driven dispatch, and
that no kernel dispatches on a block's kind by hand.

* The committed ``explorer/kernels/_kinds_array.py`` is the kinds' ``ARRAY`` snippets rendered, text for
  text: editing a kind without re-rendering fails here.
* Every kind module has the parts the kernels and the plan read; kind numbers are 0 … n−1; the block
  table's fields are the union of the kinds' fields.
* No module of ``explorer/kernels`` other than the rendered one compares a block's kind with a number.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

import explorer
from explorer import kinds
from explorer.testing import kernels_render as _render
from explorer.testing import BLOCK_DTYPE

KERNELS = Path(explorer.__file__).parent / "kernels"


def test_committed_dispatch_is_the_kinds_rendered():
    assert _render.MODULE.read_text(encoding="utf-8") == _render.kinds_module_source(), (
        "explorer/kernels/_kinds_array.py differs from the kinds rendered: run python -m explorer.kernels._render")


def test_every_kind_has_its_parts():
    assert [k.NUMBER for k in kinds.KINDS] == list(range(len(kinds.KINDS)))
    for k in kinds.KINDS:
        for attr in ("NAME", "TEXT", "COLUMNS", "READS", "FIELDS", "START", "ARRAY", "SCALAR", "classify", "lower",
                     "assemble", "branch"):
            assert hasattr(k, attr), (k.NAME, attr)
        assert k.START in ("sign", "always", "stop")
        assert set(k.READS) <= set(k.COLUMNS)
        for name, dt in k.FIELDS:
            assert BLOCK_DTYPE[name] == np.dtype(dt), (k.NAME, name)
    assert kinds.BlockKind.DYAD == 0 and kinds.KIND_TEXT["GENERAL"]
    assert [eq.ORDER for eq in kinds.EQUATIONS] == sorted(eq.ORDER for eq in kinds.EQUATIONS)


def test_no_kernel_dispatches_on_a_kind_by_hand():
    # a block's kind compared with a number, a kind's name or a kind module's NUMBER (the driver's kind,
    # ``_drive``, is another thing)
    pattern = re.compile(r"(\.kind|blk_kind|kind\[\w+\]|\bkind(_r)?)\s*[!=]=\s*(\d|DYAD|ATTACH|SLIDE|GENERAL|GEARS)\b"
                         r"|[!=]=\s*(DYAD|ATTACH|SLIDE|GENERAL|GEARS|\w+\.NUMBER)\b")
    found = []
    for path in sorted(KERNELS.glob("*.py")):
        if path.name in ("_kinds_array.py", "_drive.py"):
            continue
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            code = line.split("#")[0]
            if pattern.search(code) and '"""' not in code and "``" not in code:
                found.append(f"{path.name}:{n}: {line.strip()}")
    assert not found, "\n".join(found)
