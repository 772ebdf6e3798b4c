"""The comparison report in a real browser: headless Chromium (Debian's ``chromium``, installed by
``make setup`` when missing: tools/ensure-chromium.sh) driven by playwright.

Checks that every image decoded, that there were no console messages of type error and no page
errors, that the page asked for nothing but its own file, that it fits a phone's width and that
it prints; saves screenshots (desktop, phone) and the PDF next to the report. Skipped only when
chromium is not installed (and cannot be: no root, no network).
"""

from __future__ import annotations

from pathlib import Path

import pytest

import labcut
from browser import launch, needs_chromium, open_page

pytestmark = needs_chromium


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """A small report: two cuts (a spec and a mesh file) under two scenarios, tiny renders."""
    out = tmp_path_factory.mktemp("report")
    mesh = Path(__file__).resolve().parents[1] / "meshes" / "oval-16x12-high.ply"
    cmp = labcut.compare_cuts(["cab:oval,16x12,low,res=64", str(mesh)], scenarios=["bench", "display"], quality="draft",
                              resolution=32, spp=2)
    return cmp.save_html(out / "report.html"), cmp


def test_report_opens_cleanly_in_chromium(report):
    from playwright.sync_api import sync_playwright

    path, cmp = report
    url = path.resolve().as_uri()
    with sync_playwright() as p:
        browser = launch(p)
        try:
            opened = open_page(browser, url)
            page, errors, requests, images = opened.page, opened.errors, opened.requests, opened.images
            page.screenshot(path=str(path.with_name("report-desktop.png")), full_page=True)

            assert errors == []
            assert requests == [url], f"the page fetched more than its own file: {requests}"
            n_cuts, n_scen = len(cmp.cuts), len(cmp.scenarios)
            assert len(images) == n_scen * (2 * n_cuts + 4) + 1
            bad = [i["alt"] for i in images if not (i["ok"] and i["w"] > 0 and i["h"] > 0)]
            assert bad == [], f"images that did not decode: {bad}"
            assert page.title().startswith("Cut comparison: 2 cuts × 2 scenarios")
            assert page.locator("h2").first.inner_text() == "Ranked summary"

            # a phone: the page itself never scrolls sideways (wide tables scroll in their own box)
            phone = browser.new_page(viewport={"width": 390, "height": 844}, device_scale_factor=2, is_mobile=True)
            phone.goto(url, wait_until="load")
            width = phone.evaluate("document.documentElement.scrollWidth")
            assert width <= 390 + 1, f"the page is {width} px wide on a 390 px phone"
            widest = phone.evaluate("Math.max(...Array.from(document.images).map(i => i.getBoundingClientRect().right))")
            assert widest <= 390 + 1
            phone.screenshot(path=str(path.with_name("report-phone.png")), full_page=False)

            # print: A4 pages, the navigation hidden
            page.emulate_media(media="print")
            assert page.evaluate("getComputedStyle(document.querySelector('nav')).display") == "none"
            pdf = page.pdf(format="A4", print_background=True)
            assert pdf[:5] == b"%PDF-" and pdf.count(b"/Type /Page") - pdf.count(b"/Type /Pages") >= 2 + n_scen
            path.with_name("report.pdf").write_bytes(pdf)
        finally:
            browser.close()
    for name in ("report-desktop.png", "report-phone.png"):
        assert path.with_name(name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
