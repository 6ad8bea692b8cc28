"""The load-case editor's fixtures: the real ``loadpath edit`` command and real headless Chromium.

Registered by the last line of ``tests/conftest.py``.

``editor(part, case)`` starts ``loadpath edit PART --loadcase CASE --no-browser --port 0`` as a child
process and returns its URL; ``browser`` is Debian's Chromium driven by chromedriver through
selenium.  A failing test leaves a screenshot of the page in its tmp folder (``failure.png``).
"""

from __future__ import annotations

import re
import subprocess
import sys
import time
from pathlib import Path

import conftest as root  # tests/conftest.py, which imports this module at its end
import pytest

LOADPATH = Path(sys.executable).with_name("loadpath")

__all__ = ["editor", "chromium", "browser"]


class Editor:
    """A running ``loadpath edit``."""

    def __init__(self, part: Path, case: Path, port: int = 0) -> None:
        self.part, self.case = Path(part), Path(case)
        self.proc = subprocess.Popen(
            [str(LOADPATH), "edit", str(part), "--loadcase", str(case), "--no-browser", "--port", str(port)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        line = self.proc.stdout.readline()
        m = re.search(r"editor at (http://127\.0\.0\.1:(\d+)/)", line)
        if not m:
            self.proc.kill()
            raise AssertionError(f"loadpath edit did not start: {line!r} {self.proc.stderr.read()}")
        self.url, self.port = m.group(1), int(m.group(2))
        self.banner = line

    def stop(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
        self.proc.stdout.close()
        self.proc.stderr.close()


@pytest.fixture
def editor():
    started: list[Editor] = []

    def start(part, case, port=0) -> Editor:
        e = Editor(part, case, port)
        started.append(e)
        return e

    yield start
    for e in started:
        e.stop()


def _require_browser():
    root.require_tool("chromium")
    root.require_tool("chromedriver")
    try:
        import selenium  # noqa: F401
    except ImportError:
        msg = "selenium is not installed: pip install -e '.[test]'"
        if root.IN_CI:
            pytest.fail(f"CI=true but {msg}")
        pytest.skip(msg)


@pytest.fixture(scope="session")
def chromium():
    _require_browser()
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    opts = Options()
    opts.binary_location = "/usr/bin/chromium"
    for a in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        "--window-size=1280,800",
        "--no-first-run",
        "--disable-extensions",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
    ):
        opts.add_argument(a)
    drv = webdriver.Chrome(options=opts, service=Service("/usr/bin/chromedriver"))
    drv.set_script_timeout(30)
    yield drv
    drv.quit()


@pytest.fixture
def browser(chromium, request, tmp_path):
    """Chromium with a 1280 x 800 viewport; screenshot to tmp_path/failure.png when the test fails."""
    set_viewport(chromium, 1280, 800)
    failed_before = request.session.testsfailed
    yield chromium
    if request.session.testsfailed > failed_before:  # this test's call failed (reported before teardown)
        chromium.save_screenshot(str(tmp_path / "failure.png"))
        print(f"screenshot of the page: {tmp_path / 'failure.png'}")
    chromium.get("about:blank")


def set_viewport(drv, width: int, height: int) -> None:
    drv.execute_cdp_cmd(
        "Emulation.setDeviceMetricsOverride",
        {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False},
    )


def wait_for(drv, script: str, timeout: float = 30.0, what: str = ""):
    """Poll a JS expression until it is truthy; its value."""
    t = time.monotonic() + timeout
    while True:
        v = drv.execute_script("return " + script)
        if v:
            return v
        if time.monotonic() > t:
            raise AssertionError(f"timed out after {timeout:g} s waiting for {what or script}")
        time.sleep(0.1)
