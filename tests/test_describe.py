"""``explorer describe MECHANISM``: the person's text and the JSON of every built-in, masses and
[operating] from a file, and bad input as one line with exit 2."""

from __future__ import annotations

import json
from importlib import resources

import pytest

from explorer.cli import main
from explorer.mechanism import builtin_mechanisms, load_mechanism


def _describe(capsys, *argv):
    code = main(["describe", *argv])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert err == ""
    return out


def _section(text: str, title: str) -> list[str]:
    """The lines of a section (from its title line to the next blank line), title excluded."""
    lines = text.splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith(title))
    out = []
    for ln in lines[start + 1:]:
        if not ln.strip():
            break
        out.append(ln)
    return out


@pytest.mark.parametrize("name", builtin_mechanisms())
def test_text_names_every_vertex_link_and_parameter(name, capsys):
    mech = load_mechanism(name)
    out = _describe(capsys, name)
    assert out.splitlines()[0].startswith(f"{mech.name}: ")
    assert mech.description in out
    joints = {ln.split()[0]: ln for ln in _section(out, "joints (")[1:]}  # past the header row
    assert list(joints) == list(mech.vertices)
    assert "foot" in joints[mech.foot]
    for v in mech.vertices:
        if v != mech.foot:
            assert "foot" not in joints[v]
        if v in mech.fixed:
            assert "fixed ground pivot" in joints[v]
            x, y = mech.fixed[v]
            assert f"({x:g}, {y:g})" in joints[v]
    if mech.crank is not None:
        assert "crank tip" in joints[mech.crank.tip]
        assert sum("crank tip" in ln for ln in joints.values()) == 1
        assert f"crank: centre ({mech.crank.center[0]:g}, {mech.crank.center[1]:g}), radius {mech.crank.radius:g}" in out
    else:
        assert "driven vertex (path)" in joints[mech.path.vertex]
        assert "path driver: vertex" in out
    links = {ln.split()[0]: ln.split() for ln in _section(out, "links (")[1:]}
    assert list(links) == list(mech.link_names)
    for lk in mech.links:
        assert links[lk.name][1:] == [lk.a, lk.b, f"{lk.length:g}"]
    for b in mech.bodies:
        assert f"  {b.name}: " in out
    params = [ln.split()[0] for ln in _section(out, "design parameters (")[1:]]
    assert params == list(mech.parameters())
    kinds = {ln.split()[0]: ln.split()[2] for ln in _section(out, "design parameters (")[1:]}
    assert kinds == {p: mech.parameter_kind(p) for p in mech.parameters()}
    assert "solve plan (" in out
    assert "masses: none given" in out
    assert "operating point: none in the file" in out
    if mech.crank is not None:
        assert f"legs {(mech.walker.legs if mech.walker else 4)}" in out
        if any(sl.ground and sl.vertex == mech.foot for sl in mech.sliders):  # a piston, a ram: no screen
            assert "walker, leg and screen metrics: not applicable" in out and "min_transmission_angle" not in out
        else:
            assert "min_transmission_angle 5°" in out and "max_foot_speed 6 " in out


@pytest.mark.parametrize("name", builtin_mechanisms())
def test_json_parameters_roles_and_plan(name, capsys):
    from explorer.gait import Screen
    from explorer.kernels import plan_for
    from explorer.mechanism import Walker

    mech = load_mechanism(name)
    d = json.loads(_describe(capsys, name, "--format", "json"))
    assert d["name"] == mech.name and d["description"] == mech.description and d["foot"] == mech.foot
    assert d["parameters"] == mech.parameters()
    assert list(d["parameters"]) == list(mech.parameters())
    assert d["parameter_kinds"] == {p: mech.parameter_kind(p) for p in mech.parameters()}
    joints = {j["name"]: j for j in d["joints"]}
    assert list(joints) == list(mech.vertices)
    assert {v for v, j in joints.items() if j["role"] == "fixed"} == set(mech.fixed)
    for v, xy in mech.fixed.items():
        assert joints[v]["position"] == list(xy)
    assert [v for v, j in joints.items() if j["foot"]] == [mech.foot]
    driven = [v for v, j in joints.items() if j["role"] in ("crank_tip", "driven")]
    assert driven == [mech.driven]
    assert joints[mech.driven]["role"] == ("crank_tip" if mech.crank is not None else "driven")
    assert {v for v, j in joints.items() if j["role"] == "moving"} == set(mech.guess)
    for v, j in joints.items():
        assert j["links"] == [lk.name for lk in mech.links if v in (lk.a, lk.b)]
        assert j["bodies"] == [b.name for b in mech.bodies if v in b.joints]
    assert [(lk["name"], lk["a"], lk["b"], lk["length"]) for lk in d["links"]] == \
        [(lk.name, lk.a, lk.b, lk.length) for lk in mech.links]
    for bj, b in zip(d["bodies"], mech.bodies, strict=True):
        assert bj["name"] == b.name
        assert bj["joints"] == {j: list(p) for j, p in zip(b.joints, b.points)}
    if mech.crank is not None:
        assert d["driver"]["kind"] == "crank"
        assert d["driver"]["center"] == list(mech.crank.center) and d["driver"]["radius"] == mech.crank.radius
        w = mech.walker or Walker()
        assert d["walker"]["legs"] == w.legs and d["walker"]["mirrored"] == list(w.mirrored)
        assert d["walker"]["from"] == ("file" if mech.walker is not None else "default")
        assert d["screen"] == Screen().as_dict()
    else:
        assert d["driver"]["kind"] == "path" and d["driver"]["vertex"] == mech.path.vertex
        assert d["walker"] is None and d["screen"] is None
    plan = plan_for(mech)
    from explorer.plan import BlockKind
    kinds = {int(k): k.name for k in BlockKind}
    assert [s["kind"] for s in d["plan"]] == [kinds[int(b.kind)] for b in plan.blocks]
    assert [s["places"] for s in d["plan"]] == [[mech.vertices[v] for v in b.vertices] for b in plan.blocks]
    placed = [v for s in d["plan"] for v in s["places"]]
    assert sorted(placed) == sorted(mech.guess)  # every moving joint is placed once
    assert d["mass"]["given"] is False and d["operating"] is None


