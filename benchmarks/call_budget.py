"""Whole-call time budgets: ``labcut recommend-orientation NEW_MESH --time-budget 2`` from the shell,
on stones labcut has never seen (each bundled stone scaled by a factor no run used before, so no
cache of the stone or of its pilot renders holds it), the first call (cold) and the same call again
(warm). Prints a markdown table of wall seconds, with the interpreter's start-up (``python -c
pass``) and the CLI's imports (``python -c "import labcut_cli.app"``) for scale.

    .venv/bin/python benchmarks/call_budget.py [--budget 2] [MESH ...]

The machine's one-time calibrations (kept in the user cache) are assumed made (any earlier
``make test`` or ``make demo`` made them): they are measured once per machine and labcut version.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

import trimesh

ROOT = Path(__file__).resolve().parents[1]
EXE = Path(sys.executable).with_name("labcut")
MESHES = ["carving-biplane.ply", "oval-16x12-medium.ply", "round-12-high.ply", "buff-top-oval-16x12.ply"]


def wall(cmd: list[str]) -> tuple[float, subprocess.CompletedProcess[str]]:
    t = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    return time.perf_counter() - t, proc


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--budget", type=float, default=2.0)
    ap.add_argument("meshes", nargs="*")
    args = ap.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="labcut-budget-"))
    start = min(wall([sys.executable, "-c", "pass"])[0] for _ in range(3))
    imports = min(wall([sys.executable, "-c", "import labcut_cli.app"])[0] for _ in range(3))
    print(f"interpreter start-up {start:.2f} s; `import labcut_cli.app` {imports:.2f} s; budget {args.budget:g} s\n")
    print("| stone (never seen) | call | wall (s) | loading (s) | quality | predicted (s) | recommendation (s) | pilots |")
    print("|---|---|---|---|---|---|---|---|")
    for name in args.meshes or MESHES:
        src = Path(name) if Path(name).exists() else ROOT / "meshes" / name
        mesh = trimesh.load(src, force="mesh")
        mesh.apply_scale(1.0 + (uuid.uuid4().int % 997) / 1e5)  # a stone no cache has seen
        path = folder / f"new-{src.stem}.ply"
        mesh.export(path)
        for call in ("cold", "warm"):
            out = folder / f"{src.stem}-{call}.json"
            seconds, proc = wall([str(EXE), "recommend-orientation", str(path), "--time-budget", f"{args.budget:g}",
                                  "--json", str(out)])
            if proc.returncode != 0:
                print(f"| {src.name} | {call} | failed: {proc.stderr.strip()[:120]} |")
                break
            data = json.loads(out.read_text())
            b = data["settings"]["time_budget"]
            ir = data["plan"]["effects"].get("inter_reflection", {})
            pilots = ("skipped" if "not measured" in ir.get("why", "") else
                      f"{b['pilot_seconds']:.2f} s" if b.get("pilot_seconds") else "none")
            print(f"| {src.name} | {call} | {seconds:.2f} | {b['before_seconds']:.2f} | {b['quality']} | "
                  f"{b['predicted_seconds']:.2f} | {data['seconds']:.2f} | {pilots} |")


if __name__ == "__main__":
    main()
