"""Throughput of ``labcut batch``: per-row cost and peak memory, sequential vs Dask workers.

    .venv/bin/python benchmarks/batch_throughput.py [--catalog examples/catalog.csv] [--rows N]
        [--quality Q] [--out docs/batch.md] [--json benchmarks/data/batch-throughput.json]

Runs the rows of a catalogue (default: the bundled ``examples/catalog.csv``, 12 rows of the
bundled meshes, standard quality) three ways, each from an empty results store:

1. **sequential**: one Python process calls :func:`labcut.batch.run_row` (read the stone,
   :func:`labcut.recommend_orientation`) row after row, no Dask; Dr.Jit uses every core;
2. **Dask, 1 worker**: :func:`labcut.batch.run` on an embedded ``LocalCluster`` of one worker
   process (Dr.Jit: every core);
3. **Dask, 2 workers**: the same with two worker processes (Dr.Jit: cores / 2 threads each).

Before them every row runs once in a throw-away process so that Dr.Jit's kernel cache is warm
for all three (a row whose kernels are not cached yet compiles them: seconds more). About a
minute on 2 cores for the default catalogue (four passes over its 12 rows at standard quality). Every wall time includes the run's start-up,
also reported apart: for the sequential run starting Python and importing labcut, for a Dask
run starting the cluster and the worker plugin's set-up (the driver has imported labcut). Per-row
seconds are measured around each row on the process that ran it; peak memory is the largest
resident set (``ru_maxrss``) of that process after its rows. Writes the table between the
``batch-throughput`` markers of ``--out`` (default docs/batch.md; ``-`` prints it only) and the
raw figures (every row's seconds, each run's wall time, start-up, threads, peak memory, the
machine and its load) to ``--json`` (default benchmarks/data/batch-throughput.json; ``-``: none).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BEGIN, END = "<!-- batch-throughput:begin -->", "<!-- batch-throughput:end -->"


def _catalog(path: str, rows: int | None, quality: str | None):
    from labcut.batch import read_catalog
    from labcut.batch.catalog import Defaults

    cat = read_catalog(path, Defaults(quality=quality or "standard"))
    return cat.rows[:rows] if rows else cat.rows


def child(args: argparse.Namespace) -> None:
    """Run rows in this process, no Dask; print one JSON line of per-row seconds and peak RSS."""
    from labcut.batch import run_row  # first: labcut sets Dr.Jit's kernel cache and libLLVM before drjit loads
    from labcut.batch.plugin import cores

    import drjit as dr

    dr.set_thread_count(cores())
    rows = _catalog(args.catalog, args.rows, args.quality)
    t0 = time.perf_counter()
    records = [run_row(r) for r in rows]
    wall = time.perf_counter() - t0
    bad = [r["error"] for r in records if r["status"] != "ok"]
    if bad:
        raise SystemExit(f"a row failed: {bad[0]}")
    print(json.dumps({"wall": wall, "seconds": [r["seconds"] for r in records],
                      "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}))


def sequential(args: argparse.Namespace) -> dict:
    cmd = [sys.executable, __file__, "--child", "--catalog", args.catalog]
    if args.rows:
        cmd += ["--rows", str(args.rows)]
    if args.quality:
        cmd += ["--quality", args.quality]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"sequential run failed:\n{proc.stderr[-2000:]}")
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    # the whole process, as a Dask run's wall includes its cluster: start-up is Python and the imports
    return {**result, "rows_wall": result["wall"], "wall": wall, "startup": wall - result["wall"]}


def dask_run(args: argparse.Namespace, workers: int) -> dict:
    from labcut.batch import run
    from labcut.batch.catalog import Catalog

    rows = _catalog(args.catalog, args.rows, args.quality)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        result = run(Catalog(Path(args.catalog), list(rows)), out=Path(tmp) / "r.parquet", workers=workers)
        wall = time.perf_counter() - t0
    records = result.records()
    if result.failed:
        raise SystemExit(f"a row failed: {[r['error'] for r in records if r['status'] != 'ok'][0]}")
    return {"wall": wall, "startup": result.startup_seconds, "seconds": [r["seconds"] for r in records],
            "peak_mib": max(r["worker_peak_rss_mib"] for r in records),
            "threads": sorted({w["threads"] for w in result.workers})}


def table(results: list[tuple[str, dict]], n: int, cores: int) -> str:
    base = results[0][1]["wall"]
    lines = ["| run | Dr.Jit threads per process | wall s | of which start-up s | rows/min | speed-up vs sequential "
             "| per row s: mean (min-max) | peak memory per process MiB |",
             "|---|---|---|---|---|---|---|---|"]
    for label, r in results:
        s = r["seconds"]
        threads = "/".join(map(str, r.get("threads", [cores])))
        startup = f"{r['startup']:.1f}"
        lines.append(f"| {label} | {threads} | {r['wall']:.1f} | {startup} | {60 * n / r['wall']:.1f} | "
                     f"{base / r['wall']:.2f}x | {statistics.mean(s):.2f} ({min(s):.2f}-{max(s):.2f}) | {r['peak_mib']:.0f} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--catalog", default=str(ROOT / "examples" / "catalog.csv"))
    parser.add_argument("--rows", type=int, default=None, help="the first N rows only (default: all)")
    parser.add_argument("--quality", default=None, help="quality of rows that do not say (default: standard)")
    parser.add_argument("--out", default=str(ROOT / "docs" / "batch.md"))
    parser.add_argument("--json", default=str(ROOT / "benchmarks" / "data" / "batch-throughput.json"),
                        help="raw figures as JSON ('-': not written)")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args)
        return

    from labcut import __version__
    from labcut.batch.plugin import cores

    n = len(_catalog(args.catalog, args.rows, args.quality))
    ncores = cores()
    load0 = os.getloadavg()[0]
    warm = sequential(args)  # every row once: the kernel cache is warm for every run below
    results = [("sequential (one process, no Dask)", sequential(args)),
               ("Dask, 1 worker", dask_run(args, 1)),
               ("Dask, 2 workers", dask_run(args, 2))]
    load1 = os.getloadavg()[0]
    try:
        catalog = str(Path(args.catalog).resolve().relative_to(ROOT))
    except ValueError:
        catalog = args.catalog
    trim = os.environ.get("MALLOC_TRIM_THRESHOLD_")  # set: every process of the runs inherits it (docs/batch.md)
    cmd = (f"MALLOC_TRIM_THRESHOLD_={trim} " if trim is not None else "") + ".venv/bin/python benchmarks/batch_throughput.py"
    extra = "".join(f" --{k} {v}" for k, v in (("rows", args.rows), ("quality", args.quality)) if v)
    report = "\n".join([
        BEGIN,
        f"`{cmd}{extra}` (labcut {__version__}, {datetime.now(timezone.utc):%Y-%m-%d}): {n} rows of "
        f"`{catalog}`, {args.quality or 'standard'} quality where a row does not say; {ncores} cores "
        f"({platform.processor() or platform.machine()}), load average {load0:.1f} before and {load1:.1f} after; "
        "Dr.Jit's kernel cache warm.",
        "",
        table(results, n, ncores),
        END,
    ])
    print(report)
    if args.json != "-":
        raw = {"kind": "labcut.benchmark.batch_throughput", "labcut_version": __version__,
               "date": datetime.now(timezone.utc).isoformat(timespec="seconds"), "command": f"{cmd}{extra}",
               "catalogue": catalog, "rows": n, "quality": args.quality or "standard", "cores": ncores,
               "processor": platform.processor() or platform.machine(), "python": platform.python_version(),
               "malloc_trim_threshold": trim, "load_average_before": load0, "load_average_after": load1, "warm_up_wall": warm["wall"],
               "runs": [{"run": label, **r} for label, r in results]}
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(raw, indent=1) + "\n")
        print(f"raw figures written to {args.json}")
    if args.out == "-":
        return
    out = Path(args.out)
    text = out.read_text()
    if BEGIN not in text or END not in text:
        raise SystemExit(f"{out} has no {BEGIN} ... {END} section to replace")
    head, rest = text.split(BEGIN, 1)
    out.write_text(head + report + rest.split(END, 1)[1])
    print(f"written to {out}")


if __name__ == "__main__":
    main()
