"""One side of an A/B timing of the standard recommendation, run once per checkout and alternated.

    .venv/bin/python benchmarks/recommend_ab.py LABEL [--calls N]

The bundled oval cabochon under ``bench`` at standard quality, the blue preset: three warm-up
calls, then ``N`` timed calls (default 21) in this process; prints the best and the median. To
compare two checkouts on one machine, run it alternately in each (the older one from a git
worktree with ``PYTHONPATH=WORKTREE:WORKTREE/cli``), three times each, as docs/performance.md
("Issue 31: the redesign's cost in time") records.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("label")
    parser.add_argument("--calls", type=int, default=21)
    args = parser.parse_args()
    import labcut

    mesh = labcut.load_mesh(ROOT / "meshes" / "oval-16x12-low.ply")
    lab = labcut.Labradorite.preset("blue")

    def call() -> float:
        t = time.perf_counter()
        labcut.recommend_orientation(mesh, lab, scenario="bench", quality="standard")
        return time.perf_counter() - t

    for _ in range(3):
        call()
    seconds = [call() for _ in range(args.calls)]
    print(f"{args.label} best {min(seconds):.4f} median {statistics.median(seconds):.4f}")


if __name__ == "__main__":
    main()
