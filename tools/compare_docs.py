"""Make the pictures of docs/compare.md: a comparison of four cabochons (two sizes x two dome
heights, a heat map's worth) under the bench and pendant scenarios, its report, screenshots of the
report in headless Chromium (desktop and phone), and each figure on its own.

    .venv/bin/python tools/compare_docs.py [--out docs/images] [--quality standard]

Needs Debian's chromium (make setup installs it) for the screenshots.
"""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

CUTS = ["cab:oval,16x12,2.4", "cab:oval,16x12,4", "cab:oval,14x10,2.4", "cab:oval,14x10,4"]
SCENARIOS = ["bench", "pendant"]
CHROMIUM = os.environ.get("LABCUT_CHROMIUM", "/usr/bin/chromium")


def screenshots(report: Path, out: Path) -> None:
    """compare-report.png (the top of the page, desktop) and compare-phone.png (a phone's first screen)."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox", "--headless", "--disable-gpu"])
        page = browser.new_page(viewport={"width": 1180, "height": 1500})
        page.goto(report.resolve().as_uri(), wait_until="load")
        page.screenshot(path=str(out / "compare-report.png"))
        phone = browser.new_page(viewport={"width": 390, "height": 844}, device_scale_factor=2, is_mobile=True)
        phone.goto(report.resolve().as_uri() + "#scenario-1", wait_until="load")
        phone.screenshot(path=str(out / "compare-phone.png"))
        browser.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/images")
    parser.add_argument("--quality", default="standard")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    import numpy as np

    import labcut
    from labcut.reports import figures as fg

    cmp = labcut.compare_cuts(CUTS, "blue", SCENARIOS, quality=args.quality)
    with tempfile.TemporaryDirectory() as tmp:
        report = cmp.save_html(Path(tmp) / "compare.html")
        screenshots(report, out)
    s = "bench"
    exposure = cmp.exposures[s]
    from labcut.rendering.images import tonemap

    gap = np.ones((cmp.render["resolution"], fg.GAP_PX, 3))
    row = []
    for c in cmp.cuts:
        row += [tonemap(c.scenarios[s].renders.main, exposure), gap]
    pictures = {
        "compare-renders.png": fg.image_png(np.concatenate(row[:-1], axis=1)),
        "compare-strip.png": fg.strip_png(cmp.cuts[0].scenarios[s].renders.strip, exposure),
        "compare-score-maps.png": fg.score_maps(cmp, s),
        "compare-tilt.png": fg.tilt_curves(cmp, s),
        "compare-misorientation.png": fg.misorientation_curves(cmp, s),
        "compare-colour.png": fg.colour_maps(cmp, "pendant"),
        "compare-design.png": fg.design_chart(cmp),
    }
    for name, data in pictures.items():
        (out / name).write_bytes(data)
    for c in cmp.ranked():
        print(c.rank, c.name, f"{c.overall_score:.2f}", c.compromise_description,
              {n: (r.rank, f"{r.energy:.4f}", f"±{r.recommendation.tolerance_deg:.1f}°") for n, r in c.scenarios.items()})
    print(f"{cmp.seconds:.1f} s; pictures in {out}/")


if __name__ == "__main__":
    main()
