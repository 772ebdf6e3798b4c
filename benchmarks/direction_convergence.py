"""How fast do the answers converge in their light and view directions? (the error bars' factor)

    .venv/bin/python benchmarks/direction_convergence.py [--stones oval,srb] [--scenarios bench,...]
        [--qualities draft,standard] [--fresh] [--report-only] [--out docs/accuracy.md]

The error bars (:mod:`labcut.orientation.uncertainty`) measure a quality's direction sets by the
distance ``d`` from its answer to the answer with twice as many directions per lamp, environment
map, viewing cone and ring, and state ``DIRECTION_FACTOR x d``. If the error falls by a ratio
``r`` per doubling, the doubled set's answer is ``(1 - 1/r)`` of the error away, so the error is
``r / (r - 1)`` times ``d``. This benchmark measures ``r``:

for the low oval and the SRB brilliant (10 mm girdle) under every scenario, at draft and standard,
the answers with the quality's directions (x1), twice (x2) and four times (x4) as many, at the
quality's surface samples and one seed. ``r = angle(x1, x2) / angle(x2, x4)``. Cases whose
``angle(x2, x4)`` is below :data:`NOISE_DEG` (converged: nothing to measure) are left out of the
ratio. The report gives each case, the pooled ratio (sum of the first differences over the sum of
the second) and the median, and the factor ``r / (r - 1)`` of each.

Results are kept in ``benchmarks/data/direction_convergence.json`` (a rerun reuses every finished
case; ``--fresh`` starts over). The report goes between the ``DIRECTION-CONVERGENCE`` markers of
``--out``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from accuracy_time import angle  # noqa: E402  (this folder's helpers)
from scenario_coverage import load, splice, write_json  # noqa: E402

STONES = ("oval", "srb")
QUALITIES = ("draft", "standard")
MULTIPLES = (1, 2, 4)
SEED = 1
#: a second difference below this (degrees) is converged: its ratio says nothing
NOISE_DEG = 0.05
DATA = ROOT / "benchmarks" / "data" / "direction_convergence.json"
BEGIN, END = "<!-- DIRECTION-CONVERGENCE:BEGIN -->", "<!-- DIRECTION-CONVERGENCE:END -->"


def directions_times(quality, k: int):
    """``quality`` with ``k`` times its directions per lamp, map, cone and ring (its surface
    samples kept)."""
    return quality.replace(name=f"{quality.name} x{k} directions", lamp_samples=k * quality.lamp_samples,
                           env_samples=k * quality.env_samples, cone_views=k * quality.cone_views,
                           ring_views=k * quality.ring_views)


def case(mesh, scenario: str, quality: str) -> dict:
    import labcut
    from labcut.scene.quality import Quality

    q = Quality.coerce(quality)
    rows = []
    for k in MULTIPLES:
        t = time.perf_counter()
        rec = labcut.recommend_orientation(mesh, "blue", scenario=scenario, quality=directions_times(q, k), seed=SEED)
        rows.append({"multiple": k, "normal": [float(x) for x in rec.normal], "score": float(rec.score),
                     "directions_angle_deg": float(rec.uncertainty.directions_angle_deg),
                     "bar_deg": float(rec.uncertainty.angle_deg), "estimator": rec.estimator,
                     "seconds": time.perf_counter() - t})
    d1 = angle(rows[0]["normal"], rows[1]["normal"])
    d2 = angle(rows[1]["normal"], rows[2]["normal"])
    return {"scenario": scenario, "quality": quality, "answers": rows, "d1_deg": d1, "d2_deg": d2,
            "error_x1_to_x4_deg": angle(rows[0]["normal"], rows[2]["normal"])}


def factor(r: float) -> float:
    """``r / (r - 1)``: the error over the difference to twice as many at a ratio ``r`` per doubling."""
    return r / (r - 1.0) if r > 1.0 else math.inf


def summary(cases: list[dict]) -> dict:
    measured = [c for c in cases if c["d2_deg"] >= NOISE_DEG]
    ratios = np.array([c["d1_deg"] / c["d2_deg"] for c in measured]) if measured else np.array([])
    pooled = (sum(c["d1_deg"] for c in measured) / sum(c["d2_deg"] for c in measured)) if measured else math.nan
    return {"cases": len(cases), "measured": len(measured), "pooled_ratio": pooled,
            "median_ratio": float(np.median(ratios)) if len(ratios) else math.nan,
            "quartiles": [float(x) for x in np.percentile(ratios, [25, 75])] if len(ratios) else [],
            "below_2": int(np.sum(ratios < 2.0)), "below_3": int(np.sum(ratios < 3.0))}


def report(results: dict, seconds: float) -> str:
    from labcut.orientation.uncertainty import DIRECTION_FACTOR

    cpu = platform.processor() or platform.machine()
    lines = [BEGIN, "", "### How fast the direction sets converge", "",
             f"Made by `.venv/bin/python benchmarks/direction_convergence.py` on {os.cpu_count()} cores ({cpu}), "
             f"{seconds / 60:.0f} min in all; results kept in `benchmarks/data/direction_convergence.json`. Each row: "
             f"the answers (seed {SEED}) with the quality's light and view directions (x1), twice (x2) and four times "
             "(x4) as many per lamp, map, viewing cone and ring, at the quality's surface samples; *d1* = angle(x1, x2), "
             "*d2* = angle(x2, x4), *r* = d1 / d2, the ratio by which the error falls per doubling. "
             f"Rows with d2 below {NOISE_DEG}° are converged and left out of the ratios (r shown as -).", "",
             "| stone | scenario | quality | d1 | d2 | r | x1 to x4 | bar's d (x1) | seconds |",
             "|---|---|---|---|---|---|---|---|---|"]
    all_cases = []
    for key in sorted(results, key=lambda k: (results[k]["stone"], results[k]["scenario"], results[k]["quality"])):
        c = results[key]
        all_cases.append(c)
        r = f"{c['d1_deg'] / c['d2_deg']:.2f}" if c["d2_deg"] >= NOISE_DEG else "-"
        lines.append(f"| {c['stone']} | {c['scenario']} | {c['quality']} | {c['d1_deg']:.2f}° | {c['d2_deg']:.2f}° | {r} | "
                     f"{c['error_x1_to_x4_deg']:.2f}° | {c['answers'][0]['directions_angle_deg']:.2f}° | "
                     f"{sum(a['seconds'] for a in c['answers']):.1f} s |")
    s = summary(all_cases)
    q = ", ".join(f"{x:.2f}" for x in s["quartiles"])
    lines += ["", f"{s['measured']} of {s['cases']} cases measured: pooled r = {s['pooled_ratio']:.2f} (factor "
              f"{factor(s['pooled_ratio']):.2f}), median r = {s['median_ratio']:.2f} (factor {factor(s['median_ratio']):.2f}; "
              f"quartiles {q}); r below 2 in {s['below_2']}, below 3 in {s['below_3']}. The code's `DIRECTION_FACTOR`: "
              f"{DIRECTION_FACTOR:g}.", "", END]
    return "\n".join(lines)


def main() -> None:
    from labcut.scene.scenario import SCENARIOS

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stones", default=",".join(STONES))
    parser.add_argument("--scenarios", default=",".join(SCENARIOS.names()))
    parser.add_argument("--qualities", default=",".join(QUALITIES))
    parser.add_argument("--out", default=str(ROOT / "docs" / "accuracy.md"))
    parser.add_argument("--fresh", action="store_true", help="recompute every case")
    parser.add_argument("--report-only", action="store_true", help="rewrite the report from the kept results")
    args = parser.parse_args()
    kept = {} if args.fresh or not DATA.exists() else json.loads(DATA.read_text())
    results = dict(kept.get("results", {}))
    seconds = float(kept.get("seconds", 0.0))
    if not args.report_only:
        for stone in args.stones.split(","):
            mesh = None
            for scenario in args.scenarios.split(","):
                for quality in args.qualities.split(","):
                    key = f"{stone}/{scenario}/{quality}"
                    if key in results:
                        continue
                    mesh = load(stone) if mesh is None else mesh
                    t = time.perf_counter()
                    res = case(mesh, scenario, quality)
                    res["stone"] = stone
                    results[key] = res
                    seconds += time.perf_counter() - t
                    r = res["d1_deg"] / res["d2_deg"] if res["d2_deg"] > 0 else math.inf
                    print(f"{key}: d1 {res['d1_deg']:.2f}°, d2 {res['d2_deg']:.2f}°, r {r:.2f}, "
                          f"{time.perf_counter() - t:.1f} s", flush=True)
                    write_json(DATA, {"seconds": seconds, "results": results})
    block = report(results, seconds)
    print(block)
    if args.out != "-":
        splice(Path(args.out), block, BEGIN, END, anchor="## Time budgets")


if __name__ == "__main__":
    main()
