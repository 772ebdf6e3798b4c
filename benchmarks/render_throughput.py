"""Render throughput of the labradorite BSDF next to Mitsuba's built-in BSDFs.

Same scene (bundled oval cabochon, overhead lamp, face-up orthographic camera,
direct lighting, 512 x 512), kernels warmed up first, timing one 32 spp render
after ``dr.sync_thread()``. Writes a markdown table.

    .venv/bin/python benchmarks/render_throughput.py [--out docs/render-performance.md]
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import labcut  # noqa: F401  (configures Dr.Jit before it is imported)
import drjit as dr
import mitsuba as mi

from labcut.rendering.api import build_scene
from labcut.rendering.scene import CameraView, camera, emitters, to_mitsuba_mesh
from labcut.scene import Lights, resolve_scene

ROOT = Path(__file__).resolve().parents[1]
RES, SPP = 512, 32


def _time(scene) -> float:
    mi.render(scene, spp=4)
    dr.sync_thread()
    best = float("inf")
    for seed in (1, 2):
        t = time.perf_counter()
        img = mi.render(scene, spp=SPP, seed=seed)
        dr.eval(img)
        dr.sync_thread()
        best = min(best, time.perf_counter() - t)
    return RES * RES * SPP / best / 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "render-performance.md"))
    args = parser.parse_args()
    mesh = labcut.load_mesh(ROOT / "meshes" / "oval-16x12-low.ply")
    lab = labcut.Labradorite.preset("blue")
    rows = []
    for mode in ("rgb", "spectral"):
        scene, plan = build_scene(mesh, lab, (0, 0, 1), resolve_scene(lighting="overhead").main_setting(), "face-up", RES, mode)
        ours = _time(scene)
        for name, bsdf in (("roughdielectric", {"type": "roughdielectric", "alpha": 0.1}),
                           ("roughconductor", {"type": "roughconductor", "alpha": 0.1})):
            d = {
                "type": "scene",
                "integrator": {"type": "direct"},
                "sensor": camera(CameraView("face-up", (0.0, 0.0, 1.0)), RES),
                "stone": to_mitsuba_mesh(mesh, mi.load_dict(bsdf)),
                **emitters(Lights.preset("overhead")),
            }
            ref = _time(mi.load_dict(d))
            rows.append((plan.variant, name, ours, ref, ref / ours))
            print(f"{plan.variant}: labradorite {ours:.2f} Msamples/s, {name} {ref:.2f} Msamples/s, ratio {ref / ours:.2f}")
    cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), platform.processor())
    lines = [
        "# Render throughput",
        "",
        "Made by `.venv/bin/python benchmarks/render_throughput.py` "
        f"on {os.cpu_count()} cores ({cpu}). Scene: `meshes/oval-16x12-low.ply`, overhead lamp, "
        f"face-up orthographic camera, direct lighting, {RES}x{RES}, {SPP} spp, warm kernel cache, best of 2.",
        "",
        "| variant | built-in BSDF | labradorite (Msamples/s) | built-in (Msamples/s) | time ratio labradorite / built-in |",
        "|---|---|---|---|---|",
    ]
    lines += [f"| {v} | {n} | {a:.2f} | {b:.2f} | {r:.2f} |" for v, n, a, b, r in rows]
    lines += ["", "Targets (issue 4): RGB within 1.5x of the built-in BSDFs, spectral within 2x.", ""]
    out = Path(args.out)
    kept = out.read_text().split("\n## ", 1) if out.exists() else []
    tail = "\n## " + kept[1] if len(kept) == 2 else ""  # later sections (render_denoise.py's) stay
    out.write_text("\n".join(lines) + tail)
    print(f"written {args.out}")


if __name__ == "__main__":
    main()
