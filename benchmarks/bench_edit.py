"""How fast ``explorer edit`` redraws a drag step, measured in headless Chromium (issue 42's target: 95 % of
drag steps redrawn within 50 ms, Jansen at 360 steps with the walker metrics, compile time excluded).

    python benchmarks/bench_edit.py [--mechanism jansen] [--steps 360] [--moves 200] [--joint 4]

It starts the editor's server in this process (the kernels warmed first: that time is printed, and is
the compile or cache load a first ``explorer edit`` pays before the page opens), loads the page in
headless Chromium (the time to the page's first drawing is printed), then drags one joint along a small
circle, one pointer move at a time: each move is a real pointer event from the browser's input pipeline
(selenium's W3C actions), and the page records, for that move, the time from the pointer event to the
animation frame after the redraw (``window.editTimings``: the request, the server's own time, the
redraw). Printed: p50, p95 and max of that latency, the server's part, and the machine's load
(``os.getloadavg``) before and after. Steps coalesce in the page (a move that arrives while a request is
in flight waits for it, and only the latest is sent); here every move waits for the previous redraw, so
each step is measured whole.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mechanism", default="jansen")
    ap.add_argument("--steps", type=int, default=360)
    ap.add_argument("--moves", type=int, default=200)
    ap.add_argument("--joint", default="4")
    ap.add_argument("--radius", type=float, default=12.0, help="radius of the circle dragged along, CSS px")
    a = ap.parse_args(argv)

    from browser import chromium, severe, wait
    from selenium.webdriver.common.action_chains import ActionChains

    from explorer.edit import EditSession, Server

    load0 = os.getloadavg()
    t = time.perf_counter()
    session = EditSession(a.mechanism, steps=a.steps)
    warm = session.warm()
    print(f"kernels warmed (compile or cache load, excluded below): {warm:.2f} s; session built in "
          f"{time.perf_counter() - t:.2f} s")
    srv = Server(session, port=0).start()
    drv = chromium("1400,1000")
    try:
        t = time.perf_counter()
        drv.get(srv.url)
        wait(drv, "return document.body.getAttribute('data-ready')", "1")
        wall = time.perf_counter() - t
        ready = drv.execute_script("return window.editReadyAt")
        print(f"first load of the page: {ready:.0f} ms from navigation to the first drawing ({wall:.2f} s as selenium "
              f"sees it)")
        handle = drv.find_element("css selector", f'[data-joint="{a.joint}"]')
        chain = ActionChains(drv, duration=0)
        chain.click_and_hold(handle).perform()
        prev = (0.0, 0.0)
        for i in range(a.moves):
            n = drv.execute_script("return window.editTimings.length")
            ang = 2 * math.pi * (i + 1) / 50
            pos = (a.radius * math.sin(ang), a.radius * (1 - math.cos(ang)))
            dx, dy = round(pos[0] - prev[0]), round(pos[1] - prev[1])
            prev = (prev[0] + dx, prev[1] + dy)
            ActionChains(drv, duration=0).move_by_offset(dx or 1, dy).perform()
            if not dx:
                prev = (prev[0] + 1, prev[1])
            wait(drv, f"return window.editTimings.length > {n} && !window.editState.inflight", timeout=30)
        ActionChains(drv, duration=0).release().perform()
        tm = drv.execute_script("return window.editTimings")
        bad = severe(drv)
    finally:
        drv.quit()
        srv.stop()
    load1 = os.getloadavg()
    ms = np.array([x["ms"] for x in tm])
    server = np.array([x["server"] for x in tm if x.get("server") is not None])
    net = np.array([x["received"] - x["sent"] for x in tm])
    draw = np.array([x["painted"] - x["received"] for x in tm])
    print(f"{a.mechanism}, {a.steps} steps, walker metrics: {len(ms)} drag steps of joint {a.joint}")
    print(f"  pointer event -> redrawn frame: p50 {np.percentile(ms, 50):.1f} ms, p95 {np.percentile(ms, 95):.1f} ms, "
          f"max {ms.max():.1f} ms ({(ms <= 50).mean():.1%} within 50 ms)")
    print(f"  of which the request (server and HTTP): p50 {np.percentile(net, 50):.1f} ms, p95 {np.percentile(net, 95):.1f} "
          f"ms; the server's own solve, metrics and drag: p50 {np.percentile(server, 50):.1f} ms, p95 "
          f"{np.percentile(server, 95):.1f} ms; decode and redraw to the next frame: p50 {np.percentile(draw, 50):.1f} "
          f"ms, p95 {np.percentile(draw, 95):.1f} ms")
    print(f"  load average (1, 5, 15 min): before {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f}, after {load1[0]:.2f} "
          f"{load1[1]:.2f} {load1[2]:.2f} on {os.cpu_count()} cores")
    if bad:
        print(f"  browser console errors: {bad}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
