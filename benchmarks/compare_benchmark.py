"""How long a cut comparison takes: 3 bundled cabochons x 2 scenarios at standard quality (issue 11:
at most 30 s on 2 cores), split by stage, and the report's files.

    .venv/bin/python benchmarks/compare_benchmark.py [--quality standard] [--scenario bench --scenario pendant]
        [--repeat 2] [--threads N] [--json PATH]

Prints a markdown table (the "Speed" section of docs/compare.md). Run 1 includes kernel
compilation unless Dr.Jit's kernel cache is warm; later runs are warm. The machine's load average
is printed with it: on a shared machine wall times grow with the load, while the CPU time (all
threads of the process) does not; on an idle machine with ``c`` cores the wall time lies between
CPU / c and CPU.
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CUTS = [str(ROOT / "meshes" / f"oval-16x12-{dome}.ply") for dome in ("low", "medium", "high")]

#: the stages of a comparison: module, function
STAGES = [
    ("labcut.study", "Study.recommend", "recommendation (Study.recommend, its misorientation curve included)"),
    ("labcut.reports.analysis", "tilt_curve", "tilt-performance curve"),
    ("labcut.reports.renders", "render_cut", "renders: main, rocking strip, schiller-only"),
    ("labcut.reports.flashcolour", "flash_colour_map", "flash-colour map"),
    ("labcut.reports.analysis", "compromise", "compromise orientation"),
]


def timed(stages: dict[str, float], spec: list[tuple[str, str, str]] | None = None) -> None:
    """Wrap each stage's function (where its caller looks it up: ``(module, name, label)``, a name
    ``Class.method`` for a method; default :data:`STAGES`) to add its wall time to ``stages[label]``.
    ``benchmarks/recommend_stages.py`` times a recommendation's stages with it too."""
    import importlib

    for module, name, label in STAGES if spec is None else spec:
        owner: object = importlib.import_module(module)
        attr = name
        if "." in name:  # a method
            cls, attr = name.split(".")
            owner = getattr(owner, cls)
        original = getattr(owner, attr)

        def wrapper(*args, __f=original, __label=label, **kwargs):
            t0 = time.perf_counter()
            try:
                return __f(*args, **kwargs)
            finally:
                stages[__label] = stages.get(__label, 0.0) + time.perf_counter() - t0

        setattr(owner, attr, wrapper)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quality", default="standard")
    parser.add_argument("--scenario", action="append", default=None)
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--threads", type=int, default=None, help="Dr.Jit threads (default: every core)")
    parser.add_argument("--json", type=Path, default=None,
                        help="also write every run's figures and the last run's ratio here (benchmarks/speed_ratio.py --compare)")
    args = parser.parse_args()
    scenarios = args.scenario or ["bench", "pendant"]

    import drjit as dr

    import labcut

    if args.threads:
        dr.set_thread_count(args.threads)
    stages: dict[str, float] = defaultdict(float)
    timed(stages)
    runs = []
    for k in range(args.repeat):
        stages.clear()
        load0 = os.getloadavg()[0]
        c0, t0 = time.process_time(), time.perf_counter()
        cmp = labcut.compare_cuts(CUTS, "blue", scenarios, quality=args.quality)
        compute, cpu = time.perf_counter() - t0, time.process_time() - c0
        with tempfile.TemporaryDirectory() as tmp:
            t1 = time.perf_counter()
            cmp.save_html(Path(tmp) / "r.html")
            html = time.perf_counter() - t1
            t2 = time.perf_counter()
            cmp.save_json(Path(tmp) / "r.json")
            cmp.save_csv(Path(tmp) / "r.csv")
            files = time.perf_counter() - t2
            sizes = {p.suffix: p.stat().st_size for p in Path(tmp).iterdir()}
        runs.append({"compute": compute, "cpu": cpu, "html": html, "files": files, "stages": dict(stages), "load": load0, "sizes": sizes})

    print(f"# labcut compare: {len(CUTS)} bundled ovals x {len(scenarios)} scenarios ({', '.join(scenarios)}), "
          f"{args.quality} quality\n")
    print(f"{platform.machine()}, {os.cpu_count()} cores, Dr.Jit {dr.__version__} ({labcut.backend.device()} backend), "
          f"{dr.thread_count()} threads\n")
    print("| run | load avg | compare_cuts | its CPU time (all threads) | save_html | JSON + CSV |")
    print("|---|---|---|---|---|---|")
    for i, r in enumerate(runs, 1):
        print(f"| {i}{' (cold)' if i == 1 else ''} | {r['load']:.1f} | {r['compute']:.1f} s | {r['cpu']:.1f} s | "
              f"{r['html']:.1f} s | {r['files']:.1f} s |")
    last = runs[-1]
    print(f"\nStages of the last run (sum over {len(CUTS) * len(scenarios)} cut x scenario steps):\n")
    print("| stage | seconds | share |")
    print("|---|---|---|")
    for _, _, label in STAGES:
        v = last["stages"].get(label, 0.0)
        print(f"| {label} | {v:.1f} | {v / last['compute']:.0%} |")
    recs, renders = (last["stages"].get(STAGES[k][2], 0.0) for k in (0, 2))
    print(f"\nThe comparison against its own six recommendations plus its renders (issue 36: at most 1.3x): "
          f"{last['compute']:.1f} s / ({recs:.1f} s + {renders:.1f} s) = {last['compute'] / (recs + renders):.2f}x")
    print(f"\nFiles: HTML {last['sizes'].get('.html', 0) / 1e6:.1f} MB, JSON {last['sizes'].get('.json', 0) / 1e6:.1f} MB, "
          f"CSV {last['sizes'].get('.csv', 0) / 1e6:.1f} MB")
    if args.json is not None:
        import json

        args.json.write_text(json.dumps({"cuts": len(CUTS), "scenarios": scenarios, "quality": args.quality, "runs": runs,
                                         "recommendations": recs, "renders": renders,
                                         "ratio": last["compute"] / (recs + renders)}, indent=1) + "\n")


if __name__ == "__main__":
    main()
