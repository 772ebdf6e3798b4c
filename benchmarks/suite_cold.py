"""The test suite on a machine that has never run it, then again (docs/performance.md, "The test
suite cold and warm").

    .venv/bin/python benchmarks/suite_cold.py [--workers 2] [--json /tmp/suite-cold.json]
    .venv/bin/python benchmarks/suite_cold.py --workers 0 --cold-only tests/test_bsdf.py ...   # some files, one process

CI runs ``make test`` on a fresh machine: Dr.Jit's kernel cache (``~/.drjit``) and labcut's user
cache (pilot renders, timing calibrations, depth exposures, convexity, tables) are empty, so every
kernel compiles and every cached figure is measured inside the tests. This script runs the suite as
``make test`` does (``pytest -n 2 --dist worksteal tests``) twice with ``HOME`` set to a new empty
folder: first cold, then warm (the same folder, now filled). For each run: wall and CPU seconds of
pytest and its workers, every test's seconds (``--durations=0``), and through the plugin
``benchmarks/suite_kernels.py`` the Dr.Jit kernels each test compiled and their LLVM compile
seconds. Prints a markdown summary: the totals, the compile seconds by test file, and the tests that
cost most more cold than warm. About 22 minutes on 2 cores. ``--cold-only`` runs the cold half
alone; test paths after the options run those files instead of ``tests``; ``--workers 0`` runs them
in pytest's own process (no kernel compiled twice by two workers: the counts compare between runs).
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DURATION = re.compile(r"^\s*([\d.]+)s (call|setup|teardown)\s+(tests/\S+)")


def run(home: Path, workers: int, kernels: Path, paths: list[str]) -> dict:
    """One run of the suite with ``HOME=home``; its figures."""
    kernels.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "HOME": str(home), "SUITE_KERNELS_DIR": str(kernels),
           "PYTHONPATH": os.pathsep.join([str(ROOT / "benchmarks"), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)}
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # as CI's shell
    spread = ["-n", str(workers), "--dist", "worksteal"] if workers > 0 else []
    cmd = [sys.executable, "-m", "pytest", "-q", *spread, "-p", "suite_kernels", "--durations=0", *paths]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    tests: dict[str, float] = collections.defaultdict(float)
    for line in proc.stdout.splitlines():
        m = DURATION.match(line)
        if m:
            tests[m.group(3)] += float(m.group(1))
    compiled = [r for f in sorted(kernels.glob("kernels-*.json")) for r in json.loads(f.read_text())]
    summary = proc.stdout.strip().splitlines()[-1] if proc.stdout.strip() else ""
    return {"returncode": proc.returncode, "summary": summary, "wall_s": wall,
            "cpu_s": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime),
            "tests": dict(tests), "compiled": compiled}


def report(cold: dict, warm: dict | None) -> str:
    out = ["| run | result | wall | CPU | kernels compiled | their compile time |", "|---|---|---|---|---|---|"]
    for name, r in (("cold", cold), ("warm", warm)):
        if r is None:
            continue
        ms = sum(k["compile_ms"] for k in r["compiled"])
        out.append(f"| {name} | {r['summary']} | {r['wall_s']:.0f} s | {r['cpu_s']:.0f} s | {len(r['compiled'])} | "
                   f"{ms / 1e3:.0f} s |")
    by_file: dict[str, float] = collections.defaultdict(float)
    for k in cold["compiled"]:
        by_file[k["test"].split("::")[0]] += k["compile_ms"] / 1e3
    out += ["", "Compile seconds of the cold run by test file (the first 15):", "",
            "| file | compile s |", "|---|---|"]
    out += [f"| `{f}` | {s:.1f} |" for f, s in sorted(by_file.items(), key=lambda x: -x[1])[:15]]
    if warm is None:
        return "\n".join(out)
    gap = sorted(((cold["tests"].get(t, 0.0) - warm["tests"].get(t, 0.0), t) for t in cold["tests"]), reverse=True)
    compiles = collections.defaultdict(float)
    for k in cold["compiled"]:
        compiles[k["test"]] += k["compile_ms"] / 1e3
    out += ["", "The tests that cost most more cold than warm (the first 15):", "",
            "| test | cold s | warm s | kernels compiled cold (s) |", "|---|---|---|---|"]
    for _, t in gap[:15]:
        out.append(f"| `{t}` | {cold['tests'][t]:.1f} | {warm['tests'].get(t, 0.0):.1f} | {compiles.get(t, 0.0):.1f} |")
    return "\n".join(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", type=Path, default=None, help="write the raw figures here")
    ap.add_argument("--cold-only", action="store_true", help="the cold run alone")
    ap.add_argument("paths", nargs="*", default=["tests"], help="test files or folders (default: tests)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="labcut-suite-") as tmp:
        home = Path(tmp) / "home"
        home.mkdir()
        cold = run(home, args.workers, Path(tmp) / "kernels-cold", args.paths)
        warm = None if args.cold_only else run(home, args.workers, Path(tmp) / "kernels-warm", args.paths)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"workers": args.workers, "cold": cold, "warm": warm}))
    print(report(cold, warm))


if __name__ == "__main__":
    main()
