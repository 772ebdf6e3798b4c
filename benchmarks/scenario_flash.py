"""Flash figures of the bundled stones under every scenario at their recommended orientation, by the
scene's own threshold (τ P, docs/orientation.md "What counts as flash") and by the old one (τ, against a
face-on lamp of the same irradiance), with a poor orientation beside the best (issue 39).

    .venv/bin/python benchmarks/scenario_flash.py [--quality standard] [--out docs/data.md]

Prints a Markdown table; the numbers in docs/scenarios.md come from it.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

import labcut

ROOT = Path(__file__).resolve().parents[1]
STONES = ["oval-16x12-low.ply", "oval-16x12-high.ply", "carving-biplane.ply"]


def area_at(problem, normal: np.ndarray, threshold: float) -> float:
    """The view-weighted flash area of ``normal`` with the given threshold (units of L_ref)."""
    radiance = problem.pair_radiance(np.asarray(normal, dtype=np.float64)[None])[:, 0]
    return float((problem.pair_alpha * (radiance >= threshold)).sum())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quality", default="standard")
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    rows = ["| stone | scenario | P | best tilt | flash area (τ P) | flash area (old: τ) | area 40° off (τ P) | seconds |",
            "|---|---|---|---|---|---|---|---|"]
    for stone in STONES:
        mesh = labcut.load_mesh(ROOT / "meshes" / stone)
        for name in labcut.scene.SCENARIOS.names():
            t0 = time.perf_counter()
            study = labcut.Study(mesh, "blue", name, args.quality, estimator="samples")
            rec = study.recommend()
            seconds = time.perf_counter() - t0
            p = study.scorer.problem
            off = labcut.scene.directions.direction(min(rec.tilt_deg + 40.0, 85.0), rec.azimuth_deg)
            rows.append(f"| {stone} | {name} | {p.threshold / p.tau:.3f} | {rec.tilt_deg:.1f}° | "
                        f"{rec.metrics.flash_area:.1%} | {area_at(p, rec.normal, p.tau):.1%} | "
                        f"{area_at(p, off, p.threshold):.1%} | {seconds:.1f} |")
            print(rows[-1], flush=True)
    text = "\n".join(rows) + "\n"
    if args.out is not None:
        args.out.write_text(text)
    print()
    print(text)


if __name__ == "__main__":
    main()
