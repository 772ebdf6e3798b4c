"""Inter-reflection left off for the biplane carving, checked by renders under every bundled
scenario whose pilots leave it off (the study ``tests/test_planner_off.py`` runs for bench and
display only: ring and outdoor take about 4 minutes of 2 cores).

For each scenario: the planner's decision and its pilot share, then the render estimator's flash
energy with direct lighting (depth 2) and with light between the parts (depth 4), at the
planner's answer and at the face-up normal, as a share of the answer's flash; the decision holds
when both changes stay under the tolerance (2 %).

Then the still scenes lit by an environment map seen past the biplane's wings (``ring-diffuse``,
``pendant-diffuse``, ``brooch-diffuse``, ``outdoor-still``): the sample estimator's answer with the
map drawn as the planner draws it there (:func:`labcut.planner.env_samples_enough`) and with the
quality's own directions, each against the render estimator's answer (which traces what each point
sees of the whole map): the flash the renders find at the samples' answer, lost against their own,
and the angle between the two. The planner is right when the dense map's loss stays under the 2 %
tolerance (tests/test_planner_off.py pins the decision and the ceiling's draft answer). With
``--quality standard`` and ``--out docs/planner.md`` the table goes into the docs.

No bundled scenario's pilots turn it on since the renders stopped counting the lights seen behind
the stone (the pendant and the brooch measured 12-14 % before, 0.2 % after: docs/performance.md,
issue 39).

    .venv/bin/python benchmarks/planner_off_check.py [--only-environment] [--quality draft] [--out docs/planner.md]
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


STILL = ("ring-diffuse", "pendant-diffuse", "brooch-diffuse", "outdoor-still")
BEGIN, END = "<!-- STILL-MAPS:BEGIN -->", "<!-- STILL-MAPS:END -->"


def environment_check(biplane, quality: str = "draft", out: Path | None = None) -> None:
    """The samples' answers under each still, map-lit scenario (the map as the planner draws it past
    the parts, and as the quality draws it) against the render estimator's; each run once to warm."""
    import dataclasses
    import os
    import platform

    rows = [f"Measured with `.venv/bin/python benchmarks/planner_off_check.py --only-environment --quality {quality}` on "
            f"{platform.machine()}, {os.cpu_count()} cores, Mitsuba LLVM variants, warm (each call run once first); "
            "loss: the flash the renders find at that answer below their own answer's.", "",
            "| scenario | planner | map directions (quality's) | samples, planner's map | apart | loss | "
            "samples, quality's map | apart | loss | renders | right (loss < 2 %) |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    print("\n".join(rows), flush=True)
    for sc in STILL:
        plan = plan_effects(biplane, scenario=sc, quality=quality, predict=False)
        forced = plan_effects(biplane, scenario=sc, quality=quality, predict=False, estimator="samples")
        kw = dict(scenario=sc, quality=quality, estimator="samples")

        def timed(fn):
            fn()
            t = time.perf_counter()
            got = fn()
            return time.perf_counter() - t, got

        t_d, dense = timed(lambda: labcut.recommend_orientation(biplane, plan=forced, **kw))
        t_c, coarse = timed(lambda: labcut.recommend_orientation(biplane, plan=dataclasses.replace(forced, env_samples=None), **kw))
        t_r, renders = timed(lambda: labcut.recommend_orientation(biplane, scenario=sc, quality=quality, estimator="render"))
        cells = []
        for rec in (dense, coarse):
            at = labcut.evaluate_orientation(biplane, rec.normal, scenario=sc, quality=quality, estimator="render").flash_energy
            loss = 1.0 - at / renders.metrics.flash_energy
            angle = math.degrees(math.acos(min(1.0, abs(float(np.dot(rec.normal, renders.normal))))))
            cells.append((angle, loss))
        n_map = plan.facts.get("map_directions")
        rows.append(f"| {sc} | {plan.estimator} | {forced.env_samples} ({n_map}) | {t_d:.2f} s | {cells[0][0]:.2f}° | "
                    f"{cells[0][1]:.2%} | {t_c:.2f} s | {cells[1][0]:.2f}° | {cells[1][1]:.2%} | {t_r:.2f} s | "
                    f"{'yes' if cells[0][1] < TOL else 'NO'} |")
        print(rows[-1], flush=True)
    if out is not None:
        text = out.read_text()
        head, rest = text.split(BEGIN, 1)
        _, tail = rest.split(END, 1)
        out.write_text(head + BEGIN + "\n" + "\n".join(rows) + "\n" + END + tail)


def main() -> None:
    biplane = labcut.load_mesh(BIPLANE)
    quality = sys.argv[sys.argv.index("--quality") + 1] if "--quality" in sys.argv else "draft"
    out = Path(sys.argv[sys.argv.index("--out") + 1]) if "--out" in sys.argv else None
    if "--only-environment" in sys.argv:
        environment_check(biplane, quality, out)
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
    environment_check(biplane, quality, out)


if __name__ == "__main__":
    main()
