"""The ``[build]`` table (issue 37): one build as data, in a mechanism file or a study (over the mechanism's, key
by key). The link masses of the forces effect are density × thickness × part width, written plainly here."""

from __future__ import annotations

from pathlib import Path

import pytest

import explorer
from explorer.errors import UserError
from explorer.mechanism import Build, build_from_dict, mechanism_toml, mechanism_from_dict, parse_toml
from explorer.study import load_study

ROOT = Path(__file__).resolve().parent.parent
PLYWOOD = ROOT / "studies" / "mechanisms" / "jansen-plywood.toml"


def test_jansen_plywood_states_its_build():
    mech = explorer.load_mechanism(PLYWOOD)
    assert mech.build == Build("birch plywood", 9.0, 30.0, 680.0, None, "steel (S235)", "steel (S235)")
    assert mech.link_density == pytest.approx(680 * 0.009 * 0.030)  # kg per metre of link
    back = mechanism_from_dict(parse_toml(mechanism_toml(mech), "x"), "x")  # written back: the same build
    assert back.build == mech.build and back.link_density == mech.link_density


def test_build_keys_one_line_errors():
    base = Build(thickness=3.0)
    assert build_from_dict({"part_width": 20}, "s.toml", base=base) == Build(thickness=3.0, part_width=20.0)
    for table, key, value in (({"thickness": 0}, "build.thickness", "0"), ({"part_width": True}, "build.part_width",
                                                                              "True"),
                              ({"material": "balsa"}, "build.material", "balsa"), ({"colour": 1}, "build.colour", ""),
                              ({"shaft_material": "unobtainium"}, "build.shaft_material", "unobtainium")):
        with pytest.raises(UserError, match=f"s.toml: {key}") as e:
            build_from_dict(table, "s.toml")
        assert value in str(e.value) and "\n" not in str(e.value)


def _study(tmp_path, build=None, operating=None):
    d = {"study": {"name": "b", "mechanism": str(PLYWOOD), "variants": 2, "steps": 24},
         "perturb": {"spread": 0.01}, "output": {"path": str(tmp_path / "b.h5")}}
    if build is not None:
        d["build"] = build
    if operating is not None:
        d["operating"] = operating
    return d


def test_a_study_overrides_the_build_key_by_key(tmp_path):
    s = load_study(_study(tmp_path, build={"part_width": 48.0}))
    assert s.mech.build.part_width == 48.0 and s.mech.build.thickness == 9.0  # the rest is the mechanism's
    assert s.mech.link_density == pytest.approx(680 * 0.009 * 0.048)
    assert s.as_dict()["build"] == {"part_width": 48.0}
    assert "build" not in load_study(_study(tmp_path)).as_dict()  # a study without one keeps its fingerprint
    with pytest.raises(UserError, match=r"operating.unit: 0.02 m per model unit, but the build says unit = 0.01"):
        load_study(_study(tmp_path, build={"unit": 0.01}, operating={"unit": 0.02}))


def test_a_results_file_rebuilds_the_study_s_build(tmp_path, capsys):
    """A study's [build] over its mechanism's reaches every reader: the results' mechanism weighs its links so."""
    from explorer.cli import main
    from explorer.mechanism import dumps_toml
    (tmp_path / "s.toml").write_text(dumps_toml(_study(tmp_path, build={"part_width": 48.0})))
    assert main(["run", str(tmp_path / "s.toml")]) == 0
    capsys.readouterr()
    with explorer.open_results(tmp_path / "b.h5") as res:
        assert res.mechanism.build.part_width == 48.0
        assert res.mechanism.link_density == pytest.approx(680 * 0.009 * 0.048)
