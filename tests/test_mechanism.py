"""Mechanism model and TOML loader: the built-ins, variants, and every validation error."""

from __future__ import annotations

import math

import pytest

import naive
from explorer import Mechanism, UserError, builtin_mechanisms, load_mechanism


# -- built-ins and variants --------------------------------------------------------------------------------
def test_builtins_listed():
    assert {"jansen", "fourbar"} <= set(builtin_mechanisms())


def test_jansen_loads_with_seed_numbers(jansen):
    assert isinstance(jansen, Mechanism)
    assert jansen.name == "jansen" and jansen.source == "builtin:jansen"
    assert jansen.vertices == naive.JANSEN_VERTICES  # tip, fixed, then guessed in file order
    assert jansen.link_names == tuple(f"{a}-{b}" for a, b in naive.JANSEN_LINKS)
    assert tuple(jansen.lengths) == naive.JANSEN_LENGTHS
    assert jansen.crank.radius == 15.0 and jansen.crank.tip == "1"
    assert jansen.foot == "7"
    assert jansen.vertex_index("7") == 6 and jansen.link_index("6-7") == 9


def test_fourbar_loads(fourbar):
    assert fourbar.vertices == ("A", "B0", "B", "P")
    assert fourbar.link_names == ("coupler", "rocker", "A-P", "B-P")
    assert fourbar.foot == "P"


