"""How far the default answer moves with the surface samples' seed: random against stratified samples.

The sample estimator scores a lamella normal from ``surface_points`` samples of the stone's surface
(8,000 at standard). A flash lives on a small patch of a dome, and its energy is that patch's share of
the samples: drawn at random, that share scatters by its square root, and on a flat-topped score the
optimum follows the scatter. Stratified samples (one in each of as many equal-area stretches of the
faces along a Morton curve, :func:`labcut.geometry.surface.draw_samples`) hold every patch's share to
within one or two. Per case: the default recommendation's tilt and 90 % tolerance over ``--seeds``
seeds with each sampling (sample estimator, quality standard otherwise), their mean and standard
deviation, and the converged tilt (``--converged`` random points, the mean of ``--seeds`` seeds).
Results in ``benchmarks/data/sampling_spread.json`` and as a markdown table (docs/accuracy.md,
"Stratified surface samples").

    .venv/bin/python benchmarks/sampling_spread.py [--seeds 8] [--converged 400000]
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import labcut  # noqa: E402
from volume_reference import STONES, case_lights  # noqa: E402

DATA = ROOT / "benchmarks" / "data" / "sampling_spread.json"
DOC = ROOT / "docs" / "accuracy.md"
BEGIN, END = "<!-- SAMPLING-SPREAD:BEGIN -->", "<!-- SAMPLING-SPREAD:END -->"
CASES = [(stone, lamp) for stone in ("low oval", "medium oval", "high oval") for lamp in ("lamp 35° in front", "overhead lamp")]


def answers(mesh: object, lights: labcut.Lights, sampling: str, points: int, seeds: int) -> list[dict]:
    """The sample estimator's answer at standard quality with ``points`` samples placed by ``sampling``,
    once per seed."""
    q = labcut.Quality.coerce("standard").replace(surface_points=points, surface_sampling=sampling)
    out = []
    for seed in range(seeds):
        rec = labcut.recommend_orientation(mesh, material=labcut.Labradorite(), lighting=lights, viewing="face-up",
                                           quality=q, estimator="samples", seed=seed)
        out.append({"seed": seed, "tilt_deg": rec.tilt_deg, "tolerance_deg": rec.tolerance_deg,
                    "normal": [float(x) for x in rec.normal]})
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=8)
    parser.add_argument("--converged", type=int, default=400_000, help="random points of the converged answer")
    parser.add_argument("--report-only", action="store_true", help="rewrite the docs' table from the stored results")
    args = parser.parse_args()
    if args.report_only:
        write_doc(json.loads(DATA.read_text()))
        return
    lights = case_lights()
    rows = []
    for stone, lamp in CASES:
        mesh = labcut.load_mesh(ROOT / STONES[stone])
        row: dict = {"stone": stone, "lamp": lamp}
        for sampling in ("random", "stratified"):
            t0 = time.perf_counter()
            row[sampling] = answers(mesh, lights[lamp], sampling, 8_000, args.seeds)
            row[f"{sampling}_seconds"] = time.perf_counter() - t0
        row["converged"] = answers(mesh, lights[lamp], "random", args.converged, min(args.seeds, 4))
        rows.append(row)
        print(stone, lamp, {k: [round(a["tilt_deg"], 2) for a in row[k]] for k in ("random", "stratified", "converged")},
              flush=True)
    data = {"rows": rows, "seeds": args.seeds, "converged_points": args.converged,
            "machine": f"{platform.machine()}, Python {platform.python_version()}"}
    DATA.parent.mkdir(parents=True, exist_ok=True)
    DATA.write_text(json.dumps(data, indent=1))
    print()
    print(table(rows))
    write_doc(data)


def write_doc(data: dict) -> None:
    """The table between the markers of docs/accuracy.md, with the command and the machine."""
    text = DOC.read_text()
    if BEGIN not in text or END not in text:
        raise SystemExit(f"{DOC} has no {BEGIN} ... {END} block")
    seconds = sum(r["random_seconds"] + r["stratified_seconds"] for r in data["rows"])
    body = (f"Measured with `.venv/bin/python benchmarks/sampling_spread.py --seeds {data['seeds']} --converged "
            f"{data['converged_points']}` ({data['machine']}, 2 cores; {seconds / 60:.1f} min for the 8,000-point answers). "
            f"Sample estimator, quality standard otherwise, the comparison's lamps (docs/physics-accuracy.md §7); "
            f"*converged*: the mean of {min(data['seeds'], 4)} seeds' answers at {data['converged_points']:,} random points; "
            f"tilts as mean ± standard deviation over the seeds, *farthest* the largest distance of a seed's tilt from the "
            f"converged one.\n\n" + table(data["rows"]))
    head, rest = text.split(BEGIN, 1)
    DOC.write_text(head + BEGIN + "\n" + body + "\n" + END + rest.split(END, 1)[1])


def table(rows: list[dict]) -> str:
    """The markdown table of docs/accuracy.md: tilt mean ± standard deviation over the seeds per
    sampling, the largest distance of a seed's tilt from the converged one, the tolerance's spread."""
    out = ["| stone | lamp | converged tilt | random: tilt | farthest from converged | tolerance | stratified: tilt | "
           "farthest from converged | tolerance |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        conv = float(np.mean([a["tilt_deg"] for a in r["converged"]]))
        cells = [r["stone"], r["lamp"], f"{conv:.2f}°"]
        for sampling in ("random", "stratified"):
            t = np.array([a["tilt_deg"] for a in r[sampling]])
            tol = np.array([a["tolerance_deg"] for a in r[sampling]])
            cells += [f"{t.mean():.2f}° ± {t.std(ddof=1):.2f}°", f"{np.abs(t - conv).max():.2f}°",
                      f"±{tol.mean():.2f}° ± {tol.std(ddof=1):.2f}°"]
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


if __name__ == "__main__":
    main()
