"""Take a screenshot of the load-case editor with headless Chromium (the README's picture).

Usage::

    .venv/bin/python scripts/editor_screenshot.py PART CASE.toml OUT.png [--size 1600x1000] [--no-solve]

Starts the real ``loadpath edit PART --loadcase CASE.toml --no-browser``, opens it in Debian's
Chromium (chromium + chromium-driver, selenium from the test extras), presses Solve unless
``--no-solve``, and saves the page.  The README's picture: the bracket of ``tests/slicing.py``
sliced by PrusaSlicer 2.5 (``PRUSA_MIXED``) with ``examples/bracket.toml``-style case (fixed top
edge, 500 N on the bolt hole, sparse infill replaced).
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import time
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("part")
    ap.add_argument("case")
    ap.add_argument("out")
    ap.add_argument("--size", default="1600x1000")
    ap.add_argument("--no-solve", action="store_true")
    a = ap.parse_args(argv)
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By

    w, h = (int(v) for v in a.size.split("x"))
    exe = Path(sys.executable).with_name("loadpath")
    proc = subprocess.Popen(
        [str(exe), "edit", a.part, "--loadcase", a.case, "--no-browser"], stdout=subprocess.PIPE, text=True
    )
    try:
        m = re.search(r"editor at (\S+)", proc.stdout.readline())
        if not m:
            print("editor_screenshot: loadpath edit did not start", file=sys.stderr)
            return 1
        opts = Options()
        opts.binary_location = "/usr/bin/chromium"
        for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--hide-scrollbars"):
            opts.add_argument(arg)
        drv = webdriver.Chrome(options=opts, service=Service("/usr/bin/chromedriver"))
        try:
            drv.execute_cdp_cmd(
                "Emulation.setDeviceMetricsOverride",
                {"width": w, "height": h, "deviceScaleFactor": 1, "mobile": False},
            )
            drv.get(m.group(1))
            _wait(drv, "document.body.dataset.ready === '1' && document.body.dataset.resolved === '1'", 60)
            if not a.no_solve:
                drv.find_element(By.ID, "solve").click()
                _wait(drv, "document.body.dataset.solved === '1'", 900)
                drv.execute_script("document.getElementById('results').scrollIntoView(false)")
            drv.save_screenshot(a.out)
        finally:
            drv.quit()
    finally:
        proc.terminate()
        proc.wait(10)
    print(f"editor_screenshot: wrote {a.out} ({w} x {h})")
    return 0


def _wait(drv, script: str, timeout: float) -> None:
    t = time.monotonic() + timeout
    while not drv.execute_script("return " + script):
        if time.monotonic() > t:
            raise SystemExit(f"editor_screenshot: timed out waiting for {script}")
        time.sleep(0.2)


if __name__ == "__main__":
    sys.exit(main())
