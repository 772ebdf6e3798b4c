"""What each of the standard recommendation's switchable speed-ups buys.

    .venv/bin/python benchmarks/recommend_switches.py [--out docs/performance.md] [--rounds N]

The bundled oval cabochon under ``bench`` at standard quality, the blue preset, in one process:
for each switch, ``N`` rounds (default 9) of one call with the switch as labcut has it and one
with it set back to what came before, interleaved so that the machine's drift falls on both;
the best and the median of each, and the answers' angle (the switch must not move the answer
beyond its error bar). Each switch is a field of the call's
:class:`~labcut.orientation.kernels.KernelOptions` (handed in through its ``FlashQuestion``):

* ``bins``: the triples binned in Dr.Jit kernels (64-bit fixed-point sums) against numpy's
  bincounts;
* ``lit_cells``: which lights reach each pair's point tested and compacted on the device against
  the host's (points x lights) tables;
* ``map_min_normals``: calls of 8 normals or more (the tolerance rings) in the map kernel, which
  finds their tiles on the device, against numpy's blocks below 2^20 terms;
* ``map_kernel_rtol``: the map kernel culling at its own float32 precision (1e-6) against the
  numpy paths' 1e-8.

These are also the machine-tuned constants' home: rerun it on a new machine before changing a
default of ``KernelOptions``.

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

#: (KernelOptions field, what it does, the value before it)
SWITCHES = [
    ("bins", "the binning in Dr.Jit kernels", False),
    ("lit_cells", "the lights' facing tests and lit cells on the device", False),
    ("map_min_normals", "calls of 8+ normals (the tolerance rings) in the map kernel", 10**9),
    ("map_kernel_rtol", "the map kernel's cull at 1e-6", 1e-8),
]


def measure(rounds: int) -> list[dict]:
    from dataclasses import replace

    import labcut
    from labcut.orientation.kernels import KernelOptions
    from labcut.orientation.question import FlashQuestion

    mesh = labcut.load_mesh(ROOT / "meshes" / "oval-16x12-low.ply")
    asked = FlashQuestion.build("blue", "bench", quality="standard")

    def call(kernels: KernelOptions) -> tuple[float, np.ndarray, float]:
        t = time.perf_counter()
        rec = labcut.recommend_orientation(mesh, setup=replace(asked, kernels=kernels))
        return time.perf_counter() - t, rec.normal, rec.uncertainty.angle_deg

    rows = []
    for name, what, before in SWITCHES:
        now = getattr(KernelOptions(), name)
        options = {"now": KernelOptions(), "before": KernelOptions(**{name: before})}
        times: dict[str, list[float]] = {"now": [], "before": []}
        normals = {}
        bar = 0.0
        for key in ("now", "before"):  # warm both
            call(options[key])
        for _ in range(rounds):
            for key in ("now", "before"):
                seconds, normal, bar = call(options[key])
                times[key].append(seconds)
                normals[key] = normal
        angle = math.degrees(math.acos(min(1.0, abs(float(np.dot(normals["now"], normals["before"]))))))
        rows.append({"switch": f"KernelOptions.{name}", "what": what, "before": before, "now": now,
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
