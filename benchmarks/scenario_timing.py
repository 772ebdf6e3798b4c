"""Seconds of a warm recommendation per bundled stone and scenario (issue 39: carvings under map-lit
scenarios), with the estimator the planner chose and the answer's error bar.

    .venv/bin/python benchmarks/scenario_timing.py [--quality standard] [--scenarios ring,outdoor]

Each case runs once to warm (kernels, the planner's pilots and calibrations), then once timed.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import labcut

ROOT = Path(__file__).resolve().parents[1]
STONES = ("oval-16x12-low.ply", "carving-biplane.ply")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quality", default="standard")
    parser.add_argument("--scenarios", default="ring,pendant,brooch,outdoor")
    args = parser.parse_args()
    rows = ["| stone | scenario | estimator | seconds | tilt | error bar |", "|---|---|---|---|---|---|"]
    for stone in STONES:
        mesh = labcut.load_mesh(ROOT / "meshes" / stone)
        for name in args.scenarios.split(","):
            labcut.recommend_orientation(mesh, "blue", scenario=name, quality=args.quality)
            t = time.perf_counter()
            rec = labcut.recommend_orientation(mesh, "blue", scenario=name, quality=args.quality)
            seconds = time.perf_counter() - t
            bar = rec.uncertainty.angle_deg if rec.uncertainty is not None else float("nan")
            rows.append(f"| {stone} | {name} | {rec.estimator} | {seconds:.2f} s | {rec.tilt_deg:.1f}° | ±{bar:.1f}° |")
            print(rows[-1], flush=True)
    print("\n".join(rows))


if __name__ == "__main__":
    main()
