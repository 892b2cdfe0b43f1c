"""Optional dependencies: a verb whose extra is missing says which extra to install, in one line, and
exits 2 (no traceback); nothing imports a heavy library at module level; pyproject's extras match the
table in ``explorer/_extras.py``."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from explorer.testing import EXTRAS, MissingExtra, require
from explorer.cli import main
from explorer.errors import UserError

ROOT = Path(__file__).resolve().parents[1]


def missing(monkeypatch, module: str) -> None:
    """Simulate ``module`` not installed: ``import module`` raises ImportError (None in sys.modules)."""
    for name in [n for n in sys.modules if n == module or n.startswith(module + ".")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, module, None)


def one_line_error(capsys, args, expected: str) -> None:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    assert code == 2, (code, out, err)
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert expected in err, err


@pytest.mark.parametrize("verb, module, extra", [
    ("report", "plotly", "report"),
    ("optimize", "pymoo", "optimize"),
    ("sensitivity", "SALib", "sensitivity"),
    ("physics", "mujoco", "physics"),
])
def test_verb_without_its_extra_says_which_to_install(monkeypatch, capsys, tmp_path, verb, module, extra):
    missing(monkeypatch, module)
    # the check comes before anything is read: the argument need not even exist
    one_line_error(capsys, [verb, tmp_path / "absent.h5"],
                   f"explorer {verb} needs {EXTRAS[module][1]}: pip install 'explorer[{extra}]'")


def test_mp4_without_movie_extra(monkeypatch, capsys, tmp_path):
    missing(monkeypatch, "imageio_ffmpeg")
    out = tmp_path / "jansen.mp4"
    one_line_error(capsys, ["animate", "--mechanism", "jansen", "-o", out],
                   "needs imageio-ffmpeg: pip install 'explorer[movie]', or write a .gif")
    assert not out.exists()


def test_gif_needs_no_movie_extra(monkeypatch, tmp_path):
    from explorer.view import animate
    missing(monkeypatch, "imageio_ffmpeg")
    movie = animate("fourbar", tmp_path / "f.gif", cycles=0.1, frames=3, dpi=20, steps=24)
    assert movie.path.exists()


def test_dxf_without_cad_extra(monkeypatch, tmp_path):
    from explorer.mechanism import load_mechanism
    from explorer.testing import export_dxf, export_svg
    missing(monkeypatch, "ezdxf")
    mech = load_mechanism("jansen")
    with pytest.raises(MissingExtra, match=r"needs ezdxf: pip install 'explorer\[cad\]'"):
        export_dxf(mech, tmp_path / "j.dxf")
    assert not (tmp_path / "j.dxf").exists()
    assert export_svg(mech, tmp_path / "j.svg").exists()  # svg needs nothing more


def test_saltelli_sampling_without_sensitivity_extra(monkeypatch):
    from explorer.study import Sampler
    missing(monkeypatch, "SALib")
    with pytest.raises(MissingExtra, match=r"saltelli.* needs SALib: pip install 'explorer\[sensitivity\]'"):
        Sampler("saltelli", 8, 3, 0.01)
    assert Sampler("lhs", 8, 3, 0.01).rows().shape == (8, 3)  # other designs need nothing more


def test_library_calls_raise_an_import_error_naming_the_extra(monkeypatch, tmp_path):
    from explorer.analysis import sensitivity
    from explorer.optimize import run_optimize
    from explorer.view import write_report
    for module, call in [("plotly", lambda: write_report(tmp_path / "a.h5", tmp_path / "a.html")),
                         ("pymoo", lambda: run_optimize("default")),
                         ("SALib", lambda: sensitivity(tmp_path / "a.h5"))]:
        missing(monkeypatch, module)
        with pytest.raises(ImportError) as info:  # a Python caller may catch ImportError
            call()
        assert isinstance(info.value, UserError)
        assert f"pip install 'explorer[{EXTRAS[module][0]}]'" in str(info.value)


def test_require_names_a_broken_dependency_of_an_installed_extra(monkeypatch):
    def broken(name, *a, **k):
        raise ModuleNotFoundError("No module named 'narwhals'", name="narwhals")
    monkeypatch.setattr("importlib.import_module", broken)
    with pytest.raises(MissingExtra, match=r"explorer\[report\]' \(No module named 'narwhals'\)"):
        require("plotly", "explorer report")


def test_every_verb_loads_without_the_heavy_libraries():
    """Importing the package and building the CLI touches none of them (a subprocess: a clean import)."""
    code = f"""
import sys
for m in {sorted(EXTRAS) + ['dask', 'distributed']!r}:
    sys.modules[m] = None
import explorer, explorer.view, explorer.study, explorer.analysis, explorer.gait, explorer.store
from explorer.cli import build_parser
help = build_parser().format_help()
assert "unavailable" not in help, help
print("ok")
"""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stderr


def test_pyproject_extras_match_the_table():
    deps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    core = " ".join(deps["dependencies"]).lower()
    extras = deps["optional-dependencies"]
    for module, (extra, dist) in EXTRAS.items():
        assert dist.lower() not in core, f"{dist} is a core dependency"
        assert any(r.lower().startswith(dist.lower()) for r in extras[extra]), (extra, extras[extra])
    wanted = set(e for e, _ in EXTRAS.values()) | {"dask"}
    assert extras["all"] == [f"explorer[{','.join(sorted(wanted, key=list(extras).index))}]"]
    assert "explorer[all]" in extras["test"]  # the suite exercises every verb
