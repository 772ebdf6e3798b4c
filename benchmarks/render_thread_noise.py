"""How far the render estimator's answer moves between runs, by Dr.Jit thread count: the golden
answers' render case (``tools/record_answers.py``: the carving under ``ring-diffuse`` at draft)
recommended ``--runs`` times on each of ``--threads``, each answer's angle (degrees) and score
(relative) against the recorded one. Its film and gradients add in thread order; on one thread
the answer is the same run after run, which is where ``tests/test_golden_answers.py`` checks it.

    .venv/bin/python benchmarks/render_thread_noise.py [--threads 1 2 4 8] [--runs 3]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))

import record_answers  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2, 4, 8])
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    import drjit as dr

    import labcut

    stone, scenario, quality = record_answers.RENDER_CASE
    want = json.loads((ROOT / "tests" / "data" / "answers_golden.json").read_text())["render|" + "|".join(record_answers.RENDER_CASE)]
    b = np.array([float.fromhex(x) for x in want["normal"]])
    mesh = labcut.load_mesh(ROOT / "meshes" / stone)
    print("| threads | angle from the record (°), each run | score / recorded - 1, each run |")
    print("|---|---|---|")
    before = dr.thread_count()
    try:
        for n in args.threads:
            dr.set_thread_count(n)
            angles, scores = [], []
            for _ in range(args.runs):
                got = record_answers.answer(mesh, scenario, quality, estimator="render")
                a = np.array([float.fromhex(x) for x in got["normal"]])
                angles.append(math.degrees(math.acos(min(1.0, abs(float(a @ b))))))
                scores.append(float.fromhex(got["score"]) / float.fromhex(want["score"]) - 1.0)
            print(f"| {n} | {', '.join(f'{x:.4f}' for x in angles)} | {', '.join(f'{x:+.1e}' for x in scores)} |", flush=True)
    finally:
        dr.set_thread_count(before)


if __name__ == "__main__":
    main()
