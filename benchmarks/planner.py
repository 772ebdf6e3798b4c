"""What the effect planner saves: each effect it leaves off, switched on, in time and in answer.

For the bundled stones and scenarios, every decision the planner takes (docs/planner.md) is
measured against the other choice, in one process with warm kernels (each case run once to
warm, then timed):

* occlusion on a convex stone (off, exact) vs forced on (the loader's verdict overridden);
* inter-reflection in a carving (off where pilot renders put it below 2 %) vs the render
  estimator with paths of depth 4 through every lobe;
* the estimator: samples vs render where both apply (a convex stone), and the plan's
  predicted seconds of each next to the measured ones;
* renders: direct lighting vs a path tracer for a convex stone, and RGB vs spectral vs mono.

Writes the tables between the ``BENCHMARK`` markers of docs/planner.md::

    .venv/bin/python benchmarks/planner.py [--quality standard] [--out docs/planner.md]
"""

from __future__ import annotations

import argparse
import copy
import math
import os
import platform
import time
from pathlib import Path

import numpy as np

import labcut
from labcut.planner import plan_effects

ROOT = Path(__file__).resolve().parents[1]
BEGIN, END = "<!-- BENCHMARK:BEGIN -->", "<!-- BENCHMARK:END -->"


def timed(fn, repeat: int = 1):
    fn()  # warm: kernels, caches
    best, out = math.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def angle(a, b) -> float:
    return math.degrees(math.acos(min(1.0, abs(float(np.dot(a, b))))))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quality", default="standard")
    parser.add_argument("--out", default=str(ROOT / "docs" / "planner.md"))
    args = parser.parse_args()
    q = args.quality
    from labcut.orientation.render_estimator import render_timing
    from labcut.orientation.timing import sample_timing

    labcut.recommend_orientation(labcut.cabochon(outline="oval", length=16, width=12, dome="medium"), quality="draft")  # warm
    sample_timing(refresh=True)  # calibrate the predictions here, as quiet as the measurements
    render_timing(refresh=True)
    oval = labcut.load_mesh(ROOT / "meshes" / "oval-16x12-low.ply")
    biplane = labcut.load_mesh(ROOT / "meshes" / "carving-biplane.ply")
    lab = labcut.Labradorite.preset("blue")
    rows: list[str] = []

    # 1. occlusion on a convex stone --------------------------------------------------------
    hidden = copy.deepcopy(oval)
    hidden.metadata.setdefault("labcut", {})["convex"] = False
    for scen in ("bench", "pendant"):
        t_off, a = timed(lambda: labcut.recommend_orientation(oval, lab, scenario=scen, quality=q))
        t_on, b = timed(lambda: labcut.recommend_orientation(hidden, lab, scenario=scen, quality=q))
        rows.append(f"| occlusion, oval cabochon, {scen} | off (convex: exact) | {t_off:.2f} s | on (forced) | {t_on:.2f} s "
                    f"| {t_on / t_off:.1f}x | {angle(a.normal, b.normal):.2f}° | {abs(b.score / a.score - 1):.2%} |")

    # 2. inter-reflection in a carving ------------------------------------------------------
    for scen in ("display", "bench"):
        plan = plan_effects(biplane, lab, scenario=scen, quality=q)
        t_off, _ = timed(lambda: labcut.recommend_orientation(biplane, lab, scenario=scen, quality=q))
        # the effect alone: the render estimator without and with light between the parts
        _, a = timed(lambda: labcut.recommend_orientation(biplane, lab, scenario=scen, quality=q, estimator="render"))
        t_on, b = timed(lambda: labcut.recommend_orientation(biplane, lab, scenario=scen, quality=q, estimator="render",
                                                             effects={"inter_reflection": True}))
        rows.append(f"| inter-reflection, biplane carving, {scen} (pilot: {plan.facts['interreflection_measured']:.1%}) "
                    f"| off (samples) | {t_off:.2f} s | on (render estimator, depth 4) | {t_on:.2f} s | {t_on / t_off:.1f}x "
                    f"| {angle(a.normal, b.normal):.2f}° * | {abs(b.score / a.score - 1):.2%} * |")

    # 3. the estimator where both apply, and the plan's predictions ------------------------
    pred_rows = []
    for scen in ("display", "bench"):
        plan = plan_effects(oval, lab, scenario=scen, quality=q)
        t_s, a = timed(lambda: labcut.recommend_orientation(oval, lab, scenario=scen, quality=q, estimator="samples"))
        t_r, b = timed(lambda: labcut.recommend_orientation(oval, lab, scenario=scen, quality=q, estimator="render"))
        rows.append(f"| estimator, oval cabochon, {scen} | samples (planner) | {t_s:.2f} s | render | {t_r:.2f} s "
                    f"| {t_r / t_s:.1f}x | {angle(a.normal, b.normal):.2f}° | {abs(b.score / a.score - 1):.2%} |")
        p = plan.predicted_seconds
        pred_rows.append(f"| oval cabochon, {scen} | {p['samples']:.2f} s | {t_s:.2f} s | {p['render']:.1f} s | {t_r:.1f} s |")
    for scen in ("display",):
        plan = plan_effects(biplane, lab, scenario=scen, quality=q)
        t_s, _ = timed(lambda: labcut.recommend_orientation(biplane, lab, scenario=scen, quality=q))
        p = plan.predicted_seconds
        pred_rows.append(f"| biplane carving, {scen} | {p['samples']:.2f} s | {t_s:.2f} s | {p['render']:.1f} s | (row above: depth 4) |")

    # 4. renders: integrator and colour -----------------------------------------------------
    normal = (0.05, -0.02, 1.0)
    kw = dict(scenario="bench", resolution=256, spp=32, check_flash=False, look="diagram")
    t_d, d = timed(lambda: labcut.render(oval, lab, normal, **kw))
    t_p, pth = timed(lambda: labcut.render(oval, lab, normal, max_depth=8, **kw))
    rel = float(np.abs(pth.image.mean() / d.image.mean() - 1))
    rows.append(f"| render path depth, oval, 256² 32 spp | direct (convex: exact) | {t_d:.2f} s | path, depth 8 | {t_p:.2f} s "
                f"| {t_p / t_d:.1f}x | – | {rel:.2%} (image mean) |")
    t_rgb, _ = timed(lambda: labcut.render(oval, lab, normal, mode="rgb", **kw))
    t_sp, _ = timed(lambda: labcut.render(oval, lab, normal, mode="spectral", **kw))
    t_mono, _ = timed(lambda: labcut.render(oval, lab, normal, mode="mono", **kw))
    rows.append(f"| render colour, oval, 256² 32 spp | rgb (planner) | {t_rgb:.2f} s | spectral | {t_sp:.2f} s "
                f"| {t_sp / t_rgb:.1f}x | – | – |")
    rows.append(f"| render colour, oval, 256² 32 spp | mono (asked) | {t_mono:.2f} s | rgb | {t_rgb:.2f} s "
                f"| {t_rgb / t_mono:.1f}x | – | – |")

    table = "\n".join([
        f"Measured with `.venv/bin/python benchmarks/planner.py --quality {q}` on {platform.processor() or platform.machine()}, "
        f"{os.cpu_count()} cores, Mitsuba LLVM variants, warm process (each case run once first); "
        "angle and score: how far the other choice moves the answer (* inter-reflection: the render estimator with "
        "paths of depth 4 against the same estimator with direct lighting, so the effect alone is measured; the "
        "estimator rows give the difference between the estimators).",
        "",
        "| case | planner's choice | time | the other choice | time | cost of the other | normal moves | score changes |",
        "|---|---|---|---|---|---|---|---|",
        *rows,
        "",
        "Predicted (the plan's `predicted_seconds`, calibrated on this machine) against measured seconds of a recommendation:",
        "",
        "| stone, scenario | samples predicted | samples measured | render predicted | render measured |",
        "|---|---|---|---|---|",
        *pred_rows,
    ])
    out = Path(args.out)
    text = out.read_text()
    head, rest = text.split(BEGIN)
    _, tail = rest.split(END)
    out.write_text(f"{head}{BEGIN}\n{table}\n{END}{tail}")
    print(table)


if __name__ == "__main__":
    main()
