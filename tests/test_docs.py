"""The front door and the documentation site (issue 40): the README stays a short front door that opens
with the two commands, every link in it and in the docs points at a file that exists, every page is in
the site's navigation, every picture is in the gallery, and the study-file and mechanism-file
references hold every key the loaders accept.

The accepted keys are read back from the loaders themselves, black box: each table is handed a key
nobody accepts and the one-line error lists what is allowed. So a key added to a validator without a
line in ``scripts/docs_reference.py`` fails here (and stops ``mkdocs build``), whatever the key tables
say. The site itself is built by ``.ci/run`` (``mkdocs build --strict``: broken links and anchors fail).
"""

from __future__ import annotations

import copy
import importlib.util
import re
import sys
from pathlib import Path

import pytest

from explorer import UserError
from explorer.mechanism import mechanism_from_dict
from explorer.study import study_from_dict

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def _reference():
    spec = importlib.util.spec_from_file_location("docs_reference", ROOT / "scripts" / "docs_reference.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("docs_reference", mod)
    spec.loader.exec_module(mod)
    return mod


def _allowed(message: str) -> set[str]:
    """The keys a one-line 'unknown key' error lists: '... (allowed: a, b, c)' or '(allowed in [x]: a, b)'."""
    m = re.search(r"\(allowed(?: in \[[^\]]*\])?: ([^)]*)\)\s*$", message)
    assert m, message
    return {k.strip() for k in m.group(1).split(",")}


def _refused(fn, data) -> str:
    with pytest.raises(UserError) as exc:
        fn(data)
    return str(exc.value)


# -- what the loaders accept, asked of the loaders ------------------------------------------------------------
STUDY = {"study": {"name": "s", "mechanism": "jansen"}}


def study_keys() -> dict[str, set[str]]:
    """{section: keys} the study validator accepts, from its own errors."""
    sections = _allowed(_refused(lambda d: study_from_dict(d, "s.toml"), {**STUDY, "zz_section": {}}))
    out = {}
    for sec in sections:
        data = copy.deepcopy(STUDY)
        data.setdefault(sec, {})["zz_key"] = 1
        out[sec] = _allowed(_refused(lambda d: study_from_dict(d, "s.toml"), data))
    return out


def _mech(name: str) -> dict:
    import tomllib
    return tomllib.loads((ROOT / "explorer" / "mechanism" / "builtin" / f"{name}.toml").read_text())


def mechanism_keys() -> dict[str, set[str]]:
    """{table: keys} the mechanism loader accepts, from its own errors: each table of a built-in that has it
    handed an unknown key."""
    load = lambda d: mechanism_from_dict(d, "m.toml")  # noqa: E731
    out = {"": _allowed(_refused(load, {**_mech("jansen"), "zz_key": 1}))}
    cases = {"crank": ("jansen", "crank"), "links": ("jansen", "links"), "bodies": ("klann", "bodies"),
             "sliders": ("slidercrank", "sliders"), "walker": ("klann", "walker"), "driver": ("arm", "driver")}
    for table, (name, key) in cases.items():
        data = _mech(name)
        target = data[key][0] if isinstance(data[key], list) else data[key]
        target["zz_key"] = 1
        out[table] = _allowed(_refused(load, data))
    for table in ("mass", "operating", "build"):
        data = _mech("jansen")
        data[table] = {"zz_key": 1}
        out[table] = _allowed(_refused(load, data))
    return out


def _documented(page: str) -> dict[str, set[str]]:
    """{table title: keys} of a generated reference page: '## [scene]' then rows '| `key` | ... |'."""
    out, table = {}, None
    for line in page.splitlines():
        if line.startswith("## "):
            table = line[3:].strip()
            out[table] = set()
        m = re.match(r"^\| `([^`]+)` \|", line)
        if m and table is not None:
            out[table].add(m.group(1))
    return out


def test_every_key_the_study_loader_accepts_is_in_the_reference():
    ref = _reference()
    page = _documented(ref.pages()[ref.STUDY_PAGE])
    accepted = study_keys()
    assert {"study", "perturb", "scene", "output", "screen", "optimize", "robustness"} <= set(accepted)
    for sec, keys in accepted.items():
        assert f"[{sec}]" in page, f"[{sec}] is missing from the study-file reference"
        missing = keys - page[f"[{sec}]"]
        assert not missing, f"[{sec}] keys accepted but not documented: {sorted(missing)}"


def test_every_key_the_mechanism_loader_accepts_is_in_the_reference():
    ref = _reference()
    page = _documented(ref.pages()[ref.MECHANISM_PAGE])
    titles = {"": "Top level", "links": "[[links]]", "bodies": "[[bodies]]", "sliders": "[[sliders]]"}
    for table, keys in mechanism_keys().items():
        title = titles.get(table, f"[{table}]")
        assert title in page, f"{title} is missing from the mechanism-file reference"
        missing = keys - page[title]
        assert not missing, f"{title} keys accepted but not documented: {sorted(missing)}"


def test_the_reference_fails_on_a_key_without_words(monkeypatch):
    """The guard itself: a key the loader accepts but the generator has no line for stops the build."""
    ref = _reference()
    assert ref.problems() == []
    study = dict(ref.STUDY)
    study["scene"] = {k: v for k, v in ref.STUDY["scene"].items() if k != "band"}
    monkeypatch.setattr(ref, "STUDY", study)
    assert ref.problems() == ["study file: [scene] band is not described"]
    with pytest.raises(RuntimeError, match=r"\[scene\] band is not described"):
        ref.pages()


# -- the front door and the pages ------------------------------------------------------------------------------
def test_readme_is_a_short_front_door_opening_with_the_two_commands():
    readme = (ROOT / "README.md").read_text()
    lines = readme.splitlines()
    assert len(lines) <= 250, len(lines)
    block = readme.split("```bash\n", 1)[1].split("```", 1)[0].splitlines()
    assert block[0].startswith('pip install ".[movie]" && explorer run ')
    assert block[1].startswith('pip install -e ".[test]" && python3 -m pytest ')
    # .ci/run runs exactly that test command
    ci = (ROOT / ".ci" / "run").read_text()
    assert 'pip install -e ".[test]"' in ci and "python3 -m pytest\n" in ci
    assert "mkdocs build --strict" in ci


def _links(text: str):
    for m in re.finditer(r"!?\[[^\]]*\]\(([^)\s]+)\)", text):
        target = m.group(1)
        if not re.match(r"^[a-z]+:", target):
            yield target


def test_every_relative_link_points_at_a_file():
    """The README's links work where the README is read (GitHub, a clone); the docs' links also to the
    references the site generates (mkdocs build --strict checks their anchors too)."""
    generated = {(DOCS / name).resolve() for name in _reference().pages()}
    for page in [ROOT / "README.md", *DOCS.rglob("*.md")]:
        for target in _links(page.read_text()):
            path = target.split("#")[0]
            if not path:
                continue
            file = (page.parent / path).resolve()
            ok = file.exists() or (page.parent != ROOT and file in generated)
            assert ok, f"{page.relative_to(ROOT)}: broken link {target}"


def test_every_page_is_in_the_navigation_and_every_picture_in_the_gallery():
    nav = (ROOT / "mkdocs.yml").read_text()
    generated = set(_reference().pages())
    for page in DOCS.rglob("*.md"):
        name = page.relative_to(DOCS).as_posix()
        assert f": {name}" in nav, f"docs/{name} is not in mkdocs.yml's nav"
    for name in generated:
        assert f": {name}" in nav and not (DOCS / name).exists()   # generated at build time, never committed
    gallery = (DOCS / "gallery.md").read_text()
    for png in DOCS.glob("*.png"):
        assert f"]({png.name})" in gallery, f"docs/{png.name} is not in the gallery"


def test_every_api_member_is_defined_where_the_reference_looks():
    """mkdocstrings reads the packages statically and leaves out, silently, a name it cannot find there (a
    name imported on first use, as ``explorer.simulate`` is): each member docs/reference/api.md lists is a
    plain attribute of its module once that module is imported."""
    import importlib
    text = (DOCS / "reference" / "api.md").read_text()
    blocks = re.findall(r"^::: ([\w.]+)\n((?:    .*\n)+)", text, re.M)
    assert len(blocks) >= 6
    for module, options in blocks:
        members = re.findall(r"^        - (\w+)$", options, re.M)
        assert members, module
        namespace = vars(importlib.import_module(module))
        missing = [m for m in members if m not in namespace]
        assert not missing, f"{module}: {missing}"
