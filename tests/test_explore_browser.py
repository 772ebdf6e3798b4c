"""``labcut explore`` in a real browser (Debian's chromium through playwright, tests/browser.py):
the page a user opens, driven through its data-testid hooks as a user would drive it.

The page's content policy forbids evaluating strings as script, so the waits poll the page's
text and attributes from here instead of with ``wait_for_function``."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from browser import launch, needs_chromium, open_page

OVAL = "meshes/oval-16x12-low.ply"
ROOT = Path(__file__).resolve().parents[1]


def until(probe, timeout: float = 60.0, what: str = "the page"):
    """Poll ``probe()`` until it returns something true (returned), or fail after ``timeout`` s."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        value = probe()
        if value:
            return value
        time.sleep(0.03)
    raise AssertionError(f"timed out waiting for {what}")


def start_explore(*args: str) -> tuple[subprocess.Popen, str]:
    exe = Path(sys.executable).with_name("labcut")
    env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1"}
    proc = subprocess.Popen([str(exe), "explore", *args, "--no-browser"], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)
    line = proc.stdout.readline()
    found = re.search(r"(http://127\.0\.0\.1:\d+/)", line)
    if not found:
        proc.kill()
        raise AssertionError(f"labcut explore did not start: {line!r} {proc.stderr.read()!r}")
    return proc, found.group(1)


def enter(page, testid: str, value: str) -> None:
    page.fill(f"[data-testid={testid}]", value)
    page.press(f"[data-testid={testid}]", "Enter")


@needs_chromium
def test_explore_in_the_browser(cli):
    from playwright.sync_api import sync_playwright

    proc, url = start_explore(OVAL, "--quality", "draft")
    try:
        with sync_playwright() as p:
            browser = launch(p)
            opened = open_page(browser, url, 1500, 1000)
            page = opened.page
            text = lambda testid: page.text_content(f"[data-testid={testid}]")  # noqa: E731
            until(lambda: text("energy-out"), what="the first answer")
            map_src = page.get_attribute("#map-img", "src")
            energy = text("energy-out")
            assert map_src.startswith("data:image/png;base64,")
            until(lambda: page.get_attribute("[data-testid=render]", "src"), what="the first picture")

            # the lamp moves: the score map and the energy follow
            enter(page, "lamp-elevation", "50")
            until(lambda: text("energy-out") != energy and page.get_attribute("#map-img", "src") != map_src,
                  what="the answer under the lower lamp")
            assert "50° above the horizon" in text("subject")
            # the recommendation's estimator follows the picture (the plan the answer did not wait for)
            until(lambda: text("timings").endswith("recommend: samples"), 120, "the planned estimator")

            # a value the control cannot take is refused on the page, beside the control
            shown = text("energy-out")
            enter(page, "lamp-elevation", "95")
            assert "outside 0-90" in until(lambda: page.text_content("[data-error-for=lamp_elevation]"))
            assert page.get_attribute("[data-testid=lamp-elevation]", "aria-invalid") == "true"
            enter(page, "normal-tilt", "-5")
            assert "outside 0-90" in until(lambda: page.text_content("[data-error-for=normal_tilt]"))
            time.sleep(0.5)
            assert text("energy-out") == shown  # nothing sent: the answer shown stays

            # the lamp back overhead, then "recommend here": the command line's answer
            enter(page, "lamp-elevation", "90")
            until(lambda: "90° above the horizon" in text("subject"), what="the overhead lamp")
            page.click("[data-testid=recommend]")
            until(lambda: page.query_selector("#recommendation p"), 120, "the recommendation")
            tilt = float(page.get_attribute("[data-testid=tilt-out]", "data-value"))
            ref = cli("recommend-orientation", OVAL, "--scenario", "bench", "--quality", "draft", "--json", "-")
            assert ref.returncode == 0, ref.stderr
            assert tilt == pytest.approx(json.loads(ref.stdout)["tilt_deg"], abs=0.5)

            # a click on the score map sets the normal there (the page's projection is the map's)
            box = page.locator("#map-marks").bounding_box()
            page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] * (0.5 - 0.5 * 30 / 90))
            until(lambda: abs(float(page.get_attribute("[data-testid=tilt-out]", "data-value")) - 30) < 1.0,
                  what="the normal the click set")
            assert float(page.get_attribute("[data-testid=azimuth-out]", "data-value")) == pytest.approx(90, abs=2)

            # the refined picture arrives, as big as it says
            until(lambda: page.get_attribute("[data-testid=render]", "data-done"), 120, "the refined picture")
            size = page.evaluate("[document.getElementById('render').naturalWidth, document.getElementById('render').naturalHeight]")
            assert size == [384, 384]
            browser.close()
        assert opened.errors == []
        assert all(r.startswith(url) or r.startswith("data:") for r in opened.requests), opened.requests
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            code = proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            raise
    out = proc.stdout.read()
    assert code == 0 and "stopped" in out, (code, out, proc.stderr.read())
