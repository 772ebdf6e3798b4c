"""Where a warm standard recommendation spends its time, stage by stage (issue 17 §4).

    .venv/bin/python benchmarks/recommend_stages.py [--out docs/performance.md] [--calls N]

The bundled oval cabochon under the ``bench`` scenario, standard quality, the blue preset: after
three warm-up calls, ``N`` (default 20) further calls of ``labcut.recommend_orientation`` in one
process, each stage timed by wrapping the function that does it (``time.perf_counter``; a stage
that calls another includes it; a kernel launched in one stage and read in another counts where
it is waited for). Medians and minima over the calls; the table replaces the
section between the ``recommend-stages`` markers of the report (printed too). Figures move by
±30 % with other load on the machine; the shares are steadier than the seconds.
"""

from __future__ import annotations

import argparse
import platform
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BEGIN, END = "<!-- recommend-stages: begin -->", "<!-- recommend-stages: end -->"

#: (module, function, what it is) in the order a recommendation runs them
STAGES = [
    ("labcut.orientation.recommend", "_setup", "plan the effects and build the answer's flash problem"),
    ("labcut.planner", "plan_effects", "the effect planner (inside the set-up)"),
    ("labcut.orientation.recommend", "build_problem", "the answer's flash problem (inside the set-up)"),
    ("labcut.orientation.scoring", "Scorer.launch_energy_map", "bin the triples, set up the tile-culled map, launch the hemisphere map's kernel"),
    ("labcut.orientation.scoring", "Scorer._bin_triples", "bin the triples by mirror orientation (inside the line above)"),
    ("labcut.orientation.scoring", "SparseLobeMap.__init__", "the map's tiles (inside the line above the binning)"),
    ("labcut.orientation.recommend", "run_optimizer", "NLopt: DIRECT-L while the map's kernel runs, then the L-BFGS polishes from the map's best cells (waiting for the map)"),
    ("labcut.orientation.recommend", "tolerance_deg", "every tolerance search: the answer's, the base's, the two axes'"),
    ("labcut.orientation.recommend", "axis_tolerances", "front-to-back and side-to-side tolerances (inside the line above)"),
    ("labcut.orientation.recommend", "_runners_up", "distinct runner-up optima"),
    ("labcut.orientation.recommend", "uncertainty_for", "the error bars, in all"),
    ("labcut.orientation.pairs", "build_pairs", "the error bars' two discretisation problems, as pairs (half the directions, twice the poses)"),
    ("labcut.orientation.uncertainty", "objective_values", "the bootstrap's replicates (the three stencil kernels run meanwhile)"),
    ("labcut.orientation.uncertainty", "fit_peaks", "the quadratic fits of the replicates and of the two discretisation problems"),
    ("labcut.orientation.scoring", "Scorer.metrics", "the answer's flash metrics (its every-triple sums came with the error bars' stencil)"),
]


def _label(module: str, name: str) -> str:
    """A stage's label: its module's last name and the function's."""
    return f"{module.rsplit('.', 1)[-1]}.{name}"


def measure(calls: int) -> tuple[list[str], dict[str, list[float]]]:
    import labcut
    from compare_benchmark import timed  # the same stage timers (this folder is on sys.path)

    per_call: dict[str, float] = {}
    labels = [_label(mod, name) for mod, name, _ in STAGES]
    timed(per_call, [(mod, name, _label(mod, name)) for mod, name, _ in STAGES])
    mesh = labcut.load_mesh(ROOT / "meshes" / "oval-16x12-low.ply")
    lab = labcut.Labradorite.preset("blue")
    for _ in range(3):
        labcut.recommend_orientation(mesh, lab, scenario="bench", quality="standard")
    out: dict[str, list[float]] = {k: [] for k in ["total", *labels]}
    for _ in range(calls):
        per_call.clear()
        t = time.perf_counter()
        labcut.recommend_orientation(mesh, lab, scenario="bench", quality="standard")
        out["total"].append(time.perf_counter() - t)
        for k in labels:
            out[k].append(per_call.get(k, 0.0))
    return labels, out


def table(labels: list[str], out: dict[str, list[float]], calls: int) -> list[str]:
    total = float(np.median(out["total"]))
    what = {_label(m, a): w for m, a, w in STAGES}
    rows = [f"Made by `.venv/bin/python benchmarks/recommend_stages.py` on {platform.machine()}, {calls} warm calls of the "
            "standard recommendation of `meshes/oval-16x12-low.ply` under `bench` in one process (stages nest: "
            "the set-up holds the planner and the answer's problem, the error bars their problems and sums; a "
            "Dr.Jit kernel launched in one stage runs on Dr.Jit's threads while the host goes on, and counts "
            "in the stage that waits for it).", "",
            "| stage | what | median | min | share of the median call |", "|---|---|---|---|---|",
            f"| whole call | `labcut.recommend_orientation` | {total * 1e3:.0f} ms | {min(out['total']) * 1e3:.0f} ms | 100 % |"]
    for k in labels:
        med = float(np.median(out[k]))
        rows.append(f"| `{k}` | {what[k]} | {med * 1e3:.1f} ms | {min(out[k]) * 1e3:.1f} ms | {med / total:.0%} |")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "performance.md"))
    parser.add_argument("--calls", type=int, default=20)
    args = parser.parse_args()
    labels, out = measure(args.calls)
    rows = table(labels, out, args.calls)
    print("\n".join(rows))
    section = "\n".join([BEGIN, "", *rows, "", END])
    path = Path(args.out)
    text = path.read_text()
    if BEGIN in text and END in text:
        head, rest = text.split(BEGIN, 1)
        text = head + section + rest.split(END, 1)[1]
    else:
        text = text.rstrip("\n") + "\n\n" + section + "\n"
    path.write_text(text)
    print(f"written to {path}")


if __name__ == "__main__":
    main()
