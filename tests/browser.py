"""Opening a report in headless Chromium (Debian's ``chromium``, installed by ``make setup`` when
missing: tools/ensure-chromium.sh) through playwright, for the reports' browser tests: the page,
its console and page errors, every URL it asked for, and its images as the browser decoded them."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

CHROMIUM = os.environ.get("LABCUT_CHROMIUM", "/usr/bin/chromium")
ARGS = ["--no-sandbox", "--headless", "--disable-gpu", "--no-first-run", "--disable-background-networking",
        "--disable-component-update", "--disable-sync"]
#: the browser tests' marker: skipped only where chromium is not installed (and cannot be)
needs_chromium = pytest.mark.skipif(
    not Path(CHROMIUM).exists(),
    reason=f"chromium is not installed at {CHROMIUM} (make setup installs Debian's chromium as root: tools/ensure-chromium.sh)",
)


def launch(p: Any) -> Any:
    """Debian's chromium, headless, under playwright ``p``."""
    return p.chromium.launch(executable_path=CHROMIUM, args=ARGS)


@dataclass
class Opened:
    """A page opened at a URL: the page, the errors it logged, the URLs it requested, its images."""

    page: Any
    errors: list[str] = field(default_factory=list)
    requests: list[str] = field(default_factory=list)
    images: list[dict[str, Any]] = field(default_factory=list)


def open_page(browser: Any, url: str, width: int = 1200, height: int = 900) -> Opened:
    """Open ``url`` in a new page of ``width`` x ``height`` px, recording console errors, page
    errors and requests; the images as decoded (natural size, complete, alt text)."""
    page = browser.new_page(viewport={"width": width, "height": height})
    out = Opened(page)
    page.on("console", lambda m: out.errors.append(f"console {m.type}: {m.text}") if m.type == "error" else None)
    page.on("pageerror", lambda e: out.errors.append(f"page error: {e}"))
    page.on("request", lambda r: out.requests.append(r.url))
    page.goto(url, wait_until="load")
    out.images = page.evaluate(
        "Array.from(document.images).map(i => ({w: i.naturalWidth, h: i.naturalHeight, ok: i.complete, alt: i.alt}))")
    return out
