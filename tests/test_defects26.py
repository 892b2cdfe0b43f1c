"""The defects issue 26 found on the way, each checked on the behaviour it fixes.

* ``explorer tolerance`` cuts every design parameter by default (links, crank, pivots, body points),
  ``--parameters links`` the links and the crank radius only, and its errors name the mechanism file;
* an optimisation's results file works with every verb that reads results (rank, plot --top,
  metrics, the commands in ``studies/jansen-optimize.toml``'s header);
* ``explorer sensitivity`` refuses results whose variants are no sample;
* ``rank --by iterations`` on the path-driven arm;
* one output policy for every writing verb (missing folders created, no overwrite without --force);
* every foot's path in an animation, and axis labels with the README's [unit] brackets.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from explorer.cli import main
from explorer.study import tolerance

ROOT = Path(__file__).resolve().parents[1]


def cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_line_error(code, err, *fragments):
    assert code == 2, err
    assert err.startswith("explorer: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err
    for f in fragments:
        assert str(f) in err, (f, err)


# -- 1. explorer tolerance ------------------------------------------------------------------------------
KW = dict(target=0.9, spread=0.02, variants=41, steps=36, rtol=0.25, seed=2, criterion="buildable")


@pytest.fixture(scope="module")
def klann_default():
    return tolerance("klann", **KW)


def test_tolerance_cuts_every_design_parameter_by_default(klann_default):
    from explorer import load_mechanism
    names = set(klann_default.parameters)
    # links, the crank, the pivots and the body points: every design parameter of the leg
    assert {"leg.37.x", "9.x", "crank", "lower_rocker", "connecting_rod.27.y"} <= names
    assert names == set(load_mechanism("klann").parameters())


def test_tolerance_links_only_is_looser_than_every_parameter(klann_default):
    links = tolerance("klann", parameters="links", **KW)
    assert set(links.parameters) == {"lower_rocker", "upper_rocker", "crank"}
    # the holes in the bodies and the frame matter: cutting them too leaves a tighter tolerance
    assert klann_default.spread < links.spread


def test_tolerance_cli_says_what_it_cuts(capsys):
    argv = ["tolerance", "klann", "--target", "0.9", "--variants", "21", "--steps", "24", "--rtol", "0.5"]
    code, out, err = cli(capsys, *argv)
    assert code == 0, err
    assert "every design parameter (links, crank, pivots, body points)" in out
    line = next(x for x in out.splitlines() if x.startswith("parameters cut to the spread"))
    assert "leg.37.x" in line and "9.x" in line
    code, out, err = cli(capsys, *argv, "--parameters", "links")
    assert code == 0, err
    line = next(x for x in out.splitlines() if x.startswith("parameters cut to the spread"))
    assert "leg.37.x" not in line and "lower_rocker" in line


def test_tolerance_errors_name_the_mechanism_file(tmp_path, capsys):
    text = (ROOT / "explorer" / "mechanism" / "builtin" / "klann.toml").read_text()
    assert "length = 3.59" in text
    bad = tmp_path / "stretched.toml"
    bad.write_text(text.replace("length = 3.59", "length = 30.59"))  # the lower rocker cannot reach
    code, out, err = cli(capsys, "tolerance", bad, "--variants", "20", "--steps", "24")
    one_line_error(code, err, str(bad), "cannot be assembled")
    assert "<dict>" not in err
    code, out, err = cli(capsys, "tolerance", "jansen", "--parameters", "1-3,leg.37.x", "--variants", "20")
    one_line_error(code, err, "jansen", "leg.37.x")
    assert "<dict>" not in err