def test_a_general_block_is_described(capsys):
    from naive import TRIAD

    d = json.loads(_describe(capsys, str(TRIAD), "--format", "json"))
    assert [s["kind"] for s in d["plan"]] == ["GENERAL"]
    assert len(d["plan"][0]["places"]) == 3
    assert "GENERAL places" in _describe(capsys, str(TRIAD))


def _jansen_with_masses(tmp_path):
    text = (resources.files("explorer.mechanism") / "builtin" / "jansen.toml").read_text(encoding="utf-8")
    path = tmp_path / "heavy-jansen.toml"
    path.write_text(text + "\n[mass]\nlink_density = 0.2\n\n[operating]\nunit = 0.01\nrpm = 30\n", encoding="utf-8")
    return path


def test_masses_and_operating_are_shown(tmp_path, capsys):
    path = _jansen_with_masses(tmp_path)
    out = _describe(capsys, str(path))
    assert f"source: {path}" in out
    assert "link_density 0.2 kg per metre" in out
    assert "link 1-3  -      0.1 kg" in out  # 0.2 kg/m × 50 × 0.01 m
    assert "crank     -      0.03 kg" in out  # 0.2 × 15 × 0.01
    assert "operating point ([operating]): unit 0.01 m per model unit, rpm 30" in out
    assert "masses: none given" not in out

    d = json.loads(_describe(capsys, str(path), "--format", "json"))
    assert d["mass"] == {"given": True, "link_density": 0.2}
    assert d["operating"]["unit"] == 0.01 and d["operating"]["rpm"] == 30
    assert d["links"][0]["mass"] is None and d["links"][0]["effective_mass"] == pytest.approx(0.1)
    assert d["driver"]["effective_mass"] == pytest.approx(0.03)


def test_given_masses_and_a_density_without_a_unit(tmp_path, capsys):
    text = (resources.files("explorer.mechanism") / "builtin" / "klann.toml").read_text(encoding="utf-8")
    text = text.replace('length = 3.59', 'length = 3.59\nmass = 0.5')
    text = text.replace('name = "leg"              #', 'mass = 2.0\ninertia = 0.01\nname = "leg" #')
    path = tmp_path / "klann-mass.toml"
    path.write_text(text + "\n[mass]\nlink_density = 0.1\n", encoding="utf-8")
    out = _describe(capsys, str(path))
    assert "link lower_rocker  0.5 kg  0.5 kg" in out
    assert "effective masses need [operating] unit" in out
    assert "body leg: mass 2 kg, centroid the mean of its joints, inertia 0.01 kg·m²" in out
    d = json.loads(_describe(capsys, str(path), "--format", "json"))
    leg = next(b for b in d["bodies"] if b["name"] == "leg")
    assert (leg["mass"], leg["inertia"], leg["centroid"]) == (2.0, 0.01, None)
    assert d["links"][1]["effective_mass"] is None  # a density, but no unit to turn lengths into metres


@pytest.mark.parametrize("case", ["unknown", "missing", "malformed", "undecodable", "invalid", "format"])
def test_bad_input_is_one_line_exit_2(case, tmp_path, capsys):
    argv = {"unknown": ["no-such-leg"], "missing": [str(tmp_path / "gone.toml")]}.get(case)
    named = argv[0] if argv else None
    if case == "malformed":
        named = str(tmp_path / "bad.toml")
        (tmp_path / "bad.toml").write_text('name = "x"\nfoot = [\n', encoding="utf-8")
    elif case == "undecodable":
        named = str(tmp_path / "binary.toml")
        (tmp_path / "binary.toml").write_bytes(b"\xff\xfe\x00name")
    elif case == "invalid":
        named = str(tmp_path / "nofoot.toml")
        (tmp_path / "nofoot.toml").write_text('name = "x"\n[crank]\ncenter = [0, 0]\nradius = 1\ntip = "A"\n',
                                               encoding="utf-8")
    argv = argv or [named]
    if case == "format":
        argv, named = ["jansen", "--format", "xml"], "--format"
    code = main(["describe", *argv])
    out, err = capsys.readouterr()
    assert code == 2
    assert out == ""
    assert len(err.strip().splitlines()) == 1, err
    assert err.startswith("explorer: error: ") and named in err
    assert "Traceback" not in err


def test_help_has_an_example(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["describe", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "explorer describe jansen" in out and "--format" in out
