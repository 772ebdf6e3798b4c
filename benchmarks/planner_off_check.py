"""Inter-reflection left off for the biplane carving, checked by renders under every bundled
scenario whose pilots leave it off (the study ``tests/test_planner_off.py`` runs for bench and
display only: ring and outdoor take about 4 minutes of 2 cores).

For each scenario: the planner's decision and its pilot share, then the render estimator's flash
energy with direct lighting (depth 2) and with light between the parts (depth 4), at the
planner's answer and at the face-up normal, as a share of the answer's flash; the decision holds
when both changes stay under the tolerance (2 %).

    .venv/bin/python benchmarks/planner_off_check.py
"""

from __future__ import annotations

import time
from pathlib import Path

import labcut
from labcut.planner import INTERREFLECTION_TOLERANCE as TOL
from labcut.planner import plan_effects

BIPLANE = Path(__file__).resolve().parents[1] / "meshes" / "carving-biplane.ply"


def main() -> None:
    biplane = labcut.load_mesh(BIPLANE)
    print("| scenario | pilot share | change at the answer | change face-up | holds (< 2 %) | seconds |")
    print("|---|---|---|---|---|---|")
    for scenario in ("bench", "ring", "outdoor", "display"):
        t = time.monotonic()
        plan = plan_effects(biplane, scenario=scenario, quality="draft", predict=False)
        answer = labcut.recommend_orientation(biplane, scenario=scenario, quality="draft").normal
        kw = dict(scenario=scenario, quality="draft", estimator="render")
        off = [labcut.evaluate_orientation(biplane, n, **kw).flash_energy for n in (answer, (0.0, 0.0, 1.0))]
        on = [labcut.evaluate_orientation(biplane, n, effects={"inter_reflection": True}, **kw).flash_energy
              for n in (answer, (0.0, 0.0, 1.0))]
        change = [abs(a - b) / off[0] for a, b in zip(on, off)]
        holds = (not plan.on("inter_reflection")) and max(change) < TOL
        print(f"| {scenario} | {plan.facts['interreflection_measured']:.2%} | {change[0]:.2%} | {change[1]:.2%} | "
              f"{'yes' if holds else 'NO'} | {time.monotonic() - t:.0f} |", flush=True)


if __name__ == "__main__":
    main()