@pytest.mark.parametrize("name", ["jansen", "fourbar"])
def test_load_builtin_from_any_cwd(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert load_mechanism(name).name == name
    # a folder of the same name in the working directory does not hide the built-in
    (tmp_path / name).mkdir()
    assert load_mechanism(name).name == name


def test_load_by_path_and_pathlike(triad):
    assert triad.name == "triad" and triad.source == str(naive.TRIAD)
    assert load_mechanism(str(naive.TRIAD)).links == triad.links


def test_with_lengths_returns_variant(jansen):
    before = jansen.lengths.copy()
    v = jansen.with_lengths({"1-3": 50.5}, crank=15.2)
    assert v is not jansen
    assert v.lengths[jansen.link_index("1-3")] == 50.5
    assert v.crank.radius == 15.2
    others = [i for i in range(10) if i != jansen.link_index("1-3")]
    assert list(v.lengths[others]) == list(before[others])
    assert v.vertices == jansen.vertices and v.guess == jansen.guess and v.fixed == jansen.fixed
    # the nominal is untouched
    assert list(jansen.lengths) == list(before) and jansen.crank.radius == 15.0
    assert jansen.links[0].length == 50.0
    # only the crank, or nothing
    assert jansen.with_lengths(crank=16.0).crank.radius == 16.0
    assert list(jansen.with_lengths().lengths) == list(before)


@pytest.mark.parametrize("kwargs", [
    {"lengths": {"9-9": 1.0}}, {"lengths": {"1-3": -1.0}}, {"lengths": {"1-3": 0}},
    {"lengths": {"1-3": math.nan}}, {"lengths": {"1-3": math.inf}}, {"lengths": {"1-3": "50"}},
    {"crank": 0.0}, {"crank": -15.0}, {"crank": math.nan}, {"crank": True},
])
def test_with_lengths_rejects_bad_values(jansen, kwargs):
    with pytest.raises(UserError) as exc:
        jansen.with_lengths(**kwargs)
    assert "\n" not in str(exc.value) and str(exc.value).startswith("builtin:jansen: ")


def test_unknown_vertex_lookup(jansen):
    with pytest.raises(UserError, match=r"^builtin:jansen: vertices: unknown vertex '9'"):
        jansen.vertex_index("9")
    with pytest.raises(UserError, match=r"^builtin:jansen: links: unknown link"):
        jansen.link_index("1-7")


def test_missing_file_is_user_error(tmp_path):
    missing = tmp_path / "nope.toml"
    with pytest.raises(UserError) as exc:
        load_mechanism(missing)
    assert str(exc.value).startswith(str(missing)) and "\n" not in str(exc.value)


# -- validation: one test per error, each checking file + key in a one-line message --------------------------
GOOD = """\
name = "fb"
foot = "P"

[crank]
center = [0.0, 0.0]
radius = 10.0
tip = "A"

[fixed]
B0 = [30.0, 0.0]

[guess]
B = [25.0, 24.0]
P = [15.0, 30.0]

[[links]]
a = "A"
b = "B"
length = 30.0

[[links]]
a = "B0"
b = "B"
length = 25.0

[[links]]
a = "A"
b = "P"
length = 25.0

[[links]]
a = "B"
b = "P"
length = 20.0
"""

EXTRA_LINK = '\n[[links]]\na = "{a}"\nb = "{b}"\nlength = {length}\n'


def edit(old, new, count=1):
    def apply(text):
        assert old in text, old
        return text.replace(old, new, count)
    return apply


def nth_length(n, value):
    """Replace the length of the n-th [[links]] table."""
    def apply(text):
        parts = text.split("[[links]]")
        parts[n + 1] = parts[n + 1].replace(parts[n + 1].split("length = ")[1].split("\n")[0], value, 1)
        return "[[links]]".join(parts)
    return apply


def append(extra):
    return lambda text: text + extra


def test_good_file_loads(tmp_path):
    path = tmp_path / "good.toml"
    path.write_text(GOOD)
    m = load_mechanism(path)
    assert m.vertices == ("A", "B0", "B", "P") and len(m.links) == 4


CASES = {
    # id: (edit of GOOD, key the message must name, a word of the reason)
    "unknown-vertex": (edit('a = "B"\nb = "P"', 'a = "B"\nb = "Q"'), "links[3].b", "'Q'"),
    "missing-guess": (edit("P = [15.0, 30.0]\n", ""), "links[2].b", "guess"),
    "duplicate-link": (append(EXTRA_LINK.format(a="P", b="A", length=25.0)), "links[4]", "duplicate"),
    "zero-length": (nth_length(1, "0.0"), "links[1].length", "> 0"),
    "negative-length": (nth_length(2, "-25.0"), "links[2].length", "> 0"),
    "inf-length": (nth_length(0, "inf"), "links[0].length", "finite"),
    "nan-length": (nth_length(3, "nan"), "links[3].length", "finite"),
    "string-length": (nth_length(0, '"30"'), "links[0].length", "number"),
    "bool-length": (nth_length(0, "true"), "links[0].length", "number"),
    "zero-crank": (edit("radius = 10.0", "radius = 0"), "crank.radius", "> 0"),
    "nan-crank": (edit("radius = 10.0", "radius = nan"), "crank.radius", "finite"),
    "missing-crank-radius": (edit("radius = 10.0\n", ""), "crank.radius", "missing"),
    "too-few-links": (lambda t: t[:t.rindex("[[links]]")], "links", "degrees of freedom"),
    "too-many-links": (append(EXTRA_LINK.format(a="B0", b="P", length=31.0)), "links", "degrees of freedom"),
    "unknown-top-key": (edit('name = "fb"', 'name = "fb"\ncolour = "red"'), "colour", "unknown key"),
    "unknown-crank-key": (edit("tip = \"A\"", "tip = \"A\"\nspeed = 2.0"), "crank.speed", "unknown key"),
    "unknown-link-key": (edit("length = 30.0", "length = 30.0\ncolour = 1.0"), "links[0].colour", "unknown key"),
    "malformed-toml": (edit("radius = 10.0", "radius = = 10.0"), None, "TOML"),
    "unterminated-string": (edit('name = "fb"', 'name = "fb'), None, "TOML"),
    "fixed-to-fixed": (lambda t: edit("B0 = [30.0, 0.0]", "B0 = [30.0, 0.0]\nC0 = [40.0, 0.0]")(t)
                       + EXTRA_LINK.format(a="B0", b="C0", length=10.0), "links[4]", "fixed"),
    "crank-to-fixed": (append(EXTRA_LINK.format(a="A", b="B0", length=20.0)), "links[4]", "fixed"),
    "self-link": (edit('a = "B"\nb = "P"', 'a = "P"\nb = "P"'), "links[3]", "itself"),
    "bad-fixed-point": (edit("B0 = [30.0, 0.0]", "B0 = [30.0]"), "fixed.B0", "[x, y]"),
    "nan-guess": (edit("B = [25.0, 24.0]", "B = [nan, 24.0]"), "guess.B", "finite"),
    "unknown-foot": (edit('foot = "P"', 'foot = "Z"'), "foot", "unknown vertex"),
    "fixed-foot": (edit('foot = "P"', 'foot = "B0"'), "foot", "fixed"),
    "missing-name": (edit('name = "fb"\n', ""), "name", "missing"),
    "guess-on-no-link": (edit("P = [15.0, 30.0]", "P = [15.0, 30.0]\nZ = [1.0, 1.0]"), "guess.Z", "no link"),
    "fixed-crank-tip": (edit("B0 = [30.0, 0.0]", "B0 = [30.0, 0.0]\nA = [10.0, 0.0]"), "fixed.A", "driven vertex"),
    "guess-for-fixed": (edit("P = [15.0, 30.0]", "P = [15.0, 30.0]\nB0 = [30.0, 0.0]"), "guess.B0", "no guess"),
    "links-not-array": (lambda t: "links = 3\n" + t.split("[[links]]")[0], "links", "[[links]]"),
    "non-string-vertex": (edit('a = "B0"', "a = 7"), "links[1].a", "string"),
    "non-string-name": (edit('name = "fb"', "name = 3"), "name", "string"),
    "non-string-description": (edit('name = "fb"', 'name = "fb"\ndescription = 1'), "description", "string"),
    "bad-crank-center": (edit("center = [0.0, 0.0]", 'center = [0.0, "0"]'), "crank.center", "[x, y]"),
    "fixed-not-table": (lambda t: "fixed = 3\n" + edit("[fixed]\nB0 = [30.0, 0.0]\n", "")(t), "fixed", "table"),
    "link-not-table": (lambda t: t.split("[[links]]")[0].replace('foot = "P"', 'foot = "P"\nlinks = [1, 2]'),
                       "links[0]", "table"),
    "missing-length": (edit("length = 30.0\n", ""), "links[0].length", "missing"),
    "missing-crank": (lambda t: t.replace("[crank]\ncenter = [0.0, 0.0]\nradius = 10.0\ntip = \"A\"\n", ""),
                      "crank", "missing"),
}
# a duplicate link *name* is its own error
CASES["duplicate-link-name"] = (
    lambda t: t.replace('a = "A"\nb = "B"', 'name = "x"\na = "A"\nb = "B"').replace(
        'a = "B0"\nb = "B"', 'name = "x"\na = "B0"\nb = "B"'), "links[1].name", "duplicate")


@pytest.mark.parametrize("case", sorted(CASES))
def test_validation_error(case, tmp_path):
    change, key, reason = CASES[case]
    path = tmp_path / f"{case}.toml"
    path.write_text(change(GOOD))
    with pytest.raises(UserError) as exc:
        load_mechanism(path)
    assert type(exc.value) is UserError
    msg = str(exc.value)
    assert "\n" not in msg, msg
    assert msg.startswith(f"{path}: "), msg
    if key is not None:
        assert msg.startswith(f"{path}: {key}: "), msg
    if reason is not None:
        assert reason in msg, msg


def test_crank_tip_on_no_link(tmp_path):
    """The count is right (two links, one guessed vertex) but the crank drives nothing."""
    path = tmp_path / "static.toml"
    path.write_text("""
name = "static"
foot = "B"
[crank]
center = [0.0, 0.0]
radius = 5.0
tip = "A"
[fixed]
G1 = [30.0, 0.0]
G2 = [0.0, 30.0]
[guess]
B = [20.0, 20.0]
[[links]]
a = "G1"
b = "B"
length = 22.0
[[links]]
a = "G2"
b = "B"
length = 22.0
""")
    with pytest.raises(UserError) as exc:
        load_mechanism(path)
    assert str(exc.value).startswith(f"{path}: crank.tip: ") and "no link" in str(exc.value)


def test_guess_for_crank_tip(tmp_path):
    path = tmp_path / "g.toml"
    path.write_text(GOOD.replace("P = [15.0, 30.0]", "P = [15.0, 30.0]\nA = [10.0, 0.0]"))
    with pytest.raises(UserError) as exc:
        load_mechanism(path)
    assert str(exc.value).startswith(f"{path}: guess.A: ")


def test_unreadable_file(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes(GOOD.replace("fb", "f\xe9").encode("latin-1"))
    with pytest.raises(UserError) as exc:
        load_mechanism(path)
    assert str(exc.value).startswith(f"{path}: cannot read") and "\n" not in str(exc.value)
