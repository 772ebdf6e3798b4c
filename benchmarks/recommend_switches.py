"""What each of the standard recommendation's switchable speed-ups buys (issue 17 §4).

    .venv/bin/python benchmarks/recommend_switches.py [--out docs/performance.md] [--rounds N]

The bundled oval cabochon under ``bench`` at standard quality, the blue preset, in one process:
for each switch, ``N`` rounds (default 9) of one call with the switch as labcut has it and one
with it set back to what came before, interleaved so that the machine's drift falls on both;
the best and the median of each, and the answers' angle (the switch must not move the answer
beyond its error bar). The switches:

* ``scoring.BINS_IN_DRJIT``: the triples binned in Dr.Jit kernels (64-bit fixed-point sums)
  against numpy's bincounts;
* ``problem.LIT_ON_DEVICE``: which lights reach each pair's point tested and compacted on the
  device against the host's (points x lights) tables;
* ``scoring.DEVICE_MAP_NORMALS``: calls of 8 normals or more (the tolerance rings) in the map
  kernel, which finds their tiles on the device, against numpy's blocks below 2^20 terms;
* ``scoring.DEVICE_MAP_RTOL``: the map kernel culling at its own float32 precision (1e-6) against
  the numpy paths' 1e-8.

The section between the ``recommend-switches`` markers of the report is replaced (printed too).
"""

from __future__ import annotations

import argparse
import math
import platform
import statistics
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BEGIN, END = "<!-- recommend-switches: begin -->", "<!-- recommend-switches: end -->"

#: (module, name, what it does, the value before it)
SWITCHES = [
    ("labcut.orientation.scoring", "BINS_IN_DRJIT", "the binning in Dr.Jit kernels", False),
    ("labcut.orientation.problem", "LIT_ON_DEVICE", "the lights' facing tests and lit cells on the device", False),
    ("labcut.orientation.scoring", "DEVICE_MAP_NORMALS", "calls of 8+ normals (the tolerance rings) in the map kernel", 10**9),
    ("labcut.orientation.scoring", "DEVICE_MAP_RTOL", "the map kernel's cull at 1e-6", 1e-8),
]


def measure(rounds: int) -> list[dict]:
    import importlib

    import labcut

    mesh = labcut.load_mesh(ROOT / "meshes" / "oval-16x12-low.ply")
    lab = labcut.Labradorite.preset("blue")

    def call() -> tuple[float, np.ndarray, float]:
        t = time.perf_counter()
        rec = labcut.recommend_orientation(mesh, lab, scenario="bench", quality="standard")
        return time.perf_counter() - t, rec.normal, rec.uncertainty.angle_deg

    rows = []
    for module, name, what, before in SWITCHES:
        mod = importlib.import_module(module)
        now = getattr(mod, name)
        times: dict[str, list[float]] = {"now": [], "before": []}
        normals = {}
        bar = 0.0
        try:
            for value, key in ((now, "now"), (before, "before")):  # warm both
                setattr(mod, name, value)
                call()
            for _ in range(rounds):
                for value, key in ((now, "now"), (before, "before")):
                    setattr(mod, name, value)
                    seconds, normal, bar = call()
                    times[key].append(seconds)
                    normals[key] = normal
        finally:
            setattr(mod, name, now)
        angle = math.degrees(math.acos(min(1.0, abs(float(np.dot(normals["now"], normals["before"]))))))
        rows.append({"switch": f"{module.rsplit('.', 1)[-1]}.{name}", "what": what, "before": before, "now": now,
                     "best_now": min(times["now"]), "best_before": min(times["before"]),
                     "median_now": statistics.median(times["now"]), "median_before": statistics.median(times["before"]),
                     "angle": angle, "bar": bar})
    return rows


def table(rows: list[dict], rounds: int) -> list[str]:
    out = [f"Made by `.venv/bin/python benchmarks/recommend_switches.py` on {platform.machine()}: the standard "
           f"recommendation of `meshes/oval-16x12-low.ply` under `bench` in one process, {rounds} interleaved rounds "
           "of a call with each switch as labcut has it and one with it as it was before; best and median wall "
           "times, and the angle between the two answers.", "",
           "| switch | what it does | value (before) | best: now / before | median: now / before | angle between the answers (its bar) |",
           "|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| `{r['switch']}` | {r['what']} | {r['now']} ({r['before']}) | {r['best_now'] * 1e3:.0f} ms / "
                   f"{r['best_before'] * 1e3:.0f} ms | {r['median_now'] * 1e3:.0f} ms / {r['median_before'] * 1e3:.0f} ms | "
                   f"{r['angle']:.1e}° (±{r['bar']:.2f}°) |")
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "performance.md"))
    parser.add_argument("--rounds", type=int, default=9)
    args = parser.parse_args()
    rows = table(measure(args.rounds), args.rounds)
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
