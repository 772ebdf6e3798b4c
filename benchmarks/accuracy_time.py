"""What accuracy costs in time: every knob against a converged reference (issue 17).

    .venv/bin/python benchmarks/accuracy_time.py [--out docs/accuracy.md] [--quick] [--budgets-only]

For three benchmark cases, a cabochon (the bundled 16 x 12 mm oval), a carving (the bundled
biplane) and a faceted design (GemCad SRB at a 10 mm girdle), all under the ``bench``
scenario:

1. a **converged reference**: the recommendation of a problem far finer than ``high``
   (:func:`reference_quality`: 1.3x its surface samples, 1.5x its directions per lamp and
   viewing cone, 2x its rocking poses, a 1° map), for :data:`REF_SEEDS` seeds; the reference normal is their
   axial mean, the reference score their mean, and their scatter is printed so the reader can
   see that the reference is converged well below the errors studied;
2. **every knob** that trades accuracy for time (surface points, lamp directions, viewing
   directions, rocking poses, map spacing, optimiser and its evaluation budget), varied one
   at a time from ``standard``, and the three presets: warm wall time of a full
   recommendation (``labcut.recommend_orientation``, error bars included) against the angle
   of its normal to the reference, its score ratio and its tolerance, mean over seeds;
3. the **error bars**: for the presets and seeds, whether each answer's stated bar
   (``rec.uncertainty``) covers its distance to the reference (normal and score);
4. **render knobs** (samples per pixel, resolution, mono / rgb / spectral, path depth):
   wall time and image RMSE against a 1024 spp spectral render of the same stone;
5. **time budgets**: ``recommend_orientation(..., time_budget=)`` per case and
   ``compare_cuts(..., time_budget=)`` of the cases side by side, actual against budget
   (``--budgets-only`` redoes just these).

Plots (log-log error against time, the Pareto front of all settings) go to
``docs/images/accuracy-*.png``; the report to ``docs/accuracy.md``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

CASES = {
    "cabochon": ("oval cabochon 16 x 12 mm (meshes/oval-16x12-low.ply)", "meshes/oval-16x12-low.ply", None),
    "carving": ("biplane carving (meshes/carving-biplane.ply)", "meshes/carving-biplane.ply", None),
    "faceted": ("GemCad SRB brilliant, 10 mm girdle (meshes/designs/SRB.asc)", "meshes/designs/SRB.asc", 10.0),
}
SCENARIO = "bench"
REF_SEEDS = (101, 102, 103)
SEEDS = (1, 2)
COVER_SEEDS = (1, 2, 3, 4, 5)

#: one knob at a time, from standard: (knob label, field, values)
KNOBS = [
    ("surface points", "surface_points", [1000, 2000, 4000, 8000, 16000, 32000]),
    ("directions per lamp", "lamp_samples", [3, 7, 13, 25]),
    ("viewing directions per cone", "cone_views", [3, 7, 13, 25]),
    ("rocking poses (front-back, side)", "rock_steps", [(3, 2), (5, 2), (9, 4), (17, 6)]),
    ("map spacing (deg)", "map_spacing_deg", [6.0, 4.0, 3.0, 2.0]),
    ("DIRECT-L evaluations", "nlopt_evals", [60, 120, 250, 400]),
]
OPTIMIZERS = ("nlopt", "gradient", "grid")
#: the block of docs/accuracy.md that benchmarks/scenario_coverage.py writes (kept when this report is rewritten)
COVERAGE_BEGIN, COVERAGE_END = "<!-- SCENARIO-COVERAGE:BEGIN -->", "<!-- SCENARIO-COVERAGE:END -->"
#: the whole CLI call under a budget (benchmarks/call_budget.py, written by hand): kept before the comparison's budgets
CALL_BEGIN, CALL_END = "<!-- CALL-BUDGET:BEGIN -->", "<!-- CALL-BUDGET:END -->"


def reference_quality():
    from labcut.scene.quality import Quality

    return Quality.coerce("high").replace(surface_points=32000, lamp_samples=37, cone_views=37, ring_views=60,
                                          rock_steps=(33, 12), map_spacing_deg=1.0)


def angle(a, b) -> float:
    return math.degrees(math.acos(min(1.0, abs(float(np.dot(a, b))))))


def axial_mean(normals: list[np.ndarray]) -> np.ndarray:
    m = sum(np.outer(n, n) for n in normals)
    w, v = np.linalg.eigh(m)
    n = v[:, -1]
    return n if n[2] >= 0 else -n


@dataclass
class Row:
    case: str
    knob: str
    value: str
    seconds: float
    angle_deg: float
    score_ratio: float
    tolerance_deg: float
    bar_deg: float
    bar_score: float


def load(case: str):
    import labcut

    _, path, size = CASES[case]
    return labcut.load_mesh(ROOT / path, size=size) if size else labcut.load_mesh(ROOT / path)


def timed(mesh, quality, seed: int, optimizer: str = "nlopt"):
    import labcut

    t = time.perf_counter()
    rec = labcut.recommend_orientation(mesh, "blue", scenario=SCENARIO, quality=quality, seed=seed, optimizer=optimizer)
    return rec, time.perf_counter() - t


def study_case(case: str, quick: bool) -> dict:
    from labcut.scene.quality import Quality

    mesh = load(case)
    timed(mesh, "draft", 0)  # warm: imports and kernels
    t0 = time.perf_counter()
    refs = [timed(mesh, reference_quality(), s)[0] for s in (REF_SEEDS[:1] if quick else REF_SEEDS)]
    ref_seconds = (time.perf_counter() - t0) / len(refs)
    ref_n = axial_mean([r.normal for r in refs])
    ref_score = float(np.mean([r.score for r in refs]))
    ref_scatter = max(angle(r.normal, ref_n) for r in refs)
    ref_score_scatter = float(np.std([r.score for r in refs]) / ref_score) if len(refs) > 1 else 0.0
    print(f"{case}: reference tilt {math.degrees(math.acos(ref_n[2])):.2f}°, score {ref_score:.5g}, "
          f"scatter {ref_scatter:.3f}°, {ref_seconds:.1f} s each", flush=True)
    rows: list[Row] = []
    seeds = SEEDS[:1] if quick else SEEDS

    def measure(knob: str, value: str, quality, optimizer: str = "nlopt") -> None:
        recs = [timed(mesh, quality, s, optimizer) for s in seeds]
        rows.append(Row(case, knob, value, float(np.mean([dt for _, dt in recs])),
                        float(np.mean([angle(r.normal, ref_n) for r, _ in recs])),
                        float(np.mean([r.score / ref_score for r, _ in recs])),
                        float(np.mean([r.tolerance_deg for r, _ in recs])),
                        float(np.mean([r.uncertainty.angle_deg for r, _ in recs])),
                        float(np.mean([r.uncertainty.score_rel for r, _ in recs]))))
        r = rows[-1]
        print(f"  {knob} = {value}: {r.seconds:.2f} s, {r.angle_deg:.3f}°, score x{r.score_ratio:.3f}", flush=True)

    standard = Quality.coerce("standard")
    for name in ("draft", "standard", "high"):
        measure("preset", name, name)
    for label, fld, values in KNOBS:
        for v in (values[::2] if quick else values):
            measure(label, str(v), standard.replace(**{fld: v}))
    for opt in OPTIMIZERS:
        measure("optimiser", opt, standard, opt)

    cover = cover_study(mesh, ref_n, ref_score, quick)
    return {"case": case, "label": CASES[case][0], "reference": {
        "normal": ref_n.tolist(), "score": ref_score, "seeds": len(refs), "scatter_deg": ref_scatter,
        "score_scatter": ref_score_scatter, "seconds": ref_seconds, "quality": reference_quality().to_dict()},
        "rows": [r.__dict__ for r in rows], "cover": cover}


def cover_study(mesh, ref_n: np.ndarray, ref_score: float, quick: bool) -> list[dict]:
    """Do the error bars cover the distance to the reference? One row per (preset, seed)."""
    cover = []
    for name in ("draft", "standard"):
        for s in (COVER_SEEDS[:2] if quick else COVER_SEEDS):
            rec, _ = timed(mesh, name, s)
            u = rec.uncertainty
            cover.append({"quality": name, "seed": s, "angle_deg": angle(rec.normal, ref_n), "bar_deg": u.angle_deg,
                          "score_err": abs(ref_score / rec.score - 1.0), "bar_score": u.score_rel})  # of its own score
    return cover


def render_study(quick: bool) -> list[dict]:
    """Image RMSE (linear RGB, relative to the reference's mean stone radiance) and time of render knobs."""
    import labcut

    mesh = load("cabochon")
    rec = labcut.recommend_orientation(mesh, "blue", scenario=SCENARIO, quality="draft")
    res = 96 if quick else 128

    def shot(warm: bool = True, **kw):
        if warm:  # the first render of a setting compiles its kernels: time the second
            labcut.render(mesh, labcut.Labradorite.preset("blue"), rec.normal, scenario=SCENARIO, look="diagram",
                          check_flash=False, **{**kw, "spp": min(kw.get("spp", 4), 4)})
        t = time.perf_counter()
        r = labcut.render(mesh, labcut.Labradorite.preset("blue"), rec.normal, scenario=SCENARIO, look="diagram",
                          check_flash=False, **kw)
        return r.image.astype(np.float64), time.perf_counter() - t

    shot(spp=4, resolution=32, mode="rgb")
    shot(spp=4, resolution=32, mode="spectral")
    shot(spp=4, resolution=32, mode="mono")
    ref, ref_t = shot(spp=256 if quick else 1024, resolution=res, mode="spectral")
    lum = np.array([0.2126, 0.7152, 0.0722])  # linear sRGB luminance: what a mono render shows
    scale = float(ref[ref > 0].mean()) if np.any(ref > 0) else 1.0
    out = [{"knob": "reference", "value": f"spectral, {256 if quick else 1024} spp, {res} px", "seconds": ref_t, "rmse": 0.0}]

    def rmse(img):
        if img.shape != ref.shape:  # another resolution: compare on the coarser grid (box down-sampling)
            k = ref.shape[0] // img.shape[0] if ref.shape[0] > img.shape[0] else 1
            a = ref.reshape(img.shape[0], k, img.shape[1], k, 3).mean(axis=(1, 3)) if k > 1 else ref
            b = img if k > 1 else img.reshape(ref.shape[0], img.shape[0] // ref.shape[0], ref.shape[1], -1, 3).mean(axis=(1, 3))
            return float(np.sqrt(np.mean((a - b) ** 2)) / scale)
        return float(np.sqrt(np.mean((img - ref) ** 2)) / scale)

    for spp in ((4, 16, 64) if quick else (4, 8, 16, 32, 64, 128, 256)):
        img, t = shot(spp=spp, resolution=res, mode="spectral")
        out.append({"knob": "samples per pixel (spectral)", "value": str(spp), "seconds": t, "rmse": rmse(img)})
    for mode in ("mono", "rgb", "spectral"):
        img, t = shot(spp=64, resolution=res, mode=mode)
        if mode == "mono":  # compared as luminance with the reference's luminance
            grey = img[..., 0] if img.ndim == 3 else img
            ref_y = ref @ lum
            err = float(np.sqrt(np.mean((grey - ref_y) ** 2)) / float(ref_y[ref_y > 0].mean()))
            out.append({"knob": "colour (64 spp)", "value": mode, "seconds": t, "rmse": err})
            continue
        out.append({"knob": "colour (64 spp)", "value": mode, "seconds": t, "rmse": rmse(img)})
    for r in ((res // 2, res) if quick else (res // 4, res // 2, res)):
        img, t = shot(spp=64, resolution=r, mode="spectral")
        out.append({"knob": "resolution (64 spp, spectral)", "value": f"{r} px", "seconds": t, "rmse": rmse(img)})
    for depth in (2, 3, 5):
        img, t = shot(spp=64, resolution=res, mode="spectral", max_depth=depth)
        out.append({"knob": "path depth (64 spp, spectral)", "value": str(depth), "seconds": t, "rmse": rmse(img)})
    for r in out:
        print(f"  render {r['knob']} = {r['value']}: {r['seconds']:.2f} s, RMSE {r['rmse']:.4f}", flush=True)
    return out


def budget_study(quick: bool) -> list[dict]:
    """``time_budget=``: the quality chosen, predicted and actual seconds, for each case and budget."""
    import warnings

    import labcut
    from labcut.commands.budget import corrections_path
    from labcut.hugepages import numpy_advice

    with warnings.catch_warnings():  # this machine's calibrations measured where none are kept
        warnings.simplefilter("ignore")
        labcut.recommend_orientation(load(next(iter(CASES))), "blue", scenario=SCENARIO, time_budget=0.25)
    corrections_path().unlink(missing_ok=True)  # start from the calibration alone: the table shows the learning
    out = []
    for case in CASES:
        mesh = load(case)
        labcut.recommend_orientation(mesh, "blue", scenario=SCENARIO, quality="draft")  # warm
        for budget in ((0.5, 2.0) if quick else (0.25, 0.5, 1.0, 2.0, 5.0, 10.0)):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                t = time.perf_counter()
                rec = labcut.recommend_orientation(mesh, "blue", scenario=SCENARIO, time_budget=budget)
                took = time.perf_counter() - t
            b = rec.settings["time_budget"]
            out.append({"case": case, "budget": budget, "quality": b["quality"], "predicted": b["predicted_seconds"],
                        "seconds": took, "over": b["note"] is not None, "bar_deg": rec.uncertainty.angle_deg,
                        "correction": b.get("correction", 1.0), "huge_page_advice": numpy_advice()})
            print(f"  budget {case} {budget:g} s: {b['quality']}, predicted {b['predicted_seconds']:.2f} s, took {took:.2f} s",
                  flush=True)
    return out


#: the comparison the compare budget study times: the three cases side by side, under bench
COMPARE_CUTS = [str(ROOT / CASES["cabochon"][1]), str(ROOT / CASES["carving"][1]), "cab:round,12,high"]


def compare_budget_study(quick: bool) -> list[dict]:
    """``compare_cuts(..., time_budget=)``: the quality chosen, predicted and actual seconds, for
    each budget, one comparison of :data:`COMPARE_CUTS` under the bench scenario."""
    import warnings

    import labcut
    from labcut.commands.budget import forget
    from labcut.hugepages import numpy_advice
    from labcut.reports.budget import KIND

    with warnings.catch_warnings():  # warm, this machine's calibrations measured where none are kept
        warnings.simplefilter("ignore")
        labcut.compare_cuts(COMPARE_CUTS[:1], "blue", [SCENARIO], quality="draft", resolution=32, spp=2)
        labcut.compare_cuts(COMPARE_CUTS[:1], "blue", [SCENARIO], time_budget=3.0, resolution=32, spp=2)
    forget(KIND)  # start from the calibration alone: the table shows the learning
    out = []
    for budget in ((5.0, 20.0) if quick else (3.0, 5.0, 10.0, 20.0, 40.0)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t = time.perf_counter()
            cmp = labcut.compare_cuts(COMPARE_CUTS, "blue", [SCENARIO], time_budget=budget)
            took = time.perf_counter() - t
        b = cmp.budget
        bars = [c.scenarios[SCENARIO].recommendation.uncertainty.angle_deg for c in cmp.cuts]
        out.append({"budget": budget, "quality": b["quality"], "predicted": b["predicted_seconds"], "seconds": took,
                    "over": b["note"] is not None, "bar_deg": max(bars), "correction": b.get("correction", 1.0),
                    "huge_page_advice": numpy_advice()})
        print(f"  compare budget {budget:g} s: {b['quality']}, predicted {b['predicted_seconds']:.2f} s, took {took:.2f} s",
              flush=True)
    return out


def budget_table(rows: list[dict], bar: str) -> list[str]:
    """Markdown rows of a budget study (a ``case`` column when the rows have one)."""
    case = bool(rows) and "case" in rows[0]
    head = ["case"] * case + ["budget", "quality chosen", "predicted", "correction applied", "actual", "actual / budget", bar]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for b in rows:
        flag = " (below the cheapest: ran it)" if b["over"] else ""
        cells = ([CASES[b["case"]][0]] if case else []) + [
            f"{b['budget']:g} s", f"{b['quality']}{flag}", f"{b['predicted']:.2f} s", f"x{b.get('correction', 1.0):.2f}",
            f"{b['seconds']:.2f} s", f"{b['seconds'] / b['budget']:.2f}", f"±{b['bar_deg']:.2f}°"]
        out.append("| " + " | ".join(cells) + " |")
    return out


def worst_ratio(rows: list[dict]) -> float:
    """The largest actual / budget among the runs where a rung was predicted to fit."""
    return max((b["seconds"] / b["budget"] for b in rows if not b["over"]), default=float("nan"))


def pareto(points: list[tuple[float, float]]) -> list[int]:
    """Indices of the points no other point beats in both time and error (lower is better)."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    front, best = [], math.inf
    for i in order:
        if points[i][1] < best:
            front.append(i)
            best = points[i][1]
    return front


def plot(results: list[dict], images: Path) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    images.mkdir(parents=True, exist_ok=True)
    names = []
    floor = 1e-3
    for res in results:
        fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
        rows = res["rows"]
        knobs = list(dict.fromkeys(r["knob"] for r in rows))
        for ax, key, label in ((axes[0], "angle_deg", "angle to the converged normal (deg)"),
                               (axes[1], "score_err", "|score / converged - 1|")):
            for knob in knobs:
                sel = [r for r in rows if r["knob"] == knob]
                xs = [r["seconds"] for r in sel]
                ys = [max(r["angle_deg"] if key == "angle_deg" else abs(r["score_ratio"] - 1.0), floor) for r in sel]
                ax.plot(xs, ys, "o-" if knob != "optimiser" else "s", label=knob, ms=4)
            pts = [(r["seconds"], max(r["angle_deg"] if key == "angle_deg" else abs(r["score_ratio"] - 1.0), floor)) for r in rows]
            front = pareto(pts)
            ax.plot([pts[i][0] for i in front], [pts[i][1] for i in front], "k--", lw=1, label="Pareto front")
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel("warm wall time of a recommendation (s)")
            ax.set_ylabel(label)
            ax.grid(True, which="both", alpha=0.3)
        axes[0].legend(fontsize=7)
        fig.suptitle(res["label"] + ", bench scenario")
        fig.tight_layout()
        name = f"accuracy-{res['case']}.png"
        fig.savefig(images / name, dpi=90)
        plt.close(fig)
        names.append(name)
    return names


def advice_note(budgets: list[dict]) -> str:
    """Under which numpy huge page advice the time budgets ran, as their rows recorded it."""
    seen = {b.get("huge_page_advice") for b in budgets}
    if seen == {False}:
        return ("Measured with numpy's huge page advice off, as the `labcut` command runs where the advice decides "
                "(`NUMPY_MADVISE_HUGEPAGE=0`; docs/performance.md, \"Huge pages\").")
    if seen == {True}:
        return ("Measured with numpy's huge page advice on (a library call's default; the `labcut` command turns it off "
                "where the advice decides: docs/performance.md, \"Huge pages\").")
    return ("The runs recorded different numpy huge page advice, or none (docs/performance.md, "
            "\"Huge pages\").")


def report(results: list[dict], renders: list[dict], images: list[str], args, seconds: float,
           budgets: list[dict] | None = None, compare_budgets: list[dict] | None = None) -> str:
    from labcut.commands.budget import REACH

    cpu = next((ln.split(":", 1)[1].strip() for ln in open("/proc/cpuinfo") if ln.startswith("model name")), platform.processor())
    cmd = "`.venv/bin/python benchmarks/accuracy_time.py" + (" --quick" if args.quick else "") + "`"
    lines = [
        "# What accuracy costs in time",
        "",
        f"Made by {cmd} (in parts: `--cases NAME --no-renders` reruns one case, `--cover-only` only its coverage, `--budgets-only` the time-budget studies) on {os.cpu_count()} cores ({cpu}), LLVM backend, in {seconds / 60:.1f} min. "
        "Times are warm wall times of a whole `labcut.recommend_orientation` call in one process (problem, optimiser, "
        "score map, tolerance, runners-up and the error bars); they move by ±30 % with other load on the machine. "
        "Errors are against a converged reference, not against `high`.",
        "",
        "## The converged reference",
        "",
        f"Per case, the recommendation of a problem far finer than `high` (surface points {reference_quality().surface_points:,}, "
        f"{reference_quality().lamp_samples} directions per lamp, {reference_quality().cone_views} per viewing cone, "
        f"rocking poses {reference_quality().rock_steps}, a {reference_quality().map_spacing_deg:g}° map) for "
        f"{len(REF_SEEDS) if not args.quick else 1} seeds; the reference normal is their axial mean. Its scatter "
        "(largest angle of a seed's normal to the mean) bounds how converged it is.",
        "",
        "| case | tilt | score (energy) | seeds | scatter of the normal | scatter of the score | time per seed |",
        "|---|---|---|---|---|---|---|",
    ]
    for res in results:
        ref = res["reference"]
        tilt = math.degrees(math.acos(min(1.0, ref["normal"][2])))
        lines.append(f"| {res['label']} | {tilt:.2f}° | {ref['score']:.5g} | {ref['seeds']} | {ref['scatter_deg']:.3f}° | "
                     f"{ref['score_scatter']:.2%} | {ref['seconds']:.1f} s |")
    lines += ["", "## Every knob", "",
              "One knob at a time from `standard` (standard's own value is the row whose numbers repeat the `standard` preset's), and the presets; "
              f"means over seeds {', '.join(map(str, SEEDS[:1] if args.quick else SEEDS))}. *angle*: to the converged normal; "
              "*score*: the answer's score over the converged score (each estimated at its own setting, so a bias of the "
              "setting shows); *bar*: the answer's own error bars (normal, score).", ""]
    for res, image in zip(results, images):
        lines += [f"### {res['label']}", "", f"![accuracy against time, {res['case']}](images/{image})", "",
                  "| knob | value | time | angle | score / converged | tolerance | bar (normal, score) |",
                  "|---|---|---|---|---|---|---|"]
        for r in res["rows"]:
            lines.append(f"| {r['knob']} | {r['value']} | {r['seconds']:.2f} s | {r['angle_deg']:.3f}° | {r['score_ratio']:.3f} | "
                         f"±{r['tolerance_deg']:.1f}° | ±{r['bar_deg']:.2f}°, ±{r['bar_score']:.1%} |")
        pts = [(r["seconds"], r["angle_deg"]) for r in res["rows"]]
        front = pareto(pts)
        lines += ["", "Pareto front (normal): " + "; ".join(
            f"{res['rows'][i]['knob']} = {res['rows'][i]['value']} ({pts[i][0]:.2f} s, {pts[i][1]:.3f}°)" for i in front), ""]
    lines += ["## Do the error bars cover the distance to the converged answer?", "",
              "Each recommendation states `uncertainty.angle_deg` and `uncertainty.score_rel` (printed as "
              "\"tilt 4.1° ± 1.5°\"; how they are estimated: [orientation.md](orientation.md#error-bars)). "
              "For the presets and seeds below, the share of answers whose bar covers its distance to the reference:", "",
              "| case | quality | answers | normal covered | score covered | median angle / bar | median score error / bar |",
              "|---|---|---|---|---|---|---|"]
    for res in results:
        for q in ("draft", "standard"):
            sel = [c for c in res["cover"] if c["quality"] == q]
            if not sel:
                continue
            ok_a = sum(c["angle_deg"] <= c["bar_deg"] for c in sel)
            ok_s = sum(c["score_err"] <= c["bar_score"] for c in sel)
            ra = np.median([c["angle_deg"] / c["bar_deg"] for c in sel])
            rs = np.median([c["score_err"] / max(c["bar_score"], 1e-12) for c in sel])
            lines.append(f"| {res['label']} | {q} | {len(sel)} | {ok_a}/{len(sel)} | {ok_s}/{len(sel)} | {ra:.2f} | {rs:.2f} |")
    lines += ["", "`tests/test_uncertainty.py` checks the same on a smaller scale in `make test` (the oval under bench, "
              "draft, four seeds, against a reference of 8x the samples). Every scenario, the "
              "render estimator included: below.", ""]
    if budgets:
        lines += ["## Time budgets", "",
                  "`labcut recommend-orientation MESH --time-budget SECONDS` (API `time_budget=`) runs the most accurate rung "
                  "of a ladder of qualities (below draft, draft, between, standard, between, high, beyond high) predicted to fit, "
                  "from this machine's calibration ([orientation.md](orientation.md#time-budgets)). Actual warm time against the "
                  "budget (target: at most 1.5x):", "",
                  *budget_table(budgets, "error bar")]
        worst = worst_ratio(budgets)
        lines += ["", f"Worst actual / budget where a rung fitted: {worst:.2f}. The runs go in the order shown, "
                  "starting with no learnt correction; each run's actual / predicted time updates the correction of "
                  "its kind (with or without occlusion) that the next prediction uses. A correction below 1 holds only "
                  f"up to {REACH:g}x the largest prediction a run beat (`labcut/commands/budget.py`): where the "
                  "correction applied is x1.00 after smaller runs that were faster, the rung lies beyond that reach. "
                  + advice_note(budgets), ""]
    if compare_budgets:
        lines += ["`labcut compare CUT... --time-budget SECONDS` (API `compare_cuts(..., time_budget=)`) does the same for a "
                  "whole comparison: each part of it (per cut and scenario the recommendation, the scorer of its curves, "
                  "the tilt curve, the renders and flash-colour map) predicted from this machine's calibrations, times a "
                  "correction learnt from past budgeted comparisons (`labcut/reports/budget.py`; the table shows the factor the "
                  "chosen rung's prediction had). Here the comparison of "
                  f"{len(COMPARE_CUTS)} cuts (the oval cabochon, the biplane carving and a round high cabochon `cab:round,12,high`) "
                  "under bench, the runs in the order shown, starting with no learnt correction:", "",
                  *budget_table(compare_budgets, "largest error bar")]
        lines += ["", f"Worst actual / budget where a rung fitted: {worst_ratio(compare_budgets):.2f}. The same reach "
                  f"holds here: a rung predicted beyond {REACH:g}x the largest comparison that beat its prediction is "
                  "predicted without a correction below 1, so a large budget can take a rung below the one a learnt "
                  "factor would have allowed, until a comparison of that size has run.", ""]
    lines += ["## Render knobs", "",
              "The oval cabochon at its recommended orientation, bench scenario, diagram look; RMSE of the linear RGB "
              "image against the reference, relative to the reference's mean non-zero pixel; each setting timed on its "
              "second render (the first compiles its kernels). Resolutions below the reference's are compared on their "
              "own grid (the reference box-filtered down). Mono renders are compared with the reference's luminance.", "",
              "| knob | value | time | relative RMSE |", "|---|---|---|---|"]
    for r in renders:
        lines.append(f"| {r['knob']} | {r['value']} | {r['seconds']:.2f} s | {r['rmse']:.4f} |")
    lines += ["", "Path depth changes nothing here: a convex stone has no light between its parts to carry (the planner "
              "renders it with direct lighting, [planner.md](planner.md)); for a carving it is the inter-reflection "
              "effect the planner measures. Mono is compared in luminance only, so its smaller RMSE is not a colour "
              "accuracy. The denoiser's effect at equal time (studio look): [render-performance.md](render-performance.md).", ""]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "accuracy.md"))
    parser.add_argument("--quick", action="store_true", help="one seed, every other knob value, smaller renders")
    parser.add_argument("--cases", default="cabochon,carving,faceted",
                        help="cases to (re)run; the others are taken from benchmarks/data/accuracy-time.json")
    parser.add_argument("--no-renders", dest="renders", action="store_false", help="keep the stored render and budget studies")
    parser.add_argument("--report-only", action="store_true", help="rewrite the report and plots from the stored results")
    parser.add_argument("--budgets-only", action="store_true",
                        help="redo only the time-budget studies (recommend-orientation and compare), keep the rest stored")
    parser.add_argument("--cover-only", action="store_true",
                        help="with --cases: redo only the error-bar coverage against the stored references")
    args = parser.parse_args()
    start = time.perf_counter()
    data = ROOT / "benchmarks" / "data" / "accuracy-time.json"
    stored = json.loads(data.read_text()) if data.exists() else {"cases": [], "renders": []}
    done = {c["case"]: c for c in stored["cases"]}
    if args.report_only or args.budgets_only:
        args.cases, args.renders = "", False
    for c in args.cases.split(","):
        if c and args.cover_only:  # the stored reference, the bars of the code as it is now
            ref = done[c]["reference"]
            mesh = load(c)
            timed(mesh, "draft", 0)
            done[c]["cover"] = cover_study(mesh, np.asarray(ref["normal"]), ref["score"], args.quick)
        elif c:
            done[c] = study_case(c, args.quick)
    renders = render_study(args.quick) if args.renders else stored.get("renders", [])
    redo = args.renders or args.budgets_only
    budgets = budget_study(args.quick) if redo else stored.get("budgets", [])
    compare_budgets = compare_budget_study(args.quick) if redo else stored.get("compare_budgets", [])
    results = [done[c] for c in CASES if c in done]
    whole = set(filter(None, args.cases.split(","))) >= set(CASES) and not args.cover_only and args.renders
    data.write_text(json.dumps({"cases": results, "renders": renders, "budgets": budgets, "compare_budgets": compare_budgets,
                                # the time of the runs behind the data: a whole run's own, a part's added to the rest
                                "seconds": (0.0 if whole else stored.get("seconds", 0.0)) + time.perf_counter() - start},
                               indent=1) + "\n")
    out = Path(args.out)
    images = plot(results, out.parent / "images")
    total = json.loads(data.read_text())["seconds"]
    text = report(results, renders, images, args, total, budgets, compare_budgets)
    # the coverage study of every scenario (benchmarks/scenario_coverage.py) keeps its block, and
    # what follows it up to the time budgets (its prose, benchmarks/direction_convergence.py's block)
    old = out.read_text() if out.exists() else ""
    if COVERAGE_BEGIN in old and COVERAGE_END in old:
        after = old.split(COVERAGE_BEGIN, 1)[1]
        kept = after.split("\n## ", 1)[0]  # up to the next section: the time budgets
        if COVERAGE_END not in kept:  # a page whose next section begins inside the block: the block alone
            kept = after.split(COVERAGE_END, 1)[0] + COVERAGE_END
        block = COVERAGE_BEGIN + kept.rstrip("\n")
        head, sep, tail = text.partition("## Time budgets")
        text = head + block + "\n\n" + sep + tail
    if CALL_BEGIN in old and CALL_END in old:
        block = CALL_BEGIN + old.split(CALL_BEGIN, 1)[1].split(CALL_END, 1)[0] + CALL_END
        anchor = text.find("`labcut compare CUT... --time-budget SECONDS`")
        if anchor >= 0:
            text = text[:anchor] + block + "\n\n" + text[anchor:]
    text = keep_other_sections(old, text)
    out.write_text(text)
    print(f"wrote {out} and {data}")


def keep_other_sections(old: str, new: str) -> str:
    """``new`` with the ``## `` sections of ``old`` that it does not write appended in their order
    (the volume estimator's cost, the stratified samples' spread: other benchmarks' sections)."""
    parts = old.split("\n## ")
    for part in parts[1:]:
        heading = part.split("\n", 1)[0]
        if f"\n## {heading}\n" not in new:
            new = new.rstrip("\n") + "\n\n## " + part.rstrip("\n") + "\n"
    return new


if __name__ == "__main__":
    main()
