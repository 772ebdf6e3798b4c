"""How far the best orientation moves across plausible variants of each scenario (issue 39).

    .venv/bin/python benchmarks/scenario_variants.py [--quality standard] [--variants 6]
        [--stones oval,biplane,srb] [--scenarios bench,ring,...] [--out docs/orientation.md]

For each bundled stone and scenario: ``labcut.recommend_orientation(..., variants=N)``
(labcut/scene/variants.py draws the variants, labcut/orientation/robustness.py answers them) and a
row of its tilt and error bar, tolerance, the largest and median move of the best normal across
the variants, the least share of a variant's best the recommended cut keeps, the verdict and the
seconds the variants took. The table goes between the ``SCENARIO-VARIANTS`` markers of ``--out``
(``-``: printed only).
"""

from __future__ import annotations

import argparse
import sys
import os
import platform
import time
from pathlib import Path

import labcut

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scenario_coverage import ROOT, STONES, load, splice  # noqa: E402  (this folder's stones and splice)

BEGIN, END = "<!-- SCENARIO-VARIANTS:BEGIN -->", "<!-- SCENARIO-VARIANTS:END -->"


def main() -> None:
    from labcut.scene import SCENARIOS

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quality", default="standard")
    parser.add_argument("--variants", type=int, default=6)
    parser.add_argument("--stones", default=",".join(STONES))
    parser.add_argument("--scenarios", default=",".join(SCENARIOS.names()))
    parser.add_argument("--out", default=str(ROOT / "docs" / "orientation.md"))
    args = parser.parse_args()
    t0 = time.perf_counter()
    rows = ["| stone | scenario | estimator | tilt ± bar | tolerance | moves (largest / median) | keeps at least | verdict | variants' seconds |",
            "|---|---|---|---|---|---|---|---|---|"]
    verdicts: dict[str, int] = {}
    for stone in args.stones.split(","):
        label = STONES[stone][0]
        mesh = load(stone)
        for name in args.scenarios.split(","):
            rec = labcut.recommend_orientation(mesh, "blue", scenario=name, quality=args.quality, variants=args.variants)
            r = rec.robustness
            verdicts[r.verdict] = verdicts.get(r.verdict, 0) + 1
            rows.append(f"| {label} | {name} | {rec.estimator} | {rec.tilt_deg:.1f}° ± {rec.uncertainty.angle_deg:.1f}° | "
                        f"±{rec.tolerance_deg:.1f}° | {r.spread_deg:.1f}° / {r.median_deg:.1f}° | {r.keeps_min:.0%} | "
                        f"{r.verdict} | {r.seconds:.1f} s |")
            print(rows[-1], flush=True)
    minutes = (time.perf_counter() - t0) / 60
    cmd = "benchmarks/scenario_variants.py" + (f" --quality {args.quality}" if args.quality != "standard" else "")
    block = "\n".join([
        BEGIN, "",
        f"Made by `.venv/bin/python {cmd}` ({args.variants} variants each, {args.quality} quality; "
        f"{os.cpu_count()} cores, {platform.machine()}, {minutes:.1f} min in all):", "", *rows, "",
        "Verdicts: " + ", ".join(f"{k} {v}" for k, v in sorted(verdicts.items())) + ".", "", END])
    print(block)
    if args.out != "-":
        splice(Path(args.out), block, BEGIN, END, anchor=None)


if __name__ == "__main__":
    main()
