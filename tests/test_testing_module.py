"""The tests reach explorer's internals through one documented module, explorer.testing: every name it
lists resolves, and no test file imports a private module (``explorer.x._y``) or patches one by its dotted
path, so moving a module inside explorer changes explorer/testing.py, never the tests."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

import explorer.testing as testing

TESTS = Path(__file__).parent
#: Files whose strings name private modules as data (the import graph's nodes), not as a way in.
STRINGS_OK = {"test_import_graph.py", "test_testing_module.py"}


def _private(module: str) -> bool:
    return module.startswith("explorer") and any(p.startswith("_") for p in module.split(".")[1:])


@pytest.mark.parametrize("name", sorted(testing.__all__))
def test_every_name_resolves(name):
    assert getattr(testing, name) is not None
    module, attr = testing._HOMES[name]
    # internals only (a public name is imported from its package's face)
    assert module.startswith(".") and (_private("explorer" + module) or (attr or "").startswith("_")), (name, module)


def test_an_unknown_name_says_where_to_add_it():
    with pytest.raises(AttributeError, match="add it to _HOMES"):
        testing.no_such_thing  # noqa: B018


def test_no_test_reaches_into_a_private_module():
    found = []
    for f in sorted(TESTS.glob("*.py")):
        text = f.read_text(encoding="utf-8")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                mods = [node.module] + [f"{node.module}.{a.name}" for a in node.names if a.name.startswith("_")]
                found += [f"{f.name}:{node.lineno} {m}" for m in mods if _private(m)]
            elif isinstance(node, ast.Import):
                found += [f"{f.name}:{node.lineno} {a.name}" for a in node.names if _private(a.name)]
            elif isinstance(node, ast.Constant) and isinstance(node.value, str) and \
                    re.fullmatch(r"explorer(\.\w+)*\._\w+(\.\w+)*", node.value) and f.name not in STRINGS_OK:
                found.append(f"{f.name}:{node.lineno} {node.value!r}")
    allowed = {"explorer.gait._warm"}  # a program the cache test runs with python -m, not an import
    found = [x for x in found if x.split(" ", 1)[1].strip("'") not in allowed]
    assert not found, "use explorer.testing instead: " + "; ".join(found)
