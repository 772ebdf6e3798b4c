"""What the effect planner saves: each effect it leaves off, switched on, in time and in answer.

For the bundled stones and scenarios, every decision the planner takes (docs/planner.md) is
measured against the other choice, in one process with warm kernels (each case run once to
warm, then timed):

* occlusion on a convex stone (off, exact) vs forced on (the loader's verdict overridden);
* inter-reflection in a carving (off where pilot renders put it below 2 %) vs the render
  estimator with paths of depth 4 through every lobe;
* the estimator: samples vs render where both apply (a convex stone), and the plan's
  predicted seconds of each next to the measured ones;
* renders: direct lighting vs a path tracer for a convex stone, and RGB vs spectral vs mono;
* (an environment map seen past a carving's parts: ``benchmarks/planner_off_check.py
  --only-environment``, its own table in docs/planner.md);
* the planner's own cost: the pilot renders from a cold cache, the self-view rays, and each
  calibration of the predicted seconds, measured from nothing;
* the predicted seconds of evaluate, render and a zoned recommendation against measured ones;
* the tolerance: the seed-to-seed spread of a recommendation's score at the benchmark's quality.

Writes the tables between the ``BENCHMARK`` markers of docs/planner.md::

    .venv/bin/python benchmarks/planner.py [--quality standard] [--out docs/planner.md]

``--moving`` measures only the map seen past a carving's parts by a moving stone (the worn
scenarios' motion), samples against renders, and writes its table between the ``MOVING`` markers::

    .venv/bin/python benchmarks/planner.py --moving --quality draft
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
MOVING_BEGIN, MOVING_END = "<!-- MOVING:BEGIN -->", "<!-- MOVING:END -->"
MOVING_SCENARIOS = ("ring", "pendant", "brooch", "outdoor")


def moving(quality: str, out: Path) -> None:
    """The biplane under each moving, map-lit scenario: the samples' answer against the renders'."""
    from labcut.planner import ENV_DIRECTIONS_ENOUGH

    biplane = labcut.load_mesh(ROOT / "meshes" / "carving-biplane.ply")
    lab = labcut.Labradorite.preset("blue")
    rows = [f"Measured with `.venv/bin/python benchmarks/planner.py --moving --quality {quality}` on {platform.machine()}, "
            f"{os.cpu_count()} cores, Mitsuba LLVM variants; each estimator run once to warm, then timed.", "",
            "| scenario | poses x map directions | planner's choice | samples | render | apart | loss | render's tolerance |",
            "|---|---|---|---|---|---|---|---|"]
    for name in MOVING_SCENARIOS:
        sc = labcut.Scenario.preset(name, quality)
        seen = len(sc.poses()) * (len(sc.lights) - sc.lights.n_lamps)
        t_s, a = timed(lambda: labcut.recommend_orientation(biplane, lab, scenario=sc, quality=quality, estimator="samples"))
        t_r, b = timed(lambda: labcut.recommend_orientation(biplane, lab, scenario=sc, quality=quality, estimator="render"))
        plan = plan_effects(biplane, lab, scenario=sc, quality=quality, predict=False)
        ev = labcut.evaluate_orientation(biplane, a.normal, lab, scenario=sc, quality=quality, estimator="render")
        loss = 1.0 - ev.flash_energy / b.metrics.flash_energy
        rows.append(f"| {name} | {len(sc.poses())} x {seen // len(sc.poses())} = {seen} (needs {ENV_DIRECTIONS_ENOUGH}) | "
                    f"{plan.estimator} | {t_s:.2f} s | {t_r:.2f} s | {angle(a.normal, b.normal):.2f}° | {loss:.2%} | "
                    f"±{b.tolerance_deg:.1f}° |")
        print(rows[-1], flush=True)
    text = out.read_text()
    begin, end = ((MOVING_BEGIN, MOVING_END) if quality == "draft" else
                  (MOVING_BEGIN.replace("MOVING", f"MOVING-{quality.upper()}"), MOVING_END.replace("MOVING", f"MOVING-{quality.upper()}")))
    if begin in text and end in text:
        head, rest = text.split(begin, 1)
        _, tail = rest.split(end, 1)
        out.write_text(head + begin + "\n" + "\n".join(rows) + "\n" + end + tail)
    print("\n".join(rows))


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
    parser.add_argument("--moving", action="store_true", help="only the moving stones under a map (samples vs renders)")
    args = parser.parse_args()
    q = args.quality
    if args.moving:
        moving(q, Path(args.out))
        return
    from labcut.orientation.render_estimator import render_timing
    from labcut.planner import sample_timing

    import tempfile

    import labcut.planner as planner
    from labcut.planner import evaluate_timing, render_command_timing
    from labcut.rendering.rays import self_view_fraction

    labcut.recommend_orientation(labcut.cabochon(outline="oval", length=16, width=12, dome="medium"), quality="draft")  # warm
    own: list[str] = []  # the planner's own cost
    # calibrate the predictions here, as quiet as the measurements, and time each calibration
    for label, fn in (("calibration: sample estimator (5 recommendations of an oval: 2 warm-ups, 3 timed)", lambda: sample_timing(refresh=True)),
                      ("calibration: render estimator (2 integrators x 2 sizes)", lambda: render_timing(refresh=True)),
                      ("calibration: evaluate (7 evaluations of an oval)", lambda: evaluate_timing(refresh=True)),
                      ("calibration: render command, rgb direct diagram (4 renders of a sphere)",
                       lambda: render_command_timing("rgb", False, "direct", "diagram", refresh=True))):
        t = time.perf_counter()
        fn()
        own.append(f"| {label} | {time.perf_counter() - t:.2f} s | once per machine (user cache) |")
    oval = labcut.load_mesh(ROOT / "meshes" / "oval-16x12-low.ply")
    biplane = labcut.load_mesh(ROOT / "meshes" / "carving-biplane.ply")
    lab = labcut.Labradorite.preset("blue")
    rows: list[str] = []
    t = time.perf_counter()
    f = self_view_fraction(biplane)
    own.append(f"| self-view rays, biplane carving (sky share {f:.0%}) | {time.perf_counter() - t:.2f} s | every plan of a carving |")
    with tempfile.TemporaryDirectory() as tmp:  # pilot renders from a cold cache, then from the cache
        keep = planner._pilot_cache_path
        planner._pilot_cache_path = lambda: Path(tmp) / "planner-pilot.json"
        try:
            for scen in ("display", "ring"):
                planner._PILOT_CACHE.clear()
                t = time.perf_counter()
                plan_effects(biplane, lab, scenario=scen, quality=q, predict=False)
                cold = time.perf_counter() - t
                t = time.perf_counter()
                plan_effects(biplane, lab, scenario=scen, quality=q, predict=False)
                warm = time.perf_counter() - t
                own.append(f"| plan, biplane carving, {scen}: pilot renders from a cold cache | {cold:.2f} s | "
                           f"once per stone, material and scene (then {warm:.2f} s from the cache) |")
        finally:
            planner._pilot_cache_path = keep
    for scen in ("display", "pendant"):
        t = time.perf_counter()
        plan_effects(oval, lab, scenario=scen, quality=q)
        own.append(f"| plan, oval cabochon, {scen} (calibrations cached) | {time.perf_counter() - t:.3f} s | every command |")

    # 1. occlusion on a convex stone --------------------------------------------------------
    hidden = copy.deepcopy(oval)
    hidden.metadata.setdefault("labcut", {})["convex"] = False
    for scen in ("bench", "pendant"):
        t_off, a = timed(lambda: labcut.recommend_orientation(oval, lab, scenario=scen, quality=q))
        # the samples with shadow rays (a "non-convex" stone under a map would get the render estimator)
        t_on, b = timed(lambda: labcut.recommend_orientation(hidden, lab, scenario=scen, quality=q, estimator="samples"))
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

    # (an environment map seen past a carving's parts: benchmarks/planner_off_check.py --only-environment,
    # the still scenes' table of docs/planner.md)
    # predicted against measured: evaluate, and a zoned recommendation
    for name, stone, scen in (("oval cabochon", oval, "display"), ("biplane carving", biplane, "ring")):
        plan = plan_effects(stone, lab, command="evaluate", scenario=scen, quality=q)
        n = (0.1, 0.05, 1.0)
        t_s, _ = timed(lambda: labcut.evaluate_orientation(stone, n, lab, scenario=scen, quality=q, estimator="samples"))
        t_r, _ = timed(lambda: labcut.evaluate_orientation(stone, n, lab, scenario=scen, quality=q, estimator="render"))
        p = plan.predicted_seconds
        pred_rows.append(f"| {name}, {scen} (evaluate) | {p['samples']:.2f} s | {t_s:.2f} s | {p['render']:.1f} s | {t_r:.1f} s |")
    plan = plan_effects(oval, lab, scenario="display", quality=q, zoning="smooth")
    t_z, _ = timed(lambda: labcut.recommend_orientation(oval, lab, scenario="display", quality=q, zoning="smooth"))
    pred_rows.append(f"| oval cabochon, display, zoned (recommend: coarse map of renders) | {plan.predicted_seconds['samples']:.2f} s "
                     f"| – | {plan.predicted_seconds['render']:.1f} s | {t_z:.1f} s |")

    # 3c. the tolerance: the seed-to-seed spread of a recommendation's score ------------------
    spread = []
    for scen in ("bench", "display"):
        scores = [labcut.recommend_orientation(oval, lab, scenario=scen, quality=q, seed=s).score for s in range(5)]
        spread.append(f"{scen} {np.std(scores, ddof=1) / np.mean(scores):.1%}")

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
    render_pred = []
    for stone_name, stone, res, spp, look in (("oval cabochon", oval, 256, 32, "diagram"), ("oval cabochon", oval, 512, 64, "diagram"),
                                              ("biplane carving", biplane, 256, 32, "diagram")):
        plan = plan_effects(stone, lab, command="render", scenario="bench", resolution=res, spp=spp, look=look)
        t_x, _ = timed(lambda: labcut.render(stone, lab, normal, scenario="bench", resolution=res, spp=spp, look=look))
        render_pred.append(f"| {stone_name}, {plan.facts['mode']} {'path' if plan.on('inter_reflection') else 'direct'}, "
                           f"{plan.facts['predicted_for']} | {plan.predicted_seconds['render']:.2f} s | {t_x:.2f} s |")

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
        "† map rows: the share of the flash the render estimator finds that the sample estimator's answer loses, as the "
        "render estimator scores it (the normal the renders move: the angle column).",
        "",
        "Predicted (the plan's `predicted_seconds`, calibrated on this machine) against measured seconds of a recommendation "
        "or an evaluation:",
        "",
        "| stone, scenario | samples predicted | samples measured | render predicted | render measured |",
        "|---|---|---|---|---|",
        *pred_rows,
        "",
        "Predicted against measured seconds of a render (`labcut.render`, bench scenario):",
        "",
        "| stone, render | predicted | measured |",
        "|---|---|---|",
        *render_pred,
        "",
        "The planner's own cost (the plan, before any command runs):",
        "",
        "| what | time | paid |",
        "|---|---|---|",
        *own,
        "",
        f"The tolerance: the seed-to-seed spread (standard deviation / mean over seeds 0-4) of the oval cabochon's "
        f"recommended score at {q} quality: {', '.join(spread)}.",
    ])
    out = Path(args.out)
    text = out.read_text()
    head, rest = text.split(BEGIN)
    _, tail = rest.split(END)
    out.write_text(f"{head}{BEGIN}\n{table}\n{END}{tail}")
    print(table)


if __name__ == "__main__":
    main()
