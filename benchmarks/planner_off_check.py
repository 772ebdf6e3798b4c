"""Inter-reflection left off for the biplane carving, checked by renders under every bundled
scenario whose pilots leave it off (the study ``tests/test_planner_off.py`` runs for bench and
display only: ring and outdoor take about 4 minutes of 2 cores).

For each scenario: the planner's decision and its pilot share, then the render estimator's flash
energy with direct lighting (depth 2) and with light between the parts (depth 4), at the
planner's answer and at the face-up normal, as a share of the answer's flash; the decision holds
when both changes stay under the tolerance (2 %).

Then the one "on" decision the samples cannot carry: the still ring's office ceiling (an environment
map, ``ring-diffuse``) seen past the biplane's wings. The sample estimator's answer against the render estimator's
(which the planner picks): the flash the renders find at the samples' answer, lost against their
own answer, and the angle between the two (the planner is right when the loss passes the 2 %
tolerance; tests/test_planner_off.py pins the decision itself).

No bundled scenario's pilots turn it on since the renders stopped counting the lights seen behind
the stone (the pendant and the brooch measured 12-14 % before, 0.2 % after: docs/performance.md,
issue 39).

    .venv/bin/python benchmarks/planner_off_check.py [--only-environment]
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

import labcut
from labcut.planner import INTERREFLECTION_TOLERANCE as TOL
from labcut.planner import plan_effects

BIPLANE = Path(__file__).resolve().parents[1] / "meshes" / "carving-biplane.ply"


def environment_check(biplane) -> None:
    """The render estimator under the still ring's map (``ring-diffuse``: the moving ring turns the
    map's directions, and the samples answer it), against the samples' answer."""
    t = time.monotonic()
    sc = "ring-diffuse"
    plan = plan_effects(biplane, scenario=sc, quality="draft", predict=False)
    samples = labcut.recommend_orientation(biplane, scenario=sc, quality="draft", estimator="samples")
    renders = labcut.recommend_orientation(biplane, scenario=sc, quality="draft")
    at_samples = labcut.evaluate_orientation(biplane, samples.normal, scenario=sc, quality="draft").flash_energy
    loss = 1.0 - at_samples / renders.score
    angle = math.degrees(math.acos(min(1.0, abs(float(np.dot(samples.normal, renders.normal))))))
    print("| planner's estimator | flash lost at the samples' answer | angle between the answers | right (loss > 2 %) | seconds |")
    print("|---|---|---|---|---|")
    print(f"| {plan.estimator} | {loss:.1%} | {angle:.1f}° | {'yes' if loss > TOL and plan.estimator == 'render' else 'NO'} | "
          f"{time.monotonic() - t:.0f} |", flush=True)


def main() -> None:
    biplane = labcut.load_mesh(BIPLANE)
    if "--only-environment" in sys.argv:
        environment_check(biplane)
        return
    print("| scenario | pilot share | change at the answer | change face-up | holds (< 2 %) | seconds |")
    print("|---|---|---|---|---|---|")
    for scenario in ("bench", "ring", "pendant", "brooch", "outdoor", "display"):
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
    print()
    environment_check(biplane)


if __name__ == "__main__":
    main()
