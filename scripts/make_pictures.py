#!/usr/bin/env python
"""Regenerate the docs' pictures (docs/*.png), so that they show what the code draws today.

    python scripts/make_pictures.py            # writes docs/foot_paths.png, pareto.png, report.png, accuracy.png,
                                               # watt6.png, stephenson6.png (--linkages-only: those two alone)
    python scripts/make_pictures.py --out /tmp/pictures --no-report

* ``docs/foot_paths.png`` — ``explorer plot RESULTS --top 5``: the five best foot paths over the nominal,
* ``docs/pareto.png`` — ``explorer plot RESULTS --scatter travel,bob``: the Pareto front,
* ``docs/report.png`` — ``explorer report RESULTS``, brushed to travel ≥ 138 model units per turn, as
  headless Chromium shows it (selenium; Debian: ``apt-get install chromium chromium-driver``),
* ``docs/accuracy.png`` — ``docs/accuracy.csv`` (written by ``explorer bench accuracy -o docs --force``, 52 s)
  drawn again by the same code (``explorer.bench.plot``), without re-running the benchmark.

RESULTS is a study written to a temporary folder: 2,000 variants of Jansen's leg, every link and the
crank within ±2 % (the default study at a fifth of its size), 360 steps. The whole script takes about a
minute; every picture is kept under 300 kB (PNG, the screenshot reduced to 256 colours).
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LIMIT = 300_000  # bytes per picture

STUDY = {
    "study": {"name": "jansen-2pct-2k", "mechanism": "jansen", "variants": 2000, "seed": 1, "steps": 360},
    "perturb": {"method": "uniform", "spread": 0.02, "links": "all", "crank": True},
    "scene": {"vertices": ["7"], "velocities": True, "metrics": True},
}
#: docs/accuracy.csv does not say where it ran: docs/accuracy.md does.
ACCURACY_META = {"mechanism": "jansen", "spread": 0.02, "threads": 2}


def _small_png(path: Path, width: int | None = None, colours: int | None = None) -> int:
    """Shrink ``path`` in place (optionally to ``width`` px and a ``colours`` palette); its size in bytes."""
    from PIL import Image
    with Image.open(path) as im:
        im = im.convert("RGB")
        if width is not None and im.width > width:
            im = im.resize((width, round(im.height * width / im.width)), Image.LANCZOS)
        if colours is not None:
            # octree keeps the rare saturated colours (the front, the nominal's star) that median cut merges away
            im = im.quantize(colors=colours, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
        im.save(path, optimize=True)
    return path.stat().st_size


def plots(results: Path, out: Path) -> list[Path]:
    from explorer.cli import main
    made = []
    for name, args in (("foot_paths.png", ["--top", "5"]), ("pareto.png", ["--scatter", "travel,bob"])):
        target = out / name
        if main(["plot", str(results), *args, "-o", str(target), "--dpi", "110", "--force"]) != 0:
            raise SystemExit(f"explorer plot {' '.join(args)} failed")
        if target.stat().st_size > LIMIT:
            _small_png(target, colours=256)
        made.append(target)
    return made


def _browser():
    """Headless Chromium through selenium, or the reason there is none."""
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        return None, "selenium is not installed (pip install selenium)"
    binary = next((shutil.which(b) for b in ("chromium", "chromium-browser", "google-chrome") if shutil.which(b)), None)
    driver = shutil.which("chromedriver")
    if binary is None or driver is None:
        return None, "no chromium / chromedriver on PATH (Debian: apt-get install chromium chromium-driver)"
    opts = webdriver.ChromeOptions()
    for a in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--enable-unsafe-swiftshader",
              "--window-size=1400,1000", "--hide-scrollbars"):
        opts.add_argument(a)
    opts.binary_location = binary
    return webdriver.Chrome(options=opts, service=Service(driver)), None


def report_screenshot(results: Path, out: Path, tmp: Path) -> Path | None:
    import os

    from explorer.view import write_report
    page = tmp / "report.html"
    here = Path.cwd()
    os.chdir(results.parent)  # the page names the results file as it was given: by its name only
    try:
        write_report(Path(results.name), page, force=True)
    finally:
        os.chdir(here)
    drv, why = _browser()
    if drv is None:
        print(f"report.png: skipped: {why}", file=sys.stderr)
        return None
    try:
        drv.set_script_timeout(300)
        drv.get(page.as_uri())
        t = time.monotonic()
        while drv.execute_script("return document.body.getAttribute('data-ready')") != "1":
            if time.monotonic() - t > 240:
                raise SystemExit("report.png: the page did not get ready in 4 minutes")
            time.sleep(0.2)
        # every design's line, and a brush: the designs that travel at least 138 model units per turn
        drv.execute_async_script("""
            var done = arguments[arguments.length - 1], R = window.explorerReport;
            var gd = document.getElementById('parcoords'), n = R.data.pc_lines;
            var sel = document.getElementById('pc-lines'); sel.value = String(n);
            var k = R.data.columns.find(function (c) { return c.key === 'travel'; }).dim;
            var u = {}; u['dimensions[' + k + '].constraintrange'] = [[138, 1e9]];
            R.setLines(n).then(function () { return Plotly.restyle(gd, u, [0]); })
             .then(function () { setTimeout(done, 500); });""")
        for _ in range(3):  # the whole page: the window as tall as the page (which may reflow once)
            height = int(drv.execute_script("return document.documentElement.scrollHeight"))
            drv.set_window_size(1400, height + 200)
            time.sleep(1.0)
        target = out / "report.png"
        drv.save_screenshot(str(target))
        from PIL import Image, ImageChops
        with Image.open(target) as im:
            im = im.convert("RGB")
            box = ImageChops.difference(im, Image.new("RGB", im.size, "white")).getbbox()  # trim the white below
            im.crop((0, 0, im.width, min(im.height, (box[3] if box else im.height) + 16))).save(target)
    finally:
        drv.quit()
    _small_png(target, width=1100, colours=256)
    return target


def accuracy(out: Path) -> Path | None:
    from explorer.bench import plot, read_csv
    csv_path = ROOT / "docs" / "accuracy.csv"
    if not csv_path.is_file():
        print("accuracy.png: skipped: no docs/accuracy.csv (explorer bench accuracy -o docs --force writes both)",
              file=sys.stderr)
        return None
    target = plot(read_csv(csv_path, ACCURACY_META), out / "accuracy.png")
    if target.stat().st_size > LIMIT:
        _small_png(target, colours=256)
    return target


def linkages(out: Path) -> list[Path]:
    """``docs/watt6.png`` and ``docs/stephenson6.png``: the two six-bar built-ins at θ = 0 over their foot
    paths, with the plots' own artists (the animation's leg, ground pivots and path), each joint named."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from explorer import load_mechanism, simulate
    from explorer.view._draw import LegArtists, draw_ground, draw_path
    made = []
    for name in ("watt6", "stephenson6"):
        mech = load_mechanism(name)
        cyc = simulate(mech, 360, velocities=True)
        fig, ax = plt.subplots(figsize=(5.6, 5.6), layout="constrained")
        draw_ground(ax, mech)
        foot = mech.vertex_index(mech.foot)
        draw_path(ax, cyc.positions[:, foot], label=f"foot {mech.foot}'s path over one turn")
        leg = LegArtists(ax, mech, arrow_scale=0.0, label="the linkage at θ = 0")
        leg.update(cyc.positions[0], cyc.velocities[0, foot])
        for v, (x, y) in zip(mech.vertices, cyc.positions[0]):
            ax.annotate(v, (x, y), textcoords="offset points", xytext=(5, 5), fontsize=10)
        c = mech.crank.center
        ax.annotate("A0", c, textcoords="offset points", xytext=(5, -12), fontsize=10)
        ax.set_aspect("equal")
        ax.set_xlabel("x [model units]")
        ax.set_ylabel("y [model units]")
        ax.set_title(f"{name}: {mech.description.split(':')[0]}", fontsize=10)
        ax.legend(loc="lower right", fontsize=8)
        path = out / f"{name}.png"
        fig.savefig(path, dpi=90)
        plt.close(fig)
        made.append(path)
    return made


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=ROOT / "docs", help="folder of the pictures (default: docs/)")
    ap.add_argument("--no-report", action="store_true", help="leave out the report screenshot (needs Chromium)")
    ap.add_argument("--linkages-only", action="store_true", help="only the six-bar built-ins' pictures (a few s)")
    args = ap.parse_args(argv)
    import explorer
    args.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    made = linkages(args.out)
    if args.linkages_only:
        for p in made:
            print(f"wrote {p} ({p.stat().st_size / 1e3:.0f} kB)")
        return 0
    with tempfile.TemporaryDirectory(prefix="explorer-pictures-") as d:
        tmp = Path(d)
        results = Path(explorer.run_study(STUDY, output=tmp / "jansen-2pct-2k.h5", progress=False).path)
        made += plots(results, args.out)
        if not args.no_report:
            made.append(report_screenshot(results, args.out, tmp))
    made.append(accuracy(args.out))
    for p in made:
        if p is not None:
            size = p.stat().st_size
            print(f"wrote {p} ({size / 1e3:.0f} kB)" + ("  OVER 300 kB" if size > LIMIT else ""))
    print(f"{time.perf_counter() - t0:.0f} s")
    return 0 if all(p is None or p.stat().st_size <= LIMIT for p in made) else 1


if __name__ == "__main__":
    sys.exit(main())
