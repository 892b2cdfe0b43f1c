"""Headless Chromium for the tests that look at a page (Debian's ``chromium`` and ``chromedriver``, driven by
selenium, the test extra). :func:`chromium` skips the test, naming the install command, only where no
browser or driver is found."""

from __future__ import annotations

import shutil
import time

import pytest

INSTALL = "apt-get install chromium chromium-driver (Debian; as root), then pip install selenium (the test extra)"
#: Chromium's switches: headless, no sandbox (root in a container), no GPU, nothing fetched from the network
ARGS = ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--disable-background-networking",
        "--disable-extensions", "--disable-sync", "--no-first-run", "--enable-unsafe-swiftshader")


def chromium(window: str = "1400,1600"):
    """A selenium Chrome driver on headless Chromium with the browser's console log kept (``get_log``)."""
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        pytest.skip(f"selenium is not installed: {INSTALL}")
    binary = next((shutil.which(b) for b in ("chromium", "chromium-browser", "google-chrome", "chrome")
                   if shutil.which(b)), None)
    driver_exe = shutil.which("chromedriver")
    if binary is None or driver_exe is None:
        pytest.skip(f"no headless browser found ({'chromium' if binary is None else 'chromedriver'} is not on "
                    f"PATH): {INSTALL}")
    opts = webdriver.ChromeOptions()
    for a in (*ARGS, f"--window-size={window}"):
        opts.add_argument(a)
    opts.binary_location = binary
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    drv = webdriver.Chrome(options=opts, service=Service(driver_exe))  # explicit paths: no network look-up
    drv.set_script_timeout(120)
    return drv


def wait(drv, script, want=True, timeout=60.0):
    """Run ``script`` until it returns ``want`` (or ``timeout`` seconds pass); returns its last value."""
    t = time.monotonic()
    while True:
        got = drv.execute_script(script)
        if got == want or time.monotonic() - t > timeout:
            return got
        time.sleep(0.02)


def severe(drv) -> list:
    """The browser console's SEVERE messages since the last call."""
    return [e for e in drv.get_log("browser") if e["level"] == "SEVERE"]
