"""The rough plan's report in a real browser (Debian's chromium via playwright, as the comparison
report's test): every image decodes (the views, the front, each stone's render), no console or
page errors, nothing fetched but the page itself, no sideways scroll on a phone, and it prints."""

from __future__ import annotations


import pytest

import labcut
from browser import launch, needs_chromium, open_page

pytestmark = needs_chromium


def test_rough_report_opens_cleanly_in_chromium(tmp_path):
    from playwright.sync_api import sync_playwright

    plan = labcut.plan_rough("slab:40x30x6", [0.0, 0.2, 1.0], cuts=["cab:oval,16x12,low", "cab:round,10,medium"],
                             count=2, quality="draft")
    path = plan.save_html(tmp_path / "rough.html")
    url = path.resolve().as_uri()
    with sync_playwright() as p:
        browser = launch(p)
        try:
            opened = open_page(browser, url)
            page, errors, requests, images = opened.page, opened.errors, opened.requests, opened.images
            assert errors == []
            assert requests == [url], f"the page fetched more than its own file: {requests}"
            assert len(images) == 2 + len(plan.stones)
            bad = [i["alt"] for i in images if not (i["ok"] and i["w"] > 0 and i["h"] > 0)]
            assert bad == [], f"images that did not decode: {bad}"
            assert page.locator("h3").count() == len(plan.stones)
            assert page.locator("ol li").count() == sum(len(s.workshop) for s in plan.stones)
            phone = browser.new_page(viewport={"width": 390, "height": 844}, device_scale_factor=2, is_mobile=True)
            phone.goto(url, wait_until="load")
            assert phone.evaluate("document.documentElement.scrollWidth") <= 390 + 1
            page.emulate_media(media="print")
            assert page.pdf(format="A4", print_background=True)[:5] == b"%PDF-"
        finally:
            browser.close()
